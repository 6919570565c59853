"""Where to measure next: speeds whose boundary points pin the modal parameters best.

How precisely boundary points determine fn, k and ζ depends far more on *where* they are measured than
on how many there are. On a steep lobe flank a 1 % shift of fn moves the limiting depth by tens of
percent; on a flat lobe bottom it hardly moves it. With a fixed, evenly spaced speed set, the weaker
mode of a tool is often determined to only ±0.5–1 % in fn at 2 % depth noise, while the same number
of well-placed points determines it to ±0.1 %.

This module plans the speeds (an *optimal experimental design*):

* **Information.** A boundary point at speed Ω carries the Fisher information jjᵀ/v,
  j = ∂ ln b(Ω)/∂ ln θ (the same log residuals the least-squares solver fits), with the variance of
  its ln-depth v = σ² + (σ_Ω ∂ ln b/∂ ln Ω)²: depth noise σ plus the uncertainty σ_Ω of where the
  boundary sits in speed (:data:`SPEED_NOISE`). n_i points at speed Ω_i and the already measured
  points add up: M(θ) = M₀ + Σ n_i j_i j_iᵀ/v_i.
* **Criterion.** Bayesian A-optimality in log-parameters: minimise the expected sum of the squared
  relative standard errors of the target parameters, E_θ[tr(Cᵀ M(θ)⁻¹ C)], the expectation over the
  current uncertainty of θ (a fit's covariance, or a prior spread around the hammer-test values). The
  expectation matters: a design optimal at a point estimate puts all its points on the flanks of
  *that* θ's lobes, and 1 % off in fn those flanks have moved. A fit's alternative solutions join
  the centres the expectation is taken around.
* **Algorithm.** The continuous design (weights w over candidate speeds) by multiplicative steps
  w_i ← w_i d_i / Σ w d, d_i = E_θ‖Cᵀ M⁻¹ j_i‖² (Silvey, Titterington & Torsney 1978), each followed
  by a vertex-exchange step (:func:`optimal_weights`). The general equivalence theorem certifies the
  result: at the optimum every d_i ≤ Σ_j w_j d_j, and the gap bounds the efficiency
  (:attr:`SpeedDesign.efficiency_continuous`). It is then rounded to n tests (largest remainders; a
  speed may get several tests, each an independent measurement of the limiting depth there) and the
  rounded plan improved by exchanging single tests (:func:`improve_counts`).
* **Never worse than even spacing.** The plan's own criterion is computed for it and for n tests evenly
  spaced over the candidates (the candidates nearest to n evenly spaced speeds), over the same θ
  samples; should the evenly spaced tests be better (rounding, or an exchange stuck), they are the plan.
  :attr:`SpeedDesign.efficiency` bounds the *rounded* plan's efficiency against the best continuous
  design. The criterion is a sum over the target parameters averaged over θ: a plan that lowers it can
  still determine a single parameter, at the centre θ, less well than even spacing (it trades that
  parameter's error for larger gains elsewhere); the per-parameter errors show it.

Every Jacobian of every θ sample comes from ONE batched engine call (central differences).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from millstab.errors import InputError
from millstab.identify.result import cutting_difference, cutting_record
from millstab.identify.search import options_with
from millstab.identify.tie import is_tied, tied_parameterization
from millstab.jsondoc import check_schema, floats_in, floats_out, int_in, names_in, need, number_in, number_out
from millstab.model import Cutting
from millstab.params import Parameterization
from millstab.forward import forward, log_jacobian

#: default prior spread (standard deviation of ln θ) around a structure that is not a fit: a hammer
#: test's modes move a few percent in fn and tens of percent in k and ζ once the spindle turns
PRIOR_SPREAD = {"fn": 0.05, "k": 0.3, "zeta": 0.3}
#: default relative uncertainty of where the boundary sits in speed: spindle-speed error and the drift
#: of the natural frequencies between tests. It turns a point on a near-vertical lobe flank (|∂ ln b/∂ ln Ω|
#: of 10–100) from the most informative test into a poor one, which it is: there the measured limit
#: depends on exactly where the flank is, and a fit through it is not a smooth least-squares problem.
SPEED_NOISE = 0.005
#: central-difference step in ln θ (and ln Ω)
FD_STEP = 1e-4


@dataclass(frozen=True)
class SpeedDesign:
    """A planned set of test speeds and what it is expected to achieve.

    Attributes:
        rpm: the n planned tests [rev/min], sorted; a speed appears once per test planned there.
        candidates: the candidate speeds [rev/min] (m,); weights: the optimal continuous design over
            them (m,), summing to 1.
        names: the free parameters; target: those the criterion weighs.
        theta: the centre of the uncertainty the design averages over (P,) [Hz, N/m, -].
        noise: relative depth noise assumed (standard deviation, 0.02 = 2 %); speed_noise: relative
            uncertainty of the boundary's speed assumed (see :data:`SPEED_NOISE`).
        sigma_existing: predicted relative standard error of each parameter from the existing points
            alone (P,), ``None`` without existing points or when they cannot determine θ (inf where
            singular); sigma_uniform: with n more tests evenly spaced over the candidates;
            sigma_design: with the n planned tests. All at ``theta`` (relative: 0.001 = 0.1 %).
        efficiency: lower bound on the efficiency of the planned n tests against the best continuous
            design (1 = optimal), from the equivalence theorem: Φ* ≥ efficiency_continuous · Φ(w), so
            Φ*/Φ(plan) ≥ efficiency_continuous · Φ(w)/Φ(plan).
        efficiency_continuous: the same bound for the continuous design (before rounding).
        criterion_design, criterion_uniform: the criterion (expected sum of squared relative standard
            errors of the target parameters over the θ samples) of the planned tests and of n tests
            evenly spaced over the candidates; criterion_design ≤ criterion_uniform always.
        uniform: True when the evenly spaced tests were at least as good and are the plan.
        sigma_existing_mean, sigma_uniform_mean, sigma_design_mean: the relative standard errors as the
            criterion weighs them: root-mean-square over the θ samples (P,), ``None`` for existing points
            when there are none. Over the target parameters, Σ σ²_mean is the criterion, so the planned
            column always sums lower than the evenly spaced one, while at ``theta`` alone (sigma_design)
            the plan can be worse: the samples spread the lobes over speed, and the plan serves them all.
        iterations: design-algorithm iterations; samples: θ samples averaged over (those the
            candidates can determine).
        predicted_depth_mm: the limiting depth at ``theta`` at each planned speed [mm] (n,).
        engine: the stability engine the plan's Jacobians and predicted depths come from.
    """

    rpm: np.ndarray
    candidates: np.ndarray
    weights: np.ndarray
    names: tuple[str, ...]
    target: tuple[str, ...]
    theta: np.ndarray
    noise: float
    speed_noise: float
    sigma_existing: np.ndarray | None
    sigma_uniform: np.ndarray
    sigma_design: np.ndarray
    efficiency: float
    iterations: int
    samples: int
    predicted_depth_mm: np.ndarray
    efficiency_continuous: float = 1.0
    criterion_design: float = float("nan")
    criterion_uniform: float = float("nan")
    uniform: bool = False
    sigma_existing_mean: np.ndarray | None = None
    sigma_uniform_mean: np.ndarray | None = None
    sigma_design_mean: np.ndarray | None = None
    engine: str = "zoa"

    def tests(self) -> list[tuple[float, int, float]]:
        """(rpm, number of tests, predicted depth [mm]) per distinct planned speed, by speed."""
        speeds, first, counts = np.unique(self.rpm, return_index=True, return_counts=True)
        return [(float(s), int(c), float(self.predicted_depth_mm[i])) for s, i, c in zip(speeds, first, counts)]

    def figure(self, ax=None, *, title: str | None = None):
        """The planned tests at their predicted depths (:func:`millstab.plot.identify.plot_design`; the SLD
        they were planned around is a new computation: :func:`millstab.api.identify.design_figure`), into
        ``ax`` or a new figure, which it returns."""
        from millstab.plot.identify import plot_design

        return plot_design(self, title=title, ax=ax)

    def summary(self) -> str:
        """What ``millstab design`` prints under its table of standard errors, one line each: which parameters
        the plan pins, its criterion against evenly spaced tests and its efficiency bound, the parameters it
        gives up (†) or no test determines, and the planned speeds."""
        lines = [("* = the parameters the plan pins: it minimises the sum of their squared relative standard errors, "
                  f"averaged over {self.samples} parameter samples (limits from the {self.engine} engine)")]
        ratio = self.criterion_design / self.criterion_uniform
        if self.uniform:
            head = (f"criterion (expected Σ σ² of the * parameters): the {self.rpm.size} tests evenly spaced over the "
                    "candidates are as good as any plan found, so they are the plan")
        else:
            head = (f"criterion (expected Σ σ² of the * parameters): planned {self.criterion_design:.3g}, evenly "
                    f"spaced {self.criterion_uniform:.3g} ({ratio:.2f}×)")
        lines.append(f"{head}; efficiency of these {self.rpm.size} tests ≥ {self.efficiency:.3f} against the best "
                     f"continuous design (that design itself ≥ {self.efficiency_continuous:.3f})")
        if (self.sigma_design_mean is not None and self.sigma_uniform_mean is not None
                and np.any(self.sigma_design_mean > self.sigma_uniform_mean * (1 + 1e-9))):
            lines.append("† = determined less well than by the evenly spaced tests: the plan gives this up for larger "
                         "gains elsewhere (use --target to pin the parameters that matter most)")
        if not np.all(np.isfinite(self.sigma_design)):
            lost = ", ".join(nm for nm, v in zip(self.names, self.sigma_design) if not np.isfinite(v))
            lines.append(f"note: at the values shown {lost} are not determined by any boundary points (e.g. identical "
                         "x and y modes in a symmetric cut); the plan serves the nearby structures it averages over. "
                         "Use --axisymmetric to plan for tied x and y, or --fit to plan around an identified "
                         "structure.")
        lines.append("planned speeds, rev/min (tests): "
                     + ", ".join(f"{r:.0f} ({c})" if c > 1 else f"{r:.0f}" for r, c, _ in self.tests()))
        return "\n".join(lines)

    def errors(self) -> tuple[tuple[str, ...], list[tuple[str, ...]], str]:
        """What ``millstab design`` prints above :meth:`summary`: (header, rows as text, caption): per parameter
        (* = a target) its value in the trade's units and its relative standard error with the measured points
        (if any), with n evenly spaced tests and with the n planned ones († = worse than evenly spaced)."""
        from millstab.params import shown_value

        def pct(v: float) -> str:
            return "not determined" if not np.isfinite(v) else f"± {100 * v:.3g} %"

        n = self.rpm.size
        header = ("parameter", "value") + (("measured points",) if self.sigma_existing is not None else ()) + (
            f"+ {n} evenly spaced", f"+ {n} planned")
        rows = []
        for i, name in enumerate(self.names):
            row = [name + (" *" if name in self.target else ""), shown_value(name, self.theta[i])]
            if self.sigma_existing is not None:
                row.append(pct(self.sigma_existing_mean[i]))
            worse = self.sigma_design_mean[i] > self.sigma_uniform_mean[i] * (1 + 1e-9)
            row += [pct(self.sigma_uniform_mean[i]), pct(self.sigma_design_mean[i]) + (" †" if worse else "")]
            rows.append(tuple(row))
        caption = (f"relative standard errors at {self.noise:.3g} depth noise and {self.speed_noise:.3g} speed noise: "
                   f"root-mean-square over the {self.samples} parameter samples the plan serves (the values shown and "
                   "draws around them)")
        return header, rows, caption

    def table(self) -> tuple[tuple[str, ...], tuple[list, ...]]:
        """(header, columns) of the plan CSV (``millstab design --out``, the web app's plan.csv): rpm (to
        0.001 rev/min), tests, predicted_depth_mm, one row per distinct planned speed."""
        tests = self.tests()
        return ("rpm", "tests", "predicted_depth_mm"), ([round(r, 3) for r, _, _ in tests], [c for _, c, _ in tests],
                                                        [d for _, _, d in tests])

    def to_json(self) -> dict[str, Any]:
        """The JSON form (plain types, schema ``millstab.design/1``): every attribute under its own name,
        arrays as lists, a relative standard error the tests cannot determine as ``"inf"``, ``null`` for
        an absent array (no existing points) or a criterion not computed (NaN); conventions of
        :mod:`millstab.jsondoc`. ``tests`` adds the per-speed plan (rpm, tests, predicted depth [mm]).

        Raises:
            ValueError: a NaN in an array (a result never carries one silently).
        """
        doc: dict[str, Any] = {"schema": DESIGN_SCHEMA, "units": {"rpm": "rev/min", "theta": "Hz, N/m, -",
                                                                  "sigma": "relative", "predicted_depth_mm": "mm"}}
        for name in _DESIGN_ARRAYS:
            doc[name] = floats_out(getattr(self, name), f"design.{name}")
        for name in ("names", "target"):
            doc[name] = list(getattr(self, name))
        for name in ("noise", "speed_noise", "efficiency", "efficiency_continuous"):
            doc[name] = number_out(getattr(self, name), f"design.{name}")
        for name in ("criterion_design", "criterion_uniform"):
            doc[name] = number_out(getattr(self, name), f"design.{name}", nan_ok=True)
        doc.update(iterations=int(self.iterations), samples=int(self.samples), uniform=bool(self.uniform),
                   engine=self.engine,
                   tests=[{"rpm": r, "tests": c, "predicted_depth_mm": number_out(d, "design.tests")}
                          for r, c, d in self.tests()])
        return doc

    @staticmethod
    def from_json(doc: Any, source: str = "design") -> "SpeedDesign":
        """Rebuild a :class:`SpeedDesign` from :meth:`to_json` output (``tests`` is derived, not read).

        Raises:
            InputError: another schema, a missing field or one of the wrong kind (named with ``source``).
        """
        check_schema(doc, DESIGN_SCHEMA, source)
        arrays = {}
        for name in _DESIGN_ARRAYS:
            optional = name in _DESIGN_OPTIONAL
            value = need(doc, name, source, (list, type(None)) if optional else list)
            arrays[name] = None if value is None else floats_in(value, f"{source}: {name}")
        names = names_in(need(doc, "names", source), f"{source}: names")
        target = names_in(need(doc, "target", source), f"{source}: target")
        nums = {name: number_in(need(doc, name, source), f"{source}: {name}",
                                nan_ok=name.startswith("criterion"))
                for name in ("noise", "speed_noise", "efficiency", "efficiency_continuous", "criterion_design",
                             "criterion_uniform")}
        return SpeedDesign(names=names, target=target,
                           iterations=int_in(need(doc, "iterations", source), f"{source}: iterations"),
                           samples=int_in(need(doc, "samples", source), f"{source}: samples"),
                           uniform=need(doc, "uniform", source, bool),
                           engine=str(doc.get("engine", "zoa")),  # a plan written before it was recorded: zoa
                           **arrays, **nums)


#: the ``"schema"`` of :meth:`SpeedDesign.to_json`
DESIGN_SCHEMA = "millstab.design/1"
#: SpeedDesign's float arrays, and those that may be absent (``None``)
_DESIGN_ARRAYS = ("rpm", "candidates", "weights", "theta", "sigma_existing", "sigma_uniform", "sigma_design",
                  "predicted_depth_mm", "sigma_existing_mean", "sigma_uniform_mean", "sigma_design_mean")
_DESIGN_OPTIONAL = ("sigma_existing", "sigma_existing_mean", "sigma_uniform_mean", "sigma_design_mean")


def log_jacobians(par: Parameterization, cutting: Cutting, theta: np.ndarray, rpm: np.ndarray,
                  engine: str = "zoa") -> tuple[np.ndarray, np.ndarray]:
    """Sensitivities of ln b at each row of ``theta`` (S, P) and speeds ``rpm`` (m,).

    Returns (J (S, m, P) = ∂ ln b/∂ ln θ, slope (S, m) = ∂ ln b/∂ ln Ω), by central differences
    (step :data:`FD_STEP`) from ONE engine call. Where a sample has no finite limit the rows are
    zero (no boundary point can be measured there).
    """
    jac, slope = log_jacobian(forward(par, cutting, engine), theta, rpm, rel_step=FD_STEP, central=True, speed=True)
    ok = np.isfinite(jac).all(axis=2) & np.isfinite(slope)
    return np.where(ok[..., None], jac, 0.0), np.where(ok, slope, 0.0)


def prior_covariance(par: Parameterization, spread: dict[str, float] | None = None) -> np.ndarray:
    """Diagonal covariance of ln θ from per-kind spreads (default :data:`PRIOR_SPREAD`)."""
    sp = {**PRIOR_SPREAD, **(spread or {})}
    return np.diag([sp[par.kind(n)] ** 2 for n in par.free])


def fit_covariance(std_errors: Sequence[float], correlation, theta: Sequence[float]) -> np.ndarray:
    """Covariance of ln θ from a fit's standard errors [physical units] and correlation matrix."""
    rel = np.asarray(std_errors, float) / np.asarray(theta, float)
    corr = np.asarray(correlation, float)
    return rel[:, None] * corr * rel[None, :]


def relative_sigma(info: np.ndarray) -> np.ndarray:
    """Relative standard errors √diag(M⁻¹) from information matrices (..., P, P); inf where singular."""
    info = np.asarray(info, float)
    out = np.full(info.shape[:-1], np.inf)
    scale = np.sqrt(np.clip(np.diagonal(info, axis1=-2, axis2=-1), 1e-300, None))
    # scaled to unit diagonal first, so the conditioning test is independent of the parameters' units
    m = info / (scale[..., :, None] * scale[..., None, :])
    cond = np.linalg.cond(m)
    ok = np.isfinite(cond) & (cond < 1e12)
    if np.any(ok):
        inv = np.linalg.inv(m[ok])
        out[ok] = np.sqrt(np.clip(np.diagonal(inv, axis1=-2, axis2=-1), 0, None)) / scale[ok]
    return out


def optimal_weights(jac: np.ndarray, n: int, *, info0: np.ndarray | None = None, target: np.ndarray | None = None,
                    iterations: int = 2000, tol: float = 1e-3) -> tuple[np.ndarray, float, int]:
    """Bayesian A-optimal continuous design over candidates.

    Each iteration is a multiplicative step w_i ← w_i d_i / Σ w d (Silvey, Titterington & Torsney
    1978), which moves all weights at once but empties poor candidates only geometrically slowly,
    followed by a vertex-exchange step (Böhning 1986): weight moves from the worst supported candidate
    straight to the best one, by an exact line search over the amount. Together (the idea of Yu's 2011
    cocktail algorithm) they reach designs concentrated on a few speeds hundreds of times faster than
    the multiplicative step alone.

    Args:
        jac: (S, m, P) per-sample Jacobian rows of the m candidates, already divided by the noise σ.
        n: number of tests the weights will be spread over (the existing information counts in full).
        info0: (S, P, P) information of the existing points per sample, or ``None``.
        target: indices of the parameters the criterion sums (default all).
        iterations: at most this many updates; tol: stop when the equivalence-theorem gap
            max_i d_i / Σ w d − 1 falls below it.
    Returns:
        (weights (m,), efficiency lower bound, iterations used).
    """
    s, m, p = jac.shape
    c = np.eye(p)[:, np.arange(p) if target is None else np.asarray(target)]
    cs = np.broadcast_to(c, (s, p, c.shape[1]))
    # a small ridge keeps samples whose candidates miss a parameter finite (:func:`ridge`; it is ~1e-9 of a typical
    # information and so never changes a design that does determine the parameter)
    m0 = (np.zeros((s, p, p)) if info0 is None else np.asarray(info0, float)) + ridge(jac)
    jac_t = np.transpose(jac, (0, 2, 1))
    outer = lambda i: jac[:, i, :, None] * jac[:, i, None, :]  # noqa: E731  (S, P, P) of candidate i

    def phi(info: np.ndarray) -> np.ndarray:
        """E tr(Cᵀ M⁻¹ C) for a stack of information matrices (..., S, P, P)."""
        inv_c = np.linalg.solve(info, np.broadcast_to(cs, info.shape[:-1] + (c.shape[1],)))
        return (cs * inv_c).sum(axis=(-3, -2, -1)) / s

    w = np.full(m, 1.0 / m)
    fractions = np.array([1.0, 0.5, 0.25, 0.125, 0.0625, 0.03125, 0.0])
    eff, it = 0.0, 0
    info = m0 + n * (jac_t @ (w[None, :, None] * jac))
    for it in range(1, iterations + 1):
        inv_c = np.linalg.solve(info, cs)  # M⁻¹ C per sample (S, P, T)
        crit = float((cs * inv_c).sum()) / s
        d = ((jac @ inv_c) ** 2).sum(axis=2).mean(axis=0)  # −∂Φ/∂w_i / n
        wd = float(w @ d)
        # convexity of Φ in w: Φ(w*) ≥ Φ(w) − n (max d − w·d)  ⇒  efficiency Φ(w*)/Φ(w) ≥ 1 − n(max d − w·d)/Φ
        eff = max(0.0, 1.0 - n * (float(d.max()) - wd) / crit)
        if d.max() <= wd * (1 + tol):
            break
        w = w * d / wd
        # vertex exchange: move weight from the worst supported candidate to the best one
        info = m0 + n * (jac_t @ (w[None, :, None] * jac))
        inv_c = np.linalg.solve(info, cs)
        d = ((jac @ inv_c) ** 2).sum(axis=2).mean(axis=0)
        support = np.flatnonzero(w > 1e-12)
        best, worst = int(np.argmax(d)), int(support[np.argmin(d[support])])
        if best != worst:
            moves = fractions * w[worst]
            swap = n * (outer(best) - outer(worst))
            t = moves[int(np.argmin(phi(info[None] + moves[:, None, None, None] * swap[None])))]
            w[best] += t
            w[worst] -= t
            info = info + t * swap  # the next iteration's information, without another full product
    return w / w.sum(), eff, it


def round_design(weights: np.ndarray, n: int) -> np.ndarray:
    """Integer test counts (m,) summing to n from continuous weights (largest remainders)."""
    exact = n * np.asarray(weights, float)
    counts = np.floor(exact).astype(int)
    short = n - int(counts.sum())
    counts[np.argsort(counts - exact, kind="stable")[:short]] += 1
    return counts


def ridge(jac: np.ndarray) -> np.ndarray:
    """The small ridge every information matrix of a plan carries: 1e-9 × the mean over samples of
    Σ_candidates ‖j‖², times the identity (P, P). It keeps samples whose planned speeds miss a parameter
    finite — a tiny prior: where a sample's tests do determine the parameters it changes nothing, where
    they nearly miss one it caps that sample's weight in the criterion."""
    return 1e-9 * float(np.mean(np.einsum("smi,smi->s", jac, jac))) * np.eye(jac.shape[-1])


def criterion(jac: np.ndarray, counts: np.ndarray, info0: np.ndarray | None, target: np.ndarray,
              ridge: np.ndarray | float = 0.0) -> np.ndarray:
    """The design criterion E_θ tr(Cᵀ M⁻¹ C) for test counts (..., m) over candidates with per-sample
    rows ``jac`` (S, m, P) (already divided by the noise), M = M₀ + ridge + Σ_i c_i j_i j_iᵀ; ``target``
    the parameter indices C selects (a plan's own criterion uses ``ridge`` = :func:`ridge` of the candidate
    rows). Returns one value per leading index of ``counts`` (or a scalar)."""
    c = np.asarray(counts, float)
    s, _, p = jac.shape
    info = np.einsum("smi,...m,smj->...sij", jac, c, jac) + ridge
    if info0 is not None:
        info = info + info0
    sel = np.eye(p)[:, np.asarray(target)]
    inv_c = np.linalg.solve(info, np.broadcast_to(sel, info.shape[:-1] + (sel.shape[1],)))
    return np.einsum("pt,...spt->...", sel, inv_c) / s


def improve_counts(jac: np.ndarray, counts: np.ndarray, info0: np.ndarray | None, target: np.ndarray,
                   ridge: np.ndarray | float = 0.0, max_moves: int | None = None, n_add: int = 4) -> np.ndarray:
    """Improve an integer design by moving single tests (a discrete exchange, as Fedorov's algorithm).

    Each move tries, in one batched evaluation, taking one test from every supported candidate and
    giving it to each of the ``n_add`` candidates with the largest directional derivative
    d_i = E‖Cᵀ M⁻¹ j_i‖², and keeps the best move if it lowers the criterion; it stops when none
    does (at most ``max_moves``, default 2n, moves). The total number of tests is kept. (Trial designs
    that lose a parameter are kept finite by a 1e-12 relative ridge of their own, and so never win.)"""
    c = np.asarray(counts, int).copy()
    n = int(c.sum())
    s, m, p = jac.shape
    sel = np.eye(p)[:, np.asarray(target)]
    info = np.einsum("smi,m,smj->sij", jac, c.astype(float), jac) + ridge + (0 if info0 is None else info0)
    info = info + 1e-12 * np.trace(info, axis1=1, axis2=2)[:, None, None] / p * np.eye(p)

    def phi(mats: np.ndarray) -> np.ndarray:  # E tr(Cᵀ M⁻¹ C) for (..., S, P, P)
        inv_c = np.linalg.solve(mats, np.broadcast_to(sel, mats.shape[:-1] + (sel.shape[1],)))
        return np.einsum("pt,...spt->...", sel, inv_c) / s

    best = float(phi(info))
    for _ in range(max_moves if max_moves is not None else 2 * n):
        inv_c = np.linalg.solve(info, np.broadcast_to(sel, (s, p, sel.shape[1])))
        d = ((jac @ inv_c) ** 2).sum(axis=2).mean(axis=0)
        add = np.argsort(-d, kind="stable")[:n_add]
        rem = np.flatnonzero(c > 0)
        rank1 = lambda idx: jac[:, idx, :, None] * jac[:, idx, None, :]  # noqa: E731  (S, K, P, P)
        # info after moving one test from rem[b] to add[a], for every pair: (A, B, S, P, P)
        trial = (info[None, None] + np.moveaxis(rank1(add), 1, 0)[:, None] - np.moveaxis(rank1(rem), 1, 0)[None, :])
        vals = phi(trial)
        a, b = np.unravel_index(int(np.argmin(vals)), vals.shape)
        if not vals[a, b] < best * (1 - 1e-9) or add[a] == rem[b]:
            break
        best, info = float(vals[a, b]), trial[a, b]
        c[rem[b]] -= 1
        c[add[a]] += 1
    return c


def evenly_spaced(candidates: np.ndarray, n: int) -> np.ndarray:
    """Counts (m,) of n tests evenly spaced over sorted candidates: the candidate nearest to each of n
    evenly spaced speeds from the first to the last (the middle one for n = 1)."""
    cand = np.asarray(candidates, float)
    targets = np.linspace(cand[0], cand[-1], n) if n > 1 else np.array([(cand[0] + cand[-1]) / 2])
    idx = np.clip(np.searchsorted(cand, targets), 1, cand.size - 1)
    idx = np.where(np.abs(cand[idx - 1] - targets) <= np.abs(cand[idx] - targets), idx - 1, idx)
    return np.bincount(idx, minlength=cand.size)


@dataclass(frozen=True)
class DesignOptions:
    """The settings of :func:`design_speeds` (its docstring explains each), checked when built: a noise that
    is not a finite number ≥ 0 (the depth noise > 0) or a sample count < 1 is an InputError naming it.
    ``design_speeds(..., options=DesignOptions(samples=4))`` and ``design_speeds(..., samples=4)`` are the
    same call (the keywords replace fields of ``options``)."""

    noise: float = 0.02
    speed_noise: float = SPEED_NOISE
    samples: int = 16
    iterations: int = 2000

    def __post_init__(self) -> None:
        for field_name, v in (("noise", self.noise), ("speed_noise", self.speed_noise)):
            if not (math.isfinite(v) and v >= 0):
                raise InputError(field_name, v,
                                 "a relative standard deviation must be a finite number >= 0 (0.02 = 2 %)")
        if self.noise == 0:
            raise InputError("noise", self.noise, "relative depth noise must be > 0 (0.02 = 2 %)")
        if not (isinstance(self.samples, (int, np.integer)) and self.samples >= 1):
            raise InputError("samples", self.samples, "must be an integer >= 1")


def design_speeds(par: Parameterization, cutting: Cutting, candidates, n: int, *, theta=None, cov_u=None,
                  alternatives: Sequence[Sequence[float]] = (), existing_rpm=None, existing_weight=None,
                  target: Sequence[str] | None = None, options: DesignOptions | None = None, seed: int = 0,
                  engine: str = "zoa", **tuning) -> SpeedDesign:
    """Plan ``n`` boundary-point tests among ``candidates`` [rev/min] that best determine θ.

    Args:
        par: the free parameters (their base structure supplies the fixed ones).
        cutting: the cutting conditions of the tests.
        candidates: speeds the tests may use [rev/min] (e.g. the spindle's range on a fine grid).
        n: number of tests to plan (≥ 1).
        theta: centre of the current knowledge (P,) [Hz, N/m, -]; default the base structure's values.
        cov_u: covariance of ln θ (P, P), e.g. :func:`fit_covariance` of a first fit; default
            :func:`prior_covariance`.
        alternatives: other parameter sets (P,) that explain the data so far as well as ``theta`` (a
            fit's alternatives); the samples are shared among all centres, so the plan serves each.
        existing_rpm, existing_weight: speeds [rev/min] (and weights) of points already measured, whose
            information the plan adds to.
        target: parameters whose relative standard errors the plan minimises (sum of squares); default
            all free parameters. ``["fn_x", "fn_y"]`` pins the natural frequencies first.
        options: the settings (:class:`DesignOptions`: noise, speed_noise, samples, iterations);
            keywords named as its fields replace them.
        noise: relative standard deviation of a measured limiting depth (0.02 = 2 %).
        speed_noise: relative uncertainty of where the boundary sits in speed (see :data:`SPEED_NOISE`).
        samples: θ samples the criterion averages over (each centre itself, then draws from
            N(ln centre, cov_u) with ``seed``, clipped to the bounds).
    Raises:
        InputError: bad n, noise, samples, candidates or target names; or candidates that cannot
            determine the target parameters even all together.
    """
    cand = np.unique(np.asarray(candidates, dtype=float).ravel())
    if cand.size < 2 or not np.all(np.isfinite(cand)) or cand[0] <= 0:
        raise InputError("candidates", f"{cand.size} speeds", "need at least 2 finite positive speeds (rev/min)")
    if not (isinstance(n, (int, np.integer)) and n >= 1):
        raise InputError("n", n, "the number of tests to plan must be an integer >= 1")
    o = options_with(options, DesignOptions, tuning, "design_speeds")  # checked when built
    noise, speed_noise, samples, iterations = o.noise, o.speed_noise, o.samples, o.iterations
    names = par.free
    tgt = tuple(names if not target else (par.canonical(t) for t in target))
    unknown = [t for t in tgt if t not in names]
    if unknown:
        raise InputError("target", unknown[0], f"not a free parameter; free: {', '.join(names)}")
    t_idx = np.array([names.index(t) for t in tgt])
    centre = par.theta0 if theta is None else np.asarray(theta, dtype=float)
    cov = prior_covariance(par) if cov_u is None else np.asarray(cov_u, dtype=float)
    if cov.shape != (par.size, par.size):
        raise InputError("cov_u", cov.shape, f"need a ({par.size}, {par.size}) covariance of ln θ")
    u = _samples(np.log(np.vstack([centre, *[np.asarray(a, float) for a in alternatives]])), cov, samples,
                 np.log(par.lower), np.log(par.upper), seed)
    ex = None if existing_rpm is None else np.asarray(existing_rpm, dtype=float).ravel()
    n_ex = 0 if ex is None else ex.size
    if n + n_ex < par.size:
        raise InputError("n", n, f"{n} tests{f' and {n_ex} measured points' if n_ex else ''} cannot determine "
                         f"{par.size} free parameters: plan at least {par.size - n_ex}, or free fewer parameters")
    speeds = cand if ex is None else np.concatenate([cand, ex])
    jac_all, slope = log_jacobians(par, cutting, np.exp(u), speeds, engine)
    # a point's ln-depth variance: depth noise plus the speed uncertainty carried through the slope
    jac_all = jac_all / np.sqrt(noise ** 2 + (speed_noise * slope) ** 2)[..., None]
    jac, jac_ex = jac_all[:, :cand.size], jac_all[:, cand.size:]
    info0 = None
    if ex is not None and ex.size:
        wex = np.ones(ex.size) if existing_weight is None else np.asarray(existing_weight, float).ravel()
        info0 = np.einsum("smi,m,smj->sij", jac_ex, wex, jac_ex)
    # each sample must be determinable by all the candidates together; samples that are not (identical
    # x and y modes in a symmetric cut enter the boundary identically) are left out of the criterion
    every = (0 if info0 is None else info0) + n * (np.transpose(jac, (0, 2, 1)) @ jac) / cand.size
    keep = np.isfinite(relative_sigma(every)[:, t_idx]).all(axis=1)
    if not keep.any():
        bad = names[int(t_idx[np.argmax(~np.isfinite(relative_sigma(every[0])[t_idx]))])]
        raise InputError("candidates", f"{cand[0]:.0f}-{cand[-1]:.0f} rpm",
                         f"boundary points at these speeds cannot determine {bad}: widen the speed range, or fix or "
                         "tie parameters the boundary cannot tell apart")
    jac_c, info0_c = jac[0], None if info0 is None else info0[0]  # the centre, for the reported errors
    jac, info0 = jac[keep], None if info0 is None else info0[keep]
    w, eff_w, its = optimal_weights(jac, n, info0=info0, target=t_idx, iterations=iterations)
    # the criterion exactly as optimal_weights sees it (same ridge), for the rounded and the even plans
    rdg = ridge(jac)
    counts = improve_counts(jac, round_design(w, n), info0, t_idx, rdg)
    even = evenly_spaced(cand, n)
    phi_w, phi_plan, phi_even = criterion(jac, np.stack([n * w, counts, even]), info0, t_idx, rdg)
    uniform = not phi_plan < phi_even  # rounding or a stuck exchange: never plan worse than even spacing
    if uniform:
        counts, phi_plan = even, phi_even
    rpm = np.repeat(cand, counts)

    def sigma(counts_: np.ndarray) -> np.ndarray:
        info = (0 if info0_c is None else info0_c) + np.einsum("mi,m,mj->ij", jac_c, counts_.astype(float), jac_c)
        return relative_sigma(info)

    def sigma_mean(counts_: np.ndarray | None) -> np.ndarray:
        info = (0 if info0 is None else info0) + rdg
        if counts_ is not None:
            info = info + np.einsum("smi,m,smj->sij", jac, counts_.astype(float), jac)
        return np.sqrt(np.mean(relative_sigma(info) ** 2, axis=0))

    speeds, at = np.unique(rpm, return_inverse=True)  # (the engine wants distinct speeds)
    depth = forward(par, cutting, engine)(centre[None], speeds)[0, at] * 1e3
    return SpeedDesign(
        rpm=rpm, candidates=cand, weights=w, names=names, target=tgt, theta=centre, noise=float(noise),
        engine=engine, speed_noise=float(speed_noise),
        sigma_existing=None if info0_c is None else relative_sigma(info0_c),
        sigma_uniform=sigma(even), sigma_design=sigma(counts),
        efficiency=float(min(1.0, eff_w * phi_w / phi_plan)), iterations=its, samples=int(keep.sum()),
        predicted_depth_mm=depth, efficiency_continuous=float(eff_w), criterion_design=float(phi_plan),
        criterion_uniform=float(phi_even), uniform=bool(uniform),
        sigma_existing_mean=None if info0 is None else sigma_mean(None), sigma_uniform_mean=sigma_mean(even),
        sigma_design_mean=sigma_mean(counts))


def design_after_fit(fit, cutting: Cutting, candidates, n: int, **options) -> SpeedDesign:
    """:func:`design_speeds` around a :class:`~millstab.identify.result.Fit`: its estimate, its
    covariance (from standard errors and correlation; the prior spread where it has none) and its
    alternative solutions. A fit that reports x and y tied (:mod:`~millstab.identify.tie`) is planned
    for in the tied parameters. Pass the fitted points' speeds as ``existing_rpm`` to plan the next tests.

    Raises:
        InputError: the fit was made under other cutting conditions than ``cutting``.
    """
    if fit.cutting is not None:
        diff = cutting_difference(cutting_record(fit.cutting), cutting)
        if diff:
            raise InputError("fit", "fitted under other cutting conditions",
                             f"{diff}; plan with the conditions the fit's points were measured under")
    alts = [[a["estimate"][name] for name in fit.names] for a in fit.alternatives]
    par, theta, cov, alts = fit_view(fit.par, cutting, fit.estimate, fit.std_errors, fit.correlation, alts,
                                     is_tied(fit))
    return design_speeds(par, cutting, candidates, n, theta=theta, cov_u=cov, alternatives=alts, **options)


def fit_view(par: Parameterization, cutting: Cutting, estimate, std_errors, correlation, alternatives, tied: bool):
    """(parameterization, θ, covariance of ln θ or ``None``, alternatives) to plan around a fit's results.

    With ``tied`` (the fit chose x = y) the tied parameterization, whose θ takes each pair's common value,
    and no alternatives (the free solution the tied fit lists is not a different structure to serve)."""
    theta = np.asarray(estimate, float)
    se = None if std_errors is None else np.asarray(std_errors, float)
    corr = None if correlation is None else np.asarray(correlation, float)
    if tied:
        made = tied_parameterization(par, cutting)
        if made is not None:
            par, index = made
            first = [int(np.argmax(index == j)) for j in range(par.size)]
            theta = theta[first]
            se = None if se is None else se[first]
            corr = None if corr is None else corr[np.ix_(first, first)]
            alternatives = []
    cov = None
    if se is not None and corr is not None and np.all(np.isfinite(se)):
        cov = fit_covariance(se, corr, theta)
    return par, theta, cov, [np.asarray(a, float) for a in alternatives]


def _samples(centres: np.ndarray, cov: np.ndarray, samples: int, lo: np.ndarray, hi: np.ndarray,
             seed: int) -> np.ndarray:
    """ln θ samples (S, P): every centre (C, P) first, then draws N(centre, cov) taking turns over the
    centres, S = max(samples, C); clipped to [lo, hi]. An eigen-factor of cov, which may be singular."""
    rng = np.random.default_rng(seed)
    vals, vecs = np.linalg.eigh((cov + cov.T) / 2)
    factor = vecs * np.sqrt(np.clip(vals, 0, None))
    extra = max(samples - centres.shape[0], 0)
    draws = centres[np.arange(extra) % centres.shape[0]] + rng.standard_normal((extra, centres.shape[1])) @ factor.T
    return np.clip(np.vstack([centres, draws]), lo, hi)


__all__ = ["DESIGN_SCHEMA", "PRIOR_SPREAD", "SPEED_NOISE", "DesignOptions", "SpeedDesign", "criterion",
           "design_after_fit", "design_speeds", "evenly_spaced", "fit_covariance", "fit_view", "improve_counts",
           "log_jacobians", "optimal_weights", "prior_covariance", "relative_sigma", "ridge", "round_design"]
