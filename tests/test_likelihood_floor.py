"""Floors in the accurate likelihood (issue 28; :meth:`Likelihood.floors`, the mirror of the ceilings): below the
depth where every cut's term at a column is saturated to the last bit, the spectral engine returns a ladder rung
below the floor instead of searching for the limit (``envelope_batch(..., floor=...)``). log L, the bounded second
stage and the anchored screen's limits must give the same numbers bit for bit as without floors."""

from __future__ import annotations

import numpy as np
import pytest

from millstab.io import load_config
from millstab.io.config import PriorTable
from millstab.model import Cutting
from millstab.points import PointSet
from millstab.update import make_prior
from millstab.update.likelihood import Evidence, Likelihood, cut_loglik

RPM = np.array([5116.0, 6889.0, 8805.0, 10106.0, 11546.0])


@pytest.fixture(scope="module")
def case():
    """Example 1 at a/D 0.1 down milling, the default prior with learned label error and depth noise, 8 cuts at 5
    speeds (chatter cuts far above most draws' limits: columns a floor decides) and 60 prior draws."""
    cfg = load_config("example:ex1")
    cut = Cutting.from_immersion(cfg.cutting.teeth, cfg.cutting.kt, cfg.cutting.kr, 0.1, "down")
    prior = make_prior(cfg.structure, cut, PriorTable({}, sigma_depth_rel=0.05))
    rpm = np.r_[RPM, RPM[[1, 3, 4]]]
    depth = np.array([9.0, 60.0, 50.0, 9.5, 8.0, 80.0, 12.0, 45.0])
    label = np.array(["stable", "chatter", "chatter", "stable", "chatter", "chatter", "chatter", "chatter"])
    v = prior.sample_full(60, np.random.default_rng(5))
    return prior, PointSet(rpm, depth, label), v


def _pair(prior, cuts):
    floored = Likelihood(prior, Evidence.from_points(cuts), "spectral")
    plain = Likelihood(prior, Evidence.from_points(cuts), "spectral")
    plain._floor = False
    return floored, plain


def test_each_cut_term_is_the_same_bits_below_its_floor(case):
    """Brute force: every cut's term at b_lim = its column's floor and at b_lim = 1e-9 mm (a limit far below) are
    the same to the last bit, per row; at 0.8 of the way from the cut down to its own saturation depth they are not.
    A held label error of 0: no term is the same bits below any depth (a stable term log Φ(−z) → −∞, a chatter term
    log Φ(z) → 0 without an ulp scale), so no column has a floor."""
    prior, cuts, v = case
    lik = Likelihood(prior, Evidence.from_points(cuts), "spectral")
    ev, w = lik.evidence, v[:, prior.size:prior.dim]
    low = lik.floors(v[:, :prior.size], w)
    col = low[:, lik._ic]
    pos = col > 0  # (none where a row's depth noise puts b − k s σ_b below 0)
    assert pos.mean() > 0.8
    eps, fac = prior.noise(w, v.shape[0])
    sig = prior.sigma_depth_mm(ev.cut_depth_mm)[None, :] * fac[:, None]

    def terms(b_lim):
        return cut_loglik((ev.cut_depth_mm[None, :] - b_lim) / sig, None, eps[:, None], ev.cut_grade[None, :])

    far = terms(np.full(col.shape, 1e-9))
    np.testing.assert_array_equal(terms(col)[pos], far[pos])
    own = lik.saturation_depths(v[:, :prior.size], w, above=False, bits=True)
    assert np.all(own[pos] >= col[pos])
    assert np.all(terms(ev.cut_depth_mm - 0.8 * (ev.cut_depth_mm - own))[pos] != far[pos])
    held = make_prior(prior.par.structure(prior.median), prior.cutting,
                      PriorTable({}, sigma_depth_rel=0.05, label_error=0.0))
    lik0 = Likelihood(held, Evidence.from_points(cuts), "spectral")
    assert np.all(lik0.floors(v[:, :prior.size], None) == 0)


def test_log_likelihood_with_floors_is_the_same_bits(case):
    """log L of 60 prior draws (noise columns included) with and without floors: equal bit for bit, with a sixth of
    the entries or more floored; so are the anchored screen's log L (:meth:`Likelihood.depths`, whose limits differ
    only where floored: a rung below the floor in place of a limit below it) and the bounded stage's."""
    prior, cuts, v = case
    floored, plain = _pair(prior, cuts)
    got, want = floored(v), plain(v)
    np.testing.assert_array_equal(got, want)
    assert np.isfinite(want).sum() > 40 and floored.n_floored > 0 and plain.n_floored == 0
    ll_f, d_f = floored.depths(v)
    ll_p, d_p = plain.depths(v)
    np.testing.assert_array_equal(ll_f, ll_p)
    low = floored.floors(v[:, :prior.size], v[:, prior.size:prior.dim])
    moved = d_f != d_p
    assert moved.sum() > 0.15 * moved.size
    assert np.all(d_f[moved] < low[moved]) and np.all(d_p[moved] < low[moved])
    rng = np.random.default_rng(3)
    cut_at = np.where(rng.random(want.size) < 0.5, want - 1.0, -3.0)
    np.testing.assert_array_equal(floored.bounded(v, cut_at), plain.bounded(v, cut_at))


def test_with_chatter_frequencies_the_columns_without_a_reading_are_still_censored(case):
    """Measured chatter frequencies (a microphone's, `millstab listen`): the frequency term reads f_c at the limit of
    its cut's column, so those columns are searched to the limit, and every other column keeps its ceiling and floor
    (until 2026-11-29 any reading switched both off for the whole update: a spectral update with readings cost ~3×
    one without). log L of 60 prior draws equals, to rounding, that of a likelihood without ceilings and floors; the
    entries censored or floored lie in the columns without a reading only, and there are some."""
    prior, cuts, v = case
    hz = np.where(cuts.label == "chatter", 1.0, np.nan) * np.array([1010, 1030, 990, 0, 1005, 1020, 985, 1015.0])
    read = PointSet(cuts.rpm, cuts.depth_mm, cuts.label, chatter_hz=hz)
    lik = Likelihood(prior, Evidence.from_points(read), "spectral")
    plain = Likelihood(prior, Evidence.from_points(read), "spectral")
    plain._censor = plain._floor = False
    assert lik.uses_frequency and lik._censor and lik._floor
    got, want = lik(v), plain(v)
    ok = np.isfinite(want)
    assert ok.sum() > 40 and np.array_equal(np.isfinite(got), ok)
    np.testing.assert_allclose(got[ok], want[ok], rtol=1e-12, atol=1e-10)
    assert lik.n_censored + lik.n_floored > 0 and plain.n_censored + plain.n_floored == 0
    # which columns: the ones holding a reading are exact (an infinite ceiling, no floor)
    w = v[:, prior.size:prior.dim]
    cap, low = lik.ceilings(v[:, :prior.size], w), lik.floors(v[:, :prior.size], w)
    read_cols = np.unique(lik._ic[np.isfinite(hz)])
    assert np.all(np.isinf(cap[:, read_cols])) and np.all(low[:, read_cols] == 0)
    free = np.setdiff1d(np.arange(lik.speeds.size), read_cols)
    assert free.size and (np.isfinite(cap[:, free]).any() or (low[:, free] > 0).any())

