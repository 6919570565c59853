"""Predictions for given cuts from a posterior: the chance that each cut is stable (the process) and
the chance that an operator writes "chatter" for it (the label model of the likelihood, learned).

The two answer different questions. ``p_stable`` is about the process: the share of posterior samples
whose limit lies above the cut, free of label noise. ``p_label_chatter`` is about the written label,
the posterior predictive of the likelihood itself: averaged over the samples (θ, ε, s),
P(label chatter) = ε + (1 − 2ε)·Φ((b − b_lim(θ))/(s·σ_b)), with the learned label error ε and the
learned depth noise s·σ_b. It is never 0 or 1 (a written label is a noisy observation; the learned ε
and σ_b say how noisy), and it is the probability a held-out written label should be scored against
(Brier, log loss); scoring ``p_stable`` against written labels charges the process model for the
operators' disagreement.

With a test-day effect (:mod:`millstab.update.batch`) a cut of a day the posterior has seen (``batch``
given, the day among the posterior's days) is predicted at that day's shifts δ_g; any other cut (a new
day, or no day) at a new day's, δ ~ N(0, τ²) marginalised.

Units: rpm and mm at this interface.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.special import ndtr

from millstab.errors import InputError
from millstab.update.batch import fn_columns, shift_fn
from millstab.update.likelihood import limits_by_condition, stickout_groups
from millstab.update.posterior import Posterior


def cut_limits(post: Posterior, rpm: np.ndarray, batch=None, conditions: tuple | None = None,
               cond_index=None) -> np.ndarray:
    """The limiting depth of each cut under each posterior sample (N, n) [mm]: a new day's (the samples
    :attr:`Posterior.decision_u`), or with ``batch`` (n,) and a test-day effect, the known day's shifts for
    cuts of a day the posterior has seen; each cut in its own condition (``conditions``, a
    :class:`~millstab.model.Cutting` per distinct condition, and ``cond_index`` (n,); ``None``: every cut in
    ``post.condition``). One engine call per day at its distinct (condition, speed) pairs and distinct rows (a
    resampled posterior repeats rows; a row's limits do not depend on the other rows of a call)."""
    ci = np.zeros(rpm.size, dtype=np.int64) if cond_index is None else np.asarray(cond_index, dtype=np.int64)
    if ci.shape != rpm.shape:
        raise InputError("cuts", f"{ci.size} condition indices", f"need one per cut ({rpm.size})")
    day = np.full(rpm.size, -1)
    if batch is not None and post.batch is not None:
        known = {d: g for g, d in enumerate(post.batch.days) if d}  # "" (no day) is no particular day: a new one
        day = np.array([known.get(str(b), -1) for b in np.asarray(batch, dtype=object)])
    blim = np.empty((post.u.shape[0], rpm.size))
    for g in np.unique(day):  # a loop over the days (a handful), never over cuts or samples
        m = day == g
        u = post.decision_u if g < 0 else shift_fn(post.u, fn_columns(post.prior), post.batch.shifts[:, g])
        pairs, idx = np.unique(np.c_[ci[m], rpm[m]], axis=0, return_inverse=True)
        rows, inv = np.unique(u, axis=0, return_inverse=True)
        d, _ = limits_by_condition(post.prior, rows, pairs[:, 1], pairs[:, 0].astype(np.int64), conditions,
                                   post.engine, options=post.engine_options)
        blim[:, m] = d[np.asarray(inv).ravel()][:, np.asarray(idx).ravel()]
    return blim


def predict_cuts(post: Posterior, rpm, depth_mm, conditions: tuple | None = None, cond_index=None,
                 batch=None) -> tuple[np.ndarray, np.ndarray]:
    """``(p_stable, p_label_chatter)`` (n,) for n cuts at ``rpm`` (n,) [rev/min] and ``depth_mm`` (n,) [mm],
    in the input order; one engine call for every distinct (condition, speed) pair (per day with ``batch``,
    the test day of each cut: see the module docstring).

    ``conditions`` (a :class:`~millstab.model.Cutting` per distinct condition) and ``cond_index`` (n,) give
    each cut's own condition; ``None``: every cut in ``post.condition``.

    ``p_stable``: the fraction of posterior samples whose limiting depth lies above the cut's depth.
    ``p_label_chatter``: P(the written label says chatter), the mean over the samples of
    ε + (1 − 2ε)·Φ((b − b_lim)/(s·σ_b)) with each sample's learned label error ε and depth-noise
    factor s (held values for a posterior without learned noise); see the module docstring.

    Raises:
        InputError: lengths differ, a speed or depth not finite and > 0.
    """
    r = np.atleast_1d(np.asarray(rpm, dtype=float))
    d = np.atleast_1d(np.asarray(depth_mm, dtype=float))
    if r.shape != d.shape or r.ndim != 1:
        raise InputError("cuts", f"{r.size} speeds and {d.size} depths", "need one depth per speed")
    for name, a, unit in (("rpm", r, "rev/min"), ("depth_mm", d, "mm")):
        bad = ~(np.isfinite(a) & (a > 0))
        if bad.any():
            i = int(np.argmax(bad))
            raise InputError(f"cuts.{name}[{i}]", float(a[i]), f"must be a finite number > 0 {unit}")
    if r.size == 0:
        return np.zeros(0), np.zeros(0)
    blim = cut_limits(post, r, batch, conditions, cond_index)  # (N, n)
    p_stable = (blim > d[None, :]).mean(axis=0)
    eps, fac = post.label_error[:, None], post.sigma_depth_factor[:, None]
    sig = post.prior.sigma_depth_mm(d)[None, :] * fac
    with np.errstate(invalid="ignore"):  # an infinite limit (no boundary): Φ(−∞) = 0
        phi = ndtr((d[None, :] - blim) / sig)
    return p_stable, (eps + (1.0 - 2.0 * eps) * phi).mean(axis=0)


def predict_at_stickouts(post: Posterior, rpm, depth_mm, conditions: tuple | None = None, cond_index=None,
                         batch=None, stickout=None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`predict_cuts` with each cut at its own tool stickout ``stickout`` (n,) [m] (NaN: the posterior's own;
    ``None``: every cut there): the posterior's holder samples with the tip at each distinct stickout, grouped as
    the update's likelihood groups its cuts (:func:`millstab.update.likelihood.stickout_groups`), one engine call
    per stickout.

    Raises:
        InputError: stickouts with a posterior over the tip's modes (as the update refuses them), and as
            :func:`predict_cuts`.
    """
    so = None if stickout is None else np.atleast_1d(np.asarray(stickout, dtype=float))
    if so is None or np.isnan(so).all():
        return predict_cuts(post, rpm, depth_mm, conditions, cond_index, batch)
    r, d = np.atleast_1d(np.asarray(rpm, dtype=float)), np.atleast_1d(np.asarray(depth_mm, dtype=float))
    idx = None if cond_index is None else np.asarray(cond_index)
    day = None if batch is None else np.asarray(batch, dtype=object)
    ps, pl = np.empty(r.size), np.empty(r.size)
    for prior, m in stickout_groups(post.prior, so):  # a few stickouts, each one engine call over its cuts
        at = post if prior is post.prior else replace(post, prior=prior)
        ps[m], pl[m] = predict_cuts(at, r[m], d[m], conditions, None if idx is None else idx[m],
                                    None if day is None else day[m])
    return ps, pl


__all__ = ["cut_limits", "predict_at_stickouts", "predict_cuts"]
