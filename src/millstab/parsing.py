"""Parsing option text shared by the command line and any other front end (one place, one set of
messages): ``NAME=VALUE`` lists, ``START:STOP:STEP`` speed grids and ``LOW:HIGH`` / ``START:STOP:STEP``
ranges. Each error is an :class:`InputError` naming the option and the text as written.
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

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


def parse_rpm_range(text: str) -> np.ndarray:
    """``START:STOP:STEP`` in rpm (STOP included when it falls on the grid) → speeds array."""
    parts = text.split(":")
    if len(parts) != 3:
        raise InputError("--rpm", text, "expected START:STOP:STEP in rev/min, e.g. 2000:12000:25")
    try:
        start, stop, step = (float(p) for p in parts)
    except ValueError:
        raise InputError("--rpm", text, "START, STOP and STEP must be numbers (rev/min)") from None
    if not (start > 0 and stop > start and step > 0):
        raise InputError("--rpm", text, "need 0 < START < STOP and STEP > 0")
    n = int(np.floor((stop - start) / step + 1e-9)) + 1
    if n > 1_000_000:
        raise InputError("--rpm", text, f"{n} speeds is too many (max 1e6); use a larger STEP")
    return start + step * np.arange(n)


def parse_range(text: str, option: str, unit: str, parts_wanted: int) -> tuple[float, ...]:
    """``A:B`` (``parts_wanted`` 2) or ``A:B:S`` (3) → floats ≥ 0 in ``unit``, with a one-line error naming the option."""
    parts = text.split(":")
    form = "LOW:HIGH" if parts_wanted == 2 else "START:STOP:STEP"
    if len(parts) != parts_wanted:
        raise InputError(option, text, f"expected {form} in {unit}")
    try:
        vals = tuple(float(p) for p in parts)
    except ValueError:
        raise InputError(option, text, f"{form} must be numbers ({unit})") from None
    if not all(math.isfinite(v) for v in vals) or not 0 <= vals[0] < vals[1] or (parts_wanted == 3 and vals[2] <= 0):
        raise InputError(option, text, f"need 0 <= {form.split(':')[0]} < {form.split(':')[1]}" +
                         (" and STEP > 0" if parts_wanted == 3 else ""))
    return vals


__all__ = ["parse_assignments", "parse_range", "parse_rpm_range"]
