"""Quantities with units, as written in config files, to SI floats.

``"12.53 N/um"`` → 12.53e6 (N/m), ``"556.31 MPa"`` → 556.31e6 (N/m²), ``"126.9 deg"`` → rad.
A plain number means SI. Parsing uses pint; the registry is built lazily (it takes ~0.3 s).

Angles need care because pint treats the radian as dimensionless: to pint, ``Hz``, ``rad/s`` and
``rpm`` are all 1/time, and ``"900 rpm"`` converts to "94.25 Hz" (rad/s) and ``"5655 rad/s"`` to
"5655 Hz". millstab's frequencies are cycles per second, so the angle content of the written unit
is counted (its power of the radian after reduction to base units) and converted explicitly:
a frequency written per angle (``rad/s``, ``deg/s``, ``rpm``, ``rps``, ``cycle/s``) is divided by
2π rad per cycle (900 rpm = 15 Hz, 5655 rad/s = 900.0 Hz); an angle must carry an angle unit
(``deg``, ``rad``, ``turn``) or be a plain number (rad); every other quantity must carry none
(``kr = "2 deg"`` or ``fn = "10 %"`` are refused, not read as 0.035 and 0.1).
"""

from __future__ import annotations

import functools
import math
import re

from millstab.errors import InputError

#: dimension name → (SI unit string for pint, power of the radian the unit must carry, what is allowed)
DIMENSIONS: dict[str, tuple[str, int, str]] = {
    "frequency": ("Hz", 0, "a frequency, e.g. \"903 Hz\" or \"0.9 kHz\"; \"rad/s\" and \"rpm\" are converted "
                           "to Hz (plain number = Hz)"),
    "stiffness": ("N/m", 0, "a stiffness, e.g. \"12.53 N/um\" or \"12.53 MN/m\" (plain number = N/m)"),
    "pressure": ("N/m**2", 0, "a cutting coefficient, e.g. \"556.31 MPa\" or \"556.31 N/mm^2\" (plain number = N/m^2)"),
    "angle": ("rad", 1, "an angle, e.g. \"126.9 deg\" or \"2.21 rad\" (plain number = rad)"),
    "length": ("m", 0, "a length, e.g. \"2 mm\" (plain number = m)"),
    "dimensionless": ("", 0, "a plain number (or a percentage, e.g. \"20 %\")"),
}

#: a number with a decimal comma or thousands separators, e.g. "900,5" or "1,000"
_COMMA_NUMBER = re.compile(r"[-+]?\d*,\d")
#: the text must start with a number (pint would read "Hz" alone as 1 Hz)
_LEADING_NUMBER = re.compile(r"\s*[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?|\s*[-+]?(inf|nan)\b", re.IGNORECASE)


@functools.lru_cache(maxsize=1)
def registry():
    """The shared pint unit registry (``um`` and ``µm`` both mean micrometre; ``rev`` is a revolution)."""
    import pint

    ureg = pint.UnitRegistry()
    if "rev" not in ureg:  # "rev/min" is how spindle speeds are often written
        ureg.define("rev = revolution")
    return ureg


def parse_quantity(value: object, field: str, dimension: str) -> float:
    """Convert a config value to an SI float.

    Args:
        value: a number (taken as SI), a string with units such as ``"12.53 N/um"``, or a pint Quantity with a
            scalar magnitude (of any registry: read by its units' names, angle content counted as for a string).
        field: the config field name, used in error messages.
        dimension: one of :data:`DIMENSIONS`.

    Raises:
        InputError: unknown unit, wrong dimension (angle content included, see the module doc),
            a decimal comma, not a number, NaN or infinity. The message echoes ``value`` as given.
    """
    si_unit, angle_power, allowed = DIMENSIONS[dimension]
    if isinstance(value, bool):
        raise InputError(field, value, f"expected {allowed}")
    if isinstance(value, (int, float)):
        x = float(value)
    elif isinstance(value, str):
        x = _parse_string(value, field, si_unit, angle_power, allowed)
    elif is_quantity(value):
        try:
            x = _parse_string(_quantity_text(value, field, allowed), field, si_unit, angle_power, allowed)
        except InputError as exc:  # the message shows the Quantity as given, not its text
            raise InputError(field, value, exc.allowed) from None
    else:
        raise InputError(field, value, f"expected {allowed}")
    if not math.isfinite(x):
        raise InputError(field, value, f"must be finite; expected {allowed}")
    return x


def is_quantity(value: object) -> bool:
    """Whether ``value`` looks like a pint Quantity (a magnitude and units), without importing pint."""
    return hasattr(value, "magnitude") and hasattr(value, "units") and hasattr(value, "to_tuple")


def quantity_values(q, field: str, dimension: str):
    """A pint Quantity (a scalar or an array, any registry) as a float array in the SI unit of ``dimension``
    (:data:`DIMENSIONS`; a frequency in Hz, rpm counted as turns), through the factor of one of its units: numpy
    alone would strip the unit (``np.asarray(100 * Hz)`` is 100, read as 100 rpm).

    Raises:
        InputError: a unit of another dimension, or a magnitude that is not numbers (naming ``field``).
    """
    import numpy as np

    # a Quantity has a unit: what a plain number would mean here is not this field's business
    allowed = re.sub(r" \(plain number = [^)]*\)", "", DIMENSIONS[dimension][2])
    magnitude, units = q.to_tuple()
    try:
        values = np.asarray(magnitude, dtype=float)
    except (TypeError, ValueError):
        raise InputError(field, q, f"numbers with a unit; expected {allowed}") from None
    one = " * ".join(["1.0"] + [f"{name} ** {power!r}" for name, power in units])
    try:
        factor = _parse_string(one, field, DIMENSIONS[dimension][0], DIMENSIONS[dimension][1], allowed)
    except InputError as exc:  # the message shows the Quantity as given, not its unit's text
        raise InputError(field, q, exc.allowed) from None
    return values * factor


def _quantity_text(q, field: str, allowed: str) -> str:
    """A pint Quantity as the text :func:`_parse_string` reads (``"12.5 micrometer ** -1 * newton ** 1"``): its units
    by name, so that a Quantity of the user's own registry is read by millstab's, and ``rpm`` counts its angle."""
    magnitude, units = q.to_tuple()
    try:
        x = float(magnitude)
    except (TypeError, ValueError):
        raise InputError(field, q, f"a single quantity, not an array; expected {allowed}") from None
    return " * ".join([repr(x)] + [f"{name} ** {power!r}" for name, power in units])


def _parse_string(text: str, field: str, si_unit: str, angle_power: int, allowed: str) -> float:
    import pint

    cleaned = text.strip().replace("µ", "u").replace("μ", "u").replace("^", "**")
    if not cleaned:
        raise InputError(field, text, f"empty; expected {allowed}")
    if _COMMA_NUMBER.search(cleaned):  # pint reads "900,5 Hz" as 9005 Hz
        raise InputError(field, text, "numbers must use a decimal point and no thousands separator "
                                      f"(write 900.5, not 900,5); expected {allowed}")
    try:
        return float(cleaned)  # a bare number in a string: SI
    except ValueError:
        pass
    if not _LEADING_NUMBER.match(cleaned):
        raise InputError(field, text, f"expected a number followed by a unit: {allowed}")
    ureg = registry()
    try:
        q = ureg.Quantity(cleaned)
    except (pint.errors.UndefinedUnitError, pint.errors.DefinitionSyntaxError) as exc:
        raise InputError(field, text, f"unknown unit ({exc}); expected {allowed}") from None
    except Exception:  # pint raises assorted tokenizer errors for garbage
        raise InputError(field, text, f"cannot be read as a quantity; expected {allowed}") from None
    if not isinstance(q, ureg.Quantity):
        return float(q)
    try:
        x = float(q.to(si_unit).magnitude) if si_unit else float(q.to("").magnitude)
    except pint.errors.DimensionalityError:
        raise InputError(field, text, f"has units of {q.units:~} but expected {allowed}") from None
    # pint counts the radian as dimensionless: compare the angle content separately
    power = dict(q.to_base_units().unit_items()).get("radian", 0)
    if power == angle_power:
        return x
    if si_unit == "Hz" and power == 1:  # rad/s, rpm, deg/s: pint gave rad/s; Hz counts cycles (turns)
        return float(q.to("turn/s").magnitude)
    if angle_power == 1:
        raise InputError(field, text, f"has no angle unit; expected {allowed}")
    raise InputError(field, text, f"has units of {q.units:~}, which include an angle; expected {allowed}")


#: frequency unit labels that files write in other cases than pint's ("HZ", "KHZ", "RPM", "RAD/S")
#: how a parameter in SI is shown to the trade: {SI unit: (factor, shown unit)}; stiffness in N/µm, a
#: cutting coefficient in MPa, frequency in Hz, ζ bare (printed tables, figure axes; JSON stays SI)
SHOWN = {"Hz": (1.0, "Hz"), "N/m": (1e-6, "N/µm"), "-": (1.0, ""), "N/m^2": (1e-6, "MPa")}


def shown(value: float, si_unit: str) -> tuple[float, str]:
    """``value`` [``si_unit``] as the trade reads it: (value × factor, shown unit) from :data:`SHOWN`; a unit
    not in it is shown as it is."""
    factor, unit = SHOWN.get(si_unit, (1.0, si_unit))
    return value * factor, unit


_HZ_LABELS = {"hz": 1.0, "khz": 1e3, "rpm": 1.0 / 60.0, "rad/s": 1.0 / (2.0 * math.pi)}


def frequency_factor(label: str) -> float | None:
    """Hz per unit of a file's frequency-axis label (``"Hz"`` 1, ``"rad/s"`` 1/2π, ``"rpm"`` 1/60).

    Returns ``None`` when the label is not a unit of frequency (a word such as ``"Frequency"``, or a
    unit of another dimension), so the caller can keep its default. Angle content is counted as in
    :func:`parse_quantity`: ``rad/s`` is divided by 2π, never read as Hz.
    """
    text = label.strip()
    if text.lower() in _HZ_LABELS:
        return _HZ_LABELS[text.lower()]
    if not text or not re.search(r"[A-Za-z]", text):
        return None
    try:
        return parse_quantity(f"1 {text}", "label", "frequency")
    except InputError:
        return None
