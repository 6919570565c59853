"""Units as written in configs: rotational and angular frequencies, angles, and unit slips refused.

pint treats the radian as dimensionless, so Hz, rad/s and rpm are all 1/time to it; millstab's
frequencies count cycles. The expected values here are the closed forms f = n/60 (rpm) and
f = ω/2π (rad/s), computed independently of pint.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from millstab.errors import InputError
from millstab.io.config import parse_config
from millstab.units import parse_quantity

HEAD = """
[cutting]
teeth = 2
kt = "556.31 MPa"
kr = 0.404
entry = "0 deg"
exit = "180 deg"
[[structure.x]]
fn = {fn}
k = "12.53 N/um"
zeta = 0.03
"""


@pytest.mark.parametrize("text,hz", [
    ("900 rpm", 900 / 60),
    ("900 rev/min", 900 / 60),
    ("5655 rad/s", 5655 / (2 * math.pi)),
    ("54000 deg/s", 54000 / 360),
    ("15 rps", 15.0),
    ("900 cycle/s", 900.0),
    ("54000 1/min", 54000 / 60),  # min^-1 without an angle counts cycles, like Hz
    ("0.9 kHz", 900.0),
    ("903 Hz", 903.0),
    ("903", 903.0),
])
def test_rotational_and_angular_frequencies_convert_to_hz(text, hz):
    assert parse_quantity(text, "fn", "frequency") == pytest.approx(hz, rel=1e-13)


def test_the_issue_cases_in_a_config():
    """The reported slips: "900 rpm" was read as 94.25 Hz and "5655 rad/s" as 5655 Hz."""
    fn_rpm = parse_config(HEAD.format(fn='"900 rpm"')).structure.x[0].fn
    fn_rad = parse_config(HEAD.format(fn='"5655 rad/s"')).structure.x[0].fn
    assert fn_rpm == pytest.approx(15.0, rel=1e-14)
    assert fn_rad == pytest.approx(900.0, rel=1e-4) and fn_rad == pytest.approx(5655 / (2 * math.pi), rel=1e-13)


def test_angular_frequency_round_trip_on_random_values():
    """ω = 2πf written in rad/s, and 60f written in rpm, give f back for many f (seeded)."""
    f = np.random.default_rng(7).uniform(1.0, 20000.0, 40)
    for fi in f:
        assert parse_quantity(f"{float(2 * math.pi * fi)!r} rad/s", "fn", "frequency") == pytest.approx(fi, rel=1e-12)
        assert parse_quantity(f"{float(60 * fi)!r} rpm", "fn", "frequency") == pytest.approx(fi, rel=1e-12)


@pytest.mark.parametrize("text,rad", [("126.9 deg", math.radians(126.9)), ("2.21 rad", 2.21),
                                      ("0.25 turn", math.pi / 2), ("100 grad", math.pi / 2), ("1.5", 1.5)])
def test_angles(text, rad):
    assert parse_quantity(text, "cutting.entry", "angle") == pytest.approx(rad, rel=1e-13)


@pytest.mark.parametrize("text,dimension,words", [
    ("2 rad", "frequency", "frequency"),          # was read as 2 Hz
    ("10 %", "frequency", "frequency"),           # was read as 0.1 Hz
    ("903 Hz/rad", "frequency", "angle"),
    ("Hz", "frequency", "number"),                # was read as 1 Hz
    ("900,5 Hz", "frequency", "decimal point"),   # was read as 9005 Hz
    ("1,000 Hz", "frequency", "decimal point"),
    ("50 %", "angle", "angle"),                   # was read as 0.5 rad
    ("1 rpm", "angle", "angle"),
    ("2 deg", "dimensionless", "angle"),          # kr = "2 deg" was read as 0.035
    ("0.4 rad", "dimensionless", "angle"),
    ("12 N/um/rad", "stiffness", "angle"),
    ("556 MPa/rad", "pressure", "angle"),
    ("inf Hz", "frequency", "finite"),
])
def test_dimension_slips_are_refused_as_written(text, dimension, words):
    with pytest.raises(InputError) as info:
        parse_quantity(text, "the.field", dimension)
    err = info.value
    assert err.field == "the.field" and err.value == text
    assert f"the.field = {text!r}" in str(err) and words in str(err)


def test_percent_is_a_plain_number():
    assert parse_quantity("3 %", "zeta", "dimensionless") == pytest.approx(0.03, rel=1e-15)
    assert parse_quantity("20 %", "radial_immersion", "dimensionless") == pytest.approx(0.2, rel=1e-15)


@pytest.mark.parametrize("field,old,new", [
    ("structure.x[0].fn", 'fn = "903 Hz"', 'fn = "2 rad"'),
    ("structure.x[0].zeta", "zeta = 0.03", 'zeta = "0.03 rad"'),
    ("cutting.kr", "kr = 0.404", 'kr = "23 deg"'),
    ("cutting.entry", 'entry = "0 deg"', 'entry = "0 %"'),
    ("cutting.kt", 'kt = "556.31 MPa"', 'kt = "556,31 MPa"'),
])
def test_every_config_quantity_field_refuses_angle_slips(field, old, new):
    text = HEAD.format(fn='"903 Hz"')
    assert old in text
    with pytest.raises(InputError) as info:
        parse_config(text.replace(old, new))
    assert info.value.field == field


@pytest.mark.parametrize("value,words", [('"5000 Hz"', "300000 rpm"), ('"523.6 rad/s"', "5000.0"),
                                         ('"5000,5"', "decimal point")])
def test_speeds_in_other_units_are_refused_with_their_rpm(value, words):
    with pytest.raises(InputError) as info:
        parse_config(HEAD.format(fn="903") + f"[speeds]\nstart = {value}\nstop = 6000\nstep = 100\n")
    assert info.value.field == "speeds.start" and words in str(info.value)


def test_speeds_rpm_spellings():
    c = parse_config(HEAD.format(fn="903") + '[speeds]\nstart = "5000 RPM"\nstop = "6000 r/min"\nstep = "500 1/min"\n')
    np.testing.assert_array_equal(c.rpm, [5000.0, 5500.0, 6000.0])


def test_speeds_and_points_given_as_pint_arrays_keep_their_units():
    """numpy strips a Quantity's unit (pint only warns): 100 Hz was read as 100 rpm, a depth of 0.002 m as 0.002 mm.
    The speeds (api.speeds, every engine's check_rpm) and a PointSet's columns convert from the unit given."""
    pint = pytest.importorskip("pint")
    import warnings

    from millstab import api
    from millstab.points import PointSet
    from millstab.stability import check_rpm

    u = pint.UnitRegistry()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no UnitStrippedWarning: nothing reaches numpy with its unit
        np.testing.assert_array_equal(api.speeds(np.array([100.0, 150.0]) * u.Hz), [6000.0, 9000.0])
        np.testing.assert_allclose(check_rpm(u.Quantity(np.array([5000.0]), "rpm")), [5000.0], rtol=1e-15)
        p = PointSet(u.Quantity([5000.0], "rpm"), u.Quantity([0.002], "m"), ["chatter"], chatter_hz=[900.0] * u.Hz)
    np.testing.assert_allclose([p.rpm[0], p.depth_mm[0], p.chatter_hz[0]], [5000.0, 2.0, 900.0], rtol=1e-15)
    with pytest.raises(InputError) as exc:
        PointSet([5000.0], [2.0] * u.Hz)
    assert exc.value.field == "points.depth_mm" and "expected a length" in exc.value.allowed
    with pytest.raises(InputError, match="--rpm"):
        api.speeds(np.array([1.0]) * u.m)
