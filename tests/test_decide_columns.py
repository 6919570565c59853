"""A decision's limits computed once per (distinct sample, speed) (issue 28: a spectral campaign in minutes): the
repeats of a resampled posterior evaluated once, a column asked twice read from memory, the fast search's
±tolerance neighbours read only where they can change the answer. Each is checked against the plain computation
(every row, every column, one call), on cheap zero-order posteriors; the spectral engine's row and speed
independence, which makes them exact there too, on a few samples (slow tier)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from millstab.model import Cutting, Mode, Structure
from millstab.update import Posterior, decide, make_prior
from millstab.update.decide import LimitColumns, decision_options, distinct_limits, recommend
from millstab.update.likelihood import limits

CUT = Cutting(2, 556.31e6, 0.404, 0.0, math.pi)
STRUCT = Structure(x=(Mode(903.0, 12.53e6, 0.03),), y=(Mode(1050.0, 15e6, 0.04),))
RANGE = (5000.0, 9000.0)


def _resampled(n: int, distinct: int, seed: int, engine: str = "zoa", cutting: Cutting = CUT) -> Posterior:
    """A posterior of ``n`` rows drawn with repeats from ``distinct`` prior draws (as resampling leaves it)."""
    prior = make_prior(STRUCT, cutting)
    rng = np.random.default_rng(seed)
    u = prior.sample(distinct, rng)[rng.integers(0, distinct, n)]
    return Posterior(prior, np.exp(u), engine, cuts={"rpm": list(RANGE)})


def test_distinct_rows_are_evaluated_once_and_give_every_rows_limits(monkeypatch):
    post = _resampled(300, 70, 0)
    speeds = np.linspace(*RANGE, 17)
    want = limits(post.prior, post.u, speeds)[0]
    seen = []

    def spy(prior, u, rpm, *a, **k):
        seen.append(u.shape[0])
        return limits(prior, u, rpm, *a, **k)

    monkeypatch.setattr(decide, "limits", spy)
    got = distinct_limits(post.prior, post.u, speeds)
    assert seen == [np.unique(post.u, axis=0).shape[0]] and seen[0] <= 70
    np.testing.assert_array_equal(got, want)  # bit for bit: a row's limit does not depend on the other rows


def test_a_column_asked_twice_is_computed_once(monkeypatch):
    post = _resampled(200, 90, 1)
    asked = []

    def spy(prior, u, rpm, *a, **k):
        asked.append(np.asarray(rpm, float).copy())
        return limits(prior, u, rpm, *a, **k)

    monkeypatch.setattr(decide, "limits", spy)
    cols = LimitColumns(post, post.u)
    a = cols([6000.0, 7000.0, 8000.0])
    b = cols([7000.0, 8500.0, 6000.0, 7000.0])  # two seen, one new, one repeat within the request
    assert [x.tolist() for x in asked] == [[6000.0, 7000.0, 8000.0], [8500.0]]
    whole = limits(post.prior, post.u, [6000.0, 7000.0, 8000.0, 8500.0])[0]
    np.testing.assert_array_equal(a, whole[:, :3])
    np.testing.assert_array_equal(b, whole[:, [1, 3, 0, 1]])
    assert cols([]).shape == (200, 0)


@pytest.mark.parametrize("seed", [0, 1, *(pytest.param(s, marks=pytest.mark.slow) for s in (2, 3))])
def test_the_bounded_search_chooses_the_cut_of_reading_every_neighbour(monkeypatch, seed):
    """The fast search with the nominal-speed bound (:data:`decide.SEARCH_BOUND`) recommends the very cut (speed,
    depth, P(chatter), next test) of the search that reads every candidate's ±tolerance neighbours, reading fewer
    every-sample columns; with a data guard (chatter cuts the prior does not explain) and without."""
    monkeypatch.setattr(decide, "SEARCH_SAMPLES", 40)
    post = _resampled(300, 180, seed)
    if seed % 2:
        post.cuts.update({"rpm": [5200.0, 8800.0, 7000.0], "depth_mm": [0.4, 0.5, 3.0],
                          "label": ["chatter", "chatter", "stable"]})
    count = {}

    def spy(prior, u, rpm, *a, **k):
        count[flag] = count.get(flag, 0) + (np.size(rpm) if u.shape[0] > 40 else 0)
        return limits(prior, u, rpm, *a, **k)

    monkeypatch.setattr(decide, "limits", spy)
    out = {}
    for flag in (True, False):
        monkeypatch.setattr(decide, "SEARCH_BOUND", flag)
        out[flag] = recommend(post, 0.05, RANGE, seed=seed, search="fast", coarse_points=50, speed_tolerance=0.01)
    a, b = out[True], out[False]
    assert (a.rpm, a.depth_mm, a.p_chatter, a.p_chatter_speed_error, a.limited_by) == \
        (b.rpm, b.depth_mm, b.p_chatter, b.p_chatter_speed_error, b.limited_by)
    assert a.next_test == b.next_test
    assert count[True] < count[False]


def test_a_confirmed_search_reuses_the_first_searchs_limits(monkeypatch):
    """With ``confirm="always"`` the search runs again with the confirmed cuts' speeds: its subsample scan and every
    sample's columns already computed are read from memory (each (rows, speed) asked of the engine once), and the
    answer is that of a fresh computation (the cut's P(chatter) by every sample's own limit)."""
    monkeypatch.setattr(decide, "SEARCH_SAMPLES", 40)
    post = _resampled(240, 150, 5)
    post.cuts.update({"rpm": [6100.0, 7300.0], "depth_mm": [0.3, 0.35], "label": ["stable", "stable"]})
    asked: dict[int, list] = {}

    def spy(prior, u, rpm, *a, **k):
        asked.setdefault(u.shape[0], []).extend(np.ravel(rpm).tolist())
        return limits(prior, u, rpm, *a, **k)

    monkeypatch.setattr(decide, "limits", spy)
    rec = recommend(post, 0.05, RANGE, seed=2, search="fast", coarse_points=40, confirm="always")
    for speeds in asked.values():
        assert len(speeds) == len(set(speeds))
    own = limits(post.prior, post.decision_u, [rec.rpm])[0][:, 0]
    assert rec.p_chatter == pytest.approx(np.mean(own <= rec.depth_mm), abs=1e-12)


@pytest.mark.slow
def test_spectral_limits_do_not_depend_on_the_other_rows_or_speeds_of_a_call():
    """Under the decision's pinned discretisation, the spectral limits of a posterior's rows at speeds split over
    calls in two ways (and its repeats evaluated once) are those of one call of every row at every speed to the
    root search's tolerance (measured 3e-13 relative: the continuation from speed to speed starts each search
    elsewhere), at a/D 0.1 down milling (the campaigns' case)."""
    cut = Cutting.from_immersion(2, 556.31e6, 0.404, 0.1, "down")
    post = _resampled(12, 5, 7, "spectral", cut)
    rng_ = (8000.0, 11000.0)
    opts = decision_options(post, rng_)
    assert set(opts) == {"nodes", "near"}
    speeds = np.array([8000.0, 8600.0, 9300.0, 9301.0, 10400.0, 11000.0])
    whole = limits(post.prior, post.u, speeds, "spectral", options=opts)[0]
    a = LimitColumns(post, post.u, opts)
    a(speeds[[4, 1]])
    np.testing.assert_allclose(a(speeds), whole, rtol=1e-10)
    b = LimitColumns(post, post.u, opts)
    np.testing.assert_allclose(np.concatenate([b(speeds[:3]), b(speeds[3:])], axis=1), whole, rtol=1e-10)


def test_a_campaigns_memo_reads_the_kept_samples_and_decides_alike(monkeypatch):
    """Two posteriors that share most rows (as consecutive rounds of a campaign do): with a :class:`LimitMemo` the
    second recommendation and map ask the engine only for the rows the first did not have at the repeated speeds,
    and give the answers (cut, next test, map) of a fresh computation."""
    from millstab.update.decide import LimitMemo, p_stable_map

    monkeypatch.setattr(decide, "SEARCH_SAMPLES", 40)
    first = _resampled(300, 150, 8)
    rng = np.random.default_rng(9)
    u = first.u.copy()
    moved = rng.random(u.shape[0]) < 0.3  # a move changed 30 % of the particles
    u[moved] += 0.01 * rng.standard_normal((moved.sum(), u.shape[1]))
    second = Posterior(first.prior, np.exp(u), "zoa", cuts={"rpm": list(RANGE)})
    grid = np.linspace(*RANGE, 11)
    memo = LimitMemo()
    recommend(first, 0.05, RANGE, seed=1, search="fast", coarse_points=40, memo=memo)
    p_stable_map(first, grid, [0.5, 1.0], memo=memo)
    rows = []

    def spy(prior, u, rpm, *a, **k):
        rows.append((u.shape[0], np.size(rpm)))
        return limits(prior, u, rpm, *a, **k)

    monkeypatch.setattr(decide, "limits", spy)
    got = recommend(second, 0.05, RANGE, seed=1, search="fast", coarse_points=40, memo=memo)
    got_map = p_stable_map(second, grid, [0.5, 1.0], memo=memo)
    # the map's grid: only the moved rows (and none of the kept ones) went to the engine
    assert rows[-1] == (np.unique(u[moved], axis=0).shape[0], grid.size)
    monkeypatch.setattr(decide, "limits", limits)
    want = recommend(second, 0.05, RANGE, seed=1, search="fast", coarse_points=40)
    assert (got.rpm, got.depth_mm, got.p_chatter, got.next_test) == (want.rpm, want.depth_mm, want.p_chatter,
                                                                      want.next_test)
    np.testing.assert_array_equal(got_map, p_stable_map(second, grid, [0.5, 1.0]))


def test_limit_memo_keeps_limits_by_row_and_speed_against_a_dense_reference():
    """:class:`LimitMemo` against a plain dict of (row, speed) → limit filled in the same order: what it returns
    as known is exactly what was kept last (later values replace earlier ones, NaN entries are not kept), rows
    and speeds first seen in any order, columns grown as new rows arrive; another posterior's binding clears it."""
    from millstab.update.decide import LimitMemo

    rng = np.random.default_rng(5)
    keys = [rng.bytes(48) for _ in range(30)]
    speeds = [float(x) for x in rng.uniform(5000, 9000, 12).round()]
    memo, dense = LimitMemo(), {}
    for _ in range(40):
        ks = [keys[i] for i in rng.choice(30, rng.integers(1, 12), replace=False)]
        xs = [speeds[j] for j in rng.choice(12, rng.integers(1, 5), replace=False)]
        vals = rng.uniform(0.1, 5.0, (len(ks), len(xs)))
        vals[rng.random(vals.shape) < 0.3] = np.nan  # a censored bound or an entry not asked: not kept
        vals[rng.random(vals.shape) < 0.05] = np.inf  # no boundary: a limit, kept
        memo.remember(ks, xs, vals)
        for i, k in enumerate(ks):
            for j, x in enumerate(xs):
                if not np.isnan(vals[i, j]):
                    dense[k, x] = vals[i, j]
        got, have = memo.known(keys, speeds)
        want = np.array([[dense.get((k, x), np.nan) for x in speeds] for k in keys])
        np.testing.assert_array_equal(have, ~np.isnan(want))
        np.testing.assert_array_equal(got[have], want[have])
        assert np.all(got[~have] == 0.0)
    post = _resampled(50, 20, 1)
    memo.bind(post, {})
    assert not memo.known(keys, speeds)[1].any()
