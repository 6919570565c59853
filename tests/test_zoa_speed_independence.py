"""A zero-order limit must not depend on which other speeds or cutting conditions share the engine call
(issue 27: an update evaluates every (speed, condition) pair of its cuts in ONE call, and any cheaper path per
condition must keep each limit exactly what the grid scan gives it alone).

Why it can hold exactly: the candidate scan of :mod:`millstab.stability._zoa_kernel` skips a grid segment only
when its best 1/b (× REFINE_MARGIN) is below the worst speed's estimate, and refines a crossing only when its
estimate is within REFINE_MARGIN of its own speed's best; a segment skipped for another speed's sake can hold
no crossing that its own speeds would refine. On one grid (the same frequencies and receptances) a speed's
depth, lobe and chatter frequency are therefore the same bits alone, in any subset and in any call. Through the
public API the grid reaches the highest tooth-passing frequency of the call, so depths may move within the
engine's stated accuracy there.

Random structures (one or two modes per direction), conditions from slotting to a/D 0.05, up and down, random
speed sets (including speeds that share a lobe tip, from a dense cluster).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from millstab.errors import InputError
from millstab.frf import ModalBatch
from millstab.model import Conditions, Cutting, Mode, Structure
from millstab.stability import _zoa_kernel as K
from millstab.stability import zoa

TWO_PI = 2 * math.pi
IMMERSIONS = ((1.0, "down"), (0.5, "up"), (0.5, "down"), (0.25, "down"), (0.05, "up"), (0.05, "down"))
NONE = np.zeros(0, dtype=np.int64)


def random_structure(rng) -> Structure:
    def modes(n):
        return tuple(Mode(float(rng.uniform(300, 3000)), float(rng.uniform(5e6, 8e7)), float(rng.uniform(0.008, 0.06)))
                     for _ in range(n))
    return Structure(x=modes(int(rng.integers(1, 3))), y=modes(int(rng.integers(1, 3))))


def packed(s: Structure) -> np.ndarray:
    return K.pack_modes(*(np.array(v) for v in (
        [TWO_PI * m.fn for m in s.x], [m.k for m in s.x], [m.zeta for m in s.x],
        [TWO_PI * m.fn for m in s.y], [m.k for m in s.y], [m.zeta for m in s.y])))


def random_speeds(rng, n: int) -> np.ndarray:
    """Uniform speeds plus a tight cluster (neighbouring speeds inside one lobe's tip), ascending."""
    base = rng.uniform(2000.0, 20000.0, n)
    centre = rng.uniform(3000.0, 15000.0)
    return np.sort(np.r_[base, centre * (1 + 1e-3 * rng.standard_normal(4))])


def on_grid(w, G, md, cut: Cutting, rpm: np.ndarray):
    a = K.directional_brackets(cut.kr, cut.entry, cut.exit)
    out = np.empty(rpm.size), np.empty(rpm.size, dtype=np.int64), np.empty(rpm.size)
    K.envelope_on_grid(w, G, a, cut.teeth, cut.kt, np.ascontiguousarray(rpm), md, False, *out, NONE, np.zeros(0))
    return out


def test_on_one_grid_each_speed_gets_the_same_bits_alone_and_in_any_subset():
    rng = np.random.default_rng(27)
    n_speeds = 0
    for case in range(24):
        s = random_structure(rng)
        md = packed(s)
        ri, milling = IMMERSIONS[case % len(IMMERSIONS)]
        cut = Cutting.from_immersion(int(rng.integers(2, 6)), 7e8, float(rng.uniform(0.1, 0.7)), ri, milling)
        rpm = random_speeds(rng, int(rng.integers(2, 30)))
        w, G = K.modal_grid(md, TWO_PI * cut.teeth * rpm[-1] / 60.0, zoa.N_BASE, zoa._OFFSETS)
        full = on_grid(w, G, md, cut, rpm)
        assert np.isfinite(full[0]).any()
        sub = np.sort(rng.choice(rpm.size, int(rng.integers(1, rpm.size + 1)), replace=False))
        part = on_grid(w, G, md, cut, rpm[sub])
        for x, y in zip(full, part):
            np.testing.assert_array_equal(x[sub], y)
        for j in rng.choice(rpm.size, 3):
            alone = on_grid(w, G, md, cut, rpm[j:j + 1])
            for x, y in zip(full, alone):
                np.testing.assert_array_equal(x[j:j + 1], y)
        n_speeds += rpm.size
    assert n_speeds > 300


def test_a_call_over_several_conditions_gives_each_speed_its_own_limit():
    """Four conditions of random speeds in one call against each (condition, speed) alone, on a batch of
    random structures: equal within the engine's accuracy (the grids differ only by the call's top
    tooth-passing frequency), and equal to the last bit where that top is below 4·f_n (the same grid)."""
    rng = np.random.default_rng(3)
    structures = [random_structure(rng) for _ in range(4)]
    n_x = max(len(s.x) for s in structures)
    n_y = max(len(s.y) for s in structures)
    structures = [Structure(x=(s.x * 2)[:n_x], y=(s.y * 2)[:n_y]) for s in structures]  # one mode count
    batch = ModalBatch.from_structures(structures)
    cuts = [Cutting.from_immersion(2, 7e8, 0.3, ri, m) for ri, m in IMMERSIONS[:4]]
    rpm = rng.uniform(2000.0, 9000.0, 24)
    index = rng.integers(0, len(cuts), rpm.size)
    together = zoa.envelope_batch(batch, Conditions.of(cuts, index), rpm)
    top_ok = 1.05 * TWO_PI * 2 * rpm.max() / 60.0 < 4.0 * TWO_PI * min(m.fn for s in structures for m in s.modes)
    for j in range(rpm.size):
        alone = zoa.envelope_batch(batch, cuts[index[j]], rpm[j:j + 1])[:, 0]
        np.testing.assert_allclose(together[:, j], alone, rtol=10 * zoa.depth_accuracy)
        if top_ok:
            np.testing.assert_array_equal(together[:, j], alone)


def test_vectorized_roots_equal_the_sequential_square_root_everywhere():
    """_branches_diag takes the discriminant's square root without a branch (selects) and sends the nodes
    outside _csqrt's range to it: the same bits as the general complex path (_branches, _csqrt per node) for
    receptances of any size (|disc|² below 1e-280 and above 1e280, and zeros) and signs."""
    rng = np.random.default_rng(5)
    n = 400
    mag = 10.0 ** rng.uniform(-160, 140, n)
    gx = mag * np.exp(1j * rng.uniform(-np.pi, np.pi, n))
    gy = mag * rng.uniform(0.01, 100, n) * np.exp(1j * rng.uniform(-np.pi, np.pi, n))
    gx[::37] = 0.0
    gy[::53] = -0.0
    gx[5] = complex(1e-6, -0.0)
    zero = np.zeros(n, dtype=complex)
    for ri, milling in IMMERSIONS:
        cut = Cutting.from_immersion(3, 6e8, float(rng.uniform(0.1, 0.7)), ri, milling)
        a = K.directional_brackets(cut.kr, cut.entry, cut.exit)
        fast = K._branches_diag(a, gx, gy)
        general = K._branches(a, gx, zero, zero, gy)
        assert np.array_equal(fast.view(np.float64), general.view(np.float64), equal_nan=True)


def test_a_censored_search_returns_the_limit_below_the_ceiling_and_the_ceiling_above_it():
    """zoa.envelope_batch(ceiling=...) (issue 27): each speed's estimate starts at its ceiling's 1/b, so the scan
    certifies only down to it. Where the limit is at or below the ceiling the same bits as without one; where it is
    above, the ceiling itself (a lower bound of the limit); an infinite ceiling is no ceiling; the scan does no more
    work than without; a ceiling of the wrong shape, NaN or not positive is refused."""
    rng = np.random.default_rng(11)
    structures = [random_structure(rng) for _ in range(6)]
    structures = [Structure(x=(s.x * 2)[:2], y=(s.y * 2)[:2]) for s in structures]
    batch = ModalBatch.from_structures(structures)
    cuts = [Cutting.from_immersion(3, 7e8, 0.3, ri, m) for ri, m in IMMERSIONS[:4]]
    rpm = rng.uniform(2000.0, 15000.0, 20)
    cond = Conditions.of(cuts, rng.integers(0, len(cuts), rpm.size))
    free = zoa.envelope_batch(batch, cond, rpm)
    ceiling = free * rng.uniform(0.5, 2.0, free.shape)
    ceiling[rng.random(free.shape) < 0.2] = np.inf
    got = zoa.envelope_batch(batch, cond, rpm, ceiling=ceiling)
    below = free <= ceiling
    assert 0.2 < below.mean() < 0.9
    np.testing.assert_array_equal(got[below], free[below])
    np.testing.assert_array_equal(got[~below], ceiling[~below])
    np.testing.assert_array_equal(zoa.envelope_batch(batch, cond, rpm, ceiling=np.full(free.shape, np.inf)), free)
    # one Cutting: the same through the conditions kernel
    one = zoa.envelope_batch(batch, cuts[1], rpm)
    cap = one * rng.uniform(0.5, 2.0, one.shape)
    got1 = zoa.envelope_batch(batch, cuts[1], rpm, ceiling=cap)
    np.testing.assert_array_equal(got1, np.where(one <= cap, one, cap))
    counted = [np.zeros((batch.size, K.N_STATS), dtype=np.int64) for _ in range(2)]
    zoa._run_modal(batch, cond, zoa.check_rpm(rpm), counted[0])
    zoa._run_modal(batch, cond, zoa.check_rpm(rpm), counted[1], ceiling=ceiling)
    visited = K.STAT_NAMES.index("segments visited")
    assert (counted[1][:, visited] <= counted[0][:, visited]).all()
    for bad in (ceiling[:, :3], np.where(below, np.nan, ceiling), np.zeros_like(ceiling)):
        with pytest.raises(InputError, match="ceiling"):
            zoa.envelope_batch(batch, cond, rpm, ceiling=bad)


def test_a_censored_search_refines_a_root_whose_estimate_lies_far_below_it():
    """A prior draw of the issue-27 benchmark (Example 1's x mode at ζ 0.011, its y mode at ζ 0.128, a/D 0.25 down
    milling, 6 710 rpm) whose limiting root's linear estimate is ~40 % below its 1/b: the search without a ceiling
    refines it as its speed's best estimate; the censored one refined only estimates within REFINE_MARGIN of the
    ceiling's 1/b, so with a ceiling 1-30 % above the limit it returned the ceiling (log L off by 4.3 in that
    update). Fails on the old kernel; the refinement now compares estimates with estimates, as without a ceiling."""
    s = Structure(x=(Mode(950.5317641234421, 14734958.269829692, 0.01065330229328504),),
                  y=(Mode(1077.4178596823203, 15342223.805677295, 0.12843850201811602),))
    cut = Cutting(2, 556.31e6, 0.404, 2.0943951023931957, math.pi)
    batch = ModalBatch.from_structures([s])
    rpm = np.array([6710.0])
    free = zoa.envelope_batch(batch, cut, rpm)
    for f in (1.01, 1.1, 1.2185, 1.3, 1.5, 3.0):
        np.testing.assert_array_equal(zoa.envelope_batch(batch, cut, rpm, ceiling=free * f), free)
    np.testing.assert_array_equal(zoa.envelope_batch(batch, cut, rpm, ceiling=free * 0.99), free * 0.99)
