"""Every validation path of the model classes: the error names the field, the value and what is allowed."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from millstab.errors import FRFWarning, InputError, UnitWarning
from millstab.model import Cutting, MeasuredFRF, Mode, Structure

NAN = float("nan")


def _raises(field: str, fn, *args, **kwargs) -> InputError:
    """Call fn, expect InputError whose field is ``field`` and whose message names it."""
    with pytest.raises(InputError) as info:
        fn(*args, **kwargs)
    assert info.value.field == field
    assert field in str(info.value)
    return info.value


# ------------------------------------------------------------------------------------- Mode

@pytest.mark.parametrize("fn", [0.0, -903.0, NAN, math.inf, "abc", None, True])
def test_mode_bad_fn(fn):
    _raises("structure.x[0].fn", Mode, fn, 12.53e6, 0.03, "structure.x[0]")


@pytest.mark.parametrize("k", [0.0, -1e6, NAN, -math.inf])
def test_mode_bad_k(k):
    _raises("structure.y[1].k", Mode, 903.0, k, 0.03, "structure.y[1]")


@pytest.mark.parametrize("zeta", [0.0, 1.0, -0.01, 1.5, NAN])
def test_mode_bad_zeta(zeta):
    err = _raises("structure.x[0].zeta", Mode, 903.0, 12.53e6, zeta, "structure.x[0]")
    assert ("finite" if math.isnan(zeta) else "(0, 1)") in err.allowed


def test_mode_error_carries_value_and_allowed():
    err = _raises("m.fn", Mode, -5.0, 1e7, 0.02, "m")
    assert err.value == -5.0
    assert "> 0 Hz" in str(err)


def test_low_stiffness_warns_with_field_name():
    with pytest.warns(UnitWarning, match=r"structure\.x\[0\]\.k.*N/um"):
        Mode(903.0, 12.53, 0.03, "structure.x[0]")


@pytest.mark.parametrize("k, ok", [(12.53e12, False), (2e10, False), (5e8, True), (2e9, True)])
def test_implausibly_high_stiffness_warns_naming_the_unit(k, ok):
    """12.53 N/µm typed as N/mm and read as N/m (or units applied twice) gives 10⁶× the stiffness: every
    limit 10⁶× too deep. A spindle mode of a few hundred N/µm (5e8, 2e9 N/m) is real and passes."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        Mode(903.0, k, 0.03, "structure.y[1]")
    texts = [str(w.message) for w in caught if issubclass(w.category, UnitWarning)]
    if ok:
        assert texts == []
    else:
        assert len(texts) == 1 and texts[0].startswith("structure.y[1].k = ")
        assert f"{k * 1e-6:g} N/um" in texts[0] and "tool tip" in texts[0]


def test_normal_stiffness_does_not_warn():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = Mode(903.0, 12.53e6, 0.03)
    assert m.k == 12.53e6


def test_the_unit_the_warning_asks_for_is_taken_by_the_python_api():
    """The low-stiffness warning says 'Give units explicitly, e.g. "12.53 N/um"': Mode and Cutting take such a
    string, and a pint Quantity of the user's own registry, converted as in a config file (rpm counts its angle)."""
    with pytest.warns(UnitWarning, match='e.g. "12.53 N/um"'):
        Mode(903.0, 12.53, 0.03)
    assert Mode(903.0, "12.53 N/um", "3 %") == Mode(903.0, 12.53e6, 0.03)
    c = Cutting(4, "556.31 MPa", 0.4, entry="90 deg", exit="180 deg", process_damping="2e5 N/m", diameter="12 mm")
    assert (c.kt, c.entry, c.exit, c.process_damping, c.diameter) == (556.31e6, math.pi / 2, math.pi, 2e5, 0.012)
    pint = pytest.importorskip("pint")
    u = pint.UnitRegistry()
    m = Mode(u.Quantity(54180.0, "rpm"), u.Quantity(12.53, "N/um"), u.Quantity(3, "percent"))
    assert (m.fn, m.k, m.zeta) == pytest.approx((903.0, 12.53e6, 0.03), rel=1e-15)
    assert Cutting(2, u.Quantity(600, "MPa"), 0.3).kt == 600e6
    err = _raises("mode.fn", Mode, u.Quantity(1000, "kg"), 1e7, 0.03)
    assert err.value == u.Quantity(1000, "kg") and "expected a frequency" in err.allowed
    err = _raises("cutting.kt", Cutting, 2, "600 N/um", 0.3)
    assert "expected a cutting coefficient" in err.allowed
    _raises("mode.k", Mode, 903.0, u.Quantity(np.array([1.0, 2.0]), "N/um"), 0.03)


# ---------------------------------------------------------------------------------- Cutting

@pytest.mark.parametrize("teeth", [0, -2, 2.5, "4", None, True])
def test_cutting_bad_teeth(teeth):
    err = _raises("cutting.teeth", Cutting, teeth, 6e8, 0.3)
    assert "positive integer" in err.allowed


def test_cutting_float_integer_teeth_accepted():
    assert Cutting(4.0, 6e8, 0.3).teeth == 4


@pytest.mark.parametrize("kt", [0.0, -6e8, NAN])
def test_cutting_bad_kt(kt):
    _raises("cutting.kt", Cutting, 2, kt, 0.3)


@pytest.mark.parametrize("kr", [-0.1, NAN, math.inf])
def test_cutting_bad_kr(kr):
    _raises("cutting.kr", Cutting, 2, 6e8, kr)


@pytest.mark.parametrize("entry", [-0.1, 3.5, NAN])
def test_cutting_entry_outside_range(entry):
    _raises("cutting.entry", Cutting, 2, 6e8, 0.3, entry, math.pi)


@pytest.mark.parametrize("exit_", [-0.5, 4.0, NAN])
def test_cutting_exit_outside_range(exit_):
    _raises("cutting.exit", Cutting, 2, 6e8, 0.3, 0.0, exit_)


@pytest.mark.parametrize("entry,exit_", [(1.0, 1.0), (2.0, 1.0)])
def test_cutting_entry_not_before_exit(entry, exit_):
    err = _raises("cutting.entry", Cutting, 2, 6e8, 0.3, entry, exit_)
    assert "less than the exit" in err.allowed


@pytest.mark.parametrize("ri", [0.0, -0.2, 1.2, NAN])
def test_cutting_bad_radial_immersion(ri):
    _raises("cutting.radial_immersion", Cutting.from_immersion, 3, 6e8, 0.3, ri, "down")


@pytest.mark.parametrize("milling", ["climb", "Down", "", None])
def test_cutting_bad_milling(milling):
    _raises("cutting.milling", Cutting.from_immersion, 3, 6e8, 0.3, 0.2, milling)


def test_from_immersion_angles():
    down = Cutting.from_immersion(3, 2173e6, 0.268, 0.2, "down")
    assert math.degrees(down.entry) == pytest.approx(126.87, abs=0.01) and down.exit == math.pi
    up = Cutting.from_immersion(3, 2173e6, 0.268, 0.2, "up")
    assert up.entry == 0.0 and math.degrees(up.exit) == pytest.approx(53.13, abs=0.01)


def test_low_kt_warns():
    with pytest.warns(UnitWarning, match="cutting.kt"):
        Cutting(2, 556.31, 0.404)


def test_high_kt_and_kr_warn_and_real_ones_do_not():
    """Kt of 556.31e12 (MPa applied to a value already in N/m²) and Kr of 300 (Kn in MPa given as the ratio)
    each warn, naming the field; the seed paper's values and a hardened steel's (5 000 MPa, Kr 1.2) do not."""
    with pytest.warns(UnitWarning, match=r"cutting\.kt = 5\.5631e\+14 N/m\^2 \(5\.5631e\+08 MPa\)"):
        Cutting(2, 556.31e12, 0.404)
    with pytest.warns(UnitWarning, match=r"cutting\.kr = 300 is no radial-to-tangential ratio.*Kn"):
        Cutting(2, 556.31e6, 300.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Cutting(2, 556.31e6, 0.404)
        Cutting(4, 5000e6, 1.2)


# -------------------------------------------------------------------------------- Structure

def test_structure_without_modes():
    err = _raises("structure", Structure)
    assert "at least one mode" in err.allowed


def test_structure_modes_and_frf():
    f = np.linspace(100, 2000, 10)
    frf = MeasuredFRF(f, np.ones(10) * 1e-7 + 0j, None)
    err = _raises("structure", Structure, x=(Mode(903, 1e7, 0.03),), frf=frf)
    assert "not both" in err.allowed


def test_structure_entry_not_a_mode():
    _raises("structure.y", Structure, y=((903, 1e7, 0.03),))


def test_one_mode_needs_no_tuple_and_a_number_is_named():
    m = Mode(903, 1e7, 0.03)
    assert Structure(x=m, y=[m]) == Structure(x=(m,), y=(m,))
    err = _raises("structure.x", Structure, x=903.0)
    assert "sequence of Modes" in err.allowed


def test_rigid_direction_is_allowed():
    s = Structure(x=(Mode(922, 1.34e6, 0.011),))
    assert s.y == () and s.is_modal


# ------------------------------------------------------------------------------ MeasuredFRF

def _h(n=10):
    return np.full(n, 1e-7 + 1e-8j)


@pytest.mark.parametrize("freq", [np.linspace(100, 200, 3), np.array([[1.0, 2.0], [3.0, 4.0]])])
def test_frf_too_few_frequencies(freq):
    _raises("frf.freq_hz", MeasuredFRF, freq, _h(freq.size), None)


@pytest.mark.parametrize("bad", [0.0, -5.0, NAN])
def test_frf_nonpositive_or_nan_frequency(bad):
    f = np.linspace(10, 100, 10)
    f[0] = bad
    _raises("frf.freq_hz", MeasuredFRF, f, _h(), None)


def test_frf_unsorted_frequency():
    f = np.linspace(10, 100, 10)
    f[[3, 4]] = f[[4, 3]]
    err = _raises("frf.freq_hz", MeasuredFRF, f, _h(), None)
    assert "increasing" in err.allowed


def test_frf_no_direct_term():
    _raises("frf", MeasuredFRF, np.linspace(10, 100, 10), None, None, _h(), None)


def test_frf_wrong_length():
    _raises("frf.yy", MeasuredFRF, np.linspace(10, 100, 10), _h(), _h(9))


def test_frf_nan_value():
    h = _h()
    h[4] = complex(NAN, 0)
    _raises("frf.xy", MeasuredFRF, np.linspace(10, 100, 10), _h(), None, h)


# --------------------------------------------------------------- issue 10: sign convention, plain echo

def test_conjugated_direct_term_warns_and_correct_one_does_not():
    """G = 1/(k(1 - r^2 + 2iζr)) (x = Re(G F e^{iωt})) has Im G < 0 at resonance; its conjugate does not."""
    f = np.linspace(100.0, 3000.0, 600)
    r = f / 903.0
    g = 1.0 / (12.53e6 * (1 - r * r + 2j * 0.03 * r))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        MeasuredFRF(f, g, g, np.conj(g), None)  # a cross term may have either sign
        MeasuredFRF(f, _h(f.size), None)  # flat, small positive Im: no resonance, no warning
    for term in ("xx", "yy"):
        with pytest.warns(FRFWarning, match=rf"frf\.{term}.*near 90\d\.?\d* Hz.*Im G < 0"):
            MeasuredFRF(f, **{"xx": g, "yy": g, term: np.conj(g)})


@pytest.mark.parametrize("value,shown", [
    (np.array([-1.5, 0.0, 0.5]), "[-1.5, 0, 0.5]"),
    (np.float64(4.71238898038469), "4.71238898038469"),
    (np.int64(3), "3"),
    (np.complex128(complex(math.inf, 0.0)), "inf+0j"),
    ((np.float64(2.0), np.float64(1.0)), "(2, 1)"),
    (np.arange(20.0), "[0, 1, 2, 3, 4, 5, 6, 7, ... (20 values)]"),
    ("270 deg", "'270 deg'"),
    (1e-07, "1e-07"),
])
def test_input_error_shows_values_plainly(value, shown):
    err = InputError("eps", value, "allowed")
    assert str(err) == f"eps = {shown} is invalid: allowed"
    assert "array(" not in str(err) and "np." not in str(err)
