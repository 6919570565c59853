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
  flip lobes; see the field notes); suggests ``--engine sdm``;
* ``at_bound``: an estimate sits on its search bound (the optimum may lie outside);
* ``flat_points``: every boundary depth is the same — no lobe to locate a natural frequency by (often
  a wrong column or a constant placeholder in the file).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

from millstab.stability import get_engine

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


def radial_immersion(cutting) -> float:
    """Radial immersion a/D of one engaged arc [entry, exit] ⊂ [0, π]: (cos φst − cos φex)/2."""
    return (math.cos(cutting.entry) - math.cos(cutting.exit)) / 2


def zoa_model_poor(cutting) -> str | None:
    """Why the zero-order model is known to be approximate for this cut, or ``None``."""
    ad = radial_immersion(cutting)
    if ad < ZOA_POOR_IMMERSION * (1 - 1e-9):  # a/D 0.3 through its angles is 0.29999999999999993: not "0.3 < 0.3"
        return f"radial immersion a/D = {ad:.2g} < {ZOA_POOR_IMMERSION}"
    if cutting.teeth_in_cut < 1:  # the decisions' rule (millstab.stability.time_averaged_note)
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
    rss = float(r @ r)
    info = error_sigma(rss, n, p, scale, noise)
    dof = info["dof"]
    record = {k: info[k] for k in ("source", "estimated", "stated", "assumed")} | {"sigma": info["sigma"] / scale}
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
            chi = stats.chi2.sf(rss / (noise * scale) ** 2, dof)
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
    poor = zoa_model_poor(problem.cutting) if get_engine(problem.engine).time_averaged else None
    if poor:
        add("zoa_model", f"the zero-order model is approximate for this cut ({poor}): on points from real "
                                     "cuts or a time-domain model its estimates can be biased by tens of percent in k "
                                     "and ζ; check with the time-domain engine (--engine sdm)")
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
    return fit.with_warnings(notes, dof=dof, n_points=n, noise=record, checks=checks)


def effective_p(fit, problem) -> int:
    """Parameters the fit really estimated: the free ones, fewer by the tied pairs when it reports x = y."""
    test = fit.settings.get("xy_tie_test") or {}
    return problem.p - (int(test.get("tied_pairs", 0)) if test.get("chosen") == "tied" else 0)


def _why(problem) -> str:
    """The likely causes of a poor or systematic fit, for the warning text."""
    eng = get_engine(problem.engine)
    if eng.time_averaged and zoa_model_poor(problem.cutting):
        return ("; the zero-order model is poor for this cut: refit with the time-domain engine (--engine sdm)")
    if not eng.cheap:  # identify's two stages: a zero-order global search, then this engine's local polish
        e = problem.engine.upper()
        return (f"; the {e} stage polishes the zero-order basin and may be in the wrong one (no global {e} search): "
                "try other starts (--initial) or check the points")
    return ("; the search may have stopped in a wrong basin (try other starts with --initial), or the points hold "
            "outliers")


__all__ = ["ASSUMED_NOISE", "FEW_DOF", "POOR_RMS", "SOURCES", "check_noise", "diagnose",
           "error_sigma", "radial_immersion", "residual_scale", "runs_test", "zoa_model_poor"]
