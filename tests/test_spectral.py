"""Tests of the spectral-element engine against closed forms, SDM and independent re-computations.

The classic benchmark (Insperger & Stépán): 2 teeth, Kt = 6e8 N/m², Kn = 2e8 N/m² (Kr = 1/3), one mode
in x: fn = 922 Hz, ζ = 0.011, m = 0.03993 kg (k = m ωn²), down milling. The SDM engine's default
(Richardson-extrapolated) depths are the reference: tests/test_sdm.py checks them against a Richardson
extrapolation of 120/240 uniform steps to 1 % (measured 0.1–0.2 %).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from millstab.cli import main
from millstab.errors import InputError
from millstab.frf import ModalBatch, measured_from_structure
from millstab.model import Cutting, Mode, Structure
from millstab.stability import ENGINES, get_engine, sdm, spectral, zoa

FN, ZETA, MASS = 922.0, 0.011, 0.03993
K = MASS * (2 * math.pi * FN) ** 2
KT, KR = 6e8, 1.0 / 3.0
BENCH = Structure(x=(Mode(FN, K, ZETA),))
#: two modes per direction (x and y differ), for the multi-mode paths
TWO_MODE = Structure(x=(Mode(FN, K, ZETA), Mode(2100.0, 3 * K, 0.03)),
                     y=(Mode(1100.0, 1.5 * K, 0.02), Mode(700.0, 4 * K, 0.05)))


def bench_cut(radial_immersion: float, teeth: int = 2) -> Cutting:
    return Cutting.from_immersion(teeth, KT, KR, radial_immersion, "down")


def spectral_radius(structure, cutting, rpm, depth, nodes):
    return float(np.max(np.abs(np.linalg.eigvals(spectral.monodromy(structure, cutting, rpm, depth, nodes)))))


# --- the discretisation -----------------------------------------------------------------------------


@pytest.mark.slow
def test_rho_at_zero_depth_is_free_decay():
    """ρ(0) = exp(−ζ ωn T) (closed form; the largest over modes for several modes): to the collocation
    error (< 1e-3) with the default 4 nodes per element, to 1e-9 with 10 (spectral convergence); exact
    where the cut is one free-flight step short (the free flight is an exact exponential)."""
    rpm = np.array([5000.0, 9000.0, 17000.0, 25000.0])
    T = 60.0 / (2 * rpm)
    for cut in (bench_cut(1.0), bench_cut(0.05)):
        for nodes, tol in ((4, 1e-3), (10, 1e-9)):
            got = spectral.rho_map(BENCH, cut, rpm, [0.0], nodes=nodes)[:, 0]
            assert np.allclose(got, np.exp(-ZETA * 2 * math.pi * FN * T), rtol=tol)
    two = Structure(x=(Mode(FN, K, ZETA),), y=(Mode(400.0, K, 0.004),))
    got = spectral.rho_map(two, bench_cut(0.5), rpm, [0.0], nodes=10)[:, 0]
    expect = np.maximum(np.exp(-ZETA * 2 * math.pi * FN * T), np.exp(-0.004 * 2 * math.pi * 400.0 * T))
    assert np.allclose(got, expect, rtol=1e-9)


@pytest.mark.parametrize("cutting, rpm, depth", [(bench_cut(0.05), 5000.0, 1e-3), (bench_cut(1.0), 7000.0, 1e-3)])
def test_spectral_convergence_and_agreement_with_sdm(cutting, rpm, depth):
    """ρ with p = 2, 4, 6, 8 Gauss nodes per element: the error against p = 14 falls by > 10× per two
    nodes (spectral, not algebraic), and the converged ρ agrees with SDM's Richardson-extrapolated
    one (an independent, second-order discretisation) to its own accuracy (≈ 1e-4)."""
    ref = spectral_radius(BENCH, cutting, rpm, depth, 14)
    err = np.array([abs(spectral_radius(BENCH, cutting, rpm, depth, p) - ref) for p in (2, 4, 6, 8)])
    assert np.all(err[1:] < err[:-1] / 10), err
    assert err[-1] < 1e-7
    assert ref == pytest.approx(sdm.rho_map(BENCH, cutting, [rpm], [depth])[0, 0], abs=3e-4)


# --- the benchmark against SDM ----------------------------------------------------------------------


@pytest.mark.parametrize(
    "immersion, speeds",
    [(1.0, [5000.0, 6750.0, 12000.0, 21000.0]), (0.5, [6000.0, 11000.0, 19000.0]), (0.1, [7000.0, 14000.0, 23000.0]),
     (0.05, [5000.0, 9000.0, 10000.0, 15000.0, 20000.0, 25000.0])],
)
def test_benchmark_depth_matches_converged_sdm(immersion, speeds):
    """Within 0.5 % of converged SDM (the target is 1 %; measured ≤ 0.25 % on the whole grid, see
    benchmarks/bench_spectral.py), flip and Hopf speeds alike, and the same lobe type as SDM's
    critical multiplier."""
    cutting = bench_cut(immersion)
    env = spectral.envelope(BENCH, cutting, speeds)
    ref = sdm.envelope(BENCH, cutting, speeds).depth
    assert np.allclose(env.depth, ref, rtol=5e-3), env.depth / ref - 1
    mu_sdm = sdm.critical_multipliers(BENCH, cutting, speeds)
    flip_sdm = np.abs(np.angle(mu_sdm)) > math.pi - 1e-3
    assert np.array_equal(env.kind == "flip", flip_sdm)


def test_flip_lobes_at_low_immersion():
    """a/D = 0.05: flip lobes (μ ≈ −1) far below the zero-order depth; a flip chatters at an odd
    multiple of half the tooth-passing frequency (closed form f = (2j + 1)/(2T)); a Hopf lobe has a
    complex multiplier on the unit circle and lies near the zero-order depth."""
    cutting = bench_cut(0.05)
    speeds = np.array([10000.0, 15000.0, 20000.0])
    env = spectral.envelope(BENCH, cutting, speeds)
    b_zoa = zoa.envelope(BENCH, cutting, speeds).depth
    T = 60.0 / (2 * speeds)
    assert list(env.kind) == ["flip", "flip", "hopf"]
    for i in (0, 1):
        assert env.depth[i] < 0.65 * b_zoa[i]
        assert abs(env.multiplier[i] - (-1.0)) < 0.01
        j = env.chatter_hz[i] * 2 * T[i]
        assert abs(j - round(j)) < 1e-6 and round(j) % 2 == 1
    assert env.depth[2] == pytest.approx(b_zoa[2], rel=0.1)
    assert abs(env.multiplier[2].imag) > 0.1 and abs(abs(env.multiplier[2]) - 1) < 0.01


def test_first_crossing_by_dense_scan():
    """The reported depth is the FIRST crossing: on 60 depths from 0 to 0.995·b_lim the converged
    monodromy (more nodes than the engine chose) is stable everywhere, and unstable at 1.005·b_lim."""
    cutting = bench_cut(0.05)
    speeds = [6000.0, 10000.0, 16500.0]
    env = spectral.envelope(BENCH, cutting, speeds)
    for rpm, b in zip(speeds, env.depth):
        rho = spectral.rho_map(BENCH, cutting, [rpm], np.linspace(0.0, 0.995 * b, 60), nodes=8)[0]
        assert rho.max() < 1.0
        assert spectral_radius(BENCH, cutting, rpm, 1.005 * b, 8) > 1.0


def test_two_modes_per_direction_matches_sdm():
    """Four modes (x and y different): within 0.5 % of converged SDM at a/D = 0.1 and in slotting."""
    for cutting, speeds in ((bench_cut(0.1, teeth=3), [6000.0, 21000.0]), (bench_cut(1.0), [17000.0])):
        got = spectral.envelope(TWO_MODE, cutting, speeds).depth
        ref = sdm.envelope(TWO_MODE, cutting, speeds).depth
        assert np.allclose(got, ref, rtol=5e-3), got / ref - 1


# --- exact cases and scaling laws ---------------------------------------------------------------------

SPEEDS = np.linspace(6000.0, 24000.0, 7)


@pytest.mark.parametrize("structure", [Structure.symmetric(FN, K, ZETA), TWO_MODE])
def test_equals_zoa_for_four_teeth_slotting(structure):
    """N = 4 slotting: [A(t)] is constant, so the zero-order solution is exact. The multiplier fixes
    the chatter frequency only up to ±f + j/T (the engine takes the candidate nearest the most
    flexible mode, as SDM does), so the frequency is checked in that sense: e^{±2πi f T} agree."""
    cutting = Cutting(4, KT, KR, 0.0, math.pi)
    e = spectral.envelope(structure, cutting, SPEEDS)
    e_zoa = zoa.envelope(structure, cutting, SPEEDS)
    assert np.allclose(e.depth, e_zoa.depth, rtol=5e-4)
    T = 60.0 / (4 * SPEEDS)
    same = np.abs(np.exp(2j * np.pi * e.chatter_hz * T) - np.exp(2j * np.pi * e_zoa.chatter_hz * T)) < 1e-2
    conj = np.abs(np.exp(2j * np.pi * e.chatter_hz * T) - np.exp(-2j * np.pi * e_zoa.chatter_hz * T)) < 1e-2
    assert np.all(same | conj)
    assert np.mean(np.isclose(e.chatter_hz, e_zoa.chatter_hz, rtol=1e-3)) >= 0.8


def test_scaling_laws_batch_and_speed_order():
    """k × c ⇒ b × c and Kt × c ⇒ b / c (exact laws of the model); the batch equals single calls;
    the order of the speeds does not matter."""
    cutting = bench_cut(0.1)
    speeds = np.array([7000.0, 11000.0, 15500.0, 22000.0])
    base = Structure(x=(Mode(FN, K, ZETA),), y=(Mode(1300.0, 2 * K, 0.02),))
    scaled = Structure(x=(Mode(FN, 2.5 * K, ZETA),), y=(Mode(1300.0, 2.5 * 2 * K, 0.02),))
    depth = spectral.envelope_batch(ModalBatch.from_structures([base, scaled]), cutting, speeds)
    assert depth.shape == (2, 4)
    assert np.allclose(depth[1], 2.5 * depth[0], rtol=5e-4)
    single = spectral.envelope(base, cutting, speeds).depth
    assert np.allclose(depth[0], single, rtol=1e-12)
    kt_scaled = spectral.envelope(base, cutting.scaled_kt(3.0), speeds).depth
    assert np.allclose(kt_scaled, single / 3.0, rtol=5e-4)
    perm = np.array([2, 0, 3, 1])
    shuffled = spectral.envelope(base, cutting, speeds[perm])
    assert np.allclose(shuffled.depth, single[perm], rtol=1e-12)


# --- interface ------------------------------------------------------------------------------------------


def test_registered_and_cli(tmp_path, capsys):
    assert "spectral" in ENGINES and get_engine("spectral") is spectral
    out = tmp_path / "sld.csv"
    assert main(["lobes", "example:ex3", "--rpm", "8000:9000:250", "--engine", "spectral", "--out", str(out)]) == 0
    assert "(spectral)" in capsys.readouterr().out
    assert out.read_text().count("\n") == 6


def test_rho_map_default_converges_inside_a_band():
    """Deep inside a flip band's stable pocket a coarse collocation puts ρ on the wrong side of 1: the default
    rho_map converges its nodes and agrees with an independent SDM at 400 steps (Example 1 at a/D 0.05 down,
    12 500 rpm, 145 mm: 4 nodes 1.022, converged 0.9530, SDM 0.9526); a fixed ``nodes`` is taken as given."""
    ex1 = Structure(x=(Mode(903.0, 12.53e6, 0.03),), y=(Mode(903.0, 12.53e6, 0.03),))
    cut = Cutting.from_immersion(2, 556.31e6, 0.404, 0.05, "down")
    depths = [0.120, 0.145]
    got = spectral.rho_map(ex1, cut, [12500.0], depths)[0]
    ref = sdm.rho_map(ex1, cut, [12500.0], depths, steps=400)[0]
    assert got == pytest.approx(ref, abs=1e-3)
    assert got[1] < 0.96  # stable, as the time-domain simulation finds it (tests/test_simulate_detect.py)
    assert spectral.rho_map(ex1, cut, [12500.0], depths, nodes=4)[0, 1] == pytest.approx(
        spectral_radius(ex1, cut, 12500.0, 0.145, 4), rel=1e-12)


def test_measured_frf_rejected_and_bad_input():
    f = np.linspace(100.0, 3000.0, 500)
    measured = Structure(frf=measured_from_structure(BENCH, f))
    with pytest.raises(InputError, match="modal"):
        spectral.envelope(measured, bench_cut(1.0), [10000.0])
    with pytest.raises(InputError):
        spectral.rho_map(BENCH, bench_cut(1.0), [10000.0], [-1e-3])
    with pytest.raises(InputError):
        spectral.envelope(BENCH, bench_cut(1.0), [0.0])
    with pytest.raises(InputError, match="nodes"):
        spectral.envelope(BENCH, bench_cut(1.0), [10000.0], nodes=1)


# --- the characteristic function's exact derivatives and Newton (issue 16, speed) ----------------------


def _layout(structure, cutting, rpm, nodes=6):
    from millstab.stability import _spectral_kernel as k
    from millstab.stability.sdm import _arrays

    wn, zeta, mass, act, mdir = _arrays(ModalBatch.from_structures([structure]))
    nd = k.gauss_nodes(nodes)
    g = k.setup(cutting.teeth, cutting.kr, cutting.entry, cutting.exit, rpm, float(spectral._elem_len(wn)[0]), nd[0],
                wn[0], zeta[0], act)
    g = k.with_factors(g, wn[0], zeta[0], mass[0], mdir, nd)
    return k, (cutting.kt, wn[0], zeta[0], mass[0], mdir, g, nd)


@pytest.mark.parametrize("structure, immersion", [(BENCH, 0.05), (BENCH, 1.0), (TWO_MODE, 0.1)])
@pytest.mark.slow
def test_characteristic_derivatives_match_finite_differences(structure, immersion):
    """char_d's F equals char_fn's (the same determinant by another code path) and its ∂F/∂b, ∂F/∂θ
    (Jacobi's formula with dΨ/dσ from the element LU) equal central differences of char_fn."""
    k, args = _layout(structure, bench_cut(immersion), 9000.0)
    for b, th in ((2e-3, 1.3), (0.7e-3, 2.9), (5e-3, 0.4)):
        f, fb, ft = k.char_d(b, th, *args)
        assert f == pytest.approx(k.char_fn(b, th, *args), rel=1e-10)
        h = 1e-6
        fd_b = (k.char_fn(b * (1 + h), th, *args) - k.char_fn(b * (1 - h), th, *args)) / (2 * h * b)
        fd_t = (k.char_fn(b, th + h, *args) - k.char_fn(b, th - h, *args)) / (2 * h)
        assert abs(fb - fd_b) < 1e-5 * abs(fd_b)
        assert abs(ft - fd_t) < 1e-5 * abs(fd_t)


@pytest.mark.parametrize("immersion, rpm", [(0.05, 9000.0), (0.05, 10000.0), (1.0, 23000.0)])
def test_newton_root_is_a_multiplier_on_the_unit_circle(immersion, rpm):
    """Started 10 % off the engine's boundary point, Newton lands on a depth where the monodromy
    matrix (dense eigenvalues, an independent path) has a multiplier at e^{iθ} to 1e-7; a flip root
    has θ = π exactly."""
    cutting = bench_cut(immersion)
    env = spectral.envelope(BENCH, cutting, [rpm], nodes=6)
    k, args = _layout(BENCH, cutting, rpm, nodes=6)
    th0 = abs(float(np.angle(env.multiplier[0])))
    b, th, ok, n_eval = k.newton(1.1 * env.depth[0], th0, *args)
    assert ok and n_eval <= k.NEWTON_EVALS
    assert b == pytest.approx(env.depth[0], rel=1e-7)
    mus = np.linalg.eigvals(spectral.monodromy(BENCH, cutting, rpm, b, nodes=6))
    assert np.min(np.abs(mus - np.exp(1j * th))) < 1e-7
    if env.kind[0] == "flip":
        assert th == math.pi


def test_branch_tracking_finds_a_narrow_flip_band():
    """x = y one mode each, a/D = 0.05, 200 speeds: at 12 538 rpm a flip band opens at 14.80 mm just
    below the Hopf crossing at 15.10 mm (the engine before branch tracking reported 15.10 mm). The
    reported depth must be the first crossing: a dense ρ scan with more nodes (an independent
    re-computation) is stable below it and unstable just above."""
    xy = Structure(x=(Mode(FN, K, ZETA),), y=(Mode(FN, K, ZETA),))
    cutting = bench_cut(0.05)
    rpm = np.linspace(5000.0, 25000.0, 200)
    env = spectral.envelope(xy, cutting, rpm)
    i = 75
    b = env.depth[i]
    rho = spectral.rho_map(xy, cutting, [rpm[i]], np.linspace(0.7 * b, 0.998 * b, 30), nodes=8)[0]
    assert rho.max() < 1.0
    assert spectral_radius(xy, cutting, rpm[i], 1.002 * b, 8) > 1.0
    assert env.kind[i] == "flip"


def test_closed_band_below_a_far_continued_root():
    """A set from identification's search space (Example 1's structure moved by up to 30 %, a/D = 0.1,
    40 speeds 3 000–15 000 rpm): at 6 077 rpm a closed unstable band spans ~41–45 mm below a Hopf
    crossing at 57.4 mm. Newton continued the previous speed's boundary (42.0 mm) onto the 57.4 mm
    root, whose checks (0.7, 0.93, 0.995 of it) all lie outside the band; a branch that moves by more
    than 25 % in one speed step must not be trusted. The depth must be the first crossing (a dense ρ
    scan with more nodes, an independent re-computation, is stable below it)."""
    s = Structure(x=(Mode(685.0407184001604, 12746788.109185813, 0.029276902992752436),),
                  y=(Mode(694.4584275801416, 13638854.533296518, 0.037068853353218134),))
    cutting = Cutting.from_immersion(2, 556.31e6, 0.404, 0.1, "down")
    rpm = np.linspace(3000.0, 15000.0, 40)
    b = spectral.envelope(s, cutting, rpm).depth[10]
    rho = spectral.rho_map(s, cutting, [rpm[10]], np.linspace(0.3 * b, 0.995 * b, 40), nodes=8)[0]
    assert rho.max() < 1.0
    assert spectral_radius(s, cutting, rpm[10], 1.005 * b, 8) > 1.0


def test_unsorted_speeds_with_repeats_equal_each_speed_alone():
    """A campaign asked for [12000, 11965, 8869, 9080, 8940, 11965 ×4] rpm: the kernel divided by zero on the
    repeated speeds (continuation needs a step > 0). Each distinct speed is solved once now; every entry
    equals that speed's depth computed alone."""
    from millstab.datasets import load_example
    from millstab.model import Cutting, Mode, Structure
    from millstab.stability import spectral

    c = load_example("ex1").cutting
    s = Structure(x=(Mode(910.4205842190763, 11376171.009384518, 0.021737523430851505),),
                  y=(Mode(876.8054672929356, 14100110.438871766, 0.03742960039099899),))
    cut = Cutting.from_immersion(c.teeth, c.kt, c.kr, 0.1, "down")
    rpm = ([12000.0, 11964.824120603014, 8869.346733668342, 9080.402010050251, 8939.698492462312]
           + [11964.824120603014] * 4)
    env = spectral.envelope(s, cut, rpm)
    assert np.all(np.isfinite(env.depth))
    np.testing.assert_array_equal(env.depth[5:], env.depth[1])
    for i in (0, 2):
        alone = spectral.envelope(s, cut, [rpm[i]]).depth[0]
        np.testing.assert_allclose(env.depth[i], alone, rtol=1e-3)


# --- the reduced monodromy and the acceptance of jumped branches (issue 16, speed) ---------------------


@pytest.mark.parametrize("structure", [BENCH, Structure.symmetric(FN, K, ZETA), TWO_MODE])
@pytest.mark.parametrize("teeth, immersion, mode",
                         [(2, 0.05, "down"), (2, 1.0, "down"), (3, 0.5, "up"), (4, 1.0, "down")])
def test_reduced_monodromy_has_the_full_monodromys_multipliers(structure, teeth, immersion, mode):
    """The root search's ρ uses the monodromy on the reduced history (one chip thickness per tooth in
    the cut and node instead of the D displacements): the node factors reproduce [A] exactly, and its
    eigenvalues are the full monodromy's nonzero ones (an independent matrix, public `monodromy`)."""
    from millstab.stability import _spectral_kernel as k
    from millstab.stability.sdm import _arrays

    cutting = Cutting.from_immersion(teeth, KT, KR, immersion, mode)
    wn, zeta, mass, act, mdir = _arrays(ModalBatch.from_structures([structure]))
    nd = k.gauss_nodes(6)
    for rpm in (7000.0, 13000.0):  # two collocation elements at a/D = 0.05, one
        el = float(spectral._elem_len(wn)[0])
        g = k.setup(cutting.teeth, cutting.kr, cutting.entry, cutting.exit, rpm, el, nd[0], wn[0], zeta[0], act)
        kind, Aq, Fq, Gq, rk = g[0], g[2], g[5], g[6], g[7]
        for e in np.flatnonzero(kind == 1):
            for node in range(1, nd[0].size):
                r = rk[e, node]
                assert r <= act.size
                np.testing.assert_allclose(Fq[e, node][:, :r] @ Gq[e, node][:, :r].T, Aq[e, node], atol=1e-14)
        small = k.monodromy_small(2e-3, cutting.kt, wn[0], zeta[0], mass[0], mdir, g[0], g[1], g[2], g[4], g[5], g[6],
                                  g[7], nd[1], nd[2])
        full = np.linalg.eigvals(spectral.monodromy(structure, cutting, rpm, 2e-3, nodes=6))
        mus = np.linalg.eigvals(small)
        assert small.shape[0] <= full.size
        if teeth == 2 and act.size == 2:  # one tooth in the cut at a time: half the history
            assert small.shape[0] - 2 * wn.shape[1] == (full.size - 2 * wn.shape[1]) // 2
        big = full[np.abs(full) > 1e-6 * np.abs(full).max()]
        assert np.abs(mus).max() == pytest.approx(np.abs(full).max(), rel=1e-10)
        for m in big:
            assert np.min(np.abs(mus - m)) < 1e-7 * max(1.0, abs(m))


@pytest.mark.slow
def test_first_crossing_on_random_sets_with_bands_opening_below_a_rising_flank():
    """Random sets of identification's search space (Example 1's structure moved by up to 30 %, 40
    speeds 3 000–15 000 rpm; draws 0, 1 and 3 of seed 7): where a Hopf boundary rises towards its lobe's
    end, a new lobe (a flip band) can open far below it, at 20–60 % of it. The checks at 0.7, 0.93 and
    0.995 of the continued root stepped over such bands (at a/D = 0.1, 11 923 rpm: 36.2 mm reported,
    first crossing 14.5 mm; at a/D = 0.05, 12 231 and 14 385 rpm: 54.9 and 59.5 mm against 20.6 and
    14.4 mm). At EVERY speed the depth must be the first crossing: a dense ρ scan with more nodes (an
    independent re-computation) is stable on 40 depths from 0.02 to 0.99 of it and unstable at 1.005
    of it. (Known limit, see the module docstring: a band narrower than the rungs' spacing can still
    be missed; on other draws, bands 1–2 % wide just below the root were.)"""
    rng = np.random.default_rng(7)
    draws = [rng.uniform(0.7, 1.3, 6) for _ in range(4)]
    rpm = np.linspace(3000.0, 15000.0, 40)
    for immersion, f in ((0.1, draws[3]), (0.05, draws[0]), (0.05, draws[1])):
        cutting = Cutting.from_immersion(2, 556.31e6, 0.404, immersion, "down")
        s = Structure(x=(Mode(685.0 * f[0], 12.7e6 * f[1], 0.029 * f[2]),),
                      y=(Mode(694.0 * f[3], 13.6e6 * f[4], 0.037 * f[5]),))
        env = spectral.envelope(s, cutting, rpm)
        assert np.all(np.isfinite(env.depth))
        for i, b in enumerate(env.depth):
            rho = spectral.rho_map(s, cutting, [rpm[i]], np.linspace(0.02 * b, 0.99 * b, 40), nodes=env.nodes + 2)[0]
            assert rho.max() < 1.0, (immersion, rpm[i], b)
            assert spectral_radius(s, cutting, rpm[i], 1.005 * b, env.nodes + 2) > 1.0, (immersion, rpm[i], b)
