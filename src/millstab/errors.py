"""Errors and warnings that millstab raises for bad input.

Every input problem is reported as one :class:`InputError` whose message names the field, the value
that was given and what is allowed, so the CLI can print it on one line. Values are echoed as the
user wrote them where the caller passes the raw text (``exit = '270 deg'``), and numbers plainly
(``[-1.5, 0, 0.5]``, never ``array([-1.5, 0. , 0.5])`` or ``np.float64(4.71)``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import PurePath

#: arrays longer than this are echoed as their first items and a count
_MAX_ITEMS = 8


def _number(x: float) -> str:
    """A float as a person writes it: ``3`` not ``3.0``, shortest exact digits otherwise."""
    if math.isfinite(x) and x == int(x) and abs(x) < 1e15:
        return str(int(x))
    return repr(float(x))


def show(value: object) -> str:
    """The text an error message uses for ``value`` (strings quoted, numbers and arrays plain)."""
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, PurePath):
        return repr(str(value))
    if value is None or isinstance(value, bool):
        return str(value)
    if hasattr(value, "tolist") and hasattr(value, "dtype"):  # numpy scalars and arrays
        value = value.tolist()
    if isinstance(value, bool):
        return str(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return _number(value)
    if isinstance(value, complex):
        sign = "-" if math.copysign(1.0, value.imag) < 0 else "+"
        return f"{_number(value.real)}{sign}{_number(abs(value.imag))}j"
    if isinstance(value, (list, tuple)):
        items = [show(v) for v in value[:_MAX_ITEMS]]
        if len(value) > _MAX_ITEMS:
            items.append(f"... ({len(value)} values)")
        text = ", ".join(items)
        return f"({text}{',' if len(value) == 1 else ''})" if isinstance(value, tuple) else f"[{text}]"
    if isinstance(value, Mapping):
        return "{" + ", ".join(f"{k}: {show(v)}" for k, v in value.items()) + "}"
    return str(value)


class InputError(ValueError):
    """Invalid user input: names the offending field, its value and what is allowed.

    ``value`` is kept as given (for programs); the message shows it with :func:`show`.
    """

    def __init__(self, field: str, value: object, allowed: str):
        self.field = field
        self.value = value
        self.allowed = allowed
        super().__init__(f"{field} = {show(value)} is invalid: {allowed}")


class UnitWarning(UserWarning):
    """A value that is valid but whose magnitude suggests a unit slip (e.g. N/µm read as N/m)."""


class FRFWarning(UserWarning):
    """A measured FRF that loads but is probably wrong or incomplete: the imaginary part of a direct
    term has the wrong sign at a resonance (e^{-iωt} convention), or the terms cover different bands
    so part of one term is ignored."""
