"""Censored limits in decisions from an accurate posterior (issue 28): a map needs each limit only up to its deepest
depth, the fast search's every-sample stages only up to a ceiling above the depth a speed may hold, so an engine
with a censored search (``takes_ceiling``: spectral) stops there. Each is checked against the uncensored answer and
an independent brute force (every sample's own envelope), on cheap zero-order posteriors whose engine is declared to
censor here (zoa's ``envelope_batch`` takes a ceiling, issue 27; the rule does not depend on the engine); the
spectral engine's own censored search is checked in tests/test_likelihood_censor.py. And the doors' map default:
every sample from the cheapest engine, a seeded subsample from the others, its error stated."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from millstab.errors import InputError
from millstab.model import Cutting, Mode, Structure
from millstab.stability import get_engine, zoa
from millstab.update import Posterior, decide, make_prior
from millstab.update.decide import LimitColumns, allowed_count, effective_samples, recommend, safe_depth
from millstab.update.likelihood import limits

CUT = Cutting(2, 556.31e6, 0.404, 0.0, math.pi)
STRUCT = Structure(x=(Mode(903.0, 12.53e6, 0.03),), y=(Mode(1050.0, 15e6, 0.04),))
RANGE = (5000.0, 9000.0)


def _posterior(n: int, seed: int, engine: str = "zoa") -> Posterior:
    prior = replace(make_prior(STRUCT, CUT), tails="student")
    return Posterior(prior, np.exp(prior.sample(n, np.random.default_rng(seed))), engine, cuts={"rpm": list(RANGE)})


@pytest.fixture
def censoring(monkeypatch):
    """zoa declared to censor (its envelope_batch takes the ceiling) and a spy on the decisions' engine calls:
    a list of (rows, speeds, ceiling (R, S) or None, depths (R, S))."""
    monkeypatch.setattr(get_engine("zoa"), "takes_ceiling", True, raising=False)
    calls = []

    def spy(prior, u, rpm, *a, **k):
        out = limits(prior, u, rpm, *a, **k)
        calls.append((u.shape[0], np.asarray(rpm, float).copy(), k.get("ceiling_mm"), out[0]))
        return out

    monkeypatch.setattr(decide, "limits", spy)
    return calls


def _own(post: Posterior, speeds) -> np.ndarray:
    """Every sample's own limits [mm] (N, S): one envelope per sample, no ceiling, outside the decision code."""
    return np.array([zoa.envelope(post.prior.par.structure(t), CUT, speeds).depth_mm for t in post.samples])


def test_a_column_is_searched_to_its_ceiling_and_again_only_where_a_higher_one_needs_it(censoring):
    post = _posterior(150, 3)
    speeds = np.array([5500.0, 7100.0, 8800.0])
    want = _own(post, speeds)
    cols = LimitColumns(post, post.u)
    c1 = np.quantile(want, 0.3, axis=0)
    got = cols(speeds, c1)
    below = want < c1
    np.testing.assert_allclose(got[below], want[below], rtol=1e-12)  # below its ceiling: the limit
    assert np.all(got[~below] >= np.broadcast_to(c1, got.shape)[~below])  # above: a lower bound ≥ the ceiling
    assert np.all(got <= want * (1 + 1e-12)) and cols.censored == int((~below).sum()) > 0
    n_calls = len(censoring)
    again = cols(speeds[1:], None)  # no ceiling: the censored entries of those speeds alone, to the root
    np.testing.assert_allclose(again, want[:, 1:], rtol=1e-12)
    assert len(censoring) == n_calls + 1 and censoring[-1][0] == int((~below[:, 1:]).any(axis=1).sum())
    cols(speeds[1:], c1[1:])  # a lower ceiling than what is held: from memory
    assert len(censoring) == n_calls + 1


@pytest.mark.parametrize("margin", [None, -0.6])
def test_censored_fast_search_gives_the_uncensored_cut_and_the_full_posteriors_risk(monkeypatch, censoring, margin):
    """The fast search with its every-sample stages censored (and the subsample's coarse speeds between the ones the
    next test reads, and its refinement): the same cut, P(chatter) and next test as without,
    and the depth's risk under the full posterior by each sample's own limits (independent brute force). With the
    ceilings forced 60 % below their estimate (margin −0.6) every stage falls back to the root search where its
    depth reached the ceiling: still the same answer. Fails on the old code: no engine call carried a ceiling."""
    monkeypatch.setattr(decide, "SEARCH_SAMPLES", 30)
    if margin is not None:
        monkeypatch.setattr(decide, "SEARCH_CEILING_MARGIN", margin)
    post = _posterior(240, 0)
    tol, risk = 0.005, 0.05
    rec = recommend(post, risk, RANGE, speed_tolerance=tol, seed=0, search="fast", coarse_points=60)
    every = [(c, d) for n, _, c, d in censoring if n == np.unique(post.u, axis=0).shape[0] and c is not None]
    assert every and any(np.any((d >= c) & np.isfinite(c)) for c, d in every)  # censored entries were read
    sub = [(r, c) for n, r, c, _ in censoring if n == 30]  # the subsample: its coarse speeds between, its pockets
    assert sub[0][1] is None and sub[0][0].size == 30 and any(c is not None for _, c in sub[1:])
    if margin is not None:  # the ceilings fell below the depths: some stages searched a speed to the root again
        rows = np.unique(post.u, axis=0).shape[0]
        asked = [r for n, r, _, _ in censoring if n <= rows and n != decide.SEARCH_SAMPLES]
        assert len(np.concatenate(asked)) > len(np.unique(np.concatenate(asked)))
    monkeypatch.setattr(decide, "SEARCH_CENSOR", False)
    plain = recommend(post, risk, RANGE, speed_tolerance=tol, seed=0, search="fast", coarse_points=60)
    assert (rec.rpm, rec.p_chatter, rec.p_chatter_speed_error) == (plain.rpm, plain.p_chatter,
                                                                   plain.p_chatter_speed_error)
    assert rec.depth_mm == pytest.approx(plain.depth_mm, rel=1e-12) and rec.next_test == plain.next_test
    own = _own(post, rec.rpm * np.array([1 - tol, 1.0, 1 + tol]))
    count = allowed_count(240, risk, effective_samples(post), 0.9)
    assert (own <= rec.depth_mm).mean(0).max() <= count / 240 <= risk
    assert rec.depth_mm == pytest.approx(safe_depth(own, risk, count).min(), rel=1e-9)


def test_the_map_is_censored_at_its_deepest_depth_and_unchanged(censoring):
    """P(stable) with every limit above the map's deepest depth censored there: the same map as each sample's own
    limits counted (brute force); the engine was asked with that ceiling. Fails on the old code (no ceiling)."""
    post = _posterior(200, 1)
    rpm, depth = np.linspace(*RANGE, 11), np.linspace(0.1, 2.5, 13)
    got = decide.p_stable_map(post, rpm, depth)
    own = _own(post, rpm)
    assert 0.1 < (own > depth[-1]).mean() < 0.9  # the case censors a good share of the limits
    want = (own[:, :, None] > depth[None, None, :]).mean(0)
    np.testing.assert_allclose(got, want, atol=1e-12)
    (_, _, ceiling, d), = censoring
    assert np.all(ceiling == decide.map_ceiling(depth)) and decide.map_ceiling(depth) > depth[-1]
    assert np.sum(d >= ceiling * (1 - 1e-12)) == np.sum(own > ceiling)  # censored where the limit is above it


def test_the_doors_map_reads_a_subsample_from_an_accurate_engine_and_says_so(monkeypatch):
    """api.p_stable's default (``samples="auto"``): every sample from the cheapest engine; from another, a seeded
    subsample of decide.MAP_SAMPLES, its error stated. The engine calls are zero-order here (a spy swaps the
    engine: only the rows asked are checked). Fails on the old code (every sample read by default)."""
    from millstab import api

    asked = []

    def spy(prior, u, rpm, engine="zoa", *a, **k):
        asked.append((engine, u.shape[0]))
        return limits(prior, u, rpm, "zoa", *a, **{**k, "options": None, "ceiling_mm": None})

    monkeypatch.setattr(decide, "limits", spy)
    rpm, depth = np.linspace(*RANGE, 5), np.linspace(0.1, 2.0, 4)
    n = decide.MAP_SAMPLES + 100
    cheap, accurate = _posterior(n, 2), _posterior(n, 2, "spectral")
    api.p_stable(cheap, rpm, depth)
    assert asked[-1] == ("zoa", n)
    sub = api.p_stable(accurate, rpm, depth)
    rows = decide.map_rows(n, decide.MAP_SAMPLES, 0)
    assert asked[-1][0] == "spectral" and asked[-1][1] == np.unique(accurate.u[rows], axis=0).shape[0]
    np.testing.assert_array_equal(sub, decide.p_stable_map(cheap, rpm, depth, samples=decide.MAP_SAMPLES))
    assert api.map_samples_text(accurate) == (f"{decide.MAP_SAMPLES} of {n} samples (Monte Carlo standard error ≤ "
                                              f"{0.5 / decide.MAP_SAMPLES ** 0.5:.3f} per cell)")
    assert api.map_samples_text(cheap) == f"{n} samples" and api.map_samples(accurate, "all") is None
    assert api.map_samples(accurate, "300") == 300 and api.map_samples(accurate, 10 ** 6) is None
    for bad in ("some", "0", 0, "-3", 2.5):
        with pytest.raises(InputError, match="--samples"):
            api.map_samples(accurate, bad)


def test_a_map_and_a_recommendation_share_their_limits(monkeypatch):
    """The app's Map and recommend: the map's subsample holds the fast search's rows (nested subsamples), and with
    one memo the recommendation reads the map's limits at its coarse speeds (the map's own) instead of calling the
    engine: the same cut and next test as alone. Fails on the old code (the subsamples were drawn independently)."""
    from millstab import api

    monkeypatch.setattr(decide, "SEARCH_SAMPLES", 40)
    n = 300
    for seed in (0, 1, 2):
        small, big = decide.map_rows(n, 40, seed), decide.map_rows(n, 120, seed)
        assert np.isin(small, big).all() and big.size == np.unique(big).size == 120
    post = _posterior(n, 5)
    rpm, depth = np.linspace(*RANGE, 30), np.linspace(0.1, 3.0, 8)
    alone = recommend(post, 0.05, RANGE, seed=1, search="fast", coarse_points=30)
    calls = []

    def spy(prior, u, r, *a, **k):
        calls.append((u.shape[0], np.asarray(r, float).copy()))
        return limits(prior, u, r, *a, **k)

    monkeypatch.setattr(decide, "limits", spy)
    memo = api.limit_memo()
    pm = api.p_stable(post, rpm, depth, samples=120, seed=1, memo=memo)
    n_map = len(calls)
    rec = api.recommend(post, 0.05, RANGE, seed=1, search="fast", coarse_points=30, memo=memo)
    assert (rec.rpm, rec.depth_mm, rec.p_chatter_speed_error, rec.next_test) == (
        alone.rpm, alone.depth_mm, alone.p_chatter_speed_error, alone.next_test)
    # the subsample's coarse scan (its rows at the map's speeds) read the map's limits; every sample asks the engine
    # for the rows the map lacks at the range's ends
    assert not any(k <= 40 and np.isin(rpm, r).any() for k, r in calls[n_map:])
    np.testing.assert_array_equal(pm, decide.p_stable_map(post, rpm, depth, samples=120, seed=1))


@pytest.mark.slow
def test_a_spectral_map_censored_at_its_top_is_the_uncensored_one(monkeypatch):
    """The real censored search (spectral, through the Kt factor of the likelihood's limits): a map whose deepest depth
    is the median limit equals the count of the uncensored limits (one plain engine call), ~half of them censored."""
    post = _posterior(24, 7, "spectral")
    rpm = np.linspace(*RANGE, 5)
    full = limits(post.prior, post.decision_u, rpm, "spectral")[0]
    depth = np.linspace(0.02, 1.0, 12) * float(np.median(full))
    calls = []

    def spy(prior, u, r, *a, **k):
        out = limits(prior, u, r, *a, **k)
        calls.append((k.get("ceiling_mm"), out[0]))
        return out

    monkeypatch.setattr(decide, "limits", spy)
    got = decide.p_stable_map(post, rpm, depth)
    np.testing.assert_allclose(got, (full[:, :, None] > depth[None, None, :]).mean(0), atol=1e-12)
    (ceiling, out), = calls
    assert ceiling is not None and 0.2 < np.mean(out >= ceiling * (1 - 1e-12)) < 0.8
