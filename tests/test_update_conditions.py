"""Updating from cuts in several cutting conditions, and Kr free.

References: the single-condition likelihood of the same cuts (a prior built on that condition's own
cutting, the path of earlier versions) and the single-structure engine (zoa, spectral, sdm) at the sample's Kr."""

from __future__ import annotations

import math

import numpy as np
import pytest

from millstab.errors import InputError
from millstab.io.config import parse_config
from millstab.model import Cutting, Mode, Structure
from millstab.stability import zoa
from millstab.update import make_prior
from millstab.update.likelihood import Evidence, Likelihood, limits
from millstab.update.sampler import tempered_smc
from configs import TWO_MODE_TOML

SLOT = Cutting(2, 556.31e6, 0.404, 0.0, math.pi)
UP3 = Cutting.from_immersion(3, 556.31e6, 0.404, 0.3, "up")
STRUCT = Structure(x=(Mode(903.0, 12.53e6, 0.03),), y=(Mode(1050.0, 15e6, 0.04),))


def _evidence(rng, n, hz=False):
    rpm = rng.uniform(4000, 12000, n).round(-1)
    depth = rng.uniform(0.5, 4.0, n)
    kind = rng.integers(0, 3, n)
    chatter_hz = np.where(kind > 0, rng.uniform(850, 1150, n), np.nan) if hz else np.full(n, np.nan)
    return rpm, depth, kind, chatter_hz


def test_two_condition_likelihood_is_the_sum_of_the_single_condition_ones():
    """One likelihood over cuts in two conditions (one speed cut in both) = the likelihood of each condition's
    cuts alone, each under a prior built on that condition's cutting (chatter frequencies read against the
    cut's own tooth-passing frequency: 2 and 3 teeth)."""
    rng = np.random.default_rng(3)
    ra, da, ka, ha = _evidence(rng, 9, hz=True)
    rb, db, kb, hb = _evidence(rng, 7, hz=True)
    rb[0] = ra[0]  # the same speed under both conditions: two columns
    pa, pb = make_prior(STRUCT, SLOT), make_prior(STRUCT, UP3)
    both = Evidence(np.r_[ra, rb], np.r_[da, db], np.r_[ka, kb], np.ones(16), np.r_[ha, hb], np.array([7000.0]),
                    np.array([1.5]), np.ones(1), cut_cond=np.r_[np.zeros(9), np.ones(7)].astype(int),
                    pt_cond=np.array([1]), conditions=(SLOT, UP3))
    lik = Likelihood(pa, both)
    assert lik.speeds.size == 17 and np.unique(lik.speeds).size == 16 and lik.uses_frequency  # one speed, two columns
    la = Likelihood(pa, Evidence(ra, da, ka, np.ones(9), ha, np.zeros(0), np.zeros(0), np.zeros(0)))
    lb = Likelihood(pb, Evidence(rb, db, kb, np.ones(7), hb, np.array([7000.0]), np.array([1.5]), np.ones(1)))
    u = pa.sample_full(12, np.random.default_rng(4))
    got, want = lik(u), la(u) + lb(u)
    assert np.all(np.isfinite(want))
    np.testing.assert_allclose(got, want, rtol=1e-12)
    assert lik.n_calls == 1  # ONE engine call for both conditions
    # the conditions matter: read as all slotting, the same cuts give another likelihood
    same = Evidence(np.r_[ra, rb], np.r_[da, db], np.r_[ka, kb], np.ones(16), np.r_[ha, hb], np.array([7000.0]),
                    np.array([1.5]), np.ones(1))
    assert not np.allclose(Likelihood(pa, same)(u), got)


def test_evidence_condition_indices_are_checked():
    with pytest.raises(InputError, match="cut_cond"):
        Evidence(np.array([5000.0]), np.array([1.0]), np.array([0]), np.ones(1), np.full(1, np.nan), np.zeros(0),
                 np.zeros(0), np.zeros(0), cut_cond=np.array([1]), conditions=(SLOT,))
    with pytest.raises(InputError, match="pt_cond"):
        Evidence(np.array([5000.0]), np.array([1.0]), np.array([0]), np.ones(1), np.full(1, np.nan), np.ones(1),
                 np.ones(1), np.ones(1), pt_cond=np.array([0, 0]))


def _kr_prior(spread="20 %", extra=""):
    cfg = parse_config(TWO_MODE_TOML + f'[prior]\nkr = "{spread}"\n{extra}')
    return cfg, make_prior(cfg.structure, cfg.cutting, cfg.prior)


def test_kr_free_limits_are_the_engine_at_each_samples_kr():
    cfg, pr = _kr_prior()
    assert pr.names[-1] == "kr" and pr.kr_free and pr.units()[-1] == "-"
    assert pr.median[-1] == cfg.cutting.kr and pr.spread[-1] == pytest.approx(0.2)
    u = pr.sample(3, np.random.default_rng(0))
    rpm = np.array([4000.0, 7500.0, 11000.0])
    got, _ = limits(pr, u, rpm)
    theta, _ = pr.split(u)
    for row, kr in zip(range(3), pr.kr_of(u)):
        c = cfg.cutting
        want = zoa.envelope(pr.par.structure(theta[row]), Cutting(c.teeth, c.kt, kr, c.entry, c.exit), rpm).depth_mm
        np.testing.assert_array_equal(got[row], want)


@pytest.mark.parametrize("engine, options, direct", [("spectral", {"nodes": 6, "near": 0.02}, {"warm": False}),
                                                     ("sdm", {"steps": 20}, {})])
def test_kr_free_limits_of_the_time_domain_engines_are_each_samples_kr(engine, options, direct):
    """Kr free with the interrupted-cutting engines (issue 27): the likelihood's limits of three prior samples, one
    engine call, are each sample's own call at its Kr, bit for bit, under one pinned discretisation (a sampler's:
    the spectral engine without warm starts)."""
    from millstab.frf import ModalBatch
    from millstab.stability import get_engine

    cfg, pr = _kr_prior()
    u = pr.sample(3, np.random.default_rng(1))
    rpm = np.array([4000.0, 7500.0, 11000.0])
    got, _ = limits(pr, u, rpm, engine, options=options)
    theta, _ = pr.split(u)
    eng, c = get_engine(engine), cfg.cutting
    for row, kr in zip(range(3), pr.kr_of(u)):
        batch = ModalBatch.from_structures([pr.par.structure(theta[row])])
        cut = Cutting(c.teeth, c.kt, kr, c.entry, c.exit)
        want = eng.envelope_batch(batch, cut, rpm, **options, **direct)[0] * 1e3
        np.testing.assert_array_equal(got[row], want)
    assert len(set(pr.kr_of(u).tolist())) == 3


def test_kr_free_is_refused_for_an_engine_without_per_set_kr_and_for_kr_zero():
    import types

    import millstab.stability as stab

    _, pr = _kr_prior()
    ev = Evidence(np.array([5000.0]), np.array([1.0]), np.array([0]), np.ones(1), np.full(1, np.nan), np.zeros(0),
                  np.zeros(0), np.zeros(0))
    one_kr = types.ModuleType("one_kr")  # a plug-in engine that takes one Kr per call
    for a in stab.base.CONTRACT:
        setattr(one_kr, a, getattr(zoa, a))
    one_kr.name = "one_kr"
    one_kr.envelope_batch_hz = lambda b, c, r: zoa.envelope_batch_hz(b, c, r)
    stab.register(one_kr)
    try:
        with pytest.raises(InputError, match="prior.kr") as err:
            Likelihood(pr, ev, "one_kr")
    finally:
        stab.unregister("one_kr")
    assert "one_kr engine takes one Kr per call" in str(err.value)
    assert all(name in str(err.value) for name in ("zoa", "sdm", "spectral"))
    cfg = parse_config(TWO_MODE_TOML.replace("kr = 0.404", "kr = 0") + '[prior]\nkr = "20 %"\n')
    with pytest.raises(InputError, match="prior.kr"):
        make_prior(cfg.structure, cfg.cutting, cfg.prior)


@pytest.mark.slow
def test_a_campaign_with_a_wrong_kr_learns_it():
    """Cuts labelled by the true Kr (35 % above the config's, 1.5 prior σ) in slotting and 30 % up milling: the
    posterior of Kr moves to it (true value inside the 90 % interval, the median nearer the truth than the
    prior's, the interval narrower than the prior's)."""
    cfg, pr = _kr_prior("20 %", 'fixed = ["fn_y", "k_y", "zeta_y", "zeta_x"]\n')
    true_kr = cfg.cutting.kr * 1.35
    c = cfg.cutting
    conds = (c, Cutting.from_immersion(c.teeth, c.kt, c.kr, 0.3, "up"))
    truth = [Cutting(x.teeth, x.kt, true_kr, x.entry, x.exit) for x in conds]
    rng = np.random.default_rng(11)
    rpm, depth, kind, cond = [], [], [], []
    for i, t in enumerate(truth):
        r = np.linspace(3000, 12000, 12)
        blim = zoa.envelope(cfg.structure, t, r).depth_mm
        for f in (0.9, 1.1):  # a cut below and one above the true limit at each speed
            d = blim * f * np.exp(0.03 * rng.standard_normal(r.size))
            rpm.append(r)
            depth.append(d)
            kind.append((d > blim).astype(int))
            cond.append(np.full(r.size, i))
    rpm, depth, kind, cond = (np.concatenate(v) for v in (rpm, depth, kind, cond))
    ev = Evidence(rpm, depth, kind, np.ones(rpm.size), np.full(rpm.size, np.nan), np.zeros(0), np.zeros(0),
                  np.zeros(0), cut_cond=cond, conditions=conds)
    res = tempered_smc(pr.sample_full, pr.logpdf_full, Likelihood(pr, ev), 800, seed=1)
    kr = np.exp(res.u[:, pr.names.index("kr")])
    q05, q50, q95 = np.quantile(kr, [0.05, 0.5, 0.95])
    assert q05 <= true_kr <= q95
    assert abs(q50 - true_kr) < 0.5 * abs(c.kr - true_kr)
    prior_width = c.kr * (math.exp(1.645 * 0.2) - math.exp(-1.645 * 0.2))
    assert q95 - q05 < 0.6 * prior_width
