"""Are x and y alike? The nested-model test that decides whether to report them tied.

In an x/y-symmetric cut (α_xx = α_yy, e.g. slotting) the zero-order SLD is unchanged when x and y are
swapped. A structure whose x and y modes are alike (the seed paper's Examples 1 and 2) is a fixed
point of that swap, and there the boundary depends on the x–y *differences* only to second order:
the Jacobian is singular along them. With noisy points a free fit then splits fn_x and fn_y apart
by an amount of the order of the square root of the noise, and its linearised standard errors,
blind to that, cover the truth far less often than they claim (measured: 80 % instead of 95 % on
Examples 1–2 at 2 % noise).

So after the free fit, the tied model (x = y: the axisymmetric parameterization, three parameters per
mode pair fewer) is fitted too, and the two are compared with the F-test of nested least-squares
models, F = ((RSS_tied − RSS_free)/q) / (RSS_free/(n − p)), q = the number of tied pairs. When the
data do not reject the tied model at the 5 % level, the tied estimate is reported (both directions
carry its values, standard errors and correlations) and the free solution is listed as an
alternative; otherwise the free fit stands. Either way the test is recorded in ``settings``.

The F-test assumes Gaussian scatter. A fit with a robust ``loss`` (cauchy, soft_l1, …) says the points
may hold outliers and gives them almost no weight; with them in the test's RSS they inflated its
denominator (three depths ×1.8, ×0.45 and ×2.2 among 30 points: p = 0.14) and a tied fit 4–8σ from the
truth beat a free one at the truth. So with a robust loss both fits' residuals are compared on the
points the free fit keeps (:func:`~millstab.identify.quality.kept_points`: all but its outliers), n the
number of those points; the points left out are recorded by speed and depth. A linear fit is pulled by
every point, so its test uses every point, as its objective does (its ``outliers`` warning says to refit
with a robust loss).
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np
from scipy import stats

from millstab.identify.objective import Problem
from millstab.identify.quality import is_robust, kept_points
from millstab.identify.symmetry import swap_permutation
from millstab.identify.result import Fit
from millstab.params import Parameterization

#: significance level below which a difference between x and y is taken as real
ALPHA = 0.05
#: relative accuracy of an engine depth (tests: ≤ 1e-6): the noise floor of an exact fit's residuals
ENGINE_REL = 1e-6


def tied_parameterization(par: Parameterization, cutting) -> tuple[Parameterization, np.ndarray] | None:
    """``par`` with every free x parameter tied to its y partner, and the index map θ_free = θ_tied[index];
    ``None`` unless the cut is x/y symmetric and x and y are free in pairs with overlapping bounds."""
    if swap_permutation(par, cutting) is None:
        return None
    stem = [re.sub(r"_[xy]", "", name) for name in par.free]
    tied_names = list(dict.fromkeys(stem))
    bounds = {}
    for t in tied_names:
        members = [i for i, s in enumerate(stem) if s == t]
        lo, hi = max(par.lower[members]), min(par.upper[members])
        if not lo < hi:
            return None  # the x and y bounds do not overlap: x = y is excluded by the user
        bounds[t] = (lo, hi)
    return Parameterization(par.base, tuple(tied_names), True, bounds), np.array([tied_names.index(s) for s in stem])


def tied_problem(problem: Problem) -> tuple[Problem, np.ndarray] | None:
    """:func:`tied_parameterization` of a problem: the tied problem and the index map."""
    made = tied_parameterization(problem.par, problem.cutting)
    if made is None:
        return None
    tied, index = made
    prob = Problem(tied, problem.cutting, problem.rpm, problem.depth_mm, problem.weight, problem.engine,
                   problem.cuts, problem.residual)
    return prob, index


def is_tied(fit: Fit) -> bool:
    """Whether ``fit`` reports the tied (x = y) estimate (:attr:`Fit.tied`)."""
    return fit.tied


def f_test(rss_tied: float, rss_free: float, n: int, p: int, q: int, floor: float) -> tuple[float, float]:
    """(F, p-value) of the tied model against the free one; residuals below ``floor`` count as exact."""
    den = max(rss_free, floor) / (n - p)
    f = max(rss_tied - rss_free, 0.0) / q / den
    return float(f), float(stats.f.sf(f, q, n - p))


def tested_rss(problem: Problem, free: Fit, tied: Fit, index: np.ndarray) -> tuple[float, float, int, list[dict]]:
    """(RSS of the tied fit, RSS of the free fit, points n, points left out) the F-test compares.

    A linear fit: its own RSS over every point, no engine call. A robust fit (module docstring): both
    residual vectors (one engine call each) over the points the free fit keeps; left out: [{"rpm" [rev/min],
    "depth_mm" [mm]}] of its outliers (empty when it flags none). ``tied``: the fit of the tied problem,
    ``index``: θ_free = θ_tied[index].
    """
    loss = free.settings.get("loss")
    if not is_robust(loss):
        return float(tied.rss), float(free.rss), problem.n, []
    r_free = problem.residuals(problem.predict_mm(free.estimate[None]))[0]
    r_tied = problem.residuals(problem.predict_mm(tied.estimate[index][None]))[0]
    keep = kept_points(loss, r_free, problem, problem.p)
    left = [{"rpm": float(problem.rpm[i]), "depth_mm": float(problem.depth_mm[i])} for i in np.flatnonzero(~keep)]
    return float(r_tied[keep] @ r_tied[keep]), float(r_free[keep] @ r_free[keep]), int(keep.sum()), left


def prefer_tied(problem: Problem, free: Fit, refit) -> Fit:
    """The fit to report: ``free``, or the tied fit (``refit(tied_problem, start)``) when the points do
    not reject x = y (module docstring)."""
    made = tied_problem(problem)
    n, p = problem.n, problem.p
    if made is None or n <= p:
        return free
    tprob, index = made
    q = p - tprob.p
    # start the tied fit at the geometric mean of the free estimate's x and y values
    start = np.exp(np.array([np.log(free.estimate[index == j]).mean() for j in range(tprob.p)]))
    tied = refit(tprob, start)
    rss_tied, rss_free, n_tested, left_out = tested_rss(problem, free, tied, index)
    scale = 1.0 if problem.residual == "log" else float(np.mean(problem.depth_mm))
    floor = n_tested * (ENGINE_REL * scale) ** 2
    f, pval = f_test(rss_tied, rss_free, n_tested, p, q, floor)
    test = {"F": f, "p_value": pval, "tied_pairs": q, "rss_tied": float(tied.rss), "rss_free": float(free.rss),
            "alpha": ALPHA, "tied_iterations": int(tied.iterations)}
    if left_out:
        test |= {"points_tested": n_tested, "rss_tied_tested": rss_tied, "rss_free_tested": rss_free,
                 "left_out": left_out}
    if pval < ALPHA:
        return dataclasses.replace(free, settings={**free.settings, "xy_tie_test": {**test, "chosen": "free"}})
    alt = {"estimate": problem.par.as_dict(free.estimate), "mlae": float(free.mlae), "rss": float(free.rss),
           "why": f"the fit with x and y free; the x–y differences it finds are not significant "
                  f"(F = {f:.3g}, p = {pval:.2f})"}
    # the tied fit's own alternatives (other tied structures as good), in the free names
    alts = [alt] + [{**a, "estimate": problem.par.as_dict(np.array([a["estimate"][t] for t in tprob.par.free])[index])}
                    for a in tied.alternatives]
    # the tied fit's warnings but its x/y symmetry note (the tie says it); each warning carries its code
    kept = [n for n in tied.notes if n["code"] != "xy_symmetry"]
    codes = ["xy_tied"] + [n["code"] for n in kept]
    warn = [n["message"] for n in kept]
    on = f" on the {n_tested} points kept by the {free.settings.get('loss')} loss" if left_out else ""
    warn.insert(0, f"x and y tied: the points do not show x and y differing (F-test of the tied against the free fit"
                   f"{on}: p = {pval:.2f} ≥ {ALPHA}), so the estimate gives both directions the tied values; near "
                   "x = y a free fit splits them by noise alone, with overconfident standard errors")
    se = None if tied.std_errors is None else tied.std_errors[index]
    corr = None if tied.correlation is None else tied.correlation[np.ix_(index, index)]
    return Fit(method=free.method, par=problem.par, estimate=tied.estimate[index], start=free.start, mlae=tied.mlae,
               rss=tied.rss, iterations=free.iterations + 1, evaluations=free.evaluations + tied.evaluations,
               engine_calls=free.engine_calls + tied.engine_calls, time_s=free.time_s + tied.time_s,
               # the free search's history, then the tied estimate as one more step (the tied search's own
               # iterations are in settings["xy_tie_test"])
               history_theta=np.vstack([free.history_theta, tied.estimate[index]]),
               history_mlae=np.append(free.history_mlae, tied.mlae),
               history_rss=np.append(free.history_rss, tied.rss), std_errors=se, correlation=corr,
               condition=tied.condition, warnings=warn, codes=codes, alternatives=alts, cutting=free.cutting,
               symmetry=free.symmetry,
               test_cuts=tied.test_cuts, settings={**free.settings, "xy_tie_test": {**test, "chosen": "tied"}})


__all__ = ["ALPHA", "f_test", "is_tied", "prefer_tied", "tested_rss", "tied_parameterization", "tied_problem"]
