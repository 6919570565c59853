"""A chatter frequency read as the family member near the mode (``[prior] chatter_hz_alias`` < 1, issue 24).

The family term alone (the default, alias 1) is informative modulo the tooth-passing frequency only, and its
aliases f_c ± m·f_tp are exactly the lobe-number ambiguity fn ↔ fn·(n + 1)/n: a structure whose limiting lobe
chatters one f_tp away from the reading fits it as well. Read as the member near the mode (what `millstab
listen` reports), the reading places fn itself. Checked against a hand computation of the mixture.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np
import pytest
from scipy.stats import norm

from millstab.errors import InputError
from millstab.io.config import _prior_lines, parse_config
from millstab.model import Cutting, Mode, Structure
from millstab.points import PointSet
from millstab.update import make_prior
from millstab.update.likelihood import Evidence, Likelihood
from millstab.update.prior import Prior
from configs import TWO_MODE_TOML as TOML

CUT = Cutting(2, 556.31e6, 0.404, 0.0, math.pi)
STRUCT = Structure(x=(Mode(903.0, 12.53e6, 0.03),), y=(Mode(1050.0, 15e6, 0.04),))


def _likelihoods(alias: float, depth_mm: float = 1.05):
    """(near-the-mode likelihood, family-only likelihood) of one chatter cut at 6 000 rpm heard at 1 000 Hz."""
    cuts = PointSet([6000.0], [depth_mm], ["chatter"], chatter_hz=[1000.0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "every cut is chatter"
        ev = Evidence.from_points(cuts)
    family = replace(make_prior(STRUCT, CUT), chatter_hz_alias=1.0)  # the family term alone
    return Likelihood(replace(family, chatter_hz_alias=alias), ev), Likelihood(family, ev)


def test_a_reading_near_the_mode_tells_the_lobe_aliases_apart():
    near, family = _likelihoods(0.1)
    f_tp = 2 * 6000 / 60  # 200 Hz
    # predicted limiting-lobe frequencies: the reading itself, one tooth-passing alias up, its mirror, 10 Hz off
    hz = np.array([[1000.0], [1000.0 + f_tp], [2 * f_tp - 1000.0 + 4 * f_tp], [1010.0]])
    depth = np.ones((4, 1))  # 1 mm limits: the 1.05 mm cut chatters under every row, the same label term
    ll_f, ll_n = family.from_limits(depth, hz), near.from_limits(depth, hz)
    assert ll_f[0] == pytest.approx(ll_f[1], abs=1e-12) and ll_f[0] == pytest.approx(ll_f[2], abs=1e-12)
    # by hand: 5 % over its limit, σ = hypot(20 Hz, 0.017 × 1 000 Hz × ln 1.05), a reading of another vibration
    # with 0.05 + 0.12 ln 1.05 (uniform over the 200 Hz tooth-passing band)
    x = math.log(1.05)
    s, o = math.hypot(20.0, 0.017 * 1000.0 * x), 0.05 + 0.12 * x

    def term(d0, d, a):
        return math.log((1 - o) * ((1 - a) * norm.pdf(d0, scale=s) + a * norm.pdf(d, scale=s)) + o / f_tp)

    for i, (d0, d) in enumerate([(0.0, 0.0), (f_tp, 0.0), (abs(hz[2, 0] - 1000.0), 0.0), (10.0, 10.0)]):
        assert ll_n[i] - ll_f[i] == pytest.approx(term(d0, d, 0.1) - term(d, d, 1.0), abs=1e-9)
    # the alias pays ≈ 2 nats against the structure that chatters at the reading
    assert ll_n[0] - ll_n[1] == pytest.approx(term(0.0, 0.0, 0.1) - term(f_tp, 0.0, 0.1), abs=1e-9)
    assert ll_n[0] - ll_n[1] > 1.5
    # alias 1 is the family term bit for bit
    one, _ = _likelihoods(1.0)
    np.testing.assert_array_equal(one.from_limits(depth, hz), ll_f)
    # cuts without a frequency (the calibration campaigns' labels) are untouched by the option
    cuts = PointSet([6000.0, 6000.0], [50.0, 0.1], ["chatter", "stable"])
    prior = make_prior(STRUCT, CUT)
    lls = [Likelihood(replace(prior, chatter_hz_alias=a), Evidence.from_points(cuts)).from_limits(depth, hz)
           for a in (0.1, 1.0)]
    np.testing.assert_array_equal(lls[0], lls[1])


def test_chatter_hz_alias_from_the_config_and_in_the_posterior_record():
    table = parse_config(TOML + '[prior]\nchatter_hz_alias = "10 %"\n').prior
    assert table.chatter_hz_alias == pytest.approx(0.1)
    assert 'chatter_hz_alias = "10 %"' in _prior_lines(table)
    p = make_prior(STRUCT, CUT, table)
    assert p.chatter_hz_alias == pytest.approx(0.1)
    assert Prior.from_dict(p.to_dict()).chatter_hz_alias == pytest.approx(0.1)
    old = p.to_dict()
    del old["chatter_hz_alias"]  # a posterior written before the option: any member alike, as it was fitted
    assert Prior.from_dict(old).chatter_hz_alias == 1.0
    # the default (issue 24): the member near the mode with 0.9, any member with 0.1
    assert make_prior(STRUCT, CUT).chatter_hz_alias == pytest.approx(0.1)
    table = parse_config(TOML + '[prior]\nchatter_hz_alias = "100 %"\n').prior  # the family term alone, on request
    assert make_prior(STRUCT, CUT, table).chatter_hz_alias == 1.0
    for bad in ('"0 %"', '"120 %"', "-0.1"):
        with pytest.raises(InputError, match="chatter_hz_alias"):
            parse_config(TOML + f"[prior]\nchatter_hz_alias = {bad}\n")
    with pytest.raises(InputError, match="chatter_hz_alias"):
        replace(p, chatter_hz_alias=0.0)


def test_a_deep_cuts_reading_says_less_than_one_at_its_limit():
    """A cut far above its limit chatters at its own vibration, not at the boundary's f_c (measured drift:
    benchmarks/bench_chatter_drift.py): its reading's σ grows with ln(depth / limit) and its outlier share too, so
    the same 100 Hz miss costs a cut at its limit ~4.3 nats (bounded by the 5 % share of readings of another
    vibration; 12.5 nats by σ alone) and a cut at 7.4× its limit under 2 nats; at or below the limit σ is the
    prior's."""
    from millstab.update.likelihood import frequency_spread

    hz = np.array([[1000.0], [1100.0]])  # the reading's own frequency, and 100 Hz off it
    miss = {}
    for depth_mm in (1.0, 7.4):
        near, _ = _likelihoods(0.1, depth_mm)
        ll = near.from_limits(np.ones((2, 1)), hz)
        miss[depth_mm] = float(ll[0] - ll[1])
    s0 = 20.0
    at_limit = math.log(0.95 * norm.pdf(0, scale=s0) + 0.05 / 200) - math.log(0.95 * norm.pdf(100, scale=s0)
                                                                              + 0.05 / 200)
    assert miss[1.0] == pytest.approx(at_limit, rel=1e-3) and 4.0 < miss[1.0] < 4.5  # the 0.1 alias share adds ~0
    assert 0.5 < miss[7.4] < 2.0
    s, o = frequency_spread(20.0, np.array([1000.0, 1000.0, 1000.0]), np.array([0.5, 1.0, 7.4]), np.ones((1, 3)))
    np.testing.assert_allclose(s[0], [20.0, 20.0, math.hypot(20.0, 17.0 * math.log(7.4))])
    np.testing.assert_allclose(o[0], [0.05, 0.05, 0.05 + 0.12 * math.log(7.4)])
    assert frequency_spread(20.0, np.array([1e3]), np.array([50.0]), np.ones((1, 1)))[1][0, 0] == 0.3  # at most


def test_a_spectral_update_with_readings_keeps_its_ceilings_floors_and_anchored_screen():
    """The plumbing of issue 28's savings with a microphone's readings: a spectral update (a/D 0.1 down, 8 cuts, 4 of
    them chattering with a reading, 300 samples) runs with the anchored screen and censors or floors some limits (in
    the columns without a reading only: tests/test_likelihood_floor.py), and every reading's column is read: the same
    seed gives the same samples; the posterior explains the readings (the posterior median's f_c at the reading's
    column within 60 Hz of it, 3 σ)."""
    from millstab.update import update
    from millstab.update.likelihood import limits

    cfg = parse_config(TOML)
    cut = Cutting.from_immersion(cfg.cutting.teeth, cfg.cutting.kt, cfg.cutting.kr, 0.1, "down")
    cfg = replace(cfg, cutting=cut)
    prior = make_prior(cfg.structure, cut, cfg.prior)
    rpm = np.array([5200.0, 6100, 7000, 7900, 8800, 9700, 10600, 11500])
    b, f = limits(prior, np.log(prior.median)[None], rpm, "spectral", with_freq=True)
    depth = b[0] * np.array([0.6, 1.5, 0.7, 1.4, 0.5, 1.6, 0.8, 1.3])
    chat = depth > b[0]
    hz = np.where(chat, f[0] + 8.0, np.nan)
    cuts = PointSet(rpm, depth, np.where(chat, "chatter", "stable"), chatter_hz=hz)
    post = update(cfg, cuts, samples=300, seed=4, engine="spectral")
    d = post.diagnostics
    assert d.get("anchored_screen") and d["frequency_term"]
    assert d["censored_entries"] + d["floored_entries"] > 0
    again = update(cfg, cuts, samples=300, seed=4, engine="spectral")
    np.testing.assert_array_equal(post.samples, again.samples)
    _, fm = limits(prior, np.log(np.median(post.samples, axis=0))[None], rpm[chat], "spectral", with_freq=True)
    assert np.all(np.abs(fm[0] - hz[chat]) < 60.0), (fm, hz[chat])
