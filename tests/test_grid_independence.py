"""A speed's limiting depth must not depend on which other speeds share the call (issue 25 item 0, issue 28).

The spectral engine continues boundary roots from speed to speed; before this test, a root found that
way was accepted after a few checks relative to the root itself, and a speed whose branch was lost was
searched on a ladder around the previous speed's depth. On the 1 000 rpm grid of the benchmark (a/D =
0.5, down milling) that ladder stepped over a flip band at 10 000 rpm: 2.3498 mm reported, a depth that
chatters (first crossing 2.1040 mm, SDM 2.1046 mm). Now every root is accepted only against the search
from below of its own speed (a ladder on the zero-order depth there, the same as SDM's, refined near ρ = 1),
so a speed gives the same depth on a fine grid, a coarse one, a random set and alone.

The classic 1-DOF benchmark (Insperger & Stépán): 922 Hz, ζ = 0.011, m = 0.03993 kg, 2 teeth, Kt = 6e8 N/m²,
Kr = 1/3. The node count is fixed (``nodes``) where depths of different calls are compared, so the
comparison sees the search alone, not the per-call convergence check (which may pick other nodes, TOL).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from millstab.errors import InputError
from millstab.frf import ModalBatch
from millstab.model import Cutting, Mode, Structure
from millstab.stability import sdm, spectral, zoa

FN, ZETA, MASS = 922.0, 0.011, 0.03993
K = MASS * (2 * math.pi * FN) ** 2
BENCH = Structure(x=(Mode(FN, K, ZETA),))
COARSE = np.arange(5000.0, 25000.1, 1000.0)
FINE = np.arange(5000.0, 25000.1, 100.0)  # holds COARSE
NODES = 8


def cut(immersion: float, mode: str = "down") -> Cutting:
    return Cutting.from_immersion(2, 6e8, 1.0 / 3.0, immersion, mode)


def random_speeds(seed: int, n: int = 12) -> np.ndarray:
    return np.random.default_rng(seed).uniform(5000.0, 25000.0, n)


def first_unstable_above(structure, cutting, rpm, depth) -> bool:
    """SDM's own ρ (an independent, second-order discretisation) is above 1 just above ``depth``."""
    return sdm.rho_map(structure, cutting, [rpm], [1.005 * depth])[0, 0] > 1.0


def test_coarse_grid_regression_10000_rpm():
    """The issue's case: on 5 000–25 000 rpm in 1 000 rpm steps, 10 000 rpm gave 2.3498 mm (+11.65 %; the
    old code fails here); now the flip band's first crossing, as on a fine grid, alone, and in SDM."""
    c = cut(0.5)
    coarse = spectral.envelope(BENCH, c, COARSE)
    i = int(np.flatnonzero(COARSE == 10000.0)[0])
    alone = spectral.envelope(BENCH, c, [10000.0])
    ref = sdm.envelope(BENCH, c, [10000.0]).depth[0]
    assert coarse.depth_mm[i] < 2.2, coarse.depth_mm[i]
    assert coarse.kind[i] == "flip"
    assert coarse.depth[i] == pytest.approx(alone.depth[0], rel=2e-3)
    assert coarse.depth[i] == pytest.approx(ref, rel=5e-3)
    # the depth is the first crossing: a dense ρ scan with more nodes is stable below it
    rho = spectral.rho_map(BENCH, c, [10000.0], np.linspace(0.02, 0.995, 60) * coarse.depth[i], nodes=10)[0]
    assert rho.max() < 1.0


@pytest.mark.slow
@pytest.mark.parametrize("immersion, mode", [(0.05, "down"), (0.1, "down"), (0.5, "down"), (1.0, "down"),
                                             (0.05, "up"), (0.1, "up"), (0.5, "up")])
def test_spectral_depth_independent_of_the_grid(immersion, mode):
    """At every speed of a coarse grid, a random set (seeded) and alone, the depth equals the one a fine
    (100 rpm) grid gives at that speed (0.5 %; measured ≤ 1e-6 with the same nodes), and agrees with
    converged SDM: within 0.5 %, or below it where SDM's own ρ shows that SDM stepped over a band (a
    narrow flip band at 12 800–12 825 rpm, a/D = 0.5 up milling, that SDM's ladder misses)."""
    c = cut(immersion, mode)
    fine = spectral.envelope(BENCH, c, FINE, nodes=NODES).depth
    coarse = spectral.envelope(BENCH, c, COARSE, nodes=NODES).depth
    np.testing.assert_allclose(coarse, fine[np.searchsorted(FINE, COARSE)], rtol=5e-3)
    rnd = random_speeds(11)
    on_random = spectral.envelope(BENCH, c, rnd, nodes=NODES).depth
    speeds = np.concatenate([rnd, COARSE[::4]])
    alone = np.array([spectral.envelope(BENCH, c, [r], nodes=NODES).depth[0] for r in speeds])
    np.testing.assert_allclose(on_random, alone[:rnd.size], rtol=5e-3)
    np.testing.assert_allclose(alone[rnd.size:], coarse[::4], rtol=5e-3)
    ref = sdm.envelope(BENCH, c, speeds).depth
    rel = alone / ref - 1
    assert np.all(rel < 5e-3), (speeds[np.argmax(rel)], rel.max())
    for r, b, d in zip(speeds[rel < -5e-3], alone[rel < -5e-3], ref[rel < -5e-3]):
        assert first_unstable_above(BENCH, c, r, b), (r, b, d)


def test_narrow_band_found_alone_and_on_any_grid():
    """a/D = 0.5 up milling, 12 825 rpm: a flip band 1.714–1.766 mm lies between two rungs of the ladder
    (ρ 0.9954 and 0.9941 there), 3 % of the zero-order depth wide. A branch continued on a random grid
    found it (1.724 mm) while the speed alone did not (1.890 mm, as SDM): the depth depended on the grid.
    The refinement near ρ = 1 finds it alone too; SDM's own ρ is unstable just above it."""
    c = cut(0.5, "up")
    alone = spectral.envelope(BENCH, c, [12825.0], nodes=NODES).depth[0]
    grid = spectral.envelope(BENCH, c, np.sort(np.append(random_speeds(3, 25), 12825.0)), nodes=NODES)
    on_grid = grid.depth[np.flatnonzero(grid.rpm == 12825.0)[0]]
    assert alone == pytest.approx(on_grid, rel=1e-6)
    assert alone < 1.75e-3
    assert first_unstable_above(BENCH, c, 12825.0, alone)


@pytest.mark.slow
def test_warm_rows_independent_of_the_grid():
    """The warm starts (finite-difference rows following their head row, ``_spectral_warm``): every row's
    depth on a coarse grid and on a random set equals that row alone on a fine grid (0.5 %)."""
    c = cut(0.5)
    h = 1e-4
    fn = FN * np.array([1.0, 1 + h, 1.0, 1.0])
    k = K * np.array([1.0, 1.0, 1 + h, 1.0])
    zeta = ZETA * np.array([1.0, 1.0, 1.0, 1 + h])
    rows = ModalBatch(fn[:, None], k[:, None], zeta[:, None], np.zeros((4, 0)), np.zeros((4, 0)), np.zeros((4, 0)))
    rnd = random_speeds(5)
    grid = np.concatenate([COARSE, rnd])
    together = spectral.envelope_batch(rows, c, grid, nodes=NODES)
    for j in range(4):
        s = Structure(x=(Mode(fn[j], k[j], zeta[j]),))
        fine = spectral.envelope(s, c, np.sort(np.concatenate([FINE, rnd])), nodes=NODES)
        ref = fine.depth[np.searchsorted(fine.rpm, grid)]
        np.testing.assert_allclose(together[j], ref, rtol=5e-3)


def test_zero_order_depth_independent_of_the_grid():
    """The zero-order engine's lobe-by-lobe envelope: a speed's depth is the same on a fine grid, a
    coarse one, a random set and alone, to round-off."""
    for immersion in (0.05, 0.5, 1.0):
        c = cut(immersion)
        rnd = random_speeds(2)
        fine = zoa.envelope(BENCH, c, np.sort(np.concatenate([FINE, rnd])))
        ref = fine.depth[np.searchsorted(fine.rpm, np.concatenate([COARSE, rnd]))]
        np.testing.assert_allclose(zoa.envelope(BENCH, c, COARSE).depth, ref[:COARSE.size], rtol=1e-9)
        np.testing.assert_allclose(zoa.envelope(BENCH, c, rnd).depth, ref[COARSE.size:], rtol=1e-9)
        alone = np.array([zoa.envelope(BENCH, c, [r]).depth[0] for r in rnd[:4]])
        np.testing.assert_allclose(alone, ref[COARSE.size:COARSE.size + 4], rtol=1e-9)


def test_sdm_depth_independent_of_the_grid():
    """SDM solves every (structure, speed) alone (its ladder is on that speed's zero-order depth): a
    speed's depth is the same in a call with other speeds and alone."""
    c = cut(0.5)
    speeds = np.array([6300.0, 10000.0, 17000.0])
    with_others = sdm.envelope(BENCH, c, np.concatenate([speeds, random_speeds(4, 3)])).depth[:3]
    alone = np.array([sdm.envelope(BENCH, c, [r]).depth[0] for r in speeds])
    np.testing.assert_allclose(with_others, alone, rtol=1e-12)


def test_problem_settings_keep_the_acceptance():
    """A problem evaluated over many calls (identification) gets ``near = 0`` from ``settings`` (the ladder
    refined only in its unstable step: a smoother objective); the per-speed acceptance stays, so the issue's
    coarse-grid case is right there too, and equal to the speed alone. A bad margin is an InputError."""
    c = cut(0.5)
    batch = ModalBatch.from_structures([BENCH])
    opts = spectral.settings(batch, c, COARSE)
    assert opts["near"] == 0.0
    i = int(np.flatnonzero(COARSE == 10000.0)[0])
    coarse = spectral.envelope_batch(batch, c, COARSE, **opts)[0, i]
    alone = spectral.envelope_batch(batch, c, [10000.0], **opts)[0, 0]
    assert coarse == pytest.approx(alone, rel=1e-6)
    assert coarse == pytest.approx(sdm.envelope(BENCH, c, [10000.0]).depth[0], rel=5e-3)
    with pytest.raises(InputError, match="near"):
        spectral.envelope_batch(batch, c, COARSE, near=1.5)
