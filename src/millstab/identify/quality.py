"""How far a fit can be trusted: degrees of freedom, the noise its standard errors use, and whether its
residuals say the model (or the basin) is wrong.

Standard errors of a least-squares fit are σ·√diag((JᵀJ)⁻¹) with σ the standard deviation of one
residual. Which σ (:func:`error_sigma`):

* a **stated** depth noise (``noise``, relative: 0.02 = 2 %): σ = max(stated, σ̂) — the residual
  scatter σ̂ = √(RSS/(n − p)) only replaces it when larger (then the fit is poorer than the noise
  explains, and the errors widen with it);
* no stated noise and at least :data:`FEW_DOF` degrees of freedom: σ = σ̂, the usual estimate;
* no stated noise and fewer (down to none): σ̂ rests on too few residuals to be believed (with
  n = p the fit interpolates the points and RSS = 0, so σ̂ = 0 and the errors would be 0; with one spare
  point σ̂²/σ² ~ χ²₁ is below 1/100 one time in twelve), so σ = max(:data:`ASSUMED_NOISE`, σ̂) and the
  fit says so.

Warnings with structured codes (``Fit.codes``; :func:`diagnose`):

* ``no_dof`` / ``few_dof``: as above;
* ``poor_fit``: residuals well above the stated noise (χ² test and σ̂ ≥ 1.5× stated), or, without
  stated noise, above :data:`POOR_RMS` (more than a measured boundary's plausible scatter);
* ``residual_structure``: the residual signs, taken in speed order, form fewer runs than chance allows
  (Wald–Wolfowitz runs test, one-sided p < :data:`RUNS_ALPHA`) while the residuals are above the
  engine's own accuracy: systematic misfit — a wrong basin or a model that cannot follow the points;
* ``zoa_model``: the zero-order engine on a cut where its model is known to be approximate (radial
  immersion a/D < :data:`ZOA_POOR_IMMERSION`, or two or fewer teeth: strongly time-varying forces,
  flip lobes; see the field notes); suggests the accurate engine (:func:`accurate_engine`: ``--engine
  spectral``, or ``sdm`` where the cut carries process damping, which only sdm models);
* ``outliers``: points whose residual is beyond :data:`OUTLIER_Z` robust σ (:func:`outliers`), named by
  speed and depth; a fit with a robust ``loss`` leaves them out of its standard errors, its noise record
  and its x = y test (:func:`kept_points`), a linear fit is told to refit with one;
* ``at_bound``: an estimate sits on its search bound (the optimum may lie outside);
* ``flat_points``: every boundary depth is the same — no lobe to locate a natural frequency by (often
  a wrong column or a constant placeholder in the file).

Every fit carries its per-point residuals (``Fit.residuals``: speed, measured and fitted depth, residual,
outlier flag), so the points behind an ``outliers`` or ``poor_fit`` warning can be looked up.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

from millstab.stability import INTERRUPTED_BELOW, get_engine

#: fewer residual degrees of freedom than this: the residual scatter alone does not set the errors
FEW_DOF = 10
#: relative depth noise assumed when none is stated and the residuals cannot estimate it (2 %: a
#: measured limiting depth is rarely known better; the seed paper's stand-in data carry 3 %)
ASSUMED_NOISE = 0.02
#: RMS relative residual above which a fit without stated noise is poor (5 %: more than the scatter of
#: a measured boundary)
POOR_RMS = 0.05
#: residual scatter / stated noise above which (with a significant χ² test) a fit is poor
POOR_RATIO = 1.5
#: significance of the χ² and runs tests
CHI2_ALPHA = 0.01
RUNS_ALPHA = 0.01
#: below this radial immersion a/D the zero-order model is a poor one (field notes: ~59 % off at 0.05)
ZOA_POOR_IMMERSION = 0.3
#: standard errors use the residual scatter, a stated noise, or an assumed one
SOURCES = ("residuals", "stated", "assumed")
#: a residual beyond this many robust σ marks its point an outlier (:func:`outliers`): a Gaussian point
#: passes 4σ one time in 16 000 (30 points: one fit in ~500, more with the median's own scatter), while a
#: depth ×1.2 off among 2 % noise stands at ~9σ; the field report's 30 points hold a 3.2σ noise point
OUTLIER_Z = 4.0
#: σ = this × the median |residual| for Gaussian residuals (the MAD's consistency factor)
MAD_SIGMA = 1.4826


def residual_scale(residual: str, depth_mm: np.ndarray) -> float:
    """Residual units per unit of relative depth noise: 1 for log residuals (ln(1 + e) ≈ e), the median
    measured depth [mm] for mm residuals."""
    return 1.0 if residual == "log" else float(np.median(depth_mm))


def check_noise(noise: float | None, field: str = "noise") -> float | None:
    """A stated relative depth noise: ``None`` or a finite number > 0 (0.02 = 2 %); InputError otherwise."""
    from millstab.errors import InputError

    if noise is None:
        return None
    try:
        v = float(noise)
    except (TypeError, ValueError):
        raise InputError(field, noise, "a relative standard deviation, e.g. 0.02 for 2 %") from None
    if not (math.isfinite(v) and 0 < v < 1):
        raise InputError(field, noise, "a relative standard deviation must be > 0 and < 1 (0.02 = 2 %)")
    return v


def error_sigma(rss: float, n: int, p: int, scale: float, noise: float | None) -> dict:
    """The σ of one residual the standard errors use (module docstring).

    Args:
        rss: residual sum of squares; n: boundary points; p: free parameters.
        scale: :func:`residual_scale`; noise: stated relative depth noise or ``None``.
    Returns:
        {"dof", "sigma" (residual units), "source" (one of :data:`SOURCES`), "estimated" (σ̂ relative,
        ``None`` without degrees of freedom), "stated", "assumed" (relative or ``None``)}.
    """
    dof = n - p
    sig_hat = math.sqrt(rss / dof) if dof > 0 else None
    out = {"dof": dof, "estimated": None if sig_hat is None else sig_hat / scale, "stated": noise, "assumed": None}
    if noise is not None:
        floor, source = noise * scale, "stated"
    elif dof >= FEW_DOF:
        return {**out, "sigma": sig_hat, "source": "residuals"}
    else:
        floor, source = ASSUMED_NOISE * scale, "assumed"
        out["assumed"] = ASSUMED_NOISE
    if sig_hat is not None and sig_hat > floor:
        return {**out, "sigma": sig_hat, "source": "residuals"}
    return {**out, "sigma": floor, "source": source}


def runs_test(residuals: np.ndarray, rpm: np.ndarray) -> dict | None:
    """Wald–Wolfowitz runs test on the signs of the residuals in speed order (zeros dropped).

    Returns {"runs", "expected", "z", "p_value"} (one-sided: too few runs, i.e. residuals of one sign
    cluster along the speed axis), or ``None`` with fewer than 8 signed residuals or only one sign.
    """
    r = np.asarray(residuals, float)[np.argsort(rpm, kind="stable")]
    s = np.sign(r[r != 0])
    n1, n2 = int((s > 0).sum()), int((s < 0).sum())
    n = n1 + n2
    if n < 8 or n1 == 0 or n2 == 0:
        return None
    runs = 1 + int(np.count_nonzero(s[1:] != s[:-1]))
    mean = 2.0 * n1 * n2 / n + 1
    var = 2.0 * n1 * n2 * (2.0 * n1 * n2 - n) / (n * n * (n - 1))
    z = (runs - mean) / math.sqrt(var) if var > 0 else 0.0
    return {"runs": runs, "expected": mean, "z": z, "p_value": float(stats.norm.cdf(z))}


def robust_sigma(residuals: np.ndarray, p: int) -> float:
    """σ of one residual from the median |residual| (residual units): MAD_SIGMA · median|r| · √(n/(n − p)),
    the last factor undoing the shrinkage of a fit's residuals by its p parameters (as σ̂ = √(RSS/(n − p))
    does); unmoved by a few outliers, where σ̂ grows with their squares."""
    r = np.abs(np.asarray(residuals, float))
    n = r.size
    return MAD_SIGMA * float(np.median(r)) * math.sqrt(n / max(n - p, 1))


def outliers(residuals: np.ndarray, problem, p: int) -> np.ndarray:
    """(n,) bool: the points whose |residual| exceeds :data:`OUTLIER_Z` × :func:`robust_sigma`.

    None with fewer than :data:`FEW_DOF` residual degrees of freedom (the median of a near-interpolating
    fit's residuals says nothing about the noise), and none below 10× the engine's relative accuracy
    (an exact fit's residuals are round-off, not scatter). ``residuals`` in the problem's point order
    (sorted by speed), ``p`` the parameters fitted.
    """
    r = np.abs(np.asarray(residuals, float))
    if r.size - p < FEW_DOF:
        return np.zeros(r.size, bool)
    floor = 10 * get_engine(problem.engine).depth_accuracy * residual_scale(problem.residual, problem.depth_mm)
    return r > OUTLIER_Z * max(robust_sigma(r, p), floor)


def is_robust(loss: str | None) -> bool:
    """Whether a fit's ``settings["loss"]`` down-weights large residuals (anything but ``linear``; a fit
    without one, e.g. Newton's, is a plain least-squares fit)."""
    return (loss or "linear") != "linear"


def kept_points(loss: str | None, residuals: np.ndarray, problem, p: int) -> np.ndarray:
    """(n,) bool: the points a fit with ``loss`` stands on. A robust loss gives an outlier almost no weight
    in the estimate, so its standard errors, its noise and its x = y test leave the :func:`outliers` out
    too (with them in, three outliers among 30 points made σ̂ 12× the inliers' scatter and let a wrong x = y
    tie pass the F-test); a linear fit is pulled by every point, so every point stays."""
    r = np.asarray(residuals, float)
    if not is_robust(loss):
        return np.ones(r.size, bool)
    keep = ~outliers(r, problem, p)
    return keep if keep.sum() > p else np.ones(r.size, bool)


def point_residuals(problem, residuals: np.ndarray, flagged: np.ndarray) -> tuple[dict, ...]:
    """``Fit.residuals``: one record per boundary point in speed order: rpm [rev/min], depth_mm (measured)
    and fitted_mm [mm], residual (the fit's, :meth:`~millstab.identify.objective.Problem.residuals`) and
    outlier (bool, :func:`outliers`)."""
    r = np.asarray(residuals, float)
    fitted = _fitted_mm(problem, r)
    return tuple({"rpm": float(a), "depth_mm": float(b), "fitted_mm": float(c), "residual": float(d),
                  "outlier": bool(o)} for a, b, c, d, o in zip(problem.rpm, problem.depth_mm, fitted, r, flagged))


def _fitted_mm(problem, r: np.ndarray) -> np.ndarray:
    """The fitted depths [mm] behind residuals (n,), without an engine call: log residuals are
    √w ln(b*/b), mm ones √w (b* − b)."""
    sw = np.sqrt(problem.weight)
    return problem.depth_mm * np.exp(r / sw) if problem.residual == "log" else problem.depth_mm + r / sw


def accurate_engine(cutting) -> str:
    """The engine to refit with where the zero-order model is poor (:func:`millstab.stability.accurate_engine`: the
    cheap accurate one, spectral, on which the global search runs; sdm where the cut carries process damping)."""
    from millstab.stability import accurate_engine as engine_for

    return engine_for(cutting)


def _refit_advice(cutting) -> str:
    """``--engine NAME`` and why, for the warnings that send a zero-order fit to the accurate engine."""
    name = accurate_engine(cutting)
    why = ("it models the process damping of this cut" if getattr(cutting, "has_process_damping", False)
           else "the accurate engine, fast enough for the global search; --engine sdm where the cut has process "
                "damping")
    return f"--engine {name} ({why})"


def radial_immersion(cutting) -> float:
    """Radial immersion a/D of one engaged arc [entry, exit] ⊂ [0, π]: (cos φst − cos φex)/2."""
    return (math.cos(cutting.entry) - math.cos(cutting.exit)) / 2


def zoa_model_poor(cutting) -> str | None:
    """Why the zero-order model is known to be approximate for this cut, or ``None``."""
    ad = radial_immersion(cutting)
    if ad < ZOA_POOR_IMMERSION * (1 - 1e-9):  # a/D 0.3 through its angles is 0.29999999999999993: not "0.3 < 0.3"
        return f"radial immersion a/D = {ad:.2g} < {ZOA_POOR_IMMERSION}"
    if cutting.teeth_in_cut < INTERRUPTED_BELOW:  # the decisions' rule (millstab.stability.time_averaged_note)
        return f"{cutting.teeth_in_cut:.2g} teeth in the cut on average: no tooth cuts for part of every tooth period"
    if cutting.teeth <= 2:
        return f"{cutting.teeth} {'tooth' if cutting.teeth == 1 else 'teeth'}: strongly time-varying cutting forces"
    return None


def diagnose(fit, problem, noise: float | None = None, residuals: np.ndarray | None = None):
    """``fit`` with degrees of freedom, the noise record and the quality warnings (module docstring)
    added: a new :class:`~millstab.identify.result.Fit` (a fit is frozen). ``residuals`` at the
    estimate, if known (else one engine call)."""
    n, p = problem.n, effective_p(fit, problem)
    scale = residual_scale(problem.residual, problem.depth_mm)
    if residuals is None:
        residuals = problem.residuals(problem.predict_mm(fit.estimate[None]))[0]
    r = np.asarray(residuals, float)
    flagged = outliers(r, problem, p)
    loss = fit.settings.get("loss")
    # a robust fit's noise (and so its χ² check) from the points it keeps, as its standard errors
    keep = kept_points(loss, r, problem, p)
    rss = float(r[keep] @ r[keep])
    info = error_sigma(rss, int(keep.sum()), p, scale, noise)
    dof = n - p
    record = {k: info[k] for k in ("source", "estimated", "stated", "assumed")} | {"sigma": info["sigma"] / scale}
    if not keep.all():
        record["points"] = int(keep.sum())  # the points σ rests on, where fewer than n
    notes: list[tuple[str, str]] = []  # (code, warning) pairs, added to the fit at the end
    add = lambda code, text: notes.append((code, text))  # noqa: E731
    checks: dict = {}
    how = {"stated": f"the stated {100 * (noise or 0):.3g} % depth noise",
           "assumed": f"an assumed {100 * ASSUMED_NOISE:.3g} % depth noise (state the real one with --noise)",
           "residuals": "the residual scatter"}[info["source"]]
    if dof <= 0:
        add("no_dof", f"no degrees of freedom: {n} boundary points for {p} free parameters, so the fit "
                                  "passes through every point, any noise goes straight into the estimate and the "
                                  "residuals cannot tell how good it is"
                                  + (f"; the standard errors use {how}" if fit.std_errors is not None else "")
                                  + ". Measure more points or free fewer parameters")
    elif dof < FEW_DOF and noise is None:
        est = f"{100 * info['estimated']:.3g} %"
        add("few_dof", f"only {dof} degree(s) of freedom ({n} points, {p} free parameters): the residual "
                                   f"scatter ({est}) is a rough estimate of the noise"
                                   + ("" if fit.std_errors is None else
                                      f"; the standard errors use {how}" + (" instead" if info["source"] == "assumed"
                                                                             else ", larger than the assumed "
                                                                             f"{100 * ASSUMED_NOISE:.3g} %")))
    sig_hat = info["estimated"]
    if sig_hat is not None:
        if noise is not None:
            chi = stats.chi2.sf(rss / (noise * scale) ** 2, info["dof"])
            checks["chi2_p_value"] = float(chi)
            if chi < CHI2_ALPHA and sig_hat >= POOR_RATIO * noise:
                add("poor_fit", f"poor fit: the residual scatter {100 * sig_hat:.3g} % is {sig_hat / noise:.3g}× "
                                f"the stated {100 * noise:.3g} % noise (χ² test p = {chi:.2g})" + _why(problem))
        elif sig_hat > POOR_RMS:
            add("poor_fit", f"poor fit: the residual scatter {100 * sig_hat:.3g} % is above the "
                            f"{100 * POOR_RMS:.3g} % a measured boundary plausibly scatters" + _why(problem))
    rms = math.sqrt(rss / n) / scale
    runs = runs_test(r, problem.rpm)
    if runs is not None:
        checks["runs_test"] = runs
        # residuals below 10× the engine's own accuracy are numerical, not misfit
        if runs["p_value"] < RUNS_ALPHA and rms > 10 * get_engine(problem.engine).depth_accuracy:
            add("residual_structure",
                            f"the residuals are systematic, not noise: their signs form {runs['runs']} runs along the "
                            f"speed axis where about {runs['expected']:.1f} are expected (runs test p = "
                            f"{runs['p_value']:.2g})"
                            + _why(problem))
    if flagged.any():
        add("outliers", _outlier_warning(problem, r, flagged, p, loss))
    poor = zoa_model_poor(problem.cutting) if get_engine(problem.engine).time_averaged else None
    if poor:
        add("zoa_model", f"the zero-order model is approximate for this cut ({poor}): on points from real "
                                     "cuts or a time-domain model its estimates can be biased by tens of percent in k "
                                     f"and ζ; check with {_refit_advice(problem.cutting)}")
    lo, hi = np.log(problem.par.lower), np.log(problem.par.upper)
    u = np.log(fit.estimate)
    at = [name for name, a, b, x in zip(fit.names, lo, hi, u) if min(x - a, b - x) < 1e-6]
    if at:
        add("at_bound", "estimate on its search bound (the best value may lie beyond it; widen the bounds "
                                    "or check the start): " + ", ".join(at))
    depth = np.asarray(problem.depth_mm, float)
    if n > 1 and np.ptp(depth) <= 1e-12 * float(np.max(depth)):
        add("flat_points", f"all {n} boundary depths are {depth[0]:g} mm: points without lobes cannot "
                                       "locate the natural frequencies, so the estimate is arbitrary in fn; check the "
                                       "depth column of the points file")
    checks["rms"] = rms
    return fit.with_warnings(notes, dof=dof, n_points=n, noise=record, checks=checks,
                             residuals=point_residuals(problem, r, flagged))


def _outlier_warning(problem, r: np.ndarray, flagged: np.ndarray, p: int, loss: str | None) -> str:
    """The ``outliers`` warning: the flagged points by speed and depth (measured, fitted), and what the
    fit did with them."""
    sig = robust_sigma(r, p) / residual_scale(problem.residual, problem.depth_mm)
    fitted = _fitted_mm(problem, r)
    idx = np.flatnonzero(flagged)
    named = "; ".join(f"{problem.rpm[i]:.6g} rpm, {problem.depth_mm[i]:.4g} mm (fitted {fitted[i]:.4g} mm)"
                      for i in idx)
    head = (f"{idx.size} outlier{'s' if idx.size > 1 else ''} (residual beyond {OUTLIER_Z:g}× the robust "
            f"scatter {100 * sig:.3g} % of the others): {named}")
    if is_robust(loss):
        return (f"{head}; the {loss} loss gives them little weight, and the standard errors, the noise estimate "
                "and the x = y test leave them out: check those cuts")
    return (f"{head}; a linear fit is pulled by every point: check those cuts, or refit with a robust loss "
            "(--loss cauchy or soft_l1), which gives them little weight")


def effective_p(fit, problem) -> int:
    """Parameters the fit really estimated: the free ones, fewer by the tied pairs when it reports x = y."""
    test = fit.settings.get("xy_tie_test") or {}
    return problem.p - (int(test.get("tied_pairs", 0)) if test.get("chosen") == "tied" else 0)


def _why(problem) -> str:
    """The likely causes of a poor or systematic fit, for the warning text."""
    eng = get_engine(problem.engine)
    if eng.time_averaged and zoa_model_poor(problem.cutting):
        return f"; the zero-order model is poor for this cut: refit with {_refit_advice(problem.cutting)}"
    if not eng.cheap:  # identify's two stages: a zero-order global search, then this engine's local polish
        e = problem.engine.upper()
        return (f"; the {e} stage polishes the zero-order basin and may be in the wrong one (no global {e} search): "
                "try other starts (--initial) or check the points")
    return ("; the search may have stopped in a wrong basin (try other starts with --initial), or the points hold "
            "outliers")


__all__ = ["ASSUMED_NOISE", "FEW_DOF", "OUTLIER_Z", "POOR_RMS", "SOURCES", "accurate_engine", "check_noise",
           "diagnose", "error_sigma", "is_robust", "kept_points", "outliers", "point_residuals", "radial_immersion",
           "residual_scale", "robust_sigma", "runs_test", "zoa_model_poor"]
