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


def _likelihoods(alias: float):
    """(near-the-mode likelihood, family-only likelihood) of one deep chatter cut at 6 000 rpm heard at 1 000 Hz."""
    cuts = PointSet([6000.0], [50.0], ["chatter"], chatter_hz=[1000.0])
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
    depth = np.ones((4, 1))  # 1 mm limits: the 50 mm cut chatters under every row, the same label term
    ll_f, ll_n = family.from_limits(depth, hz), near.from_limits(depth, hz)
    assert ll_f[0] == pytest.approx(ll_f[1], abs=1e-12) and ll_f[0] == pytest.approx(ll_f[2], abs=1e-12)
    s = 20.0  # the default chatter-frequency noise
    for i, (d0, d) in enumerate([(0.0, 0.0), (f_tp, 0.0), (abs(hz[2, 0] - 1000.0), 0.0), (10.0, 10.0)]):
        want = math.log(0.9 * norm.pdf(d0, scale=s) + 0.1 * norm.pdf(d, scale=s)) - norm.logpdf(d, scale=s)
        assert ll_n[i] - ll_f[i] == pytest.approx(want, abs=1e-9)
    # the alias pays ln 0.1 + ln(1 + ...) ≈ −2.3 nats against the structure that chatters at the reading
    assert ll_n[0] - ll_n[1] == pytest.approx(math.log(0.9 * norm.pdf(0, scale=s) + 0.1 * norm.pdf(0, scale=s))
                                              - math.log(0.9 * norm.pdf(f_tp, scale=s) + 0.1 * norm.pdf(0, scale=s)))
    assert ll_n[0] - ll_n[1] > 2.0
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
