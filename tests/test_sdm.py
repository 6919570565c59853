"""Tests of the semi-discretization engine against closed forms and independent re-computations.

The classic benchmark (Insperger & Stépán): 2 teeth, Kt = 6e8 N/m², Kn = 2e8 N/m² (Kr = 1/3), one mode
in x: fn = 922 Hz, ζ = 0.011, m = 0.03993 kg (k = m ωn²), down milling.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
from scipy.optimize import brentq

from millstab.errors import InputError
from millstab.frf import ModalBatch, measured_from_structure
from millstab.model import Cutting, Mode, Structure
from millstab.stability import sdm, zoa

FN, ZETA, MASS = 922.0, 0.011, 0.03993
K = MASS * (2 * math.pi * FN) ** 2
KT, KR = 6e8, 1.0 / 3.0
BENCH = Structure(x=(Mode(FN, K, ZETA),))


def bench_cut(radial_immersion: float, teeth: int = 2) -> Cutting:
    return Cutting.from_immersion(teeth, KT, KR, radial_immersion, "down")


# --- the force model ------------------------------------------------------------------------------


def altintas_A(cutting: Cutting, phi0: np.ndarray) -> np.ndarray:
    """[A] (P, 2, 2) for tooth-0 angles phi0, written from the force resolution (not from the engine).

    Chip thickness h = g(φ)(Δx sinφ + Δy cosφ); Ft = a Kt h, Fr = Kr Ft;
    Fx = −Ft cosφ − Fr sinφ, Fy = Ft sinφ − Fr cosφ  ⇒  F = a Kt Σ g f nᵀ Δ = ½ a Kt [A] Δ.
    """
    out = np.zeros((phi0.size, 2, 2))
    for j in range(cutting.teeth):
        phi = phi0 + 2 * math.pi * j / cutting.teeth
        g = ((phi % (2 * math.pi)) >= cutting.entry) & ((phi % (2 * math.pi)) <= cutting.exit)
        f = np.stack([-np.cos(phi) - cutting.kr * np.sin(phi), np.sin(phi) - cutting.kr * np.cos(phi)], axis=-1)
        n = np.stack([np.sin(phi), np.cos(phi)], axis=-1)
        out += 2.0 * g[:, None, None] * f[:, :, None] * n[:, None, :]
    return out


CUTS = [
    Cutting(2, KT, KR, 0.0, math.pi),
    bench_cut(0.05),
    bench_cut(0.5, teeth=3),
    Cutting.from_immersion(3, KT, 0.3, 0.3, "up"),
    Cutting(4, KT, KR, 0.0, math.pi),
    Cutting(5, KT, 0.2, 0.4, 2.9),
]


@pytest.mark.parametrize("cutting", CUTS)
def test_time_average_of_directional_matrix_is_zero_order_matrix(cutting):
    """Mean of [A(t)] over a tooth period = (N/2π)[α], by fine midpoint quadrature of the force model."""
    pitch = 2 * math.pi / cutting.teeth
    n = 200_000
    phi0 = (np.arange(n) + 0.5) * pitch / n
    mean = altintas_A(cutting, phi0).mean(axis=0)
    expect = cutting.teeth / (2 * math.pi) * zoa.directional_matrix(cutting)
    assert np.allclose(mean, expect, atol=2e-4 * np.abs(expect).max())
    # the engine's step averages: same mean (exactly), and each step's average matches quadrature
    h, cut, abar = sdm.step_matrices(cutting, 10_000.0, 40)
    T = 60.0 / (cutting.teeth * 10_000.0)
    assert h.sum() == pytest.approx(T, rel=1e-12)
    assert np.allclose(np.einsum("i,ijk->jk", h, abar) / T, expect, atol=1e-12 * max(1, np.abs(expect).max()))
    omega = 2 * math.pi * 10_000.0 / 60.0
    t0 = np.concatenate([[0.0], np.cumsum(h)])
    for i in (0, h.size // 2, h.size - 1):
        x = (np.arange(2000) + 0.5) / 2000
        phis = cutting.entry + omega * (t0[i] + x * h[i])
        assert np.allclose(altintas_A(cutting, phis).mean(axis=0), abar[i], atol=1e-6)
        assert cut[i] == bool(np.any(altintas_A(cutting, phis) != 0))


# --- an independent, plain semi-discretization (Insperger & Stépán, full state, scipy expm) --------


def reference_rho(structure: Structure, cutting: Cutting, rpm: float, depth: float, m: int) -> float:
    """ρ by the textbook first-order SDM on a uniform grid of m steps, tooth 0 at φst at t = 0.

    State y_i = (z_i, u_{i−1}, …, u_{i−m}), u the (x, y) tool displacement; step averages of [A] by
    Gauss–Legendre quadrature; e^{Ah}, ∫e^{A(h−s)}ds, ∫e^{A(h−s)}s ds from one scipy expm of the
    block matrix [[A, I, 0], [0, 0, I], [0, 0, 0]]h.
    """
    modes = [(md, 0) for md in structure.x] + [(md, 1) for md in structure.y]
    M = len(modes)
    n = 2 * M
    T = 60.0 / (cutting.teeth * rpm)
    h = T / m
    omega = 2 * math.pi * rpm / 60.0
    C = np.zeros((2, n))
    for j, (_, d) in enumerate(modes):
        C[d, j] = 1.0
    A0 = np.zeros((n, n))
    A0[:M, M:] = np.eye(M)
    Minv = np.zeros((n, 2))
    for j, (md, d) in enumerate(modes):
        A0[M + j, j] = -md.omega**2
        A0[M + j, M + j] = -2 * md.zeta * md.omega
        Minv[M + j, d] = 1.0 / md.mass
    xg, wg = np.polynomial.legendre.leggauss(40)
    dim = n + 2 * m
    Phi_total = np.eye(dim)
    w = 0.5 * depth * cutting.kt
    for i in range(m):
        phis = cutting.entry + omega * h * (i + 0.5 + 0.5 * xg)
        abar = np.einsum("p,pjk->jk", wg / 2, altintas_A(cutting, phis))
        A = A0 + w * Minv @ abar @ C
        B = -w * Minv @ abar
        X = np.zeros((3 * n, 3 * n))
        X[:n, :n] = A
        X[:n, n:2 * n] = np.eye(n)
        X[n:2 * n, 2 * n:] = np.eye(n)
        E = scipy.linalg.expm(X * h)
        P, F1, F2 = E[:n, :n], E[:n, n:2 * n], E[:n, 2 * n:]
        G1 = F2 / h @ B
        G0 = F1 @ B - G1
        Gi = np.zeros((dim, dim))
        Gi[:n, :n] = P
        Gi[:n, n + 2 * (m - 1):n + 2 * m] += G0  # u_{i−m}
        if m >= 2:
            Gi[:n, n + 2 * (m - 2):n + 2 * (m - 1)] += G1  # u_{i−m+1}
        else:
            Gi[:n, :n] += G1 @ C
        Gi[n:n + 2, :n] = C  # u_i enters the history
        for k in range(1, m):
            Gi[n + 2 * k:n + 2 * k + 2, n + 2 * (k - 1):n + 2 * k] = np.eye(2)
        Phi_total = Gi @ Phi_total
    return float(np.abs(np.linalg.eigvals(Phi_total)).max())


@pytest.mark.parametrize(
    "structure, cutting, rpm, depth",
    [
        (BENCH, bench_cut(1.0), 7000.0, 1.0e-3),
        (BENCH, bench_cut(1.0), 12000.0, 2.0e-3),
        (Structure(x=(Mode(FN, K, ZETA), Mode(2100.0, 3 * K, 0.03)),
                   y=(Mode(1100.0, 1.5 * K, 0.02), Mode(700.0, 4 * K, 0.05))),
         Cutting(4, KT, KR, 0.0, math.pi), 9000.0, 0.3e-3),
    ],
)
@pytest.mark.slow
def test_engine_matches_textbook_sdm(structure, cutting, rpm, depth):
    """Slotting grids coincide (no entry/exit inside the period), so ρ must agree to round-off.

    Covers the closed-form 2×2 exponentials (one mode) and the eigendecomposition path (4 modes).
    """
    m = 24
    expect = reference_rho(structure, cutting, rpm, depth, m)
    got = sdm.rho_map(structure, cutting, [rpm], [depth], steps=m)[0, 0]
    assert got == pytest.approx(expect, rel=1e-8)
    assert abs(expect - 1.0) > 1e-3  # a meaningful point, not trivially 1


@pytest.mark.slow
def test_rho_at_zero_depth_is_free_decay():
    """ρ(0) = exp(−ζ ωn T) (closed form), and the largest over modes for several modes."""
    rpm = np.array([5000.0, 9000.0, 17000.0, 25000.0])
    T = 60.0 / (2 * rpm)
    got = sdm.rho_map(BENCH, bench_cut(1.0), rpm, [0.0])[:, 0]
    assert np.allclose(got, np.exp(-ZETA * 2 * math.pi * FN * T), rtol=1e-10)
    got = sdm.rho_map(BENCH, bench_cut(0.05), rpm, [0.0], steps=40)[:, 0]
    assert np.allclose(got, np.exp(-ZETA * 2 * math.pi * FN * T), rtol=1e-10)
    two = Structure(x=(Mode(FN, K, ZETA),), y=(Mode(400.0, K, 0.004),))
    got = sdm.rho_map(two, bench_cut(0.5), rpm, [0.0])[:, 0]
    expect = np.maximum(np.exp(-ZETA * 2 * math.pi * FN * T), np.exp(-0.004 * 2 * math.pi * 400.0 * T))
    assert np.allclose(got, expect, rtol=1e-10)


# --- accuracy on the benchmark --------------------------------------------------------------------


def converged_depth(cutting: Cutting, rpm: float, guess: float) -> float:
    """Richardson extrapolation (error O(h²)) of the ρ = 1 root on uniform 120 and 240 steps/period.

    Independent of the engine's default grid; brentq on ρ in a ±6 % bracket around ``guess`` (the
    bracket itself must hold, which already checks the guess to 6 %).
    """
    roots = []
    for m in (120, 240):
        def f(b):
            return sdm.rho_map(BENCH, cutting, [rpm], [b], steps=m)[0, 0] - 1.0
        roots.append(brentq(f, 0.94 * guess, 1.06 * guess, xtol=1e-9, rtol=1e-9))
    return (4 * roots[1] - roots[0]) / 3


@pytest.mark.parametrize(
    "immersion, speeds",
    [(1.0, [5000.0, 7000.0, 12000.0, 21000.0]), (0.05, [5000.0, 7000.0, 10000.0, 15000.0, 20000.0, 25000.0])],
)
def test_benchmark_depth_within_one_percent_of_converged(immersion, speeds):
    cutting = bench_cut(immersion)
    env = sdm.envelope(BENCH, cutting, speeds)
    assert np.all(np.isfinite(env.depth))
    for rpm, b in zip(speeds, env.depth):
        ref = converged_depth(cutting, rpm, b)
        assert b == pytest.approx(ref, rel=0.01), rpm


@pytest.mark.slow
def test_fixed_40_steps_too_coarse_at_low_speed():
    """The customary 40 steps per period are ~8 % off at 5 000 rpm slotting: the default must not be."""
    cutting = bench_cut(1.0)
    b40 = sdm.envelope(BENCH, cutting, [5000.0], steps=40).depth[0]
    b = sdm.envelope(BENCH, cutting, [5000.0]).depth[0]
    assert b40 / b - 1 > 0.05


def test_fn_max_hz_one_is_the_extrapolated_truth():
    """``fn_max_hz=1`` (20 and 40 steps at every speed, extrapolated; the virtual shop's truth, benchmarks/_truth.py)
    through ``envelope`` is ``envelope_batch``'s, bit for bit, and within 1 % of the converged depth (Richardson of
    120 and 240 steps) at 5 000 rpm slotting, where 40 fixed steps are ~8 % high."""
    cutting = bench_cut(1.0)
    env = sdm.envelope(BENCH, cutting, [5000.0, 9000.0], fn_max_hz=1.0)
    batch = sdm.envelope_batch(ModalBatch.from_structures([BENCH]), cutting, [5000.0, 9000.0], fn_max_hz=1.0)
    assert np.array_equal(env.depth, batch[0])
    ref = converged_depth(cutting, 5000.0, env.depth[0])
    assert env.depth[0] == pytest.approx(ref, rel=0.01)
    assert sdm.envelope(BENCH, cutting, [5000.0], steps=40).depth[0] / ref - 1 > 0.05


def test_convergence_order_in_steps():
    """ρ at a fixed point: successive differences shrink by ≈ 4 per doubling (second order)."""
    cutting = bench_cut(1.0)
    rho = [sdm.rho_map(BENCH, cutting, [5000.0], [0.4e-3], steps=m)[0, 0] for m in (20, 40, 80, 160)]
    d = np.abs(np.diff(rho))
    orders = np.log2(d[:-1] / d[1:])
    assert np.all((orders > 1.7) & (orders < 2.3)), orders


def test_flip_lobe_at_low_immersion():
    """a/D = 0.05: between the Hopf lobes the SDM boundary has flip (period-doubling) lobes the
    zero-order method misses; there the critical multiplier is ≈ −1, elsewhere a complex pair."""
    cutting = bench_cut(0.05)
    speeds = [10000.0, 15000.0, 20000.0]
    b_sdm = sdm.envelope(BENCH, cutting, speeds).depth
    b_zoa = zoa.envelope(BENCH, cutting, speeds).depth
    mu = sdm.critical_multipliers(BENCH, cutting, speeds)
    for i in (0, 1):  # flip-lobe speeds
        assert b_sdm[i] < 0.65 * b_zoa[i]
        assert abs(mu[i] - (-1.0)) < 0.01
    # a Hopf lobe: ZOA close, complex multiplier on the unit circle
    assert b_sdm[2] == pytest.approx(b_zoa[2], rel=0.1)
    assert abs(mu[2].imag) > 0.1 and abs(abs(mu[2]) - 1) < 0.01


# --- SDM against the zero-order method where that is exact ----------------------------------------

SPEEDS = np.linspace(6000.0, 24000.0, 7)


@pytest.mark.parametrize(
    "structure",
    [
        Structure.symmetric(FN, K, ZETA),
        Structure(x=(Mode(FN, K, ZETA), Mode(1400.0, 2 * K, 0.02)),
                  y=(Mode(1000.0, 1.2 * K, 0.015), Mode(600.0, 5 * K, 0.03))),
    ],
)
def test_sdm_equals_zoa_for_even_teeth_slotting(structure):
    """N = 4 slotting: [A(t)] is constant, so the zero-order solution is exact. Measured agreement
    5e-5 (the root bracket width); asserted 5e-4 in depth, 1e-3 in chatter frequency."""
    cutting = Cutting(4, KT, KR, 0.0, math.pi)
    e_sdm = sdm.envelope(structure, cutting, SPEEDS)
    e_zoa = zoa.envelope(structure, cutting, SPEEDS)
    assert np.allclose(e_sdm.depth, e_zoa.depth, rtol=5e-4)
    assert np.allclose(e_sdm.chatter_hz, e_zoa.chatter_hz, rtol=1e-3)


def test_sdm_differs_from_zoa_for_two_teeth_slotting():
    """N = 2: [A(t)] varies in time, so the zero-order solution is only approximate: the lowest
    boundary over 10 000–25 000 rpm differs by a few per cent (≈ 6 %; field notes: up to ~10 %), and
    the lobes are shifted, so on their flanks the depths at one speed differ far more."""
    cutting = bench_cut(1.0)
    speeds = np.linspace(10000.0, 25000.0, 61)
    b_sdm = sdm.envelope(BENCH, cutting, speeds).depth
    b_zoa = zoa.envelope(BENCH, cutting, speeds).depth
    assert 0.02 < b_sdm.min() / b_zoa.min() - 1 < 0.12
    assert np.abs(b_sdm / b_zoa - 1).max() > 0.1


# --- interface --------------------------------------------------------------------------------------


def test_batch_scaling_and_consistency():
    """Stiffness × c (same fn, ζ) ⇒ depth × c exactly; the batch equals single-structure calls."""
    cutting = bench_cut(0.5)
    speeds = [8000.0, 14000.0]
    scaled = Structure(x=(Mode(FN, 2.5 * K, ZETA),), y=(Mode(1300.0, 2.5 * 2 * K, 0.02),))
    base = Structure(x=(Mode(FN, K, ZETA),), y=(Mode(1300.0, 2 * K, 0.02),))
    depth = sdm.envelope_batch(ModalBatch.from_structures([base, scaled]), cutting, speeds)
    assert depth.shape == (2, 2)
    assert np.allclose(depth[1], 2.5 * depth[0], rtol=3e-4)
    assert np.allclose(depth[0], sdm.envelope(base, cutting, speeds).depth, rtol=1e-12)


def test_measured_frf_rejected_and_bad_input():
    f = np.linspace(100.0, 3000.0, 500)
    measured = Structure(frf=measured_from_structure(BENCH, f))
    with pytest.raises(InputError, match="modal"):
        sdm.envelope(measured, bench_cut(1.0), [10000.0])
    with pytest.raises(InputError):
        sdm.rho_map(BENCH, bench_cut(1.0), [10000.0], [-1e-3])
    with pytest.raises(InputError):
        sdm.envelope(BENCH, bench_cut(1.0), [0.0])
    with pytest.raises(InputError):
        sdm.rho_map(BENCH, bench_cut(1.0), [10000.0], [1e-3], steps=0)
