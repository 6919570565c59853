"""Per-column cutting conditions (`Conditions`) and a Kr per parameter set in every engine.

References are independent of the batched path: the 1-DOF slotting closed form b_min = 8kζ(1+ζ)/(N Kt Kr)
(its lobe bottoms do not move with Kr: ν = −πKr G has the phase of −G), the single-structure engine
called once per (structure, condition, Kr), and the other interrupted-cutting engine."""

from __future__ import annotations

import math

import numpy as np
import pytest

from millstab.errors import InputError
from millstab.frf import ModalBatch
from millstab.model import Conditions, Cutting, Mode, Structure
from millstab.stability import get_engine, per_set_kr, zoa

FN, ZETA, K = 922.0, 0.011, 1.34e6
KT = 6e8
SLOT = Cutting(4, KT, 0.3, 0.0, math.pi)
UP = Cutting.from_immersion(3, KT, 0.3, 0.3, "up")
DOWN = Cutting.from_immersion(4, 8e8, 0.3, 0.1, "down")


def test_conditions_columns_groups_and_validation():
    c = Conditions.of([SLOT, UP, Cutting(4, KT, 0.3, 0.0, math.pi)], [1, 0, 2, 0, 1])
    np.testing.assert_array_equal(c.teeth, [3, 4, 4, 4, 3])
    np.testing.assert_allclose(c.exit, [UP.exit, math.pi, math.pi, math.pi, UP.exit])
    cuts, inverse = c.unique()  # the third Cutting equals the first: one condition
    assert cuts == (SLOT, UP) and list(inverse) == [1, 0, 0, 0, 1]
    assert [(g, list(cols)) for g, cols in c.groups()] == [(SLOT, [1, 2, 3]), (UP, [0, 4])]
    assert Conditions.coerce(SLOT, 3) == Conditions.of([SLOT], [0, 0, 0])
    for bad, field in (([0, 3], "conditions.index"), ([0, -1], "conditions.index"), ([0.5], "conditions.index"),
                       ([], "conditions.index")):
        with pytest.raises(InputError, match=field):
            Conditions.of([SLOT, UP, DOWN], bad)
    with pytest.raises(InputError, match=r"conditions\[1\]"):
        Conditions.of([SLOT, "slot"], [0, 1])
    with pytest.raises(InputError, match="one condition per speed column"):
        zoa.envelope_batch(ModalBatch.from_structures([Structure(x=(Mode(FN, K, ZETA),))]), c, [5000.0, 6000.0])


def _bottoms(teeth: int, ks) -> np.ndarray:
    r = math.sqrt(1 + 2 * ZETA)
    nu = -math.pi / (K * complex(1 - r * r, 2 * ZETA * r))  # the phase of ν does not depend on Kr > 0
    eps = math.pi + 2 * math.atan2(nu.imag, nu.real)
    return np.array([60.0 * 2 * math.pi * FN * r / (teeth * (eps + 2 * math.pi * k)) for k in ks])


def test_per_set_kr_reaches_the_closed_form():
    """1-DOF slotting with three Kr in one call: b_min = 8kζ(1+ζ)/(N Kt Kr) at the lobe bottoms, per set."""
    kr = np.array([0.15, 0.4, 1.1])
    one = Structure(x=(Mode(FN, K, ZETA),))
    batch = ModalBatch.from_structures([one] * kr.size)
    rpm = _bottoms(4, (1, 2, 3))
    depth = zoa.envelope_batch(batch, SLOT, rpm, kr=kr)
    expect = 8 * K * ZETA * (1 + ZETA) / (4 * KT * kr)
    np.testing.assert_allclose(depth, np.repeat(expect[:, None], rpm.size, axis=1), rtol=1e-9)


def test_per_set_kr_under_mixed_conditions_equals_single_structure_calls():
    """Each (set, condition) of a mixed call with per-set Kr is the single-structure envelope at that Kr
    (same numbers bit for bit), chatter frequencies included."""
    structs = [Structure(x=(Mode(FN, K, ZETA),), y=(Mode(1100.0, 1.6 * K, 0.02),)),
               Structure(x=(Mode(800.0, 2 * K, 0.03),), y=(Mode(1300.0, K, 0.015),))]
    kr = np.array([0.25, 0.6])
    cond = Conditions.of([SLOT, UP, DOWN], [2, 0, 1, 1, 0, 2])
    rpm = np.array([9000.0, 6000.0, 6000.0, 14000.0, 11000.0, 4000.0])
    depth, hz = zoa.envelope_batch_hz(ModalBatch.from_structures(structs), cond, rpm, kr=kr)
    for b, (s, k) in enumerate(zip(structs, kr)):
        for cut, cols in cond.groups():
            env = zoa.envelope(s, Cutting(cut.teeth, cut.kt, k, cut.entry, cut.exit), rpm[cols])
            np.testing.assert_array_equal(depth[b, cols], env.depth)
            np.testing.assert_array_equal(hz[b, cols], env.chatter_hz)


#: the time-domain engines' discretisation in the per-set Kr tests: fixed, so that a call per set is the same problem
_TIME_DOMAIN = {"spectral": {"nodes": 6, "warm": False}, "sdm": {"steps": 20}}


@pytest.mark.parametrize("name", ["spectral", "sdm"])
def test_per_set_kr_in_the_time_domain_engines_equals_single_kr_calls(name):
    """A Kr per set in the interrupted-cutting engines (issue 27: Kr free with every engine): each (set, condition)
    of one mixed call is the single-Kr call of that set alone, bit for bit (the kernels build each (set, speed)'s
    directional factors anyway); and the Kr reaches the physics: the depths move with Kr."""
    eng = get_engine(name)
    structs = [Structure(x=(Mode(FN, K, ZETA),), y=(Mode(1100.0, 1.6 * K, 0.02),)),
               Structure(x=(Mode(800.0, 2 * K, 0.03),), y=(Mode(1300.0, K, 0.015),))]
    kr = np.array([0.15, 0.9])
    cond = Conditions.of([UP, DOWN], [1, 0, 1, 0])
    rpm = np.array([9000.0, 6000.0, 14000.0, 11000.0])
    opts = _TIME_DOMAIN[name]
    depth = eng.envelope_batch(ModalBatch.from_structures(structs), cond, rpm, kr=kr, **opts)
    for b, (s, k) in enumerate(zip(structs, kr)):
        for cut, cols in cond.groups():
            one = Cutting(cut.teeth, cut.kt, k, cut.entry, cut.exit)
            np.testing.assert_array_equal(depth[b, cols], eng.envelope_batch(ModalBatch.from_structures([s]), one,
                                                                              rpm[cols], **opts)[0])
    same = eng.envelope_batch(ModalBatch.from_structures(structs), cond, rpm, kr=np.full(2, 0.3), **opts)
    assert np.all(np.abs(depth / same - 1) > 1e-3)  # Kr 0.15 / 0.9 against 0.3: every depth moved
    np.testing.assert_array_equal(same, eng.envelope_batch(ModalBatch.from_structures(structs), cond, rpm, **opts))


def test_spectral_warm_starts_do_not_cross_kr():
    """The spectral engine's warm starts (rows within WARM_REL of the row heading their run start from its boundary,
    for finite-difference Jacobians) compare Kr too: two rows with the same modes and other Kr are each searched cold,
    bit for bit the single-row calls; two rows a finite-difference step apart in Kr still share the warm start."""
    from millstab.stability import spectral

    one = Structure(x=(Mode(FN, K, ZETA),), y=(Mode(1100.0, 1.6 * K, 0.02),))
    batch = ModalBatch.from_structures([one, one])
    rpm = np.array([6000.0, 9000.0])
    follow, _ = spectral._heads(*spectral._arrays(batch)[:3], np.array([0.15, 0.9]))
    assert not follow.any()
    follow, _ = spectral._heads(*spectral._arrays(batch)[:3], np.array([0.3, 0.3 * (1 + 1e-4)]))
    assert follow.tolist() == [False, True]
    kr = np.array([0.15, 0.9])
    depth = spectral.envelope_batch(batch, DOWN, rpm, nodes=6, kr=kr)  # warm starts on (the default)
    for b in range(2):
        alone = Cutting(DOWN.teeth, DOWN.kt, kr[b], DOWN.entry, DOWN.exit)
        np.testing.assert_array_equal(depth[b], spectral.envelope_batch(ModalBatch.from_structures([one]), alone, rpm,
                                                                        nodes=6)[0])


def test_per_set_kr_agrees_between_the_two_time_domain_engines():
    """Independent re-computation: the spectral-element and the semi-discretization engines (their default,
    converged discretisations) at per-set Kr far from the cutting's, a/D 0.1 down milling, within their stated
    accuracy of each other (the spectral engine is within 0.5 % of converged SDM)."""
    from millstab.stability import sdm, spectral

    structs = [Structure(x=(Mode(900.0, 9e6, 0.02),), y=(Mode(1000.0, 1.1e7, 0.03),)),
               Structure(x=(Mode(850.0, 8e6, 0.025),), y=(Mode(1050.0, 1.2e7, 0.02),))]
    batch = ModalBatch.from_structures(structs)
    cut = Cutting.from_immersion(2, 7e8, 0.3, 0.1, "down")
    kr = np.array([0.05, 1.2])
    rpm = np.array([6000.0, 8000.0, 11000.0])
    a = spectral.envelope_batch(batch, cut, rpm, kr=kr)
    b = sdm.envelope_batch(batch, cut, rpm, kr=kr)
    np.testing.assert_allclose(a, b, rtol=5e-3)
    assert np.all(np.abs(a / spectral.envelope_batch(batch, cut, rpm) - 1) > 1e-3)


def test_per_set_kr_capability_and_bad_values():
    for name in ("zoa", "sdm", "spectral"):
        assert per_set_kr(get_engine(name))
    batch = ModalBatch.from_structures([Structure(x=(Mode(FN, K, ZETA),))] * 2)
    for eng in (zoa, get_engine("sdm"), get_engine("spectral")):
        with pytest.raises(InputError, match="kr"):
            eng.envelope_batch(batch, SLOT, [5000.0], kr=[0.3])
        with pytest.raises(InputError, match="kr"):
            eng.envelope_batch(batch, SLOT, [5000.0], kr=[0.3, -0.1])


def test_forward_pinned_and_map_take_per_column_conditions():
    from millstab.forward import forward
    from millstab.params import Parameterization

    par = Parameterization(Structure(x=(Mode(FN, K, ZETA),), y=(Mode(1100.0, 1.6 * K, 0.02),)))
    rows = par.theta0[None] * np.linspace(0.9, 1.1, 5)[:, None]
    cond = Conditions.of([SLOT, UP, DOWN], [0, 1, 2, 1, 0])
    rpm = np.array([5000.0, 5000.0, 8000.0, 12000.0, 9000.0])
    f = forward(par, SLOT)
    got = f(rows, rpm, cond)
    for cut, cols in cond.groups():
        np.testing.assert_array_equal(got[:, cols], forward(par, cut)(rows, rpm[cols]))
    np.testing.assert_array_equal(f(rows, rpm), f(rows, rpm, SLOT))  # the bound cutting: the plain call
    pinned = f.pinned(rpm, rows, cond)
    np.testing.assert_array_equal(pinned(rows), got)
    np.testing.assert_array_equal(pinned.map(rows, chunk_rows=2), got)
    with pytest.raises(InputError, match="conditions"):
        f.pinned(rpm[:3], rows, cond)


def test_a_grid_extended_by_another_condition_keeps_the_depths():
    """The shared grid reaches the highest tooth-passing frequency of ALL columns: a 12-tooth condition at
    15 000 rpm (3 kHz, above 4·f_n = 1.2 kHz) extends the grid of a 2-tooth one, whose depths then come from
    other grid nodes but the same exact root polish: equal to its own call within the engine's accuracy."""
    s = Structure(x=(Mode(300.0, K, ZETA),), y=(Mode(320.0, 1.2 * K, 0.02),))
    batch = ModalBatch.from_structures([s])
    two, twelve = Cutting(2, KT, 0.3, 0.0, math.pi), Cutting.from_immersion(12, KT, 0.3, 0.2, "down")
    rpm = np.array([2000.0, 3100.0, 4700.0, 15000.0])
    mixed = zoa.envelope_batch(batch, Conditions.of([two, twelve], [0, 0, 0, 1]), rpm)
    np.testing.assert_allclose(mixed[:, :3], zoa.envelope_batch(batch, two, rpm[:3]), rtol=10 * zoa.depth_accuracy)
    np.testing.assert_array_equal(mixed[:, 3:], zoa.envelope_batch(batch, twelve, rpm[3:]))
