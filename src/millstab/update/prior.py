"""The prior of Bayesian updating: independent log-normal spreads around a hammer-test structure.

Coordinates: the sampler works in u = ln θ (θ in Hz, N/m, -, and Kt in N/m²), where the prior is a
Gaussian with mean ln θ_config and standard deviation ``spread`` per parameter, so a spread of 0.05
is a ≈ 5 % relative standard deviation of a natural frequency. Defaults (the shop's experience of
how far in-process dynamics drift from a tap test): fn 5 %, k 30 %, ζ 30 %; every modal parameter
free; the cutting coefficients fixed unless ``[prior]`` gives Kt a spread.

Kt free is exact and cheap: in both engines the boundary depends on b·Kt only (F = ½ b Kt [A] Δ),
so b_lim(Kt) = b_lim(Kt₀) · Kt₀/Kt, and the chatter frequency does not change. Freeing Kr would change
the directional matrix per sample (one engine call per sample), so it is refused for now.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from millstab.errors import InputError
from millstab.model import Cutting, Mode, Structure
from millstab.params import Parameterization

#: default σ of ln(value) per kind of parameter
DEFAULT_SPREADS = {"fn": 0.05, "k": 0.30, "zeta": 0.30}
#: default depth noise of the stability likelihood [m] (the reference's experimental value)
DEFAULT_SIGMA_DEPTH_M = 0.05e-3
#: default noise of a measured chatter frequency [Hz]
DEFAULT_SIGMA_CHATTER_HZ = 20.0
#: default probability that a cut's label is swapped (a shop mislabels a cut now and then)
DEFAULT_LABEL_ERROR = 0.02


@dataclass(frozen=True, eq=False)
class Prior:
    """Independent log-normal prior on the free parameters, and the noise levels of the likelihood.

    Attributes:
        par: the modal parameterization (free modal names; the fixed values come from its base).
        cutting: the cutting conditions (Kt is the median when ``kt`` is free).
        names: the free names, ``par.free`` followed by ``"kt"`` when Kt is free.
        median: prior medians (P,) [Hz, N/m, -, N/m²].
        spread: σ of ln(value) (P,), > 0.
        sigma_depth_m: absolute depth noise [m], or ``None`` when relative.
        sigma_depth_rel: relative depth noise (fraction of the cut's depth), or ``None``.
        sigma_chatter_hz: chatter-frequency noise [Hz].
        label_error: probability ε ∈ [0, ½) that a cut's stable/chatter label is swapped
            (:mod:`millstab.update.likelihood`).
    """

    par: Parameterization
    cutting: Cutting
    names: tuple[str, ...]
    median: np.ndarray
    spread: np.ndarray
    sigma_depth_m: float | None = DEFAULT_SIGMA_DEPTH_M
    sigma_depth_rel: float | None = None
    sigma_chatter_hz: float = DEFAULT_SIGMA_CHATTER_HZ
    label_error: float = DEFAULT_LABEL_ERROR

    def __post_init__(self):
        if not (isinstance(self.label_error, (int, float)) and 0 <= self.label_error < 0.5):
            raise InputError("prior.label_error", self.label_error, "the probability that a label is swapped must be "
                                                                    "in [0, 0.5), e.g. 0.02 (0: labels never wrong)")

    @property
    def size(self) -> int:
        """Number of free parameters P."""
        return len(self.names)

    @property
    def kt_free(self) -> bool:
        return "kt" in self.names

    @property
    def mean_u(self) -> np.ndarray:
        """Prior mean of u = ln θ (P,)."""
        return np.log(self.median)

    def units(self) -> list[str]:
        """Unit of each free parameter."""
        return self.par.units() + (["N/m^2"] if self.kt_free else [])

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """n draws of u = ln θ, shape (n, P)."""
        return self.mean_u + self.spread * rng.standard_normal((n, self.size))

    def logpdf(self, u: np.ndarray) -> np.ndarray:
        """Log density of u = ln θ (B,) (normalised Gaussian in u)."""
        z = (np.atleast_2d(u) - self.mean_u) / self.spread
        return -0.5 * np.einsum("bp,bp->b", z, z) - float(np.log(self.spread).sum()) - 0.5 * self.size * math.log(2 * math.pi)

    def split(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(modal θ (B, Pm) [Hz, N/m, -], depth factor Kt₀/Kt (B,)) from u (B, P)."""
        t = np.exp(np.atleast_2d(u))
        if not self.kt_free:
            return t, np.ones(t.shape[0])
        return t[:, :-1], self.cutting.kt / t[:, -1]

    def sigma_depth_mm(self, depth_mm: np.ndarray) -> np.ndarray:
        """The depth noise [mm] of cuts at ``depth_mm`` (absolute, or relative to each depth)."""
        d = np.asarray(depth_mm, dtype=float)
        if self.sigma_depth_rel is not None:
            return self.sigma_depth_rel * d
        return np.full(d.shape, self.sigma_depth_m * 1e3)

    # --- JSON -------------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        """Plain data (SI) that :meth:`from_dict` rebuilds the prior from."""
        c, s = self.cutting, self.par.base
        return {"cutting": {"teeth": c.teeth, "kt": c.kt, "kr": c.kr, "entry": c.entry, "exit": c.exit},
                "structure": {d: [{"fn": m.fn, "k": m.k, "zeta": m.zeta} for m in getattr(s, d)] for d in ("x", "y")},
                "names": list(self.names), "median": self.median.tolist(), "spread": self.spread.tolist(),
                "sigma_depth_m": self.sigma_depth_m, "sigma_depth_rel": self.sigma_depth_rel,
                "sigma_chatter_hz": self.sigma_chatter_hz, "label_error": self.label_error}

    @classmethod
    def from_dict(cls, d: dict) -> Prior:
        try:
            c = d["cutting"]
            cutting = Cutting(int(c["teeth"]), c["kt"], c["kr"], c["entry"], c["exit"])
            structure = Structure(*(tuple(Mode(m["fn"], m["k"], m["zeta"], f"structure.{dd}[{i}]")
                                          for i, m in enumerate(d["structure"][dd])) for dd in ("x", "y")))
            names = tuple(d["names"])
            modal = tuple(n for n in names if n != "kt")
            par = Parameterization(structure, modal)
            return cls(par, cutting, names, np.asarray(d["median"], float), np.asarray(d["spread"], float),
                       d.get("sigma_depth_m"), d.get("sigma_depth_rel"), float(d["sigma_chatter_hz"]),
                       # a posterior written before label errors existed had none
                       float(d.get("label_error", 0.0)))
        except (KeyError, TypeError, ValueError) as exc:
            if isinstance(exc, InputError):
                raise
            raise InputError("posterior.prior", type(exc).__name__, f"not a millstab prior record ({exc})") from None


def make_prior(structure: Structure, cutting: Cutting, table=None) -> Prior:
    """The prior from a config's structure and cutting conditions and its ``[prior]`` table.

    Args:
        structure: the hammer-test modal structure (the prior medians).
        cutting: the cutting conditions (Kt the median when ``table`` frees it).
        table: a :class:`millstab.io.config.PriorTable` or ``None`` (all defaults).
    Raises:
        InputError: a measured-FRF structure, an unknown or duplicated name, Kr freed, every
            parameter fixed.
    """
    spreads = dict(getattr(table, "spreads", {}) or {})
    fixed = tuple(getattr(table, "fixed", ()) or ())
    if not structure.is_modal:
        raise InputError("structure", "measured FRF", "Bayesian updating needs a modal structure (fn, k, zeta per mode)")
    if "kr" in spreads:
        raise InputError("prior.kr", spreads["kr"], "freeing Kr is not supported yet (it changes the directional "
                                                    "matrix per sample); remove prior.kr to keep Kr fixed")
    if "kt" in fixed:
        fixed = tuple(f for f in fixed if f != "kt")
    full = Parameterization(structure)
    fixed_c = set()
    for f in fixed:
        try:
            fixed_c.add(full.canonical(f))
        except InputError as exc:
            raise InputError("prior.fixed", f, exc.allowed) from None
    free = tuple(n for n in full.available() if n not in fixed_c)
    if not free:
        raise InputError("prior.fixed", list(fixed), "every modal parameter is fixed; leave at least one free")
    par = Parameterization(structure, free)
    spread = np.array([DEFAULT_SPREADS[par.kind(n)] for n in par.free])
    for key, value in spreads.items():
        if key in DEFAULT_SPREADS:
            spread[[par.kind(n) == key for n in par.free]] = value
    for key, value in spreads.items():  # a named parameter's own spread wins over its kind's
        if key in DEFAULT_SPREADS or key == "kt":
            continue
        try:
            name = full.canonical(key)
        except InputError as exc:
            raise InputError(f"prior.{key}", value, exc.allowed) from None
        if name not in par.free:
            raise InputError(f"prior.{key}", value, f"{name} is listed in prior.fixed; give it a spread or fix it, not both")
        spread[par.free.index(name)] = value
    names, median = par.free, par.theta0
    if "kt" in spreads:
        names = names + ("kt",)
        median = np.append(median, cutting.kt)
        spread = np.append(spread, spreads["kt"])
    sd_m = getattr(table, "sigma_depth_m", None)
    sd_rel = getattr(table, "sigma_depth_rel", None)
    if sd_m is None and sd_rel is None:
        sd_m = DEFAULT_SIGMA_DEPTH_M
    sf = getattr(table, "sigma_chatter_hz", None) or DEFAULT_SIGMA_CHATTER_HZ
    eps = getattr(table, "label_error", None)
    eps = DEFAULT_LABEL_ERROR if eps is None else float(eps)
    return Prior(par, cutting, names, median, spread, sd_m, sd_rel, float(sf), eps)


__all__ = ["DEFAULT_LABEL_ERROR", "DEFAULT_SIGMA_CHATTER_HZ", "DEFAULT_SIGMA_DEPTH_M", "DEFAULT_SPREADS", "Prior", "make_prior"]
