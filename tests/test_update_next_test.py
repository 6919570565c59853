"""The next test (issue 24): the blind spot above the recommendation, and the learned label model in the
criterion."""

from __future__ import annotations

import math

import numpy as np
import pytest

from millstab.model import Cutting, Mode, Structure
from millstab.update import Posterior, make_prior
from millstab.update.decide import BLIND_SPOT_WIDTH, blind_spot, recommend
from millstab.update.likelihood import limits

CUT = Cutting(2, 556.31e6, 0.404, 0.0, math.pi)
STRUCT = Structure(x=(Mode(903.0, 12.53e6, 0.03),), y=(Mode(1050.0, 15e6, 0.04),))
PRIOR = make_prior(STRUCT, CUT)
SAMPLES = np.exp(PRIOR.sample(400, np.random.default_rng(4)))
RANGE = (5000.0, 9000.0)
pytestmark = pytest.mark.filterwarnings("ignore:the speed range")


def post_with(rpm, depth, label):
    cuts = {"rpm": list(map(float, rpm)), "depth_mm": list(map(float, depth)), "label": list(label),
            "chatter_hz": [None] * len(rpm)}
    return Posterior(PRIOR, SAMPLES, cuts=cuts)


def deep_chatter_cuts(rec, speeds):
    """Cuts more productive than ``rec`` at ``speeds``, at twice the posterior's median limit there (so the
    posterior explains their chatter label and the data guard stays off)."""
    blim, _ = limits(PRIOR, np.log(SAMPLES), np.asarray(speeds, float), "zoa")
    depth = np.maximum(2 * np.median(blim, axis=0), 1.5 * rec.rpm * rec.depth_mm / np.asarray(speeds))
    return list(map(float, depth))


def test_tests_above_the_recommendation_that_keep_chattering_send_the_next_test_to_it():
    """The blind spot: the last two tests were more productive than the recommendation and chattered, and no
    cut bounds the recommendation itself; the next test must then be the recommendation. Fails on the old
    code, which kept proposing a more productive (deeper) cut."""
    rec0 = recommend(post_with([], [], []), 0.05, RANGE)
    speeds = [6000.0, 8000.0]
    depth = deep_chatter_cuts(rec0, speeds)
    post = post_with(speeds, depth, ["chatter", "chatter"])
    rec = recommend(post, 0.05, RANGE)
    assert not rec.guard  # the posterior explains both chatter labels: no data guard
    nt = rec.next_test
    assert (nt["rpm"], nt["depth_mm"]) == (rec.rpm, rec.depth_mm) and nt["relative_productivity"] == 1.0
    assert "chattered" in nt["why"] and nt["p_chatter"] == pytest.approx(rec.p_chatter_speed_error)
    # without the rule's condition the criterion proposes a more productive cut (what the old code did)
    free = recommend(post_with(speeds[::-1] + [rec.rpm], depth[::-1] + [rec.depth_mm],
                               ["chatter", "chatter", "stable"]), 0.05, RANGE).next_test
    assert free["relative_productivity"] > 1.0


@pytest.mark.parametrize("case", ["last stable", "one chatter", "tested stable near", "chatter below rec"])
def test_the_blind_spot_rule_holds_only_when_nothing_bounds_the_recommendation(case):
    rec_rpm, rec_depth = 7000.0, 1.0
    r, d, lab = [6000.0, 8000.0], [2.0, 2.0], ["chatter", "chatter"]
    assert blind_spot(post_with(r, d, lab), rec_rpm, rec_depth) is not None
    if case == "last stable":
        r, d, lab = r + [5500.0], d + [0.5], lab + ["stable"]
    elif case == "one chatter":
        r, d, lab = r[:1], d[:1], lab[:1]
    elif case == "tested stable near":  # a stable cut within ±2 % of the speed, ≥ 0.95× the depth, earlier
        r, d, lab = [rec_rpm * (1 + 0.9 * BLIND_SPOT_WIDTH)] + r, [0.96 * rec_depth] + d, ["stable"] + lab
    else:  # the last chatter cut is less productive than the recommendation: it bounds it already
        d = [2.0, 0.5]
    assert blind_spot(post_with(r, d, lab), rec_rpm, rec_depth) is None
    # a stable cut just outside the window, or too shallow, does not bound it
    for rr, dd in ((rec_rpm * (1 + 1.1 * BLIND_SPOT_WIDTH), rec_depth), (rec_rpm, 0.9 * rec_depth)):
        assert blind_spot(post_with([rr, 6000.0, 8000.0], [dd, 2.0, 2.0], ["stable", "chatter", "chatter"]),
                          rec_rpm, rec_depth) is not None


def test_the_next_test_criterion_uses_the_learned_label_model():
    """The criterion's label probability is ε + (1 − 2ε)·Φ((b − b_lim)/(s·σ_b)) with each sample's LEARNED ε and
    s (``post.label_error``, ``post.sigma_depth_factor``), as in the likelihood and ``predict_cuts``. Fails on the
    old code, which used the config's fixed ε and s = 1."""
    from scipy.special import ndtr

    from millstab.update.decide import next_test

    rng = np.random.default_rng(7)
    n = SAMPLES.shape[0]
    assert PRIOR.noise_names == ("label_error", "sigma_depth")
    noise = np.c_[rng.uniform(0.15, 0.3, n), rng.uniform(2.0, 4.0, n)]  # far from the config's ε = 0.02, s = 1
    post = Posterior(PRIOR, SAMPLES, cuts={"rpm": [5000.0, 9000.0]}, noise=noise)
    speeds = np.linspace(*RANGE, 30)
    blim, _ = limits(PRIOR, post.u, speeds, "zoa")
    nt = next_test(post, RANGE, 7000.0, 0.2, grid=(speeds, blim), test_risk=0.5)
    i = int(np.argmin(np.abs(speeds - nt["rpm"])))
    b = nt["depth_mm"]
    phi = ndtr((b - blim[:, i]) / (PRIOR.sigma_depth_mm(np.array([b]))[0] * post.sigma_depth_factor))
    pe = post.label_error + (1 - 2 * post.label_error) * phi

    def h(p):
        return -(p * np.log(p) + (1 - p) * np.log(1 - p))

    assert nt["p_label_chatter"] == pytest.approx(pe.mean(), abs=1e-12)
    assert nt["p_chatter"] == pytest.approx(phi.mean(), abs=1e-12)
    assert nt["information_nats"] == pytest.approx(h(pe.mean()) - h(pe).mean(), abs=1e-9)
