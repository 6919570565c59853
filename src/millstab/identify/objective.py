"""The identification problem: measured boundary points, a parameterization, and the batched forward model.

Everything a solver needs goes through :meth:`Problem.predict_mm`, which stacks B parameter sets into
ONE call of the forward model (:func:`millstab.forward.forward`) and returns the limiting depths at the
measured speeds.

Objectives and residuals (depths in mm, speeds in rev/min, parameters θ in Hz, N/m, -):

* MLAE (the seed paper's eq. 4):  ``mean_i log(1 + |b_exp,i − b*_i|)``, optionally weighted
  ``Σ w_i log(1 + |Δb_i|) / Σ w_i``.
* least-squares residuals, ``residual="log"`` (default): ``r_i = √w_i · ln(b*_i / b_exp,i)`` — relative
  depth errors, homoscedastic for a relative measurement error and exactly invariant to a common
  stiffness scale (all k × c ⇒ b × c), which the solvers profile out; ``residual="mm"``: ``√w_i (b*_i − b_exp,i)``.

A predicted depth may be ``inf`` (no chatter boundary at that speed); it is capped at
``DEPTH_CAP`` × the largest measured depth so objectives stay finite and the solver is pushed back.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np

from millstab.errors import InputError
from millstab.points import PointSet, check_enough
from millstab.model import Cutting, Structure
from millstab.params import Parameterization
from millstab.forward import forward
from millstab.stability import get_engine, zoa

#: a predicted depth above this multiple of the largest measured depth counts as this multiple
DEPTH_CAP = 20.0
RESIDUALS = ("log", "mm")


@dataclass(eq=False)
class Problem:
    """Boundary points to explain, the cutting conditions and which modal parameters are free.

    Attributes:
        par: the parameterization (free names, fixed values, bounds) [Hz, N/m, -].
        cutting: cutting conditions used when the points were measured (fixed).
        rpm: boundary-point spindle speeds (n,) [rev/min].
        depth_mm: measured limiting depths (n,) [mm].
        weight: per-point weights (n,) > 0 (from the point file; 1 by default).
        engine: stability engine name (``zoa``, ``sdm`` or ``spectral``).
        cuts: labelled test cuts (not fitted; reported), or ``None``.
        residual: ``log`` or ``mm`` (see module docstring).
        n_sets: parameter sets evaluated so far (counter); n_calls: engine calls so far.
    """

    par: Parameterization
    cutting: Cutting
    rpm: np.ndarray
    depth_mm: np.ndarray
    weight: np.ndarray
    engine: str = "zoa"
    cuts: PointSet | None = None
    residual: str = "log"
    n_sets: int = 0
    n_calls: int = 0
    _forward: object = field(default=None, repr=False)

    def __post_init__(self) -> None:
        self.rpm = zoa.check_rpm(self.rpm)
        self.depth_mm = np.asarray(self.depth_mm, dtype=float)
        self.weight = np.broadcast_to(np.asarray(self.weight, dtype=float), self.rpm.shape).copy()
        if self.depth_mm.shape != self.rpm.shape:
            raise InputError("depth_mm", f"{self.depth_mm.size} values", f"need one per speed ({self.rpm.size})")
        if not (np.isfinite(self.depth_mm) & (self.depth_mm > 0)).all():
            raise InputError("depth_mm", "non-positive or non-finite value", "measured depths must be finite and > 0 mm")
        if self.residual not in RESIDUALS:
            raise InputError("residual", self.residual, f"must be one of {', '.join(RESIDUALS)}")
        self._forward = forward(self.par, self.cutting, self.engine)
        # repeated tests at one speed are evaluated once (the engine also needs distinct speeds)
        self._speeds, self._at = np.unique(self.rpm, return_inverse=True)
        self._cap = DEPTH_CAP * float(self.depth_mm.max())
        self._sw = np.sqrt(self.weight)
        self._log_meas = np.log(self.depth_mm)

    # --- sizes ----------------------------------------------------------------------------------
    @property
    def n(self) -> int:
        """Number of boundary points."""
        return int(self.rpm.size)

    @property
    def p(self) -> int:
        """Number of free parameters."""
        return self.par.size

    # --- the forward model ---------------------------------------------------------------------
    def predict_mm(self, theta: np.ndarray) -> np.ndarray:
        """Limiting depths (B, n) [mm] at the measured speeds for θ of shape (B, P) [Hz, N/m, -].

        ONE batched engine call for all B rows; ``inf`` capped (see module docstring).
        """
        t = np.atleast_2d(np.asarray(theta, dtype=float))
        depth = self._forward(t, self._speeds)[:, self._at] * 1e3
        self.n_sets += t.shape[0]
        self.n_calls += 1
        return np.minimum(np.where(np.isfinite(depth), depth, self._cap), self._cap)

    def predict_u(self, u: np.ndarray) -> np.ndarray:
        """:meth:`predict_mm` for log-parameters u = ln θ, shape (B, P)."""
        return self.predict_mm(np.exp(np.atleast_2d(u)))

    # --- objectives -----------------------------------------------------------------------------
    def mlae(self, pred_mm: np.ndarray, weight: np.ndarray | None = None) -> np.ndarray:
        """MLAE (paper eq. 4) per row of ``pred_mm`` (B, n) → (B,); weighted if ``weight`` (n,) or (B, n) given."""
        e = np.log1p(np.abs(np.atleast_2d(pred_mm) - self.depth_mm))
        if weight is None:
            return e.mean(axis=1)
        w = np.broadcast_to(weight, e.shape)
        return (w * e).sum(axis=1) / w.sum(axis=1)

    def residuals(self, pred_mm: np.ndarray) -> np.ndarray:
        """Least-squares residuals (B, n) for predictions (B, n) (see module docstring)."""
        pred = np.atleast_2d(pred_mm)
        if self.residual == "log":
            return self._sw * (np.log(pred) - self._log_meas)
        return self._sw * (pred - self.depth_mm)

    def rss(self, pred_mm: np.ndarray) -> np.ndarray:
        """Residual sum of squares per row (B,)."""
        r = self.residuals(pred_mm)
        return np.einsum("bi,bi->b", r, r)

    # --- stiffness profiling ------------------------------------------------------------------------
    @property
    def k_columns(self) -> np.ndarray | None:
        """Indices of the free stiffness parameters when EVERY stiffness of the structure is free.

        Then multiplying them all by c multiplies every depth by c exactly (the depth scales as the
        compliance), so the best common scale has a closed form; ``None`` otherwise.
        """
        par = self.par
        slots = {s for name in par.free if par.kind(name) == "k" for s in par._slots(name)}
        every = {(d, i, "k") for d in ("x", "y") for i in range(len(getattr(par.base, d)))}
        if not slots or slots != every or self.residual != "log":
            return None
        return np.array([j for j, name in enumerate(par.free) if par.kind(name) == "k"])

    def profile_k(self, u: np.ndarray, pred_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Shift the log-stiffness columns of u (B, P) by the best common ln c (weighted mean log ratio),
        within the bounds; return (u', pred') with pred scaled accordingly. No-op without :attr:`k_columns`."""
        kc = self.k_columns
        if kc is None:
            return u, pred_mm
        lr = self._log_meas - np.log(pred_mm)
        shift = (lr * self.weight).sum(axis=1) / self.weight.sum()
        lo, hi = np.log(self.par.lower[kc]), np.log(self.par.upper[kc])
        # keep every k inside its bounds: clip the common shift to the tightest room
        s_lo = (lo - u[:, kc]).max(axis=1)
        s_hi = (hi - u[:, kc]).min(axis=1)
        shift = np.clip(shift, s_lo, np.maximum(s_lo, s_hi))
        u2 = u.copy()
        u2[:, kc] += shift[:, None]
        return u2, pred_mm * np.exp(shift)[:, None]

    # --- test cuts ------------------------------------------------------------------------------------
    def cut_report(self, theta: np.ndarray) -> dict[str, int] | None:
        """How the SLD of θ classifies the labelled test cuts (one engine call), or ``None`` if none.

        Returns counts: stable cuts predicted stable / chatter, chatter cuts predicted chatter / stable
        (a cut is predicted chatter when its depth exceeds the limit at its speed).
        """
        if self.cuts is None or len(self.cuts) == 0:
            return None
        speeds, at = np.unique(self.cuts.rpm, return_inverse=True)
        lim = self._forward(theta, speeds)[0, at] * 1e3
        self.n_sets += 1
        self.n_calls += 1
        pred_chatter = self.cuts.depth_mm > lim
        st, ch = self.cuts.stable, self.cuts.chatter
        return {"stable_cuts": int(st.sum()), "stable_predicted_chatter": int((st & pred_chatter).sum()),
                "chatter_cuts": int(ch.sum()), "chatter_predicted_stable": int((ch & ~pred_chatter).sum())}


# --- x ↔ y symmetry ------------------------------------------------------------------------------------
def xy_symmetric_cut(cutting: Cutting, tol: float = 1e-9) -> bool:
    """True when swapping x and y leaves every zero-order SLD unchanged exactly.

    With G = diag(g_x, g_y), swapping x and y turns the eigenvalues of [α][G] into those of
    P[α]P·G (P the swap); P[α]P equals [α]ᵀ (so the spectrum is unchanged: spec(αᵀG) = spec(Gα) = spec(αG))
    exactly when α_xx = α_yy, which holds for slotting (and a few other immersions).
    """
    a = zoa.directional_matrix(cutting)
    return abs(a[0, 0] - a[1, 1]) <= tol * max(1.0, np.abs(a).max())


def swap_permutation(par: Parameterization, cutting: Cutting) -> np.ndarray | None:
    """Index permutation of θ that swaps x and y, when that swap is an exact symmetry of the data.

    ``None`` unless: the cut is x/y symmetric (:func:`xy_symmetric_cut`), the tool is not tied
    (axisymmetric), x and y have the same number of modes, every free name's x↔y partner is free, and
    every fixed value equals its partner's.
    """
    if not xy_symmetric_cut(cutting):
        return None
    return _partner_permutation(par, 1.0)


def _partner_permutation(par: Parameterization, r: float) -> np.ndarray | None:
    """Index permutation of θ exchanging every free x parameter with its y partner, or ``None``.

    ``None`` when the tool is tied (axisymmetric), the mode counts differ, a free name's partner is not
    free, a fixed value differs from its partner's, a stiffness is fixed while the exchange rescales
    stiffnesses (r ≠ 1), or the permutation is the identity.
    """
    if par.axisymmetric or len(par.base.x) != len(par.base.y):
        return None
    swapped = [n.replace("_x", "_#").replace("_y", "_x").replace("_#", "_y") for n in par.free]
    if any(s not in par.free for s in swapped):
        return None
    free_slots = {s for n in par.free for s in par._slots(n)}
    for i, (mx, my) in enumerate(zip(par.base.x, par.base.y)):
        for p in ("fn", "k", "zeta"):
            fixed_x, fixed_y = ("x", i, p) not in free_slots, ("y", i, p) not in free_slots
            if fixed_x != fixed_y:
                return None
            if fixed_x and ((p == "k" and r != 1.0) or getattr(mx, p) != getattr(my, p)):
                return None  # (a fixed stiffness pair cannot follow the k_x' = r k_y scaling)
    perm = np.array([par.free.index(s) for s in swapped])
    return None if np.array_equal(perm, np.arange(par.size)) else perm


def exchange_map(par: Parameterization, cutting: Cutting, engine: str = "zoa") -> tuple[np.ndarray, np.ndarray] | None:
    """The generalised x↔y mode exchange that leaves every zero-order SLD unchanged exactly.

    The zero-order boundary depends only on the eigenvalues of [α][G], G = diag(g_x, g_y), i.e. on
    tr = α_xx g_x + α_yy g_y and det = det[α] g_x g_y. Exchanging the x and y modes (fn, ζ swapped) and
    scaling the stiffnesses k_x' = r k_y, k_y' = k_x / r with r = α_xx/α_yy (so g_x' = g_y/r, g_y' = r g_x)
    keeps both, for EVERY cut with α_xx α_yy > 0 — not only when α_xx = α_yy (r = 1, slotting, see
    :func:`swap_permutation`). Such a cut cannot tell the two structures apart from its boundary.

    Returns (perm, shift): θ' = θ[perm] · exp(shift) (shift = ±ln r on the k columns), or ``None`` when
    the engine's x↔y exchange is not exact (``exact_xy_exchange``: zoa only), the tool is tied, the mode counts differ, a free name's partner is not free,
    a fixed value differs from its partner's (or a stiffness is fixed while r ≠ 1), or α_xx α_yy ≤ 0.
    """
    if not get_engine(engine).exact_xy_exchange:
        return None
    a = zoa.directional_matrix(cutting)
    if not a[0, 0] * a[1, 1] > 0:
        return None
    r = float(a[0, 0] / a[1, 1])
    if abs(r - 1) <= 1e-9:
        r = 1.0
    perm = _partner_permutation(par, r)
    if perm is None:
        return None
    shift = np.zeros(par.size)
    for j, n in enumerate(par.free):
        if par.kind(n) == "k":
            shift[j] = math.log(r) if "_x" in n else -math.log(r)
    return perm, shift


def exchanged(theta: np.ndarray, xmap: tuple[np.ndarray, np.ndarray] | None) -> np.ndarray:
    """θ (P,) or (B, P) after the exchange ``xmap`` of :func:`exchange_map` (θ itself when ``None``)."""
    t = np.asarray(theta, dtype=float)
    if xmap is None:
        return t.copy()
    perm, shift = xmap
    return t[..., perm] * np.exp(shift)


def canonical(theta: np.ndarray, perm: np.ndarray | None) -> np.ndarray:
    """The canonical member of {θ, θ[perm]}: the one whose first differing x/y pair (in the order of the
    free names, fn first) has the smaller x value, so fn_x ≤ fn_y when they differ. Works on (P,) or (B, P)."""
    t = np.asarray(theta, dtype=float)
    if perm is None:
        return t.copy()
    single = t.ndim == 1
    t2 = np.atleast_2d(t)
    s = t2[:, perm]
    diff = t2 - s
    # first column where θ and its swap differ by more than round-off decides
    big = np.abs(diff) > 1e-12 * np.abs(t2)
    first = np.where(big.any(axis=1), big.argmax(axis=1), 0)
    take_swap = diff[np.arange(t2.shape[0]), first] > 0
    out = np.where(take_swap[:, None], s, t2)
    return out[0] if single else out


def oriented(theta: np.ndarray, truth: np.ndarray, perm=None, std_errors: np.ndarray | None = None):
    """θ (and its standard errors) in the x↔y orientation closer to the truth: θ itself, or its image
    under ``perm`` when that is closer in the largest relative error.

    ``perm`` may be an index permutation (:func:`swap_permutation`) or a (perm, shift) exchange map
    (:func:`exchange_map`; standard errors scale with their parameters). Returns (θ, std_errors)."""
    t, tr = np.asarray(theta, float), np.asarray(truth, float)
    if perm is None:
        return t, std_errors
    move = (lambda v: exchanged(v, perm)) if isinstance(perm, tuple) else (lambda v: np.asarray(v)[perm])  # noqa: E731
    t2 = move(t)
    if np.abs(t2 / tr - 1).max() < np.abs(t / tr - 1).max():
        return t2, None if std_errors is None else move(std_errors)
    return t, std_errors


def rel_error(theta: np.ndarray, truth: np.ndarray, perm=None) -> np.ndarray:
    """|θ/θ_true − 1| per parameter, up to the x↔y symmetry when ``perm`` is given (the better of the two:
    see :func:`oriented`)."""
    t, _ = oriented(theta, truth, perm)
    return np.abs(t / np.asarray(truth, float) - 1)


# --- building a problem --------------------------------------------------------------------------
def check_speeds(rpm: np.ndarray, n_free: int, source=None) -> int:
    """The number of distinct boundary-point speeds; InputError when fewer than ``n_free``.

    The boundary is one depth per speed: repeated tests at one speed measure that depth again (its
    scatter), not another point of the curve, so P parameters need at least P different speeds — all
    points at one speed determine at most one parameter.
    """
    r = np.asarray(rpm, dtype=float)
    distinct = int(np.unique(r[np.isfinite(r)]).size)
    if distinct < n_free:
        where = f" in {source.name}" if source is not None else ""
        at = f"all at {r[0]:g} rpm" if distinct == 1 else f"at {distinct} distinct speeds"
        raise InputError("points", f"{r.size} boundary points{where} {at}",
                         f"{n_free} free parameters need boundary points at {n_free} or more different spindle speeds "
                         "(repeats at one speed only re-measure its depth); measure at other speeds, or free fewer "
                         "parameters (--free)")
    return distinct


def parse_assignments(text: str | Mapping[str, float] | None, field_name: str = "--initial") -> dict[str, float]:
    """``"fn_x=900,k_x=12e6"`` → {name: value} (SI: Hz, N/m, -). Raises InputError naming the bad item."""
    if text is None:
        return {}
    if isinstance(text, Mapping):
        return {str(k): float(v) for k, v in text.items()}
    out: dict[str, float] = {}
    for item in (s.strip() for s in str(text).split(",")):
        if not item:
            continue
        if "=" not in item:
            raise InputError(field_name, item, "expected NAME=VALUE items separated by commas, e.g. fn_x=900,k_x=12e6")
        name, value = (s.strip() for s in item.split("=", 1))
        try:
            v = float(value)
        except ValueError:
            raise InputError(f"{field_name} {name}", value, "must be a number in SI units (Hz, N/m, -)") from None
        if not (math.isfinite(v) and v > 0):
            raise InputError(f"{field_name} {name}", value, "must be a finite number > 0 (Hz, N/m, -)")
        out[name] = v
    return out


def make_problem(structure: Structure, cutting: Cutting, points: PointSet, *, free: Sequence[str] | str | None = None,
                 axisymmetric: bool = False, initial: Mapping[str, float] | str | None = None,
                 bounds: Mapping[str, tuple[float, float]] | None = None, engine: str = "zoa",
                 residual: str = "log") -> Problem:
    """Build a :class:`Problem` from a starting structure, the cutting conditions and a point set.

    Args:
        structure: starting modal structure (e.g. hammer-test modes); supplies fixed values.
        points: boundary points (unlabelled rows are fitted; labelled test cuts are reported only).
        free: free parameter names (list or comma-separated); default all (6 for one mode per direction,
            3 when ``axisymmetric``).
        initial: start values overriding the structure's, {name: value} or ``"fn_x=900,..."`` [SI].
        bounds: {name: (lo, hi)} [SI] overriding the defaults (fn ×/÷ 2, k ×/÷ 10, ζ ×/÷ 20).
    Raises:
        InputError: unknown names, fewer boundary points (or fewer distinct speeds among them) than free
            parameters, bad values.
    """
    if isinstance(free, str):
        free = [s.strip() for s in free.split(",") if s.strip()]
    par = Parameterization(structure, tuple(free or ()), axisymmetric, dict(bounds or {}))
    init = parse_assignments(initial)
    if init:
        # re-centre: the start structure carries the initial values so default bounds surround them
        theta = par.with_values(**init)
        par = Parameterization(par.structure(theta), par.free, axisymmetric, dict(bounds or {}))
    check_enough(points, par.size)
    b = points.boundary
    check_speeds(points.rpm[b], par.size, points.source)
    cuts = points.subset(~b) if (~b).any() else None
    return Problem(par, cutting, points.rpm[b], points.depth_mm[b], points.weight[b], engine, cuts, residual)


__all__ = ["DEPTH_CAP", "Problem", "canonical", "check_speeds", "exchange_map", "exchanged", "make_problem", "oriented", "parse_assignments", "rel_error", "swap_permutation",
           "xy_symmetric_cut"]
