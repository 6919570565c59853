"""The fast speed search of ``recommend`` (issue 28: decisions from an accurate posterior): a subsample finds the
pockets, every sample sets the depth. Checked on cheap zero-order posteriors with the fast search forced and a
small subsample (the rule does not depend on the engine): the depth's risk under the FULL posterior, by an
independent brute-force count; the pockets; the full search unchanged for the cheapest engine."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from millstab.errors import InputError
from millstab.model import Cutting, Mode, Structure
from millstab.stability import zoa
from millstab.update import Posterior, make_prior
from millstab.update import decide
from millstab.update.decide import allowed_count, effective_samples, pockets, recommend, safe_depth
from millstab.update.likelihood import limits

CUT = Cutting(2, 556.31e6, 0.404, 0.0, math.pi)
STRUCT = Structure(x=(Mode(903.0, 12.53e6, 0.03),), y=(Mode(1050.0, 15e6, 0.04),))
RANGE = (5000.0, 9000.0)


def _posterior(n: int, seed: int) -> Posterior:
    # prior-wide posteriors: draws of the independent Student-t prior (the cases below were constructed on its draws)
    prior = replace(make_prior(STRUCT, CUT), tails="student")
    return Posterior(prior, np.exp(prior.sample(n, np.random.default_rng(seed))), cuts={"rpm": list(RANGE)})


def test_pockets_are_the_largest_local_maxima():
    p = np.array([3.0, 1.0, 2.0, 2.0, 0.5, 5.0, 4.0, 4.5, 1.0, 0.0, 6.0])
    # maxima: 0 (end, 3), 2 (plateau 2-3 counted once), 5 (5), 7 (4.5), 10 (end, 6)
    assert pockets(p, 3).tolist() == [10, 5, 7]
    assert pockets(p, 10).tolist() == [10, 5, 7, 0, 2]
    assert pockets(np.zeros(5), 3).tolist() == [0]


@pytest.mark.parametrize("seed", [0, pytest.param(1, marks=pytest.mark.slow), pytest.param(2, marks=pytest.mark.slow)])
def test_fast_search_depth_holds_the_full_posterior_risk(monkeypatch, seed):
    """Every sample's OWN limit (one engine call per sample, independent of the decision code) at the fast
    recommendation's speed and ±tolerance: at most the allowed count of the FULL posterior lie at or below the
    depth. Fails when the depth is the subsample's quantile (it is too deep for the full posterior in these
    seeds: a subsample of 30 cannot resolve a 5 % quantile)."""
    monkeypatch.setattr(decide, "SEARCH_SAMPLES", 30)
    post = _posterior(240, seed)
    tol, risk = 0.005, 0.05
    rec = recommend(post, risk, RANGE, confidence=0.9, speed_tolerance=tol, seed=seed, search="fast")
    speeds = rec.rpm * np.array([1 - tol, 1.0, 1 + tol])
    own = np.array([zoa.envelope(post.prior.par.structure(t), CUT, speeds).depth_mm for t in post.samples])  # (N, 3)
    frac = (own <= rec.depth_mm).mean(0)
    allowed = allowed_count(240, risk, effective_samples(post), 0.9) / 240
    assert frac.max() <= allowed <= risk
    assert rec.p_chatter == pytest.approx(frac[1], abs=1e-12)
    assert rec.p_chatter_speed_error == pytest.approx(frac.max(), abs=1e-12)
    # and it is the deepest such depth there: the full posterior's safe depth at the three speeds
    want = safe_depth(own, risk, allowed_count(240, risk, effective_samples(post), 0.9)).min()
    assert rec.depth_mm == pytest.approx(want, rel=1e-9)


def test_fast_search_finds_the_full_scans_pocket(monkeypatch):
    """A constructed case (a prior-wide posterior over a wide speed range, a subsample of 40) where the
    subsample's most productive pocket is not the full scan's: the full scan's best speed is among the
    subsample's top pockets (an independent coarse scan of the same rows), and handing them all to every
    sample recovers the full scan's productivity within 1 %; handing on the subsample's best pocket alone
    loses 18 % (so the case tells the two apart)."""
    rng_ = (6000.0, 11000.0)
    monkeypatch.setattr(decide, "SEARCH_SAMPLES", 40)
    post = _posterior(300, 1)
    post.cuts["rpm"] = list(rng_)
    full = recommend(post, 0.05, rng_, seed=3, search="full", coarse_points=60)
    fast = recommend(post, 0.05, rng_, seed=3, search="fast", coarse_points=60)
    assert fast.productivity == pytest.approx(full.productivity, rel=0.01)
    rows = np.sort(np.random.default_rng(3).choice(300, 40, replace=False))
    speeds = np.linspace(*rng_, 60)
    offs = np.array([1.0, 1 - decide.SPEED_TOLERANCE, 1 + decide.SPEED_TOLERANCE])  # the depth holds at ±tolerance
    blim = limits(post.prior, post.decision_u[rows], (speeds[None, :] * offs[:, None]).ravel())[0]
    cnt = round(allowed_count(300, 0.05, effective_samples(post), 0.9) * 40 / 300)
    depth = safe_depth(blim, 0.05, cnt).reshape(3, speeds.size).min(axis=0)
    tops = speeds[pockets(depth * speeds, decide.SEARCH_POCKETS)]
    assert np.min(np.abs(tops - full.rpm)) <= 2 * (speeds[1] - speeds[0])
    monkeypatch.setattr(decide, "SEARCH_POCKETS", 1)
    alone = recommend(post, 0.05, rng_, seed=3, search="fast", coarse_points=60)
    assert alone.productivity < 0.9 * full.productivity


def test_the_subsample_reads_the_nominal_speeds_and_every_sample_the_speed_error_too(monkeypatch):
    """The fast search's subsample stages (coarse scan, pockets' refinement) call the engine at the nominal speeds
    only; the stages with every sample (choice among the pockets, polish, the cut's own check), which set the
    depth, read the chosen cut's ±tolerance neighbours too; and no (rows, speed) is asked of the engine twice (the
    cut's own check reads the columns of the stage that chose it). On the old code the subsample's coarse call held
    3 × 40 speeds (before the nominal-only scan), and the cut's own check asked its three speeds again."""
    monkeypatch.setattr(decide, "SEARCH_SAMPLES", 30)
    calls = []

    def spy(prior, u, rpm, *a, **k):
        calls.append((u.shape[0], np.asarray(rpm, float).copy()))
        return limits(prior, u, rpm, *a, **k)

    monkeypatch.setattr(decide, "limits", spy)
    post = _posterior(120, 4)  # prior draws: every row distinct, so the calls' row counts tell the stages apart
    tol = decide.SPEED_TOLERANCE
    rec = recommend(post, 0.05, RANGE, seed=0, search="fast", coarse_points=40, confidence=None)
    sub = [r for n, r in calls if n == 30]
    every = [r for n, r in calls if n == 120]
    assert sub and every and len(sub) + len(every) == len(calls)
    np.testing.assert_allclose(sub[0], np.linspace(*RANGE, 40))  # the coarse scan: 40 nominal speeds
    assert len(sub) == 1 + decide.SEARCH_REFINE_ROUNDS
    for r in sub[1:]:  # each round: at most SEARCH_REFINE_POINTS speeds per pocket, no ±tolerance triples
        assert r.size <= decide.SEARCH_POCKETS * decide.SEARCH_REFINE_POINTS
    for group in (sub, every):  # each (rows, speed) once
        asked = np.concatenate(group)
        assert np.unique(asked).size == asked.size
    asked = np.concatenate(every)
    for x in rec.rpm * np.array([1.0, 1 - tol, 1 + tol]):  # the depth was held at the speed error, every sample
        assert np.any(asked == x)


def test_the_cheapest_engine_keeps_the_full_search_bit_for_bit():
    post = _posterior(300, 5)
    assert not decide.fast_search_for("zoa") and decide.fast_search_for("spectral")
    auto = recommend(post, 0.05, RANGE, seed=1)
    full = recommend(post, 0.05, RANGE, seed=1, search="full")
    assert (auto.rpm, auto.depth_mm, auto.next_test) == (full.rpm, full.depth_mm, full.next_test)
    with pytest.raises(InputError, match="search"):
        recommend(post, 0.05, RANGE, search="quick")


def test_map_from_a_subsample_counts_those_rows_within_its_stated_error():
    from millstab.update.decide import map_error, map_rows, p_stable_map

    post = _posterior(400, 0)
    rpm, depth = np.linspace(*RANGE, 9), np.linspace(0.05, 4.0, 12)
    sub = p_stable_map(post, rpm, depth, samples=100, seed=2)
    rows = map_rows(400, 100, 2)
    assert rows.size == 100 and np.array_equal(rows, map_rows(400, 100, 2))  # seeded
    own = np.array([zoa.envelope(post.prior.par.structure(t), CUT, rpm).depth_mm for t in post.samples[rows]])
    np.testing.assert_allclose(sub, (own[:, :, None] > depth[None, None, :]).mean(0), atol=1e-12)
    full = p_stable_map(post, rpm, depth)
    assert np.abs(sub - full).max() <= 4 * map_error(100)  # 4 sd of the largest standard error, 0.2
    assert np.array_equal(p_stable_map(post, rpm, depth, samples=400), full)
    with pytest.raises(InputError, match="--samples"):
        p_stable_map(post, rpm, depth, samples=0)


def test_the_doors_check_the_search_before_any_posterior_is_read():
    from millstab import api

    span, rule = api.decision_rule(0.05, "5000:9000", search="fast")
    assert rule["search"] == "fast" and span == (5000.0, 9000.0)
    with pytest.raises(InputError, match="--search"):
        api.decision_rule(0.05, "5000:9000", search="quick")
    assert tuple(decide.SEARCH_CHOICES) == ("auto", "fast", "full")  # the door's copy of the choices
