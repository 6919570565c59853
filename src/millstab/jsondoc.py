"""Plain-JSON documents of the result objects: the schema tag, reading fields back with clear errors,
and the float conventions of the ``millstab.<kind>/1`` schemas.

Every result object writes ``to_json()`` → a dict of plain JSON types only (``json.dumps`` works with
``allow_nan=False``) carrying ``"schema": "millstab.<kind>/1"``, and reads it back with
``from_json(doc, source)``; ``source`` (a file name, or the kind) is named in every error.

Float conventions of the envelope, design and sensitivity schemas (strict JSON has no Infinity or NaN):

* a finite float is a JSON number (Python's repr: it reads back bit for bit);
* +∞ and −∞ are the strings ``"inf"`` and ``"-inf"`` (a limiting depth with no chatter boundary, a
  standard error a design cannot determine): a value, so it must survive the round trip;
* NaN is written as ``null`` only in the fields whose documentation says "not defined" is a value
  there (e.g. the chatter frequency where there is no boundary); anywhere else writing NaN raises
  ``ValueError`` (a result never carries a NaN silently) and reading ``null`` raises InputError.

(The fit schema keeps the older convention of :func:`millstab.io.results.to_jsonable`, every
non-finite float as ``null``, so the public JSON of ``millstab identify --out`` does not change.)
"""

from __future__ import annotations

import math
from typing import Any, Iterable

import numpy as np

from millstab.errors import InputError

_INF = {"inf": math.inf, "-inf": -math.inf}


def check_schema(doc: Any, schema: str, source: str) -> dict:
    """``doc`` when it is a dict whose ``"schema"`` is ``schema``; InputError naming ``source`` otherwise."""
    if not isinstance(doc, dict):
        raise InputError(f"{source}", type(doc).__name__, f"expected a JSON object with \"schema\": {schema!r}")
    got = doc.get("schema")
    if got != schema:
        raise InputError(f"{source}: schema", got, f"expected {schema!r} (a file written by millstab for this result)")
    return doc


def need(doc: dict, key: str, source: str, kinds: type | tuple[type, ...] | None = None) -> Any:
    """``doc[key]``; InputError naming ``source: key`` when it is missing (or not of ``kinds``)."""
    if not isinstance(doc, dict) or key not in doc:
        raise InputError(f"{source}: {key}", "missing", "a required field of this result")
    value = doc[key]
    if kinds is not None and (not isinstance(value, kinds) or isinstance(value, bool) and bool not in _tuple(kinds)):
        names = " or ".join(k.__name__ for k in _tuple(kinds))
        raise InputError(f"{source}: {key}", _short(value), f"must be {names}")
    return value


def _tuple(kinds) -> tuple:
    return kinds if isinstance(kinds, tuple) else (kinds,)


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def number_out(x: float, field: str, nan_ok: bool = False) -> float | str | None:
    """One float in the schema convention (module docstring); ValueError on a NaN not allowed here."""
    v = float(x)
    if math.isfinite(v):
        return v
    if math.isnan(v):
        if nan_ok:
            return None
        raise ValueError(f"{field} holds NaN: a result must not carry a NaN where no 'not defined' is documented")
    return "inf" if v > 0 else "-inf"


def floats_out(a, field: str, nan_ok: bool = False) -> Any:
    """A float array (any shape) as nested lists in the schema convention; ``None`` stays ``None``."""
    if a is None:
        return None
    arr = np.asarray(a, dtype=float)
    if not nan_ok and np.isnan(arr).any():
        raise ValueError(f"{field} holds NaN: a result must not carry a NaN where no 'not defined' is documented")
    if arr.ndim == 0:
        return number_out(arr, field, nan_ok)
    if np.isfinite(arr).all():
        return arr.tolist()
    return _nested(arr, field, nan_ok)


def _nested(arr: np.ndarray, field: str, nan_ok: bool) -> list:
    if arr.ndim == 1:
        return [number_out(v, field, nan_ok) for v in arr.tolist()]
    return [_nested(row, field, nan_ok) for row in arr]


def number_in(value: Any, field: str, nan_ok: bool = False) -> float:
    """One float read in the schema convention; InputError naming ``field`` otherwise."""
    if value is None and nan_ok:
        return math.nan
    if isinstance(value, str) and value in _INF:
        return _INF[value]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        allowed = "a number, \"inf\" or \"-inf\"" + (" or null (not defined)" if nan_ok else "")
        raise InputError(field, _short(value), f"must be {allowed}")
    return float(value)


def floats_in(value: Any, field: str, ndim: int | None = 1, nan_ok: bool = False) -> np.ndarray:
    """A float array from nested lists in the schema convention (``ndim`` checked when given)."""
    if ndim == 0 or not isinstance(value, list):
        if ndim not in (0, None):
            raise InputError(field, _short(value), f"must be a {ndim}-d list of numbers")
        return np.asarray(number_in(value, field, nan_ok))
    try:
        arr = np.array(_nested_in(value, field, nan_ok), dtype=float)
    except ValueError:  # ragged lists
        raise InputError(field, _short(value), "rows of a table must have equal lengths") from None
    if ndim is not None and arr.ndim != ndim and not (arr.size == 0 and ndim >= 1):
        raise InputError(field, f"{arr.ndim}-d list", f"must be a {ndim}-d list of numbers")
    if arr.size == 0 and ndim is not None and arr.ndim != ndim:
        arr = arr.reshape((0,) * ndim)
    return arr


def _nested_in(value: Any, field: str, nan_ok: bool) -> Any:
    if isinstance(value, list):
        return [_nested_in(v, field, nan_ok) for v in value]
    return number_in(value, field, nan_ok)


def ints_in(value: Any, field: str) -> np.ndarray:
    """A 1-d integer array (int64) from a list of integers."""
    if not isinstance(value, list) or any(isinstance(v, bool) or not isinstance(v, int) for v in value):
        raise InputError(field, _short(value), "must be a list of integers")
    return np.asarray(value, dtype=np.int64).reshape(len(value))


def names_in(value: Any, field: str) -> tuple[str, ...]:
    """A tuple of names from a list of strings."""
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise InputError(field, _short(value), "must be a list of names (strings)")
    return tuple(value)


def int_in(value: Any, field: str) -> int:
    """An integer (not a bool)."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise InputError(field, _short(value), "must be an integer")
    return int(value)


def per_name_out(names: Iterable[str], arr, field: str, nan_ok: bool = False) -> dict[str, Any]:
    """{name: column j of ``arr``} (the last axis indexes the names), schema floats."""
    a = np.asarray(arr, dtype=float)
    return {n: floats_out(a[..., j], f"{field}.{n}", nan_ok) for j, n in enumerate(names)}


def per_name_in(value: Any, names: tuple[str, ...], field: str, ndim: int = 0, nan_ok: bool = False) -> np.ndarray:
    """The inverse of :func:`per_name_out`: an array whose last axis indexes ``names``."""
    if not isinstance(value, dict):
        raise InputError(field, _short(value), f"must be an object keyed by the parameter names ({', '.join(names)})")
    missing = [n for n in names if n not in value]
    if missing:
        raise InputError(f"{field}.{missing[0]}", "missing", "one entry per parameter is required")
    cols = [floats_in(value[n], f"{field}.{n}", ndim, nan_ok) for n in names]
    if ndim == 0:
        return np.array([float(c) for c in cols], dtype=float)
    shapes = {c.shape for c in cols}
    if len(shapes) > 1:
        raise InputError(field, f"shapes {sorted(shapes)}", "every parameter's entry must have the same length")
    return np.stack(cols, axis=-1) if cols else np.zeros((0,) * ndim + (0,))


def plain(obj: Any, field: str, nan_ok: bool = False) -> Any:
    """``obj`` (dicts, lists, tuples, numpy arrays and scalars, numbers, strings) as plain JSON types
    in the schema float convention (module docstring); NaN only with ``nan_ok`` (as ``null``)."""
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return number_out(obj, field, nan_ok)
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind in "iub":
            return obj.tolist()
        return floats_out(obj, field, nan_ok)
    if isinstance(obj, dict):
        return {str(k): plain(v, f"{field}.{k}", nan_ok) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [plain(v, field, nan_ok) for v in obj]
    raise TypeError(f"{field}: cannot write an object of type {type(obj).__name__} to JSON")


__all__ = ["check_schema", "floats_in", "floats_out", "int_in", "ints_in", "names_in", "need",
           "number_in", "number_out", "per_name_in", "per_name_out", "plain"]
