"""The identification problem: measured boundary points, a parameterization, and the batched forward model;
its objectives and residuals, and :func:`make_problem`. (The x ↔ y symmetry theory is in
:mod:`~millstab.identify.symmetry`, comparisons with a known truth in :mod:`~millstab.identify.accuracy`,
text parsing of ``--initial`` in :mod:`millstab.parsing`.)

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

from dataclasses import dataclass, field, replace
from typing import Mapping, Sequence

import numpy as np

from millstab.errors import InputError
from millstab.forward import forward
from millstab.model import Cutting, Structure, check_stiffness
from millstab.params import Parameterization
from millstab.parsing import parse_assignments
from millstab.points import PointSet, check_enough, check_speeds
from millstab.stability import check_rpm
# moved by responsibility; re-exported so the old import paths keep working
from millstab.identify.accuracy import oriented, rel_error  # noqa: E402,F401
from millstab.identify.symmetry import (canonical, exchange_map, exchanged, swap_permutation,  # noqa: E402,F401
                                        xy_symmetric_cut)

#: a predicted depth above this multiple of the largest measured depth counts as this multiple
DEPTH_CAP = 20.0
RESIDUALS = ("log", "mm")


@dataclass(eq=False)
class Problem:
    """Boundary points to explain, the cutting conditions and which modal parameters are free.

    Attributes:
        par: the parameterization (free names, fixed values, bounds) [Hz, N/m, -].
        cutting: cutting conditions used when the points were measured (fixed).
        rpm: boundary-point spindle speeds (n,) [rev/min] (the points are kept sorted by speed, depth and
            weight: the order of the rows never changes a result).
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
        self.rpm = check_rpm(self.rpm)
        self.depth_mm = np.asarray(self.depth_mm, dtype=float)
        self.weight = np.broadcast_to(np.asarray(self.weight, dtype=float), self.rpm.shape).copy()
        if self.depth_mm.shape != self.rpm.shape:
            raise InputError("depth_mm", f"{self.depth_mm.size} values", f"need one per speed ({self.rpm.size})")
        if not (np.isfinite(self.depth_mm) & (self.depth_mm > 0)).all():
            raise InputError("depth_mm", "non-positive or non-finite value",
                             "measured depths must be finite and > 0 mm")
        if self.residual not in RESIDUALS:
            raise InputError("residual", self.residual, f"must be one of {', '.join(RESIDUALS)}")
        # the points in one canonical order (speed, depth, weight): every sum over them, and so the whole
        # search path, is then the same bit for bit whatever the order of the rows in the file
        order = np.lexsort((self.weight, self.depth_mm, self.rpm))
        self.rpm, self.depth_mm, self.weight = self.rpm[order], self.depth_mm[order], self.weight[order]
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

    def refine(self, theta: np.ndarray) -> bool:
        """Re-check the engine's discretisation at the parameter row θ (P,) (a solution); True when it
        changed (see :meth:`millstab.forward.Forward.refine`): the caller evaluates again."""
        return self._forward.refine(theta, self._speeds)

    def with_engine(self, engine: str) -> Problem:
        """The same points and parameterization under another engine (fresh counters), e.g. the cheap
        zero-order twin whose global search proposes basins to an accurate one."""
        return replace(self, engine=engine, n_sets=0, n_calls=0, _forward=None)

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


# --- building a problem --------------------------------------------------------------------------
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
    for name, value in init.items():  # quiet structures follow: a start in N/um (6.3 for 6.3e6) is said here
        if par.kind(par.canonical(name)) == "k":
            check_stiffness(f"--initial {name}", value, si_only=True, stacklevel=3)
    if init:
        # re-centre: the start structure carries the initial values so default bounds surround them
        theta = par.with_values(**init)
        par = Parameterization(par.structure(theta), par.free, axisymmetric, dict(bounds or {}))
    check_enough(points, par.size)
    b = points.boundary
    check_speeds(points.rpm[b], par.size, points.source)
    cuts = points.subset(~b) if (~b).any() else None
    return Problem(par, cutting, points.rpm[b], points.depth_mm[b], points.weight[b], engine, cuts, residual)


__all__ = ["DEPTH_CAP", "Problem", "canonical", "check_speeds", "exchange_map", "exchanged", "make_problem", "oriented",
           "parse_assignments", "rel_error", "swap_permutation", "xy_symmetric_cut"]
