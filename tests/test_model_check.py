"""The check of a zero-order recommendation against interrupted cutting (millstab.update.model_check).

The case is an exploratory shop test's machine (2026-11-29): 4 teeth, x 624 Hz 3.2 N/µm ζ 0.02, y 988 Hz 20 N/µm
ζ 0.03, Kt 800 MPa, Kr 0.3; at a/D 0.5 down milling exactly one tooth cuts on average, the tooth-count rule
(< 1 tooth) is silent, and the zero-order limits are up to ~5× the interrupted cut's: its recommendation chattered.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from millstab.io.config import parse_config
from millstab.model import Cutting
from millstab.stability import spectral
from millstab.update import Posterior, make_prior
from millstab.update.decide import recommend
from millstab.update.model_check import accurate_check

SHOP = parse_config("""
[cutting]
teeth = 4
kt = "800 MPa"
kr = 0.3
entry = "0 deg"
exit = "90 deg"
[[structure.x]]
fn = "624 Hz"
k = "3.2 N/um"
zeta = 0.02
[[structure.y]]
fn = "988 Hz"
k = "20 N/um"
zeta = 0.03
""")


def _draws(cutting: Cutting, n: int = 60, shrink: float = 0.1) -> Posterior:
    """A zero-order "posterior" of ``n`` prior draws pulled to ``shrink`` of their spread about the prior median
    (as narrow as after an update of a few dozen cuts)."""
    prior = make_prior(SHOP.structure, cutting, SHOP.prior)
    u = prior.sample(n, np.random.default_rng(3))
    u0 = np.log(prior.median)
    u = u0 + shrink * (u - u0)
    return Posterior(prior, np.exp(u), "zoa", cuts={"rpm": [5000.0, 15000.0]})


def test_the_check_is_each_samples_own_spectral_limit_against_the_cut():
    """Independent recomputation: each sample's spectral limit at the speed (one envelope per sample, a plain loop)
    counted against the depth; the zero-order P(chatter) likewise from its own envelopes."""
    from millstab.stability import zoa

    down = Cutting.from_immersion(4, SHOP.cutting.kt, SHOP.cutting.kr, 0.5, "down")
    post = _draws(down)
    got = accurate_check(post, 15000.0, 3.0, 0.05)
    structures = [post.prior.par.structure(t) for t in post.samples]
    acc = np.array([spectral.envelope(s, down, [15000.0]).depth_mm[0] for s in structures])
    avg = np.array([zoa.envelope(s, down, [15000.0]).depth_mm[0] for s in structures])
    assert got["samples"] == 60
    assert got["p_chatter_accurate"] == pytest.approx(np.mean(acc < 3.0), abs=1e-12)
    assert got["p_chatter"] == pytest.approx(np.mean(avg < 3.0), abs=1e-12)
    assert got["ratio"] == pytest.approx(np.median(acc / avg), rel=1e-3)
    assert got["ratio"] < 0.8  # the interrupted cut is far less stable here than the average says


def test_a_zero_order_recommendation_at_one_tooth_in_the_cut_is_checked_and_warned():
    """At a/D 0.5 down (1.00 tooth in the cut: the tooth-count rule is silent) the zero-order recommendation is one
    the spectral engine gives P(chatter) far above the risk on the same samples: warned with both numbers and kept in
    the recommendation (fails on the old code: no warning). A 4-tooth slot (a constant directional matrix: the
    average is exact) and an interrupted-cutting posterior are not checked."""
    down = Cutting.from_immersion(4, SHOP.cutting.kt, SHOP.cutting.kr, 0.5, "down")
    assert down.teeth_in_cut == pytest.approx(1.0)
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        rec = recommend(_draws(down), 0.05, (10000, 15000))
    said = [str(x.message) for x in w if "checked against interrupted cutting" in str(x.message)]
    assert len(said) == 1 and f"({rec.rpm:.0f} rpm, {rec.depth_mm:.3g} mm)" in said[0], said
    assert "--engine spectral" in said[0] and said[0] in rec.warnings
    # up milling at the same width: the two engines agree there (ratio ~1): not warned
    up = _draws(Cutting.from_immersion(4, SHOP.cutting.kt, SHOP.cutting.kr, 0.5, "up"))
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        rec_up = recommend(up, 0.05, (3000, 15000))
    assert not [x for x in w if "checked against interrupted cutting" in str(x.message)]
    assert accurate_check(up, rec_up.rpm, rec_up.depth_mm, 0.05)["ratio"] == pytest.approx(1.0, abs=0.05)
    slot = _draws(Cutting.from_immersion(4, SHOP.cutting.kt, SHOP.cutting.kr, 1.0, "down"))
    assert slot.condition.time_invariant and accurate_check(slot, 9000.0, 2.0, 0.05) is None
    from dataclasses import replace

    assert accurate_check(replace(_draws(down), engine="spectral"), 9000.0, 2.0, 0.05) is None


def test_a_map_and_a_prediction_where_the_median_is_far_off_are_warned_with_its_figures():
    """The median check (map, predict): the largest ratio of the median parameters' zero-order to spectral limit
    over the decision's speeds, recomputed here from each engine's own envelope of the median structure; a/D 0.5
    down (one tooth in the cut, the tooth-count rule silent) is warned by p_stable_map and predict, up milling at the
    same width is not (fails on the old code: no warning)."""
    from millstab import api
    from millstab.points import PointSet
    from millstab.stability import zoa
    from millstab.update.decide import p_stable_map
    from millstab.update.model_check import median_check

    down = _draws(Cutting.from_immersion(4, SHOP.cutting.kt, SHOP.cutting.kr, 0.5, "down"))
    rpm = np.linspace(4000.0, 15000.0, 23)
    got = median_check(down, rpm)
    s = down.prior.par.structure(np.exp(np.median(down.decision_u, axis=0)))
    want = zoa.envelope(s, down.condition, rpm).depth_mm / spectral.envelope(s, down.condition, rpm).depth_mm
    assert got["ratio"] == pytest.approx(want.max(), rel=1e-3) and got["rpm"] == rpm[np.argmax(want)]
    assert got["warn"] and got["speeds"] == 23
    for post, warned in ((down, True), (_draws(Cutting.from_immersion(4, SHOP.cutting.kt, SHOP.cutting.kr, 0.5, "up")),
                                        False)):
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            p_stable_map(post, rpm, np.array([1.0, 2.0]))
            api.predict(post, PointSet(rpm[:5], np.full(5, 2.0)))
        said = [str(x.message) for x in w if "checked against interrupted cutting: in this condition" in str(x.message)]
        assert len(said) == (2 if warned else 0), said
        if warned:
            assert "(a/D 0.5 down milling, 4 teeth)" in said[0] and f"{got['ratio']:.2f}×" in said[0]


def test_a_zero_order_sld_far_from_the_interrupted_cut_is_warned():
    """api.lobes with the zero-order engine at a/D 0.5 down on the shop's tool (one tooth in the cut: the tooth-count
    rule is silent) warns with the largest ratio of its limits to the spectral engine's at 40 of its speeds,
    recomputed here; up milling at the same width, the live redraw (``check=False``) and an SLD drawn beside a
    spectral one are not warned (fails on the old code: no warning)."""
    import dataclasses

    from millstab import api

    rpm = np.linspace(3000.0, 15000.0, 121)
    for milling, warned in (("down", True), ("up", False)):
        cfg = dataclasses.replace(SHOP, name="shop", cutting=Cutting.from_immersion(4, SHOP.cutting.kt,
                                                                                   SHOP.cutting.kr, 0.5, milling))
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            res = api.lobes(cfg, rpm)
        said = [str(x.message) for x in w if "checked against interrupted cutting" in str(x.message)]
        assert len(said) == int(warned), said
        if warned:
            pick = np.unique(np.linspace(0, rpm.size - 1, 40).round().astype(int))
            ratio = res.envelope.depth_mm[pick] / spectral.envelope(cfg.structure, cfg.cutting, rpm[pick]).depth_mm
            at = rpm[pick][np.argmax(ratio)]
            assert f"up to {ratio.max():.2f}× the spectral engine's (at {at:.0f} rpm" in said[0]
            assert "shop's cut (a/D 0.5 down milling, 4 teeth)" in said[0]
            for quiet in ({"check": False}, {"compare": "spectral"}):
                with warnings.catch_warnings(record=True) as w:
                    warnings.simplefilter("always")
                    api.lobes(cfg, rpm, **quiet)
                assert not [x for x in w if "checked against interrupted cutting" in str(x.message)]
