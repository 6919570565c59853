"""The pieces of the faster zero-order kernel (issue 15, item 4), each against an independent answer:
the real-arithmetic complex square root against numpy's, the Hermite first iterate against the exact
root of a cubic, the packed modes against the structure's own receptance, the candidate scan's
overflow rerun against a scan that never overflows, and the work counters against the grid they count.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from millstab.frf import structure_receptance
from millstab.model import Cutting, Mode, Structure
from millstab.params import Parameterization
from millstab.stability import _zoa_kernel as K
from millstab.stability import zoa


def test_csqrt_is_the_principal_square_root():
    rng = np.random.default_rng(0)
    scale = 10.0 ** rng.uniform(-30, 30, 2000)
    z = (rng.normal(size=2000) + 1j * rng.normal(size=2000)) * scale
    # the negative real axis (both signs of zero imaginary part), the axes, zero and out-of-range values
    z = np.concatenate([z, [-4.0 + 0.0j, -4.0 - 0.0j, 4.0, 4j, -4j, 0j, 1e-200 + 1e-200j, 1e200 - 1e200j,
                            complex(np.nan, 1.0)]])
    ref = np.sqrt(z)
    got = np.array([K._csqrt(v) for v in z])
    finite = np.isfinite(ref)
    np.testing.assert_allclose(got[finite], ref[finite], rtol=1e-15, atol=0)
    assert np.isnan(got[~finite]).all()
    assert (got[np.isfinite(got)].real >= 0).all()


def test_hermite_first_iterate_is_exact_for_a_cubic():
    """H(t) = (t − r)(t² + 1)(c): the cubic Hermite interpolant through its values and slopes at 0 and 1
    is H itself, so its zero is r (to rounding); a non-bracketing Newton path falls back to the
    linear zero inside (0, 1)."""
    for r in (0.05, 0.3, 0.5, 0.77, 0.99):
        for c in (1.0, -3.0):
            def h(t):
                return c * (t - r) * (t * t + 1.0)

            def dh(t):
                return c * ((t * t + 1.0) + 2.0 * t * (t - r))

            t = K._hermite_root(h(0.0), h(1.0), dh(0.0), dh(1.0))
            assert t == pytest.approx(r, abs=1e-12)
    # slopes that send Newton outside the interval: the linear zero comes back
    t = K._hermite_root(-1.0, 1.0, -50.0, -50.0)
    assert 0.0 < t < 1.0


def test_packed_modes_give_the_structure_receptance():
    s = Structure(x=(Mode(700.0, 9e6, 0.02), Mode(1300.0, 2e7, 0.04), Mode(2100.0, 3e7, 0.01)),
                  y=(Mode(900.0, 1.1e7, 0.03),))
    two_pi = 2 * math.pi
    md = K.pack_modes(*(np.array(v) for v in (
        [two_pi * m.fn for m in s.x], [m.k for m in s.x], [m.zeta for m in s.x],
        [two_pi * m.fn for m in s.y], [m.k for m in s.y], [m.zeta for m in s.y])))
    assert md.shape == (2, 3, 3) and (md[1, 1, 1:] == 0).all()  # y padded with k = 0
    f = np.linspace(50.0, 4000.0, 97)
    g = structure_receptance(s, f)
    got = np.array([[K._modal_receptance(two_pi * x, md, 0), K._modal_receptance(two_pi * x, md, 1)] for x in f])
    np.testing.assert_allclose(got[:, 0], g[:, 0, 0], rtol=1e-12)
    np.testing.assert_allclose(got[:, 1], g[:, 1, 1], rtol=1e-12)
    # a rigid direction: no modes at all gives zero receptance
    rigid = K.pack_modes(md[0, 0, :1], md[0, 1, :1], md[0, 2, :1], np.zeros(0), np.zeros(0), np.zeros(0))
    assert K._modal_receptance(5000.0, rigid, 1) == 0j


def _scan_inputs(s: Structure, cut: Cutting, rpm: np.ndarray):
    """The grid, roots and node arrays that _scan hands to _collect, for one modal structure."""
    two_pi = 2 * math.pi
    md = K.pack_modes(*(np.array(v) for v in (
        [two_pi * m.fn for m in s.x], [m.k for m in s.x], [m.zeta for m in s.x],
        [two_pi * m.fn for m in s.y], [m.k for m in s.y], [m.zeta for m in s.y])))
    a = K.directional_brackets(cut.kr, cut.entry, cut.exit)
    w, G = K.modal_grid(md, two_pi * cut.teeth * rpm[-1] / 60.0, zoa.N_BASE, zoa._OFFSETS)
    nu = K._branches(a, G[0], G[1], G[2], G[3])
    valid = (nu.real > 0) & np.isfinite(nu)
    inv_b = np.where(valid, nu.real, 0.0)
    T = 60.0 / (cut.teeth * rpm)
    return w, G, nu, valid, inv_b, T, a, md


def test_collect_overflow_reports_and_keeps_the_estimates():
    """A candidate buffer that is too small must say so (the caller reruns with a larger one) while the
    per-speed estimates stay those of a scan with room for every candidate."""
    s, cut = Structure(x=(Mode(903.0, 12.53e6, 0.03),), y=(Mode(950.0, 11e6, 0.025),)), Cutting(2, 556.31e6, 0.404)
    rpm = np.linspace(2000.0, 12000.0, 200)
    w, G, nu, valid, inv_b, T, a, md = _scan_inputs(s, cut, rpm)
    none = np.zeros(0, dtype=np.int64)
    est_big, est_small = np.zeros(rpm.size), np.zeros(rpm.size)
    big = K._collect(w, G, nu, valid, inv_b, T, rpm, cut.teeth, est_big, True, a, md, False, 100_000, none)
    small = K._collect(w, G, nu, valid, inv_b, T, rpm, cut.teeth, est_small, True, a, md, False, 5, none)
    assert not big[0] and big[1].size > 5
    assert small[0]
    np.testing.assert_array_equal(est_small, est_big)


def test_work_counters_count_the_grid_and_leave_the_result_alone():
    s = Structure(x=(Mode(903.0, 12.53e6, 0.03),), y=(Mode(950.0, 11e6, 0.025),))
    cut = Cutting(2, 556.31e6, 0.404)
    par = Parameterization(s)
    theta = par.theta0 * np.random.default_rng(2).uniform(0.9, 1.1, (6, par.size))
    batch = par.batch(theta)
    rpm = np.linspace(2000.0, 12000.0, 120)
    stats = np.zeros((6, K.N_STATS), dtype=np.int64)
    counted = zoa._run_modal(batch, cut, rpm, stats)
    plain = zoa._run_modal(batch, cut, rpm)
    for x, y in zip(counted, plain):
        np.testing.assert_array_equal(x, y)
    two_pi = 2 * math.pi
    for b in range(6):
        md = K.pack_modes(two_pi * batch.fn_x[b], batch.k_x[b], batch.zeta_x[b], two_pi * batch.fn_y[b],
                          batch.k_y[b], batch.zeta_y[b])
        w, _ = K.modal_grid(md, two_pi * cut.teeth * rpm[-1] / 60.0, zoa.N_BASE, zoa._OFFSETS)
        st = dict(zip(K.STAT_NAMES, stats[b]))
        # nodes = grid + one node per Re ν = 0 edge found; every speed with a boundary needs a refinement
        assert st["grid nodes"] >= w.size
        assert st["valid segments"] <= 2 * (st["grid nodes"] - 1)
        assert st["segments visited"] <= st["valid segments"]
        assert np.isfinite(plain[0][b]).sum() <= st["candidates refined"] <= st["candidates"]


def test_diagonal_receptance_roots_equal_the_general_ones_bit_for_bit():
    """The modal path's real-arithmetic roots (_disc_diag, _branches_diag) are the general complex path's
    (_tr_det, _branches) with zero cross receptances, to the last bit, and the eigenvalues of [α][G]
    (numpy's, independent) to rounding; in slotting, up and down milling (α of either sign)."""
    rng = np.random.default_rng(4)
    s = Structure(x=(Mode(903.0, 12.53e6, 0.03), Mode(2400.0, 40e6, 0.02)), y=(Mode(950.0, 11e6, 0.025),))
    md = K.pack_modes(*(np.array(v) for v in (
        [2 * math.pi * m.fn for m in s.x], [m.k for m in s.x], [m.zeta for m in s.x],
        [2 * math.pi * m.fn for m in s.y], [m.k for m in s.y], [m.zeta for m in s.y])))
    w, G = K.modal_grid(md, 2 * math.pi * 3 * 15000 / 60, zoa.N_BASE, zoa._OFFSETS)
    zero = np.zeros_like(G[0])
    for ri, milling in ((1.0, "down"), (0.5, "up"), (0.3, "down"), (0.05, "up")):
        cut = Cutting.from_immersion(3, 600e6, float(rng.uniform(0.1, 0.6)), ri, milling)
        a = K.directional_brackets(cut.kr, cut.entry, cut.exit)
        fast = K._branches_diag(a, G[0], G[3])
        general = K._branches(a, G[0], zero, zero, G[3])
        assert np.array_equal(fast.view(np.float64), general.view(np.float64))
        for i in rng.integers(0, w.size, 20):
            tr, det = K._tr_det(a, G[0, i], 0j, 0j, G[3, i])
            disc = tr * tr - 4.0 * det
            got = K._disc_diag(a, G[0, i].real, G[0, i].imag, G[3, i].real, G[3, i].imag)
            assert got == (tr.real, tr.imag, disc.real, disc.imag)
            m = np.array([[a[0], a[1]], [a[2], a[3]]]) @ np.diag([G[0, i], G[3, i]])
            ref = np.sort_complex(np.linalg.eigvals(m))
            np.testing.assert_allclose(np.sort_complex(fast[:, i]), ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())


def test_merged_nodes_keep_the_old_ones_and_add_exact_roots():
    """_with_nodes (block copies between the new nodes): the merged grid is the sorted union; the old
    nodes' receptances and roots are copied unchanged; a new node's receptance is the structure's own at
    that frequency and its roots are the eigenvalues of [α][G] there (numpy's), for new nodes before the
    first, between, next to each other and after the last old node."""
    s = Structure(x=(Mode(903.0, 12.53e6, 0.03),), y=(Mode(950.0, 11e6, 0.025),))
    md = K.pack_modes(*(np.array(v) for v in (
        [2 * math.pi * m.fn for m in s.x], [m.k for m in s.x], [m.zeta for m in s.x],
        [2 * math.pi * m.fn for m in s.y], [m.k for m in s.y], [m.zeta for m in s.y])))
    w, G = K.modal_grid(md, 2 * math.pi * 2 * 12000 / 60, zoa.N_BASE, zoa._OFFSETS)
    cut = Cutting.from_immersion(2, 556.31e6, 0.404, 0.5, "up")
    a = K.directional_brackets(cut.kr, cut.entry, cut.exit)
    nu = K._branches_diag(a, G[0], G[3])
    extra = np.array([w[-1] * 1.01, 0.5 * (w[10] + w[11]), w[0] * 0.99, 0.3 * w[100] + 0.7 * w[101],
                      0.6 * w[100] + 0.4 * w[101]])
    w2, G2, nu2 = K._with_nodes(w, G, nu, extra, a, False, md)
    np.testing.assert_array_equal(w2, np.sort(np.r_[w, extra]))
    old = np.isin(w2, w)
    assert old.sum() == w.size
    np.testing.assert_array_equal(G2[:, old], G)
    np.testing.assert_array_equal(nu2[:, old], nu)
    for c in np.flatnonzero(~old):
        gx, gy = K._modal_receptance(w2[c], md, 0), K._modal_receptance(w2[c], md, 1)
        assert G2[0, c] == gx and G2[3, c] == gy and G2[1, c] == 0 and G2[2, c] == 0
        ref = np.linalg.eigvals(np.array([[a[0], a[1]], [a[2], a[3]]]) @ np.diag([gx, gy]))
        np.testing.assert_allclose(np.sort_complex(nu2[:, c]), np.sort_complex(ref), rtol=1e-12,
                                   atol=1e-12 * np.abs(ref).max())
