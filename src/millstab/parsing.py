"""Parsing option text shared by the command line and any other front end (one place, one set of
messages): ``NAME=VALUE`` lists, ``START:STOP:STEP`` speed grids and ``LOW:HIGH`` / ``START:STOP:STEP``
ranges, the risk of a decision, for command-line options, config values and web forms alike. Each error is an
:class:`InputError` naming the option, the text as written and what is allowed.
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from millstab.bounds import check_speeds
from millstab.errors import InputError


def parse_assignments(text: str | Mapping[str, float] | None, field_name: str = "--initial") -> dict[str, float]:
    """``"fn_x=900,k_x=12e6"`` → {name: value} (SI: Hz, N/m, -). Raises InputError naming the bad item."""
    if text is None:
        return {}
    if isinstance(text, Mapping):
        return {str(k): float(v) for k, v in text.items()}
    out: dict[str, float] = {}
    for item in (s.strip() for s in str(text).split(",")):
        if not item:
            continue
        if "=" not in item:
            raise InputError(field_name, item, "expected NAME=VALUE items separated by commas, e.g. fn_x=900,k_x=12e6")
        name, value = (s.strip() for s in item.split("=", 1))
        try:
            v = float(value)
        except ValueError:
            raise InputError(f"{field_name} {name}", value, "must be a number in SI units (Hz, N/m, -)") from None
        if not (math.isfinite(v) and v > 0):
            raise InputError(f"{field_name} {name}", value, "must be a finite number > 0 (Hz, N/m, -)")
        out[name] = v
    return out


#: units that mark a range of spindle speeds (checked against millstab.bounds)
_SPEED_UNITS = ("rpm", "rev/min")
#: the most grid points a range may expand to
MAX_POINTS = 1_000_000


def parse_interval(text: str, field: str, unit: str, *, positive: bool = False) -> tuple[float, float]:
    """``LOW:HIGH`` → (low, high) with 0 ≤ low < high (0 < low with ``positive``); a range of spindle speeds
    (``unit`` rpm or rev/min) must also lie within :func:`millstab.bounds.check_speeds`'s bounds."""
    lo, hi = _numbers(text, field, unit, "LOW:HIGH")
    if not (lo > 0 if positive else lo >= 0) or not hi > lo:
        raise InputError(field, text, f"need {'0 <' if positive else '0 <='} LOW < HIGH ({unit})")
    if unit in _SPEED_UNITS:
        check_speeds((lo, hi), field, text)
    return lo, hi


def parse_grid(text: str, field: str, unit: str, *, positive: bool = False, example: str = "",
               single: bool = False) -> np.ndarray:
    """``START:STOP:STEP`` → the grid START, START + STEP, … (STOP included when it falls on the grid);
    with ``single``, START = STOP is that one point (a grid of one, as a file of one line is).

    Raises:
        InputError: not three numbers, START < 0 (≤ 0 with ``positive``), STOP ≤ START (< START with
            ``single``), STEP ≤ 0, or more than :data:`MAX_POINTS` points.
    """
    start, stop, step = _numbers(text, field, unit, "START:STOP:STEP", example)
    if not ((start > 0 if positive else start >= 0) and (stop >= start if single else stop > start) and step > 0):
        order = "START < STOP (or START = STOP: that one value)" if single else "START < STOP"
        raise InputError(field, text, f"need {'0 <' if positive else '0 <='} {order} and STEP > 0 ({unit})")
    n = int(math.floor((stop - start) / step + 1e-9)) + 1
    if n > MAX_POINTS:
        raise InputError(field, text, f"{n} points is too many (max {MAX_POINTS:.0e}); use a larger STEP")
    return start + step * np.arange(n)


def parse_rpm_range(text: str, field: str = "--rpm", *, single: bool = False) -> np.ndarray:
    """Spindle speeds ``START:STOP:STEP`` [rev/min], all within :func:`millstab.bounds.check_speeds`'s bounds
    (10..500 000 rev/min: below, the engines' work grows without bound); with ``single`` (where a speeds file
    of one line is taken too: :func:`millstab.api.speeds`), START = STOP is that one speed."""
    grid = parse_grid(text, field, "rev/min", positive=True, example="2000:12000:25", single=single)
    check_speeds(grid, field, text)
    return grid


def _numbers(text: str, field: str, unit: str, form: str, example: str = "") -> tuple[float, ...]:
    parts = str(text).split(":")
    eg = f", e.g. {example}" if example else ""
    if len(parts) != form.count(":") + 1:
        raise InputError(field, text, f"expected {form} in {unit}{eg}")
    try:
        vals = tuple(float(p) for p in parts)
    except ValueError:
        raise InputError(field, text, f"{form} must be numbers ({unit}){eg}") from None
    if not all(math.isfinite(v) for v in vals):
        raise InputError(field, text, f"{form} must be finite numbers ({unit})")
    return vals


def check_risk(risk, field: str = "--risk") -> float:
    """``risk`` as a float when it is a probability of chatter in (0, 1) (NaN and booleans refused): the rule of
    ``recommend``, the API and the app's field, each naming its own ``field``.

    Raises:
        InputError: naming ``field``, the value and the allowed range.
    """
    try:
        r = float(risk) if not isinstance(risk, bool) else math.nan
    except (TypeError, ValueError):
        r = math.nan
    if not 0 < r < 1:
        raise InputError(field, risk, "the tolerated probability of chatter must be in (0, 1), e.g. 0.05")
    return r


__all__ = ["MAX_POINTS", "check_risk", "parse_assignments", "parse_grid", "parse_interval", "parse_rpm_range"]
