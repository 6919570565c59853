"""Censored limits in the accurate likelihood (issue 28): where a limit is far above every cut at its speed, the
label likelihood ε + (1 − 2ε)Φ(z) no longer moves, so the spectral engine stops its search from below once the
depths up to a ceiling are stable (:meth:`Likelihood.ceilings`, ``envelope_batch(..., ceiling=...)``). Checked:
the engine's censored depths (the limit itself below the ceiling, a certified lower bound above it), each cut's
term at the ceiling against its saturated value (brute force), and log L with and without censoring."""

from __future__ import annotations

import numpy as np
import pytest

from millstab.errors import InputError
from millstab.io import load_config
from millstab.io.config import PriorTable
from millstab.model import Cutting
from millstab.points import PointSet
from millstab.stability import spectral
from millstab.update import make_prior
from millstab.update.likelihood import CENSOR_TOL, Evidence, Likelihood, cut_loglik

RPM = np.array([5116.0, 6889.0, 8805.0, 10106.0, 11546.0])


@pytest.fixture(scope="module")
def case():
    """Example 1 at a/D 0.1 down milling (the docs/updating.md low-immersion case), the default prior with learned
    label error and depth noise, 7 cuts at 5 speeds (two speeds with two cuts) and 40 prior draws."""
    cfg = load_config("example:ex1")
    cut = Cutting.from_immersion(cfg.cutting.teeth, cfg.cutting.kt, cfg.cutting.kr, 0.1, "down")
    prior = make_prior(cfg.structure, cut, PriorTable({}, sigma_depth_rel=0.05))
    rpm = np.r_[RPM, RPM[[1, 3]]]
    depth = np.array([9.0, 24.0, 50.0, 9.5, 8.0, 30.0, 12.0])
    label = np.array(["stable", "chatter", "stable", "stable", "chatter", "stable", "chatter"])
    cuts = PointSet(rpm, depth, label)
    v = prior.sample_full(40, np.random.default_rng(4))
    return prior, cut, cuts, v


def test_the_engine_stops_above_the_ceiling_and_keeps_every_limit_below_it(case):
    prior, cut, _, v = case
    theta, _ = prior.split(v[:12, :prior.size])
    batch = prior.par.batch(theta)
    full = spectral.envelope_batch(batch, cut, RPM, nodes=6, warm=False)
    cap = full * np.random.default_rng(0).uniform(0.3, 1.7, full.shape)
    got = spectral.envelope_batch(batch, cut, RPM, nodes=6, warm=False, ceiling=cap)
    above = full >= cap
    assert 0.2 < above.mean() < 0.8
    # below the ceiling: the limit (a speed continued from a censored neighbour lands on the same root to ~1e-12)
    np.testing.assert_allclose(got[~above], full[~above], rtol=1e-9)
    # above it: a depth certified stable with every depth of the search below it, so between cap and the limit
    assert np.all(got[above] >= cap[above]) and np.all(got[above] <= full[above] * (1 + 1e-6))
    assert np.any(got[above] < full[above] * 0.99)  # stopped short of the root somewhere
    with pytest.raises(InputError, match="ceiling"):
        spectral.envelope_batch(batch, cut, RPM, nodes=6, ceiling=cap[:, :2])


def test_each_cut_term_is_saturated_above_its_ceiling(case):
    """Brute force: every cut's log-likelihood term at b_lim = the column's ceiling against b_lim = 1e9 mm, per row
    (its learned ε and σ_b factor): within CENSOR_TOL × 2 (and the ceiling is not needlessly high: at 0.8 of the
    excess over the cut the largest change is far above it)."""
    prior, _, cuts, v = case
    lik = Likelihood(prior, Evidence.from_points(cuts), "spectral")
    ev = lik.evidence
    w = v[:, prior.size:prior.dim]
    cap = lik.ceilings(v[:, :prior.size], w)
    assert cap.shape == (v.shape[0], lik.speeds.size) and np.all(np.isfinite(cap))
    eps, fac = prior.noise(w, v.shape[0])
    sig = prior.sigma_depth_mm(ev.cut_depth_mm)[None, :] * fac[:, None]

    def terms(b_lim):
        return cut_loglik((ev.cut_depth_mm[None, :] - b_lim) / sig, None, eps[:, None], ev.cut_grade[None, :])

    at_cap, at_inf = terms(cap[:, lik._ic]), terms(np.full(cap[:, lik._ic].shape, 1e9))
    assert np.max(np.abs(at_cap - at_inf)) <= 2 * CENSOR_TOL
    lower = ev.cut_depth_mm + 0.8 * (cap[:, lik._ic] - ev.cut_depth_mm)
    assert np.max(np.abs(terms(lower) - at_inf)) > 1e3 * CENSOR_TOL
    # a held label error of 0: a chatter term never saturates (log Φ(z) → −∞), so its column is not censored
    held = make_prior(prior.par.structure(prior.median), prior.cutting,
                      PriorTable({}, sigma_depth_rel=0.05, label_error=0.0))
    lik0 = Likelihood(held, Evidence.from_points(cuts), "spectral")
    cap0 = lik0.ceilings(v[:, :prior.size], None)
    chatter_cols = np.unique(lik0._ic[cuts.label == "chatter"])
    assert np.all(np.isinf(cap0[:, chatter_cols])) and np.all(np.isfinite(np.delete(cap0, chatter_cols, axis=1)))


def test_log_likelihood_with_censored_limits_is_the_exact_one(case):
    """log L of 40 prior draws (noise columns included) with censored limits and with every limit searched to its
    root: equal to 1e-12 (the terms above a ceiling are saturated to CENSOR_TOL; the roots themselves agree to
    ~1e-12), while a third of the entries or more were censored. Fails with ceilings ~3 s·σ_b lower (CENSOR_TOL
    1e-6: log L off by up to ~1e-7)."""
    prior, _, cuts, v = case
    lik = Likelihood(prior, Evidence.from_points(cuts), "spectral")
    got = lik(v)
    assert lik.n_censored > 0.3 * v.shape[0] * lik.speeds.size
    exact = Likelihood(prior, Evidence.from_points(cuts), "spectral")
    exact._censor = False
    want = exact(v)
    assert exact.n_censored == 0
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


def test_bounded_stage_with_censored_and_decided_columns(case):
    """Delayed acceptance's bounded stage with censored limits in its rounds: log L to 1e-12 wherever it clears the
    floor, a value below the floor elsewhere (never below the exact log L: a partial sum)."""
    prior, _, cuts, v = case
    lik = Likelihood(prior, Evidence.from_points(cuts), "spectral")
    exact = Likelihood(prior, Evidence.from_points(cuts), "spectral")
    exact._censor = False
    full = exact(v)
    rng = np.random.default_rng(2)
    floor = np.where(rng.random(full.size) < 0.5, full - 1.0, -2.5)  # half must be exact, half may stop early
    got = lik.bounded(v, floor)
    above = full > floor
    np.testing.assert_allclose(got[above], full[above], rtol=1e-12, atol=1e-12)
    margin = 1e-9 * (1 + np.abs(floor[~above]))
    assert np.all(got[~above] <= floor[~above] + margin) and np.all(got[~above] >= full[~above] - margin)
    assert lik.n_decided > 0 and lik.n_censored > 0
