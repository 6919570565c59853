"""A zero-order decision checked against interrupted cutting on the same posterior samples.

The zero-order model averages the cutting force over the tooth period. Its error is largest where few teeth cut
(:func:`millstab.stability.time_averaged_note` warns below one tooth in the cut on average), but a rule on the tooth
count alone misses it elsewhere: an exploratory shop test (2026-11-29: 4 teeth, x 600 Hz 4 N/µm ζ 0.02, y 950 Hz
25 N/µm ζ 0.03, a/D 0.5 down milling, exactly one tooth in the cut) found zero-order limits up to 4.9× SDM's (median
1.42×), and a zero-order posterior recommended 4.64 mm at 15 000 rpm, P(chatter) 0.043, where the true limit is 3.30
mm: it chattered, with no warning. So the recommendation itself is checked: the limits at its speed of a seeded
subsample of the posterior's samples are computed again by the spectral engine (collocation of the interrupted
cut, within 0.5 % of converged SDM), and where that puts the cut's P(chatter) clearly above the risk the decision
warns, with both numbers. It is a check of the model's consistency, not the truth: the samples were fitted with the
zero-order model (in the trained conditions its parameters absorb part of its error); where both engines agree on
them the average is good there. Cost: one spectral search per sample at one speed (~0.1–0.5 s for 100 samples).
The checking engine is :func:`millstab.stability.accurate_engine` without a cutting (spectral): a cut with process
damping, which only sdm models (~100× dearer per limit), is not checked.
"""

from __future__ import annotations

import math

import numpy as np

from millstab.errors import InputError
from millstab.stability import accurate_engine
from millstab.update.likelihood import limits

#: posterior samples whose limits the check computes again (a seeded subsample)
CHECK_SAMPLES = 100
#: the check warns where the accurate P(chatter) exceeds the risk by this many Monte Carlo standard errors
#: (√(p(1 − p)/M) at p = risk) and by at least 0.05 absolute (so a 2 % risk on 100 samples is not warned at 4 %)
CHECK_SIGMAS, CHECK_MARGIN = 3.0, 0.05


def averaged_here(engine: str, cutting) -> bool:
    """Whether ``engine`` averages the cutting force over the tooth period and ``cutting``'s directional matrix varies
    over it: where a check against interrupted cutting has something to find (a constant matrix: the average is
    exact)."""
    from millstab.stability import get_engine

    return bool(getattr(get_engine(engine), "time_averaged", False)) and not cutting.time_invariant


def accurate_check(post, rpm: float, depth_mm: float, risk: float, seed: int = 0,
                   samples: int = CHECK_SAMPLES) -> dict | None:
    """P(chatter) of the cut (``rpm`` [rev/min], ``depth_mm`` [mm]) under the posterior's own (time-averaged)
    engine and under :func:`accurate_engine`'s, on the same seeded subsample of ``samples`` posterior samples.

    ``None`` where there is nothing to check (an engine that does not average, a condition whose directional matrix
    is constant over the tooth period, where the average is exact, no depth) or the check cannot run (a structure
    the accurate engine does not take: measured FRFs, process damping). Keys: ``samples``, ``p_chatter`` (the
    posterior's engine), ``p_chatter_accurate``, ``ratio`` (the median over the samples of the accurate limit over
    the averaged one), ``warn`` (whether the accurate P(chatter) is clearly above ``risk``: :data:`CHECK_SIGMAS`,
    :data:`CHECK_MARGIN`).
    """
    if not averaged_here(post.engine, post.condition):
        return None
    if not (math.isfinite(depth_mm) and depth_mm > 0):
        return None
    u = post.decision_u
    if u.shape[0] > samples:
        u = u[np.sort(np.random.default_rng(seed).choice(u.shape[0], samples, replace=False))]
    r = np.array([float(rpm)])
    try:
        accurate = limits(post.prior, u, r, accurate_engine())[0][:, 0]
    except InputError:  # a structure or term the accurate engine does not carry: nothing to compare
        return None
    averaged = limits(post.prior, u, r, post.engine, options=post.engine_options)[0][:, 0]
    m = u.shape[0]
    p_acc = float(np.mean(accurate < depth_mm))
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = float(np.nanmedian(np.where(np.isfinite(averaged), accurate / averaged, np.nan)))
    sigma = math.sqrt(risk * (1 - risk) / m)
    return {"samples": m, "p_chatter": float(np.mean(averaged < depth_mm)), "p_chatter_accurate": p_acc,
            "ratio": ratio, "warn": p_acc > risk + max(CHECK_SIGMAS * sigma, CHECK_MARGIN)}


#: a decision's condition is warned where the posterior median's averaged limit exceeds the accurate one by this
#: factor at some speed (the tooth-count rule's tools stayed within 1.24× at one tooth or more in the cut)
MEDIAN_RATIO = 1.25
#: the most speeds the median's check computes (evenly picked from the decision's)
MEDIAN_SPEEDS = 40


def median_check(post, rpm) -> dict | None:
    """The posterior median's limits at (at most :data:`MEDIAN_SPEEDS` of) the decision's speeds ``rpm`` [rev/min]
    under its own time-averaged engine and under :func:`accurate_engine`'s, or ``None`` where there is nothing to check
    (as :func:`accurate_check`). Keys: ``ratio`` (the largest averaged / accurate limit), ``rpm`` (where), ``median``
    (the median ratio), ``speeds`` (how many), ``warn`` (ratio > :data:`MEDIAN_RATIO`). For a map or a prediction,
    which have no one cut to check; the parameter-wise median of the samples stands for the posterior."""
    if not averaged_here(post.engine, post.condition):
        return None
    r = checked_speeds(np.unique(np.asarray(rpm, float)))
    if r.size == 0:
        return None
    u = np.median(post.decision_u, axis=0)[None, :]
    try:
        accurate = limits(post.prior, u, r, accurate_engine())[0][0]
    except InputError:
        return None
    return worst_ratio(r, limits(post.prior, u, r, post.engine, options=post.engine_options)[0][0], accurate)


def checked_speeds(rpm: np.ndarray, n: int = MEDIAN_SPEEDS) -> np.ndarray:
    """At most ``n`` of the ascending speeds ``rpm`` [rev/min], evenly picked, the first and last among them."""
    return rpm[np.unique(np.linspace(0, rpm.size - 1, min(rpm.size, n)).round().astype(int))] if rpm.size else rpm


def worst_ratio(rpm: np.ndarray, averaged: np.ndarray, accurate: np.ndarray) -> dict | None:
    """The largest ratio of the averaged to the accurate limit [mm] over the speeds ``rpm`` where both are finite:
    ``ratio``, ``rpm`` (where), ``median`` ratio, ``speeds`` (how many), ``warn`` (ratio > :data:`MEDIAN_RATIO`);
    ``None`` where no speed has both."""
    ok = np.isfinite(averaged) & np.isfinite(accurate) & (accurate > 0)
    if not ok.any():
        return None
    ratio = averaged[ok] / accurate[ok]
    i = int(np.argmax(ratio))
    return {"ratio": float(ratio[i]), "rpm": float(rpm[ok][i]), "median": float(np.median(ratio)),
            "speeds": int(ok.sum()), "warn": bool(ratio[i] > MEDIAN_RATIO)}


def median_message(check: dict, engine: str, where: str) -> str:
    """The warning's text for a median check that warns (:func:`median_check`); ``where``: the condition's words."""
    acc = accurate_engine()
    return (f"checked against interrupted cutting: in {where} the {engine} limits of the posterior's median parameters "
            f"are up to {check['ratio']:.2f}× the {acc} engine's (at {check['rpm']:.0f} rpm; median "
            f"{check['median']:.2f}× over {check['speeds']} speeds): the {engine} model averages the force over the "
            f"tooth period, so a cut it calls stable can chatter; decide here from an update with --engine {acc}")


def check_message(check: dict, rpm: float, depth_mm: float, engine: str) -> str:
    """The warning's text for a check that warns (:func:`accurate_check`)."""
    acc = accurate_engine()
    return (f"checked against interrupted cutting: on {check['samples']} of the posterior's samples the {acc} engine "
            f"gives the recommended cut ({rpm:.0f} rpm, {depth_mm:.3g} mm) P(chatter) "
            f"{check['p_chatter_accurate']:.2f}, the {engine} engine {check['p_chatter']:.2f} (the {engine} model "
            f"averages the force over the tooth period; its limits there are {1 / check['ratio']:.2f}× the {acc} "
            f"ones, median): decide here from an update with --engine {acc}, or cut shallower")


__all__ = ["CHECK_SAMPLES", "MEDIAN_RATIO", "accurate_check", "averaged_here", "check_message",
           "checked_speeds", "median_check", "median_message", "worst_ratio"]
