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


#: every result that round-trips through JSON: (module, class, schema). docs/architecture.md's results table is
#: generated from it (``python docs/tables.py``), and tests/test_results.py round-trips one of each (a written
#: document rebuilds an equal object; another schema is an InputError), so a new result type goes here.
RESULTS: tuple[tuple[str, str, str], ...] = (
    ("millstab.identify.result", "Fit", "millstab.fit/1"),
    ("millstab.identify.design", "SpeedDesign", "millstab.design/1"),
    ("millstab.stability.base", "Envelope", "millstab.envelope/1"),
    ("millstab.sensitivity.results", "OATResult", "millstab.sensitivity.oat/1"),
    ("millstab.sensitivity.results", "MCResult", "millstab.sensitivity.mc/1"),
    ("millstab.sensitivity.results", "SobolResult", "millstab.sensitivity.sobol/1"),
    ("millstab.sensitivity.results", "MorrisResult", "millstab.sensitivity.morris/1"),
    ("millstab.update.posterior", "Posterior", "millstab.posterior/3"),
    ("millstab.update.decide", "Recommendation", "millstab.recommendation/1"),
    ("millstab.simulate", "CutResult", "millstab.simulate.cut/1"),
    ("millstab.simulate", "Labels", "millstab.simulate.labels/1"),
    ("millstab.simulate.detect", "Detection", "millstab.simulate.detection/1"),
    ("millstab.api.lobes", "Lobes", "millstab.lobes/1"),
    ("millstab.api.sensitivity", "Study", "millstab.sensitivity.study/1"),
    ("millstab.api.listen", "Heard", "millstab.listen.heard/1"),
    ("millstab.modal.run", "ModalResult", "millstab.modal.result/1"),
    ("millstab.api.predict", "Prediction", "millstab.prediction/1"),
    ("millstab.api.tooltip", "TipFRF", "millstab.tooltip.tip/1"),
)
#: documents written but not read back (a report of a run, not an input of another): (module, writer, schema)
WRITTEN: tuple[tuple[str, str, str], ...] = (
    ("millstab.modal.output", "quality", "millstab.modal/1"),
    ("millstab.update.validate", "Validation", "millstab.validation/1"),
)


__all__ = ["RESULTS", "WRITTEN", "check_schema", "complex_in", "complex_out", "config_in", "config_out", "cutting_in",
           "cutting_out", "fields_in", "fields_out", "floats_in", "floats_out", "int_in", "ints_in", "names_in", "need",
           "number_in", "number_out", "per_name_in", "per_name_out", "plain", "points_in", "points_out", "structure_in",
           "structure_out"]


# --- a frozen dataclass field by field --------------------------------------------------------------------
def fields_out(obj: Any, schema: str) -> dict:
    """The JSON of a frozen dataclass result, every field under its own name, with ``"schema"``: float
    arrays and floats in the convention above (NaN as ``null``: these results document NaN as "not
    defined", e.g. no chatter frequency of a stable cut; ±∞ as text), string arrays and tuples as lists.
    A field named ``schema`` (simulate's results carry their tag as a field) is the tag."""
    import dataclasses

    out: dict[str, Any] = {"schema": schema}
    for f in dataclasses.fields(obj):
        if f.name != "schema":
            out[f.name] = _out(getattr(obj, f.name), f.name)
    return out


def _out(v: Any, field: str) -> Any:
    if isinstance(v, np.ndarray):
        return floats_out(v, field, nan_ok=True) if v.dtype.kind in "fiu" else [str(x) for x in v.tolist()]
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        return number_out(v, field, nan_ok=True)
    if isinstance(v, (tuple, list)):
        return [_out(x, field) for x in v]
    if isinstance(v, dict):
        return {str(k): _out(x, f"{field}.{k}") for k, x in v.items()}
    return v


def fields_in(cls: type, doc: Any, schema: str, source: str) -> Any:
    """Rebuild a :func:`fields_out` document as ``cls`` (a frozen dataclass): each field read by its type
    annotation (float, int, bool, str, numpy array, tuple, dict, ``X | None``); a field with a default may
    be absent (a file written before it existed).

    Raises:
        InputError: another schema, a missing field, or a value of the wrong kind (named ``source: field``).
    """
    import dataclasses
    import typing

    check_schema(doc, schema, source)
    hints = typing.get_type_hints(cls)
    kw = {}
    for f in dataclasses.fields(cls):
        if f.name == "schema":
            continue
        if f.name not in doc:
            if f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING:
                continue
            raise InputError(f"{source}: {f.name}", "missing", "a required field of this result")
        kw[f.name] = _in(doc[f.name], hints[f.name], f"{source}: {f.name}")
    return cls(**kw)


def _in(v: Any, hint: Any, field: str) -> Any:
    import types
    import typing

    args = typing.get_args(hint)
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        if v is None and type(None) in args:
            return None
        hint = next(a for a in args if a is not type(None))
        args = typing.get_args(hint)
    origin = typing.get_origin(hint) or hint
    if origin is np.ndarray:
        if isinstance(v, list) and v and all(isinstance(x, str) for x in v):
            return np.array(v)
        return floats_in(v, field, ndim=None, nan_ok=True)
    if origin is float:
        return number_in(v, field, nan_ok=True)
    if origin is tuple:
        if not isinstance(v, list):
            raise InputError(field, _short(v), "must be a list")
        items = args[:1] * len(v) if len(args) == 2 and args[1] is Ellipsis else args
        if len(items) != len(v):
            raise InputError(field, _short(v), f"must be a list of {len(items)} values")
        return tuple(_in(x, a, field) for x, a in zip(v, items))
    if origin in (int, bool, str, dict, list):
        if isinstance(v, bool) != (origin is bool) or not isinstance(v, origin):
            raise InputError(field, _short(v), f"must be a {origin.__name__}")
        return v
    return v


# --- the inputs a result carries: cutting, structure, config ---------------------------------------------
def complex_out(a, field: str) -> dict | None:
    """A complex array as ``{"re": [...], "im": [...]}`` (finite values only); ``None`` stays ``None``."""
    if a is None:
        return None
    z = np.asarray(a, dtype=complex)
    return {"re": floats_out(z.real, f"{field}.re"), "im": floats_out(z.imag, f"{field}.im")}


def complex_in(value: Any, field: str) -> np.ndarray | None:
    """The inverse of :func:`complex_out` (bit for bit: both parts are JSON numbers)."""
    if value is None:
        return None
    if not isinstance(value, dict):
        raise InputError(field, _short(value), 'must be {"re": [...], "im": [...]}')
    re = floats_in(need(value, "re", field), f"{field}.re", ndim=None)
    im = floats_in(need(value, "im", field), f"{field}.im", ndim=None)
    if re.shape != im.shape:
        raise InputError(field, f"re {re.shape}, im {im.shape}", "real and imaginary parts of equal length")
    return re + 1j * im


def cutting_out(cutting) -> dict:
    """Cutting conditions in SI: teeth, kt [N/m²], kr, entry and exit [rad], process_damping [N/m],
    diameter [m] or null."""
    c = cutting
    return {"teeth": int(c.teeth), "kt": float(c.kt), "kr": float(c.kr), "entry": float(c.entry),
            "exit": float(c.exit), "process_damping": float(c.process_damping),
            "diameter": None if c.diameter is None else float(c.diameter)}


def cutting_in(doc: Any, source: str):
    """The inverse of :func:`cutting_out` (the conditions validate themselves: InputError)."""
    from millstab.model import Cutting

    if not isinstance(doc, dict):
        raise InputError(source, _short(doc), "must be an object of cutting conditions")
    num = {k: number_in(need(doc, k, source), f"{source}.{k}") for k in ("kt", "kr", "entry", "exit")}
    dia = doc.get("diameter")
    return Cutting(int_in(need(doc, "teeth", source), f"{source}.teeth"), num["kt"], num["kr"], num["entry"],
                   num["exit"], number_in(doc.get("process_damping", 0.0), f"{source}.process_damping"),
                   None if dia is None else number_in(dia, f"{source}.diameter"))


def structure_out(structure) -> dict:
    """A structure: modes ``{"x": [{fn [Hz], k [N/m], zeta}], "y": [...]}`` or a measured FRF
    ``{"frf": {"freq_hz", "xx", "yy", "xy", "yx"}}`` (complex receptances [m/N], :func:`complex_out`)."""
    if structure.frf is not None:
        f = structure.frf
        return {"frf": {"freq_hz": floats_out(f.freq_hz, "frf.freq_hz"),
                        **{t: complex_out(getattr(f, t), f"frf.{t}") for t in ("xx", "yy", "xy", "yx")}}}
    return {d: [{"fn": float(m.fn), "k": float(m.k), "zeta": float(m.zeta)} for m in getattr(structure, d)]
            for d in ("x", "y")}


def structure_in(doc: Any, source: str):
    """The inverse of :func:`structure_out` (modes named ``structure.x[0]`` as a config names them)."""
    from millstab.model import MeasuredFRF, Mode, Structure

    if not isinstance(doc, dict):
        raise InputError(source, _short(doc), "must be an object with x and y modes or a measured frf")
    if "frf" in doc:
        f = need(doc, "frf", source, dict)
        freq = floats_in(need(f, "freq_hz", f"{source}.frf"), f"{source}.frf.freq_hz")
        terms = [complex_in(f.get(t), f"{source}.frf.{t}") for t in ("xx", "yy", "xy", "yx")]
        return Structure(frf=MeasuredFRF(freq, *terms))
    modes = {}
    for d in ("x", "y"):
        rows = need(doc, d, source, list)
        modes[d] = tuple(Mode(*(number_in(need(m, k, f"{source}.{d}[{i}]"), f"{source}.{d}[{i}].{k}")
                                for k in ("fn", "k", "zeta")), f"structure.{d}[{i}]") for i, m in enumerate(rows))
    return Structure(**modes)


def points_out(ps) -> dict:
    """A :class:`millstab.points.PointSet`, every column under its own name (speeds [rpm], depths [mm], labels,
    weights, chatter frequencies [Hz], grades, test days, each rater's grade, the kept columns and the per-cut
    conditions; NaN as ``null`` where a cell is empty), its source file's name and its file's column order
    (``columns``, ``null`` for points not read from a file)."""
    return {"rpm": floats_out(ps.rpm, "rpm"), "depth_mm": floats_out(ps.depth_mm, "depth_mm"),
            "label": [str(x) for x in ps.label], "weight": floats_out(ps.weight, "weight"),
            "chatter_hz": floats_out(ps.chatter_hz, "chatter_hz", nan_ok=True),
            "grade": floats_out(ps.grade, "grade", nan_ok=True), "batch": [str(x) for x in ps.batch],
            "ratings": floats_out(ps.ratings, "ratings", nan_ok=True), "raters": list(ps.raters),
            "extra": {k: [str(x) for x in v] for k, v in ps.extra.items()},
            "conditions": {k: ([str(x) for x in v] if v.dtype.kind in "UO" else floats_out(v, k, nan_ok=True))
                           for k, v in ps.conditions.items()},
            "source": None if ps.source is None else str(ps.source),
            "columns": None if ps.columns is None else list(ps.columns)}


def points_in(doc: Any, source: str):
    """The inverse of :func:`points_out` (the points validate themselves: InputError); a document without
    ``columns`` (written before it was kept) reads as points not read from a file."""
    from millstab.points import PointSet

    if not isinstance(doc, dict):
        raise InputError(source, _short(doc), "must be an object of cuts (rpm, depth_mm, label, ...)")
    n = len(need(doc, "rpm", source, list))
    raters = names_in(need(doc, "raters", source), f"{source}.raters")
    ratings = floats_in(need(doc, "ratings", source), f"{source}.ratings", ndim=None, nan_ok=True)
    if ratings.size != n * len(raters):
        raise InputError(f"{source}.ratings", f"{ratings.size} values", f"one per cut and rater ({n} × {len(raters)})")
    cond = need(doc, "conditions", source, dict)
    src, order = doc.get("source"), doc.get("columns")
    return PointSet(floats_in(doc["rpm"], f"{source}.rpm", 1),
                    floats_in(need(doc, "depth_mm", source), f"{source}.depth_mm", 1),
                    names_in(need(doc, "label", source), f"{source}.label"),
                    floats_in(need(doc, "weight", source), f"{source}.weight", 1), None if src is None else str(src),
                    floats_in(need(doc, "chatter_hz", source), f"{source}.chatter_hz", 1, nan_ok=True),
                    floats_in(need(doc, "grade", source), f"{source}.grade", 1, nan_ok=True),
                    names_in(need(doc, "batch", source), f"{source}.batch"), ratings.reshape(n, len(raters)), raters,
                    {k: names_in(v, f"{source}.extra.{k}") for k, v in need(doc, "extra", source, dict).items()},
                    {k: (names_in(v, f"{source}.conditions.{k}") if k == "milling" else
                         floats_in(v, f"{source}.conditions.{k}", 1, nan_ok=True)) for k, v in cond.items()},
                    None if order is None else names_in(order, f"{source}.columns"))


def config_out(cfg) -> dict:
    """What a result keeps of the config it was computed from: its name, description, cutting conditions
    and structure (:func:`cutting_out`, :func:`structure_out`). Not its file path, ``[speeds]``, ``[prior]``
    or ``[tool]``/``[holder]`` tables: those are inputs of other tasks, and the result holds its own speeds."""
    return {"name": cfg.name, "description": cfg.description, "cutting": cutting_out(cfg.cutting),
            "structure": structure_out(cfg.structure)}


def config_in(doc: Any, source: str):
    """The :class:`millstab.config.Config` of :func:`config_out` (no path, speeds, prior or tool)."""
    from millstab.config import Config

    if not isinstance(doc, dict):
        raise InputError(source, _short(doc), "must be an object with the config's name, cutting and structure")
    return Config(cutting_in(need(doc, "cutting", source), f"{source}.cutting"),
                  structure_in(need(doc, "structure", source), f"{source}.structure"),
                  need(doc, "name", source, str), description=need(doc, "description", source, str))
