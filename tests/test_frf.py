"""Receptances (millstab.frf) against closed forms: one mode at resonance, statics, far above resonance,
superposition of modes, the 2×2 matrix of a structure, and linear interpolation of a measured FRF."""

from __future__ import annotations

import numpy as np
import pytest

from millstab.errors import InputError
from millstab.frf import ModalBatch, interpolate, measured_from_structure, modal_receptance, structure_receptance
from millstab.model import MeasuredFRF, Mode, Structure


def test_one_mode_at_resonance_is_minus_i_over_2k_zeta():
    """At f = fn the receptance 1/(k(1 − r² + 2iζr)) is 1/(2iζk) = −i/(2kζ): purely imaginary, negative."""
    fn, k, zeta = 903.0, 12.53e6, 0.03
    g = modal_receptance(np.array([fn]), np.array([fn]), np.array([k]), np.array([zeta]))
    assert g.shape == (1,)
    assert g[0] == pytest.approx(-1j / (2 * k * zeta), rel=1e-12)


def test_static_compliance_is_one_over_k_and_modes_add():
    """At f = 0 each mode gives its static compliance 1/k; two modes add (springs in series)."""
    k = np.array([2e7, 5e7])
    g = modal_receptance(np.array([0.0]), np.array([700.0, 1500.0]), k, np.array([0.02, 0.05]))
    assert g[0] == pytest.approx(1 / k[0] + 1 / k[1], rel=1e-14)
    assert g[0].imag == 0.0


def test_far_above_resonance_mass_line():
    """For f ≫ fn the receptance tends to the mass line −(fn/f)²/k = −1/(m ω²)."""
    fn, k, zeta = 500.0, 1e7, 0.05
    f = np.array([5e4, 5e5])
    g = modal_receptance(f, np.array([fn]), np.array([k]), np.array([zeta]))
    mass_line = -(fn / f) ** 2 / k
    np.testing.assert_allclose(g.real, mass_line, rtol=2e-4)
    assert np.all(np.abs(g.imag) < 0.05 * np.abs(g.real))


def test_batch_shapes_and_rigid_direction():
    """Leading dimensions of fn, k, ζ are a batch: (B, M) parameters give (B, F); M = 0 gives zeros."""
    f = np.linspace(100, 2000, 7)
    fn = np.array([[800.0, 1600.0], [900.0, 1700.0], [1000.0, 1800.0]])
    k = np.full_like(fn, 3e7)
    z = np.full_like(fn, 0.03)
    g = modal_receptance(f, fn, k, z)
    assert g.shape == (3, 7)
    for b in range(3):  # each row equals its own single evaluation
        np.testing.assert_allclose(g[b], modal_receptance(f, fn[b], k[b], z[b]), rtol=1e-14)
    assert np.all(modal_receptance(f, np.zeros(0), np.zeros(0), np.zeros(0)) == 0)


def test_structure_receptance_is_diagonal_with_each_direction():
    s = Structure(x=(Mode(900.0, 2e7, 0.03),), y=(Mode(1100.0, 3e7, 0.04),))
    f = np.array([900.0, 1100.0])
    g = structure_receptance(s, f)
    assert g.shape == (2, 2, 2)
    assert g[0, 0, 0] == pytest.approx(-1j / (2 * 2e7 * 0.03), rel=1e-12)
    assert g[1, 1, 1] == pytest.approx(-1j / (2 * 3e7 * 0.04), rel=1e-12)
    assert np.all(g[:, 0, 1] == 0) and np.all(g[:, 1, 0] == 0)
    # a rigid direction is all zeros
    gx = structure_receptance(Structure(x=(Mode(900.0, 2e7, 0.03),)), f)
    assert np.all(gx[:, 1, 1] == 0)


def test_measured_interpolation_exact_at_samples_linear_between_and_refuses_outside():
    s = Structure.symmetric(800.0, 2e7, 0.04)
    f = np.linspace(200.0, 2000.0, 91)
    meas = measured_from_structure(s, f, cross=True)
    assert meas.xy is not None and np.all(meas.xy == 0)
    g_nodes = interpolate(meas, f[[3, 40]])
    np.testing.assert_allclose(g_nodes[:, 0, 0], structure_receptance(s, f[[3, 40]])[:, 0, 0], rtol=1e-14)
    mid = 0.5 * (f[10] + f[11])
    g_mid = interpolate(meas, np.array([mid]))[0, 0, 0]
    assert g_mid == pytest.approx(0.5 * (meas.xx[10] + meas.xx[11]), rel=1e-14)
    # a structure carrying the FRF goes through the same interpolation
    np.testing.assert_allclose(structure_receptance(Structure(frf=meas), f[[5]]), interpolate(meas, f[[5]]))
    with pytest.raises(InputError, match="measured band"):
        interpolate(meas, np.array([100.0]))


def test_measured_frf_rejects_bad_input():
    f = np.linspace(100.0, 400.0, 5)
    h = np.ones(5, dtype=complex) * -1e-8j
    with pytest.raises(InputError, match="frf.freq_hz"):
        MeasuredFRF(f[::-1], h, None)
    with pytest.raises(InputError, match="direct term"):
        MeasuredFRF(f, None, None)
    with pytest.raises(InputError, match="frf.yy"):
        MeasuredFRF(f, h, h[:4])


def test_modal_batch_round_trip_and_errors():
    s1 = Structure(x=(Mode(900.0, 2e7, 0.03),), y=(Mode(1100.0, 3e7, 0.04),))
    s2 = Structure(x=(Mode(950.0, 2.5e7, 0.02),), y=(Mode(1200.0, 3.5e7, 0.05),))
    b = ModalBatch.from_structures([s1, s2])
    assert b.size == 2 and b.fn_x.shape == (2, 1)
    assert b.structure(1) == s2
    with pytest.raises(InputError, match=r"zeta_y \(set 1, mode 0\)"):
        ModalBatch(b.fn_x, b.k_x, b.zeta_x, b.fn_y, b.k_y, np.array([[0.04], [1.5]]))
    with pytest.raises(InputError, match="same number of modes"):
        ModalBatch.from_structures([s1, Structure(x=s1.x)])
