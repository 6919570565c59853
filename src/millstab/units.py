"""Quantities with units, as written in config files, to SI floats.

``"12.53 N/um"`` → 12.53e6 (N/m), ``"556.31 MPa"`` → 556.31e6 (N/m²), ``"126.9 deg"`` → rad.
A plain number means SI. Parsing uses pint; the registry is built lazily (it takes ~0.3 s).
"""

from __future__ import annotations

import functools
import math

from millstab.errors import InputError

#: dimension name → (SI unit string for pint, human description of what is allowed)
DIMENSIONS: dict[str, tuple[str, str]] = {
    "frequency": ("Hz", "a frequency, e.g. \"903 Hz\" or \"0.9 kHz\" (plain number = Hz)"),
    "stiffness": ("N/m", "a stiffness, e.g. \"12.53 N/um\" or \"12.53 MN/m\" (plain number = N/m)"),
    "pressure": ("N/m**2", "a cutting coefficient, e.g. \"556.31 MPa\" or \"556.31 N/mm^2\" (plain number = N/m^2)"),
    "angle": ("rad", "an angle, e.g. \"126.9 deg\" (plain number = rad)"),
    "length": ("m", "a length, e.g. \"2 mm\" (plain number = m)"),
    "dimensionless": ("", "a plain number"),
}


@functools.lru_cache(maxsize=1)
def registry():
    """The shared pint unit registry (``um`` and ``µm`` both mean micrometre)."""
    import pint

    return pint.UnitRegistry()


def parse_quantity(value: object, field: str, dimension: str) -> float:
    """Convert a config value to an SI float.

    Args:
        value: a number (taken as SI) or a string with units such as ``"12.53 N/um"``.
        field: the config field name, used in error messages.
        dimension: one of :data:`DIMENSIONS`.

    Raises:
        InputError: unknown unit, wrong dimension, not a number, NaN or infinity.
    """
    si_unit, allowed = DIMENSIONS[dimension]
    if isinstance(value, bool):
        raise InputError(field, value, f"expected {allowed}")
    if isinstance(value, (int, float)):
        x = float(value)
    elif isinstance(value, str):
        x = _parse_string(value, field, si_unit, allowed)
    else:
        raise InputError(field, value, f"expected {allowed}")
    if not math.isfinite(x):
        raise InputError(field, value, f"must be finite; expected {allowed}")
    return x


def _parse_string(text: str, field: str, si_unit: str, allowed: str) -> float:
    import pint

    ureg = registry()
    cleaned = text.strip().replace("µ", "u").replace("μ", "u").replace("^", "**")
    if not cleaned:
        raise InputError(field, text, f"empty; expected {allowed}")
    try:
        q = ureg.Quantity(cleaned)
    except (pint.errors.UndefinedUnitError, pint.errors.DefinitionSyntaxError) as exc:
        raise InputError(field, text, f"unknown unit ({exc}); expected {allowed}") from None
    except Exception:  # pint raises assorted tokenizer errors for garbage
        raise InputError(field, text, f"cannot be read as a quantity; expected {allowed}") from None
    if not isinstance(q, ureg.Quantity):  # a bare number in a string
        return float(q)
    if q.dimensionless and si_unit not in ("", "rad"):
        return float(q.to("").magnitude)
    try:
        return float(q.to(si_unit).magnitude) if si_unit else float(q.to("").magnitude)
    except pint.errors.DimensionalityError:
        raise InputError(field, text, f"has units of {q.units:~} but expected {allowed}") from None
