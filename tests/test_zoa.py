"""Zero-order engine: closed forms, scaling laws, symmetry and a brute-force reference."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import minimize_scalar

from millstab.frf import ModalBatch, measured_from_structure
from millstab.model import Cutting, MeasuredFRF, Mode, Structure
from millstab.params import Parameterization
from millstab.stability import _zoa_kernel, zoa
from reference_zoa import reference_depth, reference_envelope

EX1 = (Structure.symmetric(903.0, 12.53e6, 0.03), Cutting(2, 556.31e6, 0.404, 0.0, math.pi))
EX2 = (Structure.symmetric(500.0, 8.0e6, 0.02), Cutting(4, 695e6, 0.404, 0.0, math.pi))
EX3 = (Structure(x=(Mode(900.0, 9e6, 0.02),), y=(Mode(950.0, 10e6, 0.01),)),
       Cutting(3, 2173e6, 0.268, math.radians(126.9), math.pi))
FOUR_FLUTE = (Structure(x=(Mode(3890, 22.6e6, 0.0196), Mode(4182, 15.4e6, 0.0170)),
                        y=(Mode(3872, 23.4e6, 0.0220), Mode(4127, 25.1e6, 0.0177))), Cutting(4, 1110e6, 0.22))


def lobe_speed(cutting: Cutting, f_hz: float, eps: float, k: int) -> float:
    """Ω = 60 ω / (N (ε + 2kπ)) [rpm]."""
    return 60.0 * 2 * math.pi * f_hz / (cutting.teeth * (eps + 2 * math.pi * k))


# --- directional coefficients -------------------------------------------------------------------

@pytest.mark.parametrize("entry,exit_", [(0.0, math.pi), (math.radians(126.9), math.pi), (0.0, 1.1), (0.4, 2.0)])
def test_directional_brackets_are_integrals_of_the_instantaneous_coefficients(entry, exit_):
    """Each bracket equals ∫ a_ij(φ) dφ over the cut, with Altintas' instantaneous coefficients
    a_xx = −sin2φ − Kr(1 − cos2φ), a_xy = −(1 + cos2φ) − Kr sin2φ,
    a_yx = (1 − cos2φ) − Kr sin2φ, a_yy = sin2φ − Kr(1 + cos2φ)."""
    kr = 0.3
    inst = {
        (0, 0): lambda p: -math.sin(2 * p) - kr * (1 - math.cos(2 * p)),
        (0, 1): lambda p: -(1 + math.cos(2 * p)) - kr * math.sin(2 * p),
        (1, 0): lambda p: (1 - math.cos(2 * p)) - kr * math.sin(2 * p),
        (1, 1): lambda p: math.sin(2 * p) - kr * (1 + math.cos(2 * p)),
    }
    alpha = zoa.directional_matrix(Cutting(2, 6e8, kr, entry, exit_))
    for (i, j), fun in inst.items():
        assert alpha[i, j] == pytest.approx(quad(fun, entry, exit_, epsabs=1e-13)[0], abs=1e-12)


def test_slotting_directional_matrix_closed_form():
    kr = 0.404
    alpha = zoa.directional_matrix(Cutting(2, 6e8, kr))
    np.testing.assert_allclose(alpha, math.pi * np.array([[-kr, -1.0], [1.0, -kr]]), atol=1e-14)


# --- closed forms ---------------------------------------------------------------------------------

def test_one_dof_slotting_minimum_matches_closed_form():
    """x-only slotting: ν = α_xx G = −πKr G, so b(ω) = −2/(N Kt Kr Re G). For one mode
    Re G = (1 − r²)/(k((1 − r²)² + (2ζr)²)) has its minimum −1/(4kζ(1 + ζ)) at r² = 1 + 2ζ, hence
    b_min = 8kζ(1 + ζ)/(N Kt Kr). The envelope touches b_min at the lobe bottoms, the speeds
    Ω_k = 60ω*/(N(ε* + 2kπ)) with ω* = ωn√(1 + 2ζ) and ε* = π + 2 arg ν(ω*)."""
    fn, k, zeta = 903.0, 12.53e6, 0.03
    cut = Cutting(2, 556.31e6, 0.404)
    s = Structure(x=(Mode(fn, k, zeta),))
    r = math.sqrt(1 + 2 * zeta)
    g = 1 / (k * complex(1 - r * r, 2 * zeta * r))
    nu = -math.pi * cut.kr * g
    eps = math.pi + 2 * math.atan2(nu.imag, nu.real)
    speeds = [lobe_speed(cut, fn * r, eps, kk) for kk in range(2, 14)]
    env = zoa.envelope(s, cut, speeds)
    b_min = 8 * k * zeta * (1 + zeta) / (cut.teeth * cut.kt * cut.kr)
    np.testing.assert_allclose(env.depth, b_min, rtol=1e-9)
    # and nowhere on a fine scan is the envelope below it
    scan = zoa.envelope(s, cut, np.linspace(2000, 12000, 3001))
    assert scan.depth.min() >= b_min * (1 - 1e-9)
    assert scan.depth.min() <= b_min * (1 + 1e-3)


def test_symmetric_slotting_minimum_from_eigenvalues_of_alpha():
    """Symmetric single mode, slotting: [G] = G·I, so the roots are ν = λ G with λ the eigenvalues
    π(−Kr ± i) of [α]. With G = G_R + iG_I (G_I < 0): Re ν = π(−Kr G_R ∓ G_I); the branch
    Re ν = π(−Kr G_R − G_I) is the larger, and b(ω) = 2π/(N Kt Re ν) = 2/(N Kt (−Kr G_R − G_I)).
    The envelope minimum is therefore 2/(N Kt max_ω(−Kr G_R − G_I)), reached at the lobe bottoms.
    The maximum over r = ω/ωn is found here numerically (bounded scalar minimisation)."""
    (s, cut), fn, k, zeta = EX1, 903.0, 12.53e6, 0.03
    lam = np.linalg.eigvals(zoa.directional_matrix(cut))
    np.testing.assert_allclose(sorted(lam.imag), [-math.pi, math.pi], rtol=1e-12)
    np.testing.assert_allclose(lam.real, -math.pi * cut.kr, rtol=1e-12)

    def neg_re_nu(r):
        g = 1 / (k * complex(1 - r * r, 2 * zeta * r))
        return -(-cut.kr * g.real - g.imag)

    opt = minimize_scalar(neg_re_nu, bounds=(0.9, 1.1), method="bounded", options={"xatol": 1e-12})
    b_min = 2 / (cut.teeth * cut.kt * -opt.fun)
    r = opt.x
    g = 1 / (k * complex(1 - r * r, 2 * zeta * r))
    nu = math.pi * complex(-cut.kr, 1) * g  # λ = π(−Kr + i) gives Re ν = π(−Kr G_R − G_I)
    assert nu.real > 0
    eps = math.pi + 2 * math.atan2(nu.imag, nu.real)
    speeds = [lobe_speed(cut, fn * r, eps, kk) for kk in range(2, 14)]
    np.testing.assert_allclose(zoa.envelope(s, cut, speeds).depth, b_min, rtol=1e-8)
    # the field notes' small-ζ approximation 8kζ/(N Kt (1 + √(1 + Kr²)))
    approx = 8 * k * zeta / (cut.teeth * cut.kt * (1 + math.sqrt(1 + cut.kr**2)))
    assert b_min == pytest.approx(approx, rel=0.03)


# --- scaling laws and symmetry --------------------------------------------------------------------

def test_scaling_stiffness_scales_depth():
    s, cut = FOUR_FLUTE
    rpm = np.linspace(5000, 7000, 101)
    base = zoa.envelope(s, cut, rpm).depth
    c = 3.7
    scaled = Structure(x=tuple(Mode(m.fn, m.k * c, m.zeta) for m in s.x),
                       y=tuple(Mode(m.fn, m.k * c, m.zeta) for m in s.y))
    np.testing.assert_allclose(zoa.envelope(scaled, cut, rpm).depth, base * c, rtol=1e-9)


def test_scaling_kt_divides_depth():
    s, cut = EX3
    rpm = np.linspace(2000, 12000, 101)
    base = zoa.envelope(s, cut, rpm).depth
    np.testing.assert_allclose(zoa.envelope(s, cut.scaled_kt(2.5), rpm).depth, base / 2.5, rtol=1e-9)


def test_swapping_x_and_y_in_slotting_leaves_the_sld_unchanged():
    s = Structure(x=(Mode(900.0, 9e6, 0.02), Mode(1400, 30e6, 0.03)), y=(Mode(950.0, 10e6, 0.01),))
    cut = Cutting(3, 800e6, 0.3)
    rpm = np.linspace(2000, 12000, 201)
    np.testing.assert_allclose(zoa.envelope(s.swapped(), cut, rpm).depth, zoa.envelope(s, cut, rpm).depth, rtol=1e-8)


def test_swapping_x_and_y_changes_a_partial_immersion_sld():
    """Control for the test above: outside slotting [α] is not antisymmetric-plus-diagonal, so the
    swap must change the result (otherwise the swap test could pass vacuously)."""
    s, cut = EX3
    rpm = np.linspace(2000, 12000, 101)
    a, b = zoa.envelope(s, cut, rpm).depth, zoa.envelope(s.swapped(), cut, rpm).depth
    assert np.max(np.abs(a / b - 1)) > 0.01


# --- brute-force reference --------------------------------------------------------------------------

def cusp_speeds(s, cut, lo, hi, n=400):
    """Speeds where the limiting lobe changes, located by bisection on the lobe number to 1e-10."""
    rpm = np.linspace(lo, hi, n)
    lobe = zoa.envelope(s, cut, rpm).lobe
    out = []
    for i in np.nonzero(np.diff(lobe) != 0)[0][:6]:
        a, b = rpm[i], rpm[i + 1]
        la = lobe[i]
        for _ in range(50):
            m = 0.5 * (a + b)
            if zoa.envelope(s, cut, [m]).lobe[0] == la:
                a = m
            else:
                b = m
        out.append(0.5 * (a + b))
    return out


@pytest.mark.parametrize("name,case,lo,hi", [
    ("ex1", EX1, 2000, 12000),
    ("ex2", EX2, 2000, 12000),
    ("ex3", EX3, 2000, 12000),
    ("four-flute two modes per direction", FOUR_FLUTE, 5000, 7000),
])
@pytest.mark.slow
def test_envelope_matches_brute_force_including_cusps(name, case, lo, hi):
    s, cut = case
    cusps = cusp_speeds(s, cut, lo, hi)
    assert len(cusps) >= 2, "the range should contain lobe crossings"
    rpm = np.concatenate([np.linspace(lo, hi, 17), cusps])
    ref, ref_f = reference_envelope(s, cut, rpm)
    env = zoa.envelope(s, cut, rpm)
    np.testing.assert_allclose(env.depth, ref, rtol=1e-6)
    np.testing.assert_allclose(env.chatter_hz[:17], ref_f[:17], rtol=1e-6)


#: x/y modes 4.5 % apart, different damping, 5 % up milling: the discriminant of the 2×2 problem
#: crosses the principal square root's branch cut near resonance (found by a random search).
FLIP = (Structure(x=(Mode(1000.0, 15.4e6, 0.018),), y=(Mode(1045.0, 9.4e6, 0.034),)),
        Cutting.from_immersion(3, 1000e6, 0.25, 0.05, "up"))


@pytest.mark.slow
def test_asymmetric_branches_match_brute_force():
    """Where the principal square root flips, labels must not swap (no false crossings)."""
    s, cut = FLIP
    rpm = np.concatenate([np.linspace(3000, 15000, 15), cusp_speeds(s, cut, 3000, 15000)])
    ref, _ = reference_envelope(s, cut, rpm)
    np.testing.assert_allclose(zoa.envelope(s, cut, rpm).depth, ref, rtol=1e-6)


def test_branches_are_continuous_where_principal_root_flips():
    """The tracked roots move smoothly along ω, while the principal square root jumps."""
    s, cut = FLIP
    f = np.linspace(700, 1400, 20001)
    g = zoa.structure_receptance(s, f)
    a = _zoa_kernel.directional_brackets(cut.kr, cut.entry, cut.exit)
    nu = _zoa_kernel._branches(a, g[:, 0, 0].copy(), g[:, 0, 1].copy(), g[:, 1, 0].copy(), g[:, 1, 1].copy())
    scale = np.abs(nu).max()
    tracked_jump = np.abs(np.diff(nu, axis=1)).max() / scale
    m = np.einsum("ij,fjk->fik", zoa.directional_matrix(cut), g)
    tr, det = m[:, 0, 0] + m[:, 1, 1], m[:, 0, 0] * m[:, 1, 1] - m[:, 0, 1] * m[:, 1, 0]
    principal = 0.5 * (tr + np.sqrt(tr * tr - 4 * det))
    principal_jump = np.abs(np.diff(principal)).max() / scale
    assert principal_jump > 50 * tracked_jump


@pytest.mark.slow
def test_cross_frf_matrix_matches_brute_force():
    """A structure whose principal axes are rotated 30° from x/y has cross receptances
    G = R diag(g1, g2) Rᵀ; given as a measured FRF with xy and yx terms the engine must use the full
    2×2 matrix (the reference interpolates the same table)."""
    f = np.linspace(400, 4000, 20001)
    g1 = zoa.structure_receptance(Structure(x=(Mode(900, 9e6, 0.02),)), f)[:, 0, 0]
    g2 = zoa.structure_receptance(Structure(x=(Mode(1000, 12e6, 0.03),)), f)[:, 0, 0]
    c, sn = math.cos(math.radians(30)), math.sin(math.radians(30))
    gxx, gyy, gxy = c * c * g1 + sn * sn * g2, sn * sn * g1 + c * c * g2, c * sn * (g1 - g2)
    s = Structure(frf=MeasuredFRF(f, gxx, gyy, gxy, gxy))
    cut = Cutting.from_immersion(3, 900e6, 0.3, 0.5, "down")
    rpm = np.linspace(3000, 12000, 13)
    ref, _ = reference_envelope(s, cut, rpm)
    env = zoa.envelope(s, cut, rpm)
    np.testing.assert_allclose(env.depth, ref, rtol=1e-5)
    diag_only = zoa.envelope(Structure(frf=MeasuredFRF(f, gxx, gyy)), cut, rpm)
    assert np.max(np.abs(diag_only.depth / env.depth - 1)) > 0.02  # the cross terms matter


def test_measured_frf_built_from_modes_reproduces_modal_result():
    s, cut = EX3
    f = np.linspace(90, 4000, 40001)
    measured = Structure(frf=measured_from_structure(s, f))
    rpm = np.linspace(2000, 12000, 81)
    np.testing.assert_allclose(zoa.envelope(measured, cut, rpm).depth, zoa.envelope(s, cut, rpm).depth, rtol=2e-4)


# --- batch form -------------------------------------------------------------------------------------

def test_batch_matches_single_structures_and_chunking_and_speed_order():
    s, cut = EX3
    par = Parameterization(s)
    rng = np.random.default_rng(1)
    theta = par.theta0 * rng.uniform(0.8, 1.2, (7, par.size))
    rpm = rng.permutation(np.linspace(2000, 12000, 50))
    batch = par.batch(theta)
    depth = zoa.envelope_batch(batch, cut, rpm, chunk=3)
    assert depth.shape == (7, 50)
    for i in range(7):
        np.testing.assert_allclose(depth[i], zoa.envelope(batch.structure(i), cut, rpm).depth, rtol=1e-12)


@pytest.mark.slow
def test_random_structures_match_brute_force():
    """Held-out style: random fn, k, ζ, immersion and teeth; a few speeds each against the reference."""
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(6):
        fn = rng.uniform(300, 5000, 2)
        k = rng.uniform(2e6, 50e6, 2)
        z = rng.uniform(0.005, 0.08, 2)
        s = Structure(x=(Mode(fn[0], k[0], z[0]),), y=(Mode(fn[1], k[1], z[1]),))
        cut = Cutting.from_immersion(int(rng.integers(2, 7)), rng.uniform(5e8, 2.5e9), rng.uniform(0.1, 0.6),
                                     rng.uniform(0.05, 1.0), str(rng.choice(["up", "down"])))
        f_top = fn.max()
        rpm = np.sort(rng.uniform(0.2, 2.0, 6) * 60 * f_top / cut.teeth)
        ref, _ = reference_envelope(s, cut, rpm)
        env = zoa.envelope(s, cut, rpm).depth
        worst = max(worst, np.max(np.abs(env / ref - 1)))
    assert worst < 1e-6


def test_repeated_speeds_give_the_single_speed_result():
    """Three or more equal speeds once crashed the kernel (taken as evenly spaced with step 0):
    every copy must equal the depth computed alone, for modal sets, a measured FRF and duplicates
    mixed with other speeds."""
    s, cut = EX3
    batch = Parameterization(s).batch(Parameterization(s).theta0[None, :])
    measured = Structure(frf=measured_from_structure(s, np.linspace(90, 4000, 4001)))
    for rpm in ([9000.0] * 3, [9000.0] * 5, [5000.0, 5000.0, 5000.0, 6000.0], [6000.0, 5000.0, 5000.0, 5000.0]):
        alone = {r: (zoa.envelope_batch(batch, cut, [r])[0, 0], zoa.envelope(measured, cut, [r]).depth[0])
                 for r in set(rpm)}
        modal = zoa.envelope_batch(batch, cut, rpm)[0]
        frf = zoa.envelope(measured, cut, rpm).depth
        np.testing.assert_array_equal(modal, [alone[r][0] for r in rpm])
        np.testing.assert_array_equal(frf, [alone[r][1] for r in rpm])
        assert np.all(np.isfinite(modal)) and np.all(np.isfinite(frf))
    ref = reference_depth(s, cut, 9000.0)[0]
    np.testing.assert_allclose(zoa.envelope_batch(batch, cut, [9000.0] * 3)[0], ref, rtol=1e-6)


def test_one_dof_has_rigid_direction_and_depth_is_finite():
    s = Structure(x=(Mode(922.0, 1.3400496e6, 0.011),))
    env = zoa.envelope(s, Cutting.from_immersion(2, 6e8, 1 / 3, 1.0), np.linspace(5000, 25000, 11))
    assert np.all(np.isfinite(env.depth)) and np.all(env.depth > 0)
    ref = [reference_depth(s, Cutting.from_immersion(2, 6e8, 1 / 3, 1.0), r)[0] for r in (5000, 15000)]
    np.testing.assert_allclose(env.depth[[0, 5]], ref, rtol=1e-6)


def test_batch_rejects_invalid_sets_before_work():
    with pytest.raises(Exception, match=r"zeta_x \(set 1, mode 0\)"):
        ModalBatch(fn_x=[[900.0], [900.0]], k_x=[[1e7], [1e7]], zeta_x=[[0.02], [1.2]],
                   fn_y=np.zeros((2, 0)), k_y=np.zeros((2, 0)), zeta_y=np.zeros((2, 0)))


def test_bad_speeds_are_rejected():
    s, cut = EX1
    for bad in ([1000, -5], [np.nan], []):
        with pytest.raises(Exception, match="rpm"):
            zoa.envelope(s, cut, bad)


def test_lobes_for_plotting_touch_the_envelope():
    s, cut = EX1
    lobes = zoa.lobes(s, cut, 2000, 12000)
    assert len(lobes) >= 8
    touching = 0
    # the envelope is the lower envelope of the lobes: every lobe lies on or above it, and touches it
    for lb in lobes:
        ok = np.isfinite(lb.rpm) & (lb.rpm > 2000) & (lb.rpm < 12000)
        env = zoa.envelope(s, cut, lb.rpm[ok][::7]).depth
        assert np.all(lb.depth[ok][::7] >= env * (1 - 1e-6))
        touching += np.any(lb.depth[ok][::7] <= env * (1 + 1e-3))
    assert touching >= 8


def test_grid_frequencies_equal_the_sorted_union():
    """The per-set grid merges the base and every mode's cluster (already ascending runs); it must be the
    sorted union of them, clipped to [w_lo, w_hi], with near-duplicates dropped, as a plain sort gives."""
    rng = np.random.default_rng(3)
    offsets = _zoa_kernel.cluster_offsets()
    for case in range(30):
        n_modes = int(rng.integers(1, 6))
        wn = 2 * math.pi * rng.uniform(200, 5000, n_modes)
        z = rng.uniform(0.005, 0.3, n_modes)  # large ζ: the cluster's low end is clipped at 0.05 ωn
        if case % 5 == 0:
            wn[1:] = wn[0]  # coincident modes: duplicated points
        off = offsets if case % 7 else rng.permutation(offsets)
        w_lo, w_hi, n_base = 0.1 * wn.min(), 4.0 * wn.max(), 160
        grid = _zoa_kernel._grid_frequencies(wn, z, w_lo, w_hi, n_base, off)
        ratio = math.log(w_hi / w_lo) / (n_base - 1)
        pts = np.concatenate([[w_lo * math.exp(ratio * i) for i in range(n_base)]]
                             + [m * np.maximum(1.0 + zz * off, 0.05) for m, zz in zip(wn, z)])
        pts = np.sort(pts[(pts >= w_lo) & (pts <= w_hi)])
        keep = [pts[0]]
        for x in pts[1:]:
            if x - keep[-1] > 1e-12 * x:
                keep.append(x)
        np.testing.assert_array_equal(grid, keep)


def test_measured_frf_in_one_direction_alone():
    """A measured FRF with xx alone (a tool much stiffer across the feed) crashed with ZeroDivisionError: the
    empty direction's root ν ≡ 0 put its Re ν = 0 edges twice into the frequency grid. It now gives the
    limits of the modal structure with that one x mode (the grid's linear interpolation aside)."""
    from millstab.datasets import load_example
    from millstab.frf import modal_receptance
    from millstab.model import MeasuredFRF, Mode, Structure

    cut = load_example("ex3").cutting
    f = np.arange(100.0, 3000.0, 0.25)
    g = np.asarray(modal_receptance(f, [900.0], [2e7], [0.03])).reshape(-1)
    rpm = np.linspace(4000.0, 12000.0, 9)
    measured = zoa.envelope(Structure(frf=MeasuredFRF(f, g, None)), cut, rpm).depth_mm
    modal = zoa.envelope(Structure(x=(Mode(900.0, 2e7, 0.03),), y=()), cut, rpm).depth_mm
    np.testing.assert_allclose(measured, modal, rtol=1e-4)
