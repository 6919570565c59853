"""Delayed acceptance's bounded second stage (issue 28): the accurate likelihood evaluates the speed columns in
rounds and stops where log L cannot clear the floor of the test (:meth:`Likelihood.bounded`). Exact: the rows
that may clear it get the numbers of a full call, the others a value below the floor, so the sampler takes
the same decisions and the same seed gives the same particles, bit for bit."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from millstab.io.config import parse_config
from millstab.points import PointSet
from millstab.update import make_prior
from millstab.update.likelihood import Evidence, Likelihood, limits
from millstab.update.sampler import tempered_smc
from configs import TWO_MODE_TOML


def _case(n_cuts: int = 9, sigma: str = "5 %"):
    """The two-mode config, its prior with learned label error and σ_b (noise columns in the sampler's
    vector), and ``n_cuts`` cuts at distinct speeds labelled by a truth 4 % / 20 % off the medians."""
    cfg = parse_config(TWO_MODE_TOML + f'[prior]\nsigma_depth = "{sigma}"\n')
    prior = make_prior(cfg.structure, cfg.cutting, cfg.prior)
    rng = np.random.default_rng(3)
    truth = np.log(prior.median) + rng.uniform(-0.2, 0.2, prior.size) * (np.arange(prior.size) % 2 + 0.2)
    rpm = np.linspace(5200, 11000, n_cuts)
    b = limits(prior, truth[None], rpm)[0][0]
    depth = b * rng.uniform(0.6, 1.4, rpm.size)
    return prior, PointSet(rpm, depth, np.where(depth > b, "chatter", "stable"))


def test_bounded_is_the_full_likelihood_where_it_can_clear_the_floor_and_below_it_elsewhere():
    prior, cuts = _case()
    lik = Likelihood(prior, Evidence.from_points(cuts))
    rng = np.random.default_rng(0)
    v = prior.sample_full(400, rng)
    full = lik(v)
    assert prior.dim > prior.size and np.isfinite(full).mean() > 0.9  # noise columns in v
    # floors around each row's own value: half of them above it (decidable), half below (must be exact)
    floor = full + rng.normal(0.0, 3.0, full.size)
    got = lik.bounded(v, floor)
    above = full > floor
    np.testing.assert_array_equal(got[above], full[above])  # bit for bit
    assert np.all(got[~above] <= floor[~above] + 1e-9 * (1 + np.abs(floor[~above])))
    assert lik.n_decided > 50 and lik.n_entries_saved > 0  # the rounds did stop early
    # a row decided early is below the floor because of its own evaluated cuts: the partial sum is an upper
    # bound of log L (every cut's term is a log-probability), so it is never below the full value
    early = got != full
    assert early.any() and np.all(got[early] >= full[early] - 1e-9 * (1 + np.abs(full[early])))
    # unbounded floors: the plain likelihood; rows outside the support: −inf as __call__ gives
    np.testing.assert_array_equal(lik.bounded(v, np.full(v.shape[0], -np.inf)), full)
    bad = v.copy()
    bad[:3, 2] = 5.0  # ζ far above 1
    np.testing.assert_array_equal(lik.bounded(bad, full - 10.0)[:3], lik(bad)[:3])


def test_delayed_acceptance_with_the_bounded_stage_gives_the_same_particles():
    """The same seed with and without the bounded second stage (a plain function has no ``bounded``):
    identical particles and log-likelihoods; a screen from a model with Kt 25 % high, so stage 2 rejects
    often (the rounds then save engine evaluations)."""
    prior, cuts = _case()
    ev = Evidence.from_points(cuts)
    lik = Likelihood(prior, ev)
    biased = dataclasses.replace(prior, cutting=dataclasses.replace(prior.cutting, kt=1.25 * prior.cutting.kt))
    scr = Likelihood(biased, ev)
    a = tempered_smc(prior.sample_full, prior.logpdf_full, lik, 300, seed=5, screen=scr)
    b = tempered_smc(prior.sample_full, prior.logpdf_full, lambda x: lik(x), 300, seed=5, screen=scr)
    np.testing.assert_array_equal(a.u, b.u)
    np.testing.assert_array_equal(a.loglik, b.loglik)
    assert a.betas == b.betas and lik.n_decided > 0


@pytest.mark.slow
def test_spectral_columns_alone_give_the_numbers_of_the_whole_call():
    """A subset of the speed columns, evaluated alone, keeps the whole list's discretisation (the spectral
    engine's node count is chosen per speed list, here 7 speeds whose first, middle and last differ from the
    subset's): the depths of a full call to the root's accuracy (a speed continued from its neighbour in one
    call and searched alone in the other lands on the same root to ~1e-12, not to the bit)."""
    prior, cuts = _case(7)
    lik = Likelihood(prior, Evidence.from_points(cuts), "spectral")
    u = prior.sample_full(4, np.random.default_rng(1))[:, :prior.size]
    full, _ = lik._evaluate(u)
    cols = np.array([4, 1])
    settings = lik._settings(u)
    np.testing.assert_allclose(lik._columns(u, cols, settings), full[:, cols], rtol=1e-10)
    f = lik._forwards[0]
    assert settings[0] == dict(f.pinned(lik.speeds, at=f.par.theta0).settings)  # the whole list's, at θ0
