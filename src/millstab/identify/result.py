"""The one result type of every identification solver: :class:`Fit`, and its JSON form.

JSON contract (``Fit.to_json()``; keys may be added, never removed or renamed):

* ``"parameters"``: the identified structure's dominant mode per direction, ``fn_x, k_x, zeta_x, fn_y,
  k_y, zeta_y`` in Hz, N/m and dimensionless (an axisymmetric tool: ``fn, k, zeta``);
* ``"mlae"``: the paper's objective (eq. 4, depths in mm) at the estimate;
* beside them: ``free`` (names), ``estimate`` ({free name: value}), ``units``, ``std_errors``,
  ``correlation``, ``rss``, ``method``, ``iterations``, ``evaluations``, ``time_s``, ``warnings``,
  ``alternatives``, ``symmetry``, ``test_cuts``, ``history`` ({theta, mlae, rss} per iteration),
  ``structure`` (every mode), ``settings``;
* the fit's reliability: ``dof`` (residual degrees of freedom n − p), ``n_points``, ``noise`` (the σ the
  standard errors use and where it comes from: residual scatter, stated or assumed), ``warning_codes``
  (one code per warning kind, :mod:`~millstab.identify.quality`), ``checks`` (χ² and runs tests);
* ``cutting``: the cutting conditions the points were fitted under (teeth, kt [N/m²], kr, entry and exit
  [rad]), so a fit file cannot be used with a config of other conditions.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from millstab.model import Cutting, Structure
from millstab.params import Parameterization


@dataclass(eq=False)
class Fit:
    """An identification result.

    Attributes:
        method: ``lsq`` or ``newton``.
        names: free parameter names (P,); units: their units (Hz, N/m, -).
        estimate: the identified free parameters (P,) [Hz, N/m, -] (canonical x/y order when the data
            are x↔y symmetric).
        start: the starting values (P,).
        mlae: MLAE (paper eq. 4, mm) at the estimate; rss: residual sum of squares of the fitted residuals.
        iterations: solver iterations (all stages); evaluations: parameter sets evaluated by the engine;
        engine_calls: batched engine calls; time_s: wall time [s].
        history_theta: (I, P) the best parameters after each iteration; history_mlae, history_rss: (I,).
        std_errors: approximate standard errors (P,) [same units], ``None`` when not computed (newton).
        correlation: (P, P) correlation matrix of the estimate, or ``None``.
        condition: condition number of JᵀJ in log-parameters, or ``None``.
        warnings: identifiability, convergence and quality warnings (one line each).
        codes: a code per warning kind (e.g. ``no_dof``, ``poor_fit``, ``residual_structure``, ``zoa_model``;
            :mod:`~millstab.identify.quality`), in the order first raised.
        dof: residual degrees of freedom n − p (``None`` before :func:`~millstab.identify.quality.diagnose`);
            n_points: boundary points fitted.
        noise: the residual σ the standard errors use: {"sigma" (relative), "source" (``residuals``,
            ``stated`` or ``assumed``), "estimated" (σ̂ = √(RSS/dof), relative), "stated", "assumed"}.
        checks: test statistics behind the quality warnings (χ² p-value, runs test, RMS residual).
        cutting: the cutting conditions of the fitted points, or ``None``.
        alternatives: other parameter sets as good as the estimate: [{"estimate": {...}, "mlae", "rss", "why"}].
        symmetry: a line describing an exact symmetry of the data (x↔y), or ``None``.
        test_cuts: how the fitted SLD classifies the labelled test cuts (counts), or ``None``.
        snapshots: iteration indices and θ (for the paper's Fig. iter), (iteration, θ) pairs.
        settings: solver settings used (for reproducibility).
    """

    method: str
    par: Parameterization
    estimate: np.ndarray
    start: np.ndarray
    mlae: float
    rss: float
    iterations: int
    evaluations: int
    engine_calls: int
    time_s: float
    history_theta: np.ndarray
    history_mlae: np.ndarray
    history_rss: np.ndarray
    std_errors: np.ndarray | None = None
    correlation: np.ndarray | None = None
    condition: float | None = None
    warnings: list[str] = field(default_factory=list)
    alternatives: list[dict[str, Any]] = field(default_factory=list)
    symmetry: str | None = None
    test_cuts: dict[str, int] | None = None
    settings: dict[str, Any] = field(default_factory=dict)
    codes: list[str] = field(default_factory=list)
    dof: int | None = None
    n_points: int | None = None
    noise: dict[str, Any] | None = None
    checks: dict[str, Any] = field(default_factory=dict)
    cutting: Cutting | None = None

    def add_warning(self, code: str, text: str) -> None:
        """Add a warning line and its code (a code is listed once however many lines carry it)."""
        self.warnings.append(text)
        if code not in self.codes:
            self.codes.append(code)

    @property
    def names(self) -> tuple[str, ...]:
        return self.par.free

    @property
    def units(self) -> list[str]:
        return self.par.units()

    @property
    def structure(self) -> Structure:
        """The identified structure (fixed parameters from the start structure)."""
        return self.par.structure(self.estimate)

    def as_dict(self) -> dict[str, float]:
        """{free name: value} [Hz, N/m, -]."""
        return self.par.as_dict(self.estimate)

    def parameters(self) -> dict[str, float]:
        """The JSON contract's ``parameters``: dominant mode per direction (or fn, k, zeta if axisymmetric)."""
        s = self.structure
        out: dict[str, float] = {}
        dirs = ("",) if self.par.axisymmetric else ("x", "y")
        for d in dirs:
            modes = s.x if d in ("", "x") else s.y
            if not modes:
                continue
            m = modes[int(np.argmax([1.0 / (mm.k * mm.zeta) for mm in modes]))]
            suffix = f"_{d}" if d else ""
            out.update({f"fn{suffix}": m.fn, f"k{suffix}": m.k, f"zeta{suffix}": m.zeta})
        return out

    def to_json(self) -> dict[str, Any]:
        """The JSON form (see module docstring)."""
        s = self.structure
        se = None if self.std_errors is None else {n: float(v) for n, v in zip(self.names, self.std_errors)}
        return {
            "parameters": self.parameters(),
            "mlae": float(self.mlae),
            "rss": float(self.rss),
            "method": self.method,
            "free": list(self.names),
            "units": dict(zip(self.names, self.units)),
            "estimate": self.as_dict(),
            "start": self.par.as_dict(self.start),
            "std_errors": se,
            "correlation": None if self.correlation is None else self.correlation,
            "condition": self.condition,
            "iterations": int(self.iterations),
            "evaluations": int(self.evaluations),
            "engine_calls": int(self.engine_calls),
            "time_s": float(self.time_s),
            "warnings": list(self.warnings),
            "alternatives": self.alternatives,
            "symmetry": self.symmetry,
            "test_cuts": self.test_cuts,
            "structure": {d: [{"fn": m.fn, "k": m.k, "zeta": m.zeta} for m in getattr(s, d)] for d in ("x", "y")},
            "settings": self.settings,
            "dof": None if self.dof is None else int(self.dof),
            "n_points": None if self.n_points is None else int(self.n_points),
            "noise": self.noise,
            "warning_codes": list(self.codes),
            "checks": self.checks,
            "cutting": None if self.cutting is None else cutting_record(self.cutting),
            "history": {"theta": self.history_theta, "mlae": self.history_mlae, "rss": self.history_rss},
        }


def cutting_record(cutting: Cutting) -> dict[str, float]:
    """The JSON record of cutting conditions: teeth, kt [N/m²], kr [-], entry and exit [rad]."""
    return {"teeth": int(cutting.teeth), "kt": float(cutting.kt), "kr": float(cutting.kr),
            "entry": float(cutting.entry), "exit": float(cutting.exit)}


def cutting_difference(record, cutting: Cutting) -> str | None:
    """How a recorded cutting (:func:`cutting_record`, e.g. from a fit file) differs from ``cutting``
    (first differing field, both values shown as a user writes them), or ``None`` when the same
    (relative tolerance 1e-9)."""
    import math

    want = cutting_record(cutting)
    show = {"teeth": lambda v: f"{v:g}", "kt": lambda v: f"{v / 1e6:.6g} MPa", "kr": lambda v: f"{v:.6g}",
            "entry": lambda v: f"{math.degrees(v):.6g}°", "exit": lambda v: f"{math.degrees(v):.6g}°"}
    for key, fmt in show.items():
        got = record.get(key) if isinstance(record, dict) else None
        if isinstance(got, bool) or not isinstance(got, (int, float)):
            return f"cutting {key} is missing from the fit's record ({got!r})"
        if not math.isclose(float(got), want[key], rel_tol=1e-9, abs_tol=1e-12):
            return f"cutting {key} is {fmt(float(got))} in the fit but {fmt(want[key])} here"
    return None


__all__ = ["Fit", "cutting_difference", "cutting_record"]
