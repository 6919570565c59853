"""The tool tip by receptance coupling: the Timoshenko beam against closed forms and the exact continuous
solution, the coupling against the full assembly, and the holder's rotational terms recovered from
measurements on synthetic holders whose terms are known.

References: ``reference_timoshenko`` (the exact transfer-matrix solution of the Timoshenko equations, no
shared code with the FE); closed forms of the Euler–Bernoulli cantilever, f1 = 1.8751²/(2πL²)·√(EI/ρA) and
k = 3EI/L³ (REFERENCES.md, "Receptance coupling").
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import reference_timoshenko as rt
from millstab.tooltip import (MATERIALS, Beam, MeasuredHolder, RigidHolder, Section, Tool, artifact_beam, couple,
                              from_artifact, from_finite_differences, peaks, tip_grid, tip_receptance)
from millstab.tooltip.holder import artifact_points

CARBIDE, STEEL = MATERIALS["carbide"], MATERIALS["steel"]


def _eb(L, D, mat):
    I, A = math.pi / 64 * D**4, math.pi / 4 * D**2
    f1 = 1.8751**2 / (2 * math.pi * L**2) * math.sqrt(mat.E * I / (mat.density * A))
    return f1, 3 * mat.E * I / L**3


def _ref(L, D, mat):
    return rt.section(L, D, mat.E, mat.density, mat.nu)


@pytest.mark.parametrize("L, D", [(0.3, 0.01), (0.2, 0.006)])
def test_slender_cantilever_matches_euler_bernoulli_closed_forms(L, D):
    """Rigid holder, L/D ≥ 30: the tip FRF's first peak within 1 % of f1 and its static receptance within 2 %
    of L³/3EI (the Timoshenko corrections there are ~0.06 % and ~0.1 %)."""
    tool = Tool(D, L, CARBIDE, zeta=0.005)
    f, g = tip_grid(tool, RigidHolder())
    f1, k = _eb(L, D, CARBIDE)
    fn, _ = peaks(f, g)
    assert fn[0] == pytest.approx(f1, rel=0.01)
    static = tip_receptance(tool, RigidHolder(), np.array([f1 * 1e-4]))[0]
    assert abs(static) == pytest.approx(1 / k, rel=0.02)
    assert abs(static.imag / static.real) == pytest.approx(2 * 0.005, rel=1e-6)  # η = 2ζ off resonance


def test_stubby_cantilever_is_timoshenko_not_euler_bernoulli():
    """A 2-D carbide stub: the FE's first three frequencies within 1e-4 of the exact Timoshenko roots, and
    f1 about 11 % below Euler–Bernoulli (shear and rotary inertia), static tip receptance exact."""
    L, D = 0.024, 0.012
    beam = Tool(D, L, CARBIDE).beam()
    lam, _ = beam.modes(clamped=True)
    f_fe = np.sqrt(lam[:3]) / (2 * math.pi)
    f_ex = rt.clamped_frequencies([_ref(L, D, CARBIDE)], 100.0, 1.05 * f_fe[2])
    np.testing.assert_allclose(f_fe, f_ex[:3], rtol=1e-3)
    assert f_fe[0] == pytest.approx(f_ex[0], rel=2e-5)
    f1_eb, k_eb = _eb(L, D, CARBIDE)
    assert 0.85 < f_fe[0] / f1_eb < 0.93
    fs = np.array([1.0])
    g = tip_receptance(Tool(D, L, CARBIDE), RigidHolder(), fs)
    assert g[0].real == pytest.approx(rt.clamped_tip([_ref(L, D, CARBIDE)], fs)[0, 0, 0].real, rel=1e-9)
    assert g[0].real > 1.1 / k_eb  # shear adds >10 % compliance at 2 D
    # the rigid holder as R33 = 0 in the coupling formula: the clamped tool again
    fs = np.array([500.0, 20000.0, 90000.0])
    beam = Tool(D, L, CARBIDE, zeta=0.01).beam()
    np.testing.assert_allclose(couple(beam.end_receptances(fs), None)[:, 0, 0],
                               tip_receptance(Tool(D, L, CARBIDE, zeta=0.01), RigidHolder(), fs), rtol=1e-6)


def test_element_count_converges():
    """Doubling the elements cuts the frequency error about 4× (second order), from 1e-3 to < 1e-5."""
    L, D = 0.045, 0.012
    exact = rt.clamped_frequencies([_ref(L, D, CARBIDE)], 100.0, 60000.0)[:2]
    errs = []
    for n in (6, 12, 24, 48):
        lam, _ = Beam((Section(L, D, CARBIDE),), elements=n).modes(clamped=True)
        errs.append(np.abs(np.sqrt(lam[:2]) / (2 * math.pi) / exact - 1))
    errs = np.array(errs)
    assert np.all(errs[1:] < errs[:-1])
    assert np.all(errs[:-1] / errs[1:] > 3.0)
    assert errs[-1, 0] < 5e-6


def test_stepped_tool_matches_exact_stepped_beam():
    """Shank + fluted part (0.8 D): tip receptance within 0.5 % of the exact stepped solution off resonance."""
    tool = Tool(0.012, 0.06, CARBIDE, fluted_length=0.03, zeta=0.01)
    fs = np.array([200.0, 1000.0, 5000.0])
    g = tip_receptance(tool, RigidHolder(), fs)
    ref = rt.clamped_tip([_ref(0.03, 0.012, CARBIDE), _ref(0.03, 0.0096, CARBIDE)], fs, eta=0.02)[:, 0, 0]
    np.testing.assert_allclose(g, ref, rtol=5e-3)


def _holder_exact(Lh, Dh, f, eta):
    return rt.clamped_tip([_ref(Lh, Dh, STEEL)], f, eta)  # [[H, L], [N, P]] at the holder's free face


@pytest.mark.parametrize("ratio", [3, 5, 7, 10])
def test_coupled_tip_matches_full_assembly(ratio):
    """A steel holder (25 mm × 70 mm, clamped at the spindle) and a carbide tool of 12 mm at 3–10 D: the
    tool coupled by RCSA to the holder's exact face receptances against the exact assembly beam — every
    natural frequency below 8 kHz within 2 % (measured ≤ 4e-4) and every peak receptance within 5 % (measured
    ≤ 1e-4)."""
    D, Dh, Lh, eta = 0.012, 0.025, 0.07, 0.02
    L = ratio * D
    tool = Tool(D, L, CARBIDE, zeta=eta / 2)
    assembly = [_ref(Lh, Dh, STEEL), _ref(L, D, CARBIDE)]
    roots = rt.clamped_frequencies(assembly, 50.0, 8000.0, n=800)
    assert roots.size >= 1
    for fr in roots:
        f = fr * (1 + np.linspace(-0.03, 0.03, 601))
        g = couple(tool.beam().end_receptances(f), _holder_exact(Lh, Dh, f, eta))[:, 0, 0]
        ga = rt.clamped_tip(assembly, f, eta)[:, 0, 0]
        fn, amp = peaks(f, g, 1)
        fa, amp_a = peaks(f, ga, 1)
        assert fn[0] == pytest.approx(fr, rel=0.02)
        assert fn[0] == pytest.approx(fa[0], rel=1e-3)
        assert amp[0] == pytest.approx(amp_a[0], rel=0.05)


def test_coupling_with_fe_holder_equals_fe_assembly():
    """Both substructures by FE with the same mesh lines and η: RCSA reproduces the one-beam FE model of the
    assembly to round-off (the coupling algebra and the sign of L, N are right)."""
    D, Dh, Lh, L, eta = 0.012, 0.025, 0.07, 0.05, 0.02
    holder = Beam((Section(Lh, Dh, STEEL),), eta=eta, elements=14)
    tool = Beam((Section(L, D, CARBIDE),), eta=eta, elements=10)
    assembly = Beam((Section(Lh, Dh, STEEL), Section(L, D, CARBIDE)), eta=eta, elements=24)
    assert [len(b.mesh()[1]) for b in (holder, tool, assembly)] == [14, 10, 24]
    f = np.geomspace(20.0, 20000.0, 400)
    r33 = holder.receptance(f, [28, 29], clamped=True)
    g = couple(tool.end_receptances(f), r33)[:, 0, 0]
    ga = assembly.receptance(f, [48], clamped=True)[:, 0, 0]
    np.testing.assert_allclose(g, ga, rtol=1e-7)
    # a flipped rotation sign (L, N negated) is a different structure: the test can fail
    flipped = r33 * np.array([[1, -1], [-1, 1]])
    assert np.max(np.abs(couple(tool.end_receptances(f), flipped)[:, 0, 0] / ga - 1)) > 0.05


def test_tip_grid_through_a_measured_holder_matches_assembly():
    """The public path: holder face receptances as a measured table (1 Hz steps), coupled on tip_grid; peak
    frequencies and receptances of the tip as for the exact assembly (2 %, 5 %)."""
    D, Dh, Lh, L, eta = 0.012, 0.025, 0.07, 0.06, 0.02
    f_meas = np.arange(20.0, 8001.0, 1.0)
    r = _holder_exact(Lh, Dh, f_meas, eta)
    holder = MeasuredHolder(f_meas, r[:, 0, 0], r[:, 0, 1], r[:, 1, 0], r[:, 1, 1])
    f, g = tip_grid(Tool(D, L, CARBIDE, zeta=eta / 2), holder)
    fn, amp = peaks(f, g, 2)
    ga = rt.clamped_tip([_ref(Lh, Dh, STEEL), _ref(L, D, CARBIDE)], f, eta)[:, 0, 0]
    fa, amp_a = peaks(f, ga, 2)
    ok = np.isfinite(fa)
    assert ok.sum() >= 1
    np.testing.assert_allclose(fn[ok], fa[ok], rtol=0.02)
    np.testing.assert_allclose(amp[ok], amp_a[ok], rtol=0.05)


def test_artifact_test_recovers_known_holder_rotations():
    """Synthetic holder (a steel beam, exact face receptances known) with a 16 mm × 80 mm steel artifact;
    the artifact test's three FRFs from the exact assembly beam; the inverse RCSA recovers H, L = N and P
    within 1 % away from the assembly's resonances (the recovered terms are what the holder really has,
    including the rotational ones no hammer measures)."""
    Dh, Lh, eta = 0.025, 0.07, 0.02
    Da, La, off = 0.016, 0.08, 0.02
    f = np.linspace(100.0, 6000.0, 120)
    secs_before = [_ref(Lh, Dh, STEEL), _ref(La - off, Da, STEEL)]
    tip = rt.clamped_tip(secs_before + [_ref(off, Da, STEEL)], f, eta)[:, 0, 0]
    at_s = rt.clamped_point_force(secs_before, [_ref(off, Da, STEEL)], f, eta)  # force at s: (w_s, w_tip)
    art = artifact_beam(Da, La, off, STEEL, elements=80)
    art = Beam(art.sections, eta=eta, elements=art.elements)
    rec = from_artifact(f, tip, at_s[:, 1], at_s[:, 0], art, off)
    known = _holder_exact(Lh, Dh, f, eta)
    got = rec.receptance(f)
    for (i, j) in ((0, 0), (0, 1), (1, 0), (1, 1)):
        rel = np.abs(got[:, i, j] / known[:, i, j] - 1)
        assert np.median(rel) < 1e-3, (i, j)
        assert np.quantile(rel, 0.9) < 1e-2, (i, j)
    # and the recovered holder predicts another tool's tip as the assembly does
    tool = Tool(0.012, 0.05, STEEL, zeta=eta / 2)
    g = tip_receptance(tool, rec, f)
    ga = rt.clamped_tip([_ref(Lh, Dh, STEEL), _ref(0.05, 0.012, STEEL)], f, eta)[:, 0, 0]
    assert np.median(np.abs(g / ga - 1)) < 1e-3


def test_artifact_inversion_is_the_inverse_of_coupling():
    """Measurements made by the forward coupling with the same artifact model: recovery to round-off."""
    f = np.geomspace(50.0, 10000.0, 200)
    art = artifact_beam(0.016, 0.08, 0.02, STEEL)
    art = Beam(art.sections, eta=0.01, elements=art.elements)
    known = _holder_exact(0.07, 0.025, f, 0.02)
    R = art.receptance(f, artifact_points(art, 0.02))
    X = np.linalg.inv(R[:, :2, :2] + known)
    a = R[:, 2:, :2]  # rows: tip, offset point
    G = R[:, 2:, 2:] - a @ X @ np.swapaxes(a, 1, 2)
    rec = from_artifact(f, G[:, 0, 0], G[:, 0, 1], G[:, 1, 1], art, 0.02)
    np.testing.assert_allclose(rec.receptance(f), known, rtol=1e-6)


def _fd_errors(order, spacings, shear):
    """Max relative errors of N and P from finite differences on a synthetic FE holder (steel, 25 × 70 mm,
    clamped at the spindle; the face terms known from the same model), per spacing."""
    Dh, Lh = 0.025, 0.07
    f = np.array([200.0, 400.0, 600.0, 800.0])
    errs = []
    for s in spacings:
        n_pts = order + 1
        secs = (Section(Lh - n_pts * s, Dh, STEEL),) + tuple(Section(s, Dh, STEEL) for _ in range(n_pts))
        beam = Beam(secs, elements=60)
        nodes = [beam.node(Lh - i * s) for i in range(n_pts)]
        face = 2 * nodes[0]
        exact = beam.receptance(f, [face, face + 1], clamped=True)
        H = beam.receptance(f, [2 * k for k in nodes], clamped=True)
        ks = secs[0].shear_stiffness if shear else None
        rec = from_finite_differences(f, H, s, order, shear_stiffness=ks).receptance(f)
        errs.append([np.max(np.abs(rec[:, i, j] / exact[:, i, j] - 1)) for i, j in ((1, 0), (0, 1), (1, 1))])
    return np.array(errs)


@pytest.mark.parametrize("order, rate", [(1, 2.0), (2, 4.0)])
def test_finite_differences_converge_to_known_rotations(order, rate):
    """With the holder's shear stiffness, the FD rotational terms converge to the known ones: N and L as
    s^order, P as s with either stencil (its two-sided product of one-sided stencils is first order)."""
    errs = _fd_errors(order, (0.004, 0.002), shear=True)
    assert np.all(errs[0, :2] / errs[1, :2] > 0.8 * rate)
    assert errs[0, 2] / errs[1, 2] > 1.6
    assert np.all(errs[1] < (0.05 if order == 1 else 0.01))


def test_finite_differences_without_shear_correction_fail_on_a_thick_holder():
    """Without it, differences of w measure dw/dz, not the section rotation: N is off by 1/κGA (≈ 4 % here)
    whatever the spacing, and P's error grows as the spacing shrinks (≈ 1/(s κGA))."""
    errs = _fd_errors(1, (0.004, 0.002), shear=False)
    assert np.all(errs[:, 0] > 0.03)
    assert errs[1, 2] > 1.5 * errs[0, 2] > 0.3


def test_a_holder_measured_below_the_tools_mode_warns():
    from millstab.errors import FRFWarning

    f = np.linspace(10.0, 2000.0, 200)
    r = _holder_exact(0.07, 0.025, f, 0.02)
    holder = MeasuredHolder(f, r[:, 0, 0], r[:, 0, 1], r[:, 1, 0], r[:, 1, 1])
    with pytest.warns(FRFWarning, match="reach only 2000 Hz"):
        tip_grid(Tool(0.012, 0.036, CARBIDE, zeta=0.01), holder)


def test_a_noisy_measured_holder_refines_real_resonances_only():
    """0.5 % noise on the holder's terms makes local maxima everywhere in |G|; only the prominent ones are
    refined and reported, so the grid stays small and the first mode is the noise-free one."""
    f = np.arange(20.0, 9001.0, 2.0)
    r = _holder_exact(0.07, 0.025, f, 0.02)
    rng = np.random.default_rng(3)
    noisy = r * (1 + 0.005 * (rng.standard_normal(r.shape) + 1j * rng.standard_normal(r.shape)))
    tool = Tool(0.012, 0.06, CARBIDE, zeta=0.01)
    fc, gc = tip_grid(tool, MeasuredHolder(f, r[:, 0, 0], r[:, 0, 1], r[:, 1, 0], r[:, 1, 1]))
    fn, gn = tip_grid(tool, MeasuredHolder(f, noisy[:, 0, 0], noisy[:, 0, 1], noisy[:, 1, 0], noisy[:, 1, 1]))
    assert fn.size < 1.5 * fc.size
    clean, noise = peaks(fc, gc, 2)[0], peaks(fn, gn, 2)[0]
    np.testing.assert_allclose(noise, clean, rtol=0.01)
