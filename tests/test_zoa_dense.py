"""Dense speed grids: the zero-order envelope must not skip a lobe tip (issue 10, item 1).

Along the chatter frequency ω a lobe k sits at the tooth period T_k(ω) = (ε(ω) + 2kπ)/ω. Where
T_k turns back (a narrow tip, or a fold) a speed just inside the tip has two roots of
H(ω) = ωT − ε(ω) − 2kπ close together; when both fall inside one segment of the engine's frequency
grid (or of a measured table) H shows no sign change there and the tip was skipped, reporting a
depth that is too high (unsafe). Every check here compares ``zoa.envelope`` at every speed with the
vectorised brute-force reference of tests/reference_zoa.py (a uniform scan 50 points per damping
width, refined by bisection, roots identified with numpy.linalg.eigvals), to 1e-6 relative.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from millstab.frf import measured_from_structure
from millstab.model import Cutting, Mode, Structure
from millstab.stability import zoa
from reference_zoa import lobe_tips, reference_envelope_dense

#: issue 10's example: +45 % near 8 231 rpm (the k = 1 lobe's tip at ~442 Hz turns back inside one
#: segment of the per-set grid)
ISSUE = (Structure(x=(Mode(369.85, 5.4002e6, 0.0316),), y=(Mode(411.21, 6.6756e6, 0.0168),)),
         Cutting.from_immersion(2, 1319.4e6, 0.6, 0.5, "down"))


def worst_error(s: Structure, cut: Cutting, rpm: np.ndarray) -> tuple[float, float]:
    """Largest relative depth error against the reference, and the speed [rpm] where it occurs."""
    got = zoa.envelope(s, cut, rpm).depth
    finite = got[np.isfinite(got)]
    # the cap only prunes frequencies whose depth must exceed every depth the engine reports: a root
    # the engine missed below its own answer is still found
    ref, _ = reference_envelope_dense(s, cut, rpm, depth_cap=1.01 * finite.max() if finite.size else None)
    assert np.array_equal(np.isinf(got), np.isinf(ref)), "a boundary found by only one of the two"
    rel = np.where(np.isinf(ref), 0.0, np.abs(got / np.where(np.isinf(ref), 1.0, ref) - 1))
    j = int(np.argmax(rel))
    return float(rel[j]), float(rpm[j])


def test_issue_case_tip_near_8231_rpm():
    s, cut = ISSUE
    rpm = np.arange(8200.0, 8300.0, 0.5)
    err, where = worst_error(s, cut, rpm)
    assert err < 1e-6, f"{err:.3g} at {where} rpm"
    # the tip is there and matters: an independent scan finds a lobe turning back at ~8 231.5 rpm,
    # and inside it the limiting depth is ~30 % below the depth just beyond it
    tips, _ = lobe_tips(s, cut, 8200.0, 8300.0)
    assert np.any(np.abs(tips - 8231.5) < 0.5)
    ref, _ = reference_envelope_dense(s, cut, [8231.25, 8232.0])
    assert ref[0] < 0.75 * ref[1]


def test_issue_case_through_a_coarse_measured_table():
    """The measured-FRF path: between table points G is the straight line the engine interpolates,
    and a tip inside one table step must be found as well (the reference interpolates the same table)."""
    s, cut = ISSUE
    measured = Structure(frf=measured_from_structure(s, np.arange(100.0, 1704.0, 4.0)))
    err, where = worst_error(measured, cut, np.arange(8150.0, 8300.0, 0.5))
    assert err < 1e-6, f"{err:.3g} at {where} rpm"


def _draw(rng: np.random.Generator) -> tuple[Structure, Cutting]:
    """1–3 modes per direction (fn 300–1500 Hz, k 2–20 N/µm, ζ 0.01–0.05), 2–6 teeth, slotting or
    a/D 0.05–0.5 up or down milling."""

    def modes(n):
        return tuple(Mode(rng.uniform(300, 1500), rng.uniform(2e6, 20e6), rng.uniform(0.01, 0.05)) for _ in range(n))

    s = Structure(x=modes(int(rng.integers(1, 4))), y=modes(int(rng.integers(1, 4))))
    teeth = int(rng.integers(2, 7))
    kind = rng.integers(0, 3)
    if kind == 0:
        return s, Cutting(teeth, rng.uniform(5e8, 2.5e9), rng.uniform(0.1, 0.8))
    return s, Cutting.from_immersion(teeth, rng.uniform(5e8, 2.5e9), rng.uniform(0.1, 0.8), rng.uniform(0.05, 0.5),
                                     "up" if kind == 1 else "down")


def _speeds(rng: np.random.Generator, s: Structure, cut: Cutting) -> tuple[np.ndarray, int]:
    """A 2 rpm grid over 200 rpm, plus 1 rpm grids ±15 rpm around the three lowest lobe tips found
    by the reference's own scan in a band of 1.5:1 (random offsets); returns the speeds and the
    number of tips in the band."""
    fmin = min(m.fn for m in s.modes)
    lo = rng.uniform(0.3, 1.0) * 60 * fmin / cut.teeth
    tips, depth = lobe_tips(s, cut, lo, 1.5 * lo)
    bands = [np.arange(x - 15, x + 15, 1.0) + rng.uniform(0, 1) for x in tips[np.argsort(depth)[:3]]]
    return np.unique(np.concatenate(bands + [np.arange(lo, lo + 200, 2.0)])), tips.size


@pytest.mark.slow
def test_dense_grids_over_random_multimode_structures():
    """40 seeded random structures. On the code before the fix case 7 was off by +94 % (a tip near
    10 450 rpm)."""
    rng = np.random.default_rng(11)
    failures, n_tips, n_speeds = [], 0, 0
    for case in range(40):
        s, cut = _draw(rng)
        rpm, tips = _speeds(rng, s, cut)
        n_tips += tips
        n_speeds += rpm.size
        err, where = worst_error(s, cut, rpm)
        if err > 1e-6:
            failures.append(f"case {case}: {err:.3g} at {where:.1f} rpm")
    assert not failures, failures
    assert n_tips >= 60 and n_speeds >= 5000  # the draw does put many speeds next to lobe tips


def test_phase_derivatives_match_finite_differences():
    """The tip detection rests on dε/dω and d²ε/dω² from the eigenvalue formula; compare them with
    central differences of ε and dε/dω, for modes (exact G) and for a measured segment (linear G)."""
    from millstab.stability import _zoa_kernel as k_

    a = k_.directional_brackets(0.6, 0.4, 2.5)
    two_pi = 2 * math.pi
    wnx, kx, zx = two_pi * np.array([369.85, 700.0]), np.array([5.4e6, 9e6]), np.array([0.0316, 0.02])
    wny, ky, zy = two_pi * np.array([411.21]), np.array([6.6756e6]), np.array([0.0168])
    md = k_.pack_modes(wnx, kx, zx, wny, ky, zy)
    ga = np.array([2e-7 - 1e-7j, 1e-8j, -1e-8j, 1e-7 - 3e-7j])
    gb = np.array([-1e-7 - 2e-7j, 2e-8, 3e-8j, 2e-7 - 1e-7j])
    gab = np.stack([ga, gb])
    for measured in (False, True):
        for f in (300.0, 372.0, 411.0, 442.0, 690.0, 1200.0):
            w = two_pi * f
            wi, wj = w - 40.0, w + 40.0  # the measured segment around ω (ω at its middle)
            if measured:
                g = 0.5 * (ga + gb)
            else:
                g = [k_._modal_receptance(w, md, 0), 0j, 0j, k_._modal_receptance(w, md, 1)]
            tr, det = k_._tr_det(a, *g)
            for root in (0.5 * (tr + np.sqrt(tr * tr - 4 * det)), 0.5 * (tr - np.sqrt(tr * tr - 4 * det))):
                nu, d1, d2 = k_._phase_at(w, w, w + 1.0, root, root, wi, wj, a, md, measured, gab)
                assert nu == pytest.approx(root, rel=1e-12)
                h = 1e-6 * w

                def at(x):
                    return k_._phase_at(x, x, x + 1.0, nu, nu, wi, wj, a, md, measured, gab)

                eps = [2 * math.atan2(at(x)[0].imag, at(x)[0].real) for x in (w - h, w + h)]
                assert d1 == pytest.approx((eps[1] - eps[0]) / (2 * h), rel=1e-5, abs=1e-12)
                assert d2 == pytest.approx((at(w + h)[1] - at(w - h)[1]) / (2 * h), rel=1e-4, abs=1e-14)


def test_node_slopes_match_the_general_phase_derivatives():
    """At grid nodes of a modal structure the kernel takes dε/dω and d²ε/dω² from the known roots and
    receptances (no square root, no complex division): they must equal the general formula's, which the
    test above checks against finite differences."""
    from millstab.stability import _zoa_kernel as k_

    two_pi = 2 * math.pi
    rng = np.random.default_rng(5)
    for _ in range(20):
        a = k_.directional_brackets(rng.uniform(0.1, 0.6), rng.uniform(0.0, 1.5), rng.uniform(1.6, math.pi))
        wnx, wny = two_pi * rng.uniform(300, 3000, 2), two_pi * rng.uniform(300, 3000, 1)
        kx, ky = rng.uniform(2e6, 5e7, 2), rng.uniform(2e6, 5e7, 1)
        zx, zy = rng.uniform(0.005, 0.08, 2), rng.uniform(0.005, 0.08, 1)
        md = k_.pack_modes(wnx, kx, zx, wny, ky, zy)
        for w in two_pi * rng.uniform(100, 4000, 10):
            gxx, gyy = k_._modal_receptance(w, md, 0), k_._modal_receptance(w, md, 1)
            tr, det = k_._tr_det(a, gxx, 0j, 0j, gyy)
            s = np.sqrt(tr * tr - 4 * det)
            roots = (0.5 * (tr + s), 0.5 * (tr - s))
            for m in range(2):
                _, d1, d2 = k_._phase_at(w, w, w + 1.0, roots[m], roots[m], w, w + 1.0, a, md,
                                         False, np.zeros((2, 4), complex))
                f1, f2 = k_._node_slopes(w, roots[m], roots[1 - m], gxx, gyy, a, md)
                assert f1 == pytest.approx(d1, rel=1e-8, abs=1e-15)
                assert f2 == pytest.approx(d2, rel=1e-7, abs=1e-18)
