"""Point sets: stability-boundary points and labelled test cuts, read from and written to CSV.

File format (UTF-8 CSV, header required, columns in any order)::

    rpm,depth_mm,label,weight,chatter_hz
    5500,1.20,,,           <- boundary point (no label): the limiting depth at that speed
    5600,1.50,chatter,2,1012   <- test cut that chattered (at 1012 Hz), counted twice in weighted objectives
    5600,1.00,stable,,     <- test cut that was stable
    5700,1.25,marginal,,   <- test cut at the edge of chatter (light marks, growing sound)

* ``rpm`` [rev/min] and ``depth_mm`` [mm] are required, both > 0.
* ``label`` (optional column): ``stable``, ``chatter`` or ``marginal`` (case-insensitive) for a test
  cut; an empty cell marks a boundary point.
* ``weight`` (optional column): > 0, default 1 (also for an empty cell).
* ``chatter_hz`` (optional column): the measured chatter frequency [Hz] of a chatter (or marginal)
  cut, > 0; an empty cell means not measured. Given on a stable cut or a boundary point it is an error.
* Blank lines and lines starting with ``#`` are skipped (comments); any other column name is an
  error, so a misspelt header cannot be silently ignored.
"""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path
from typing import Iterable

import numpy as np

from millstab.errors import InputError
from millstab.io.results import PathLike, write_csv
from millstab.io.text import COMMA_ADVICE, check_comma_separated, parse_number, read_text
# the model type lives below io; re-exported so `from millstab.io.points import PointSet` keeps working
from millstab.points import LABEL_RULE, LABELS, PointSet, check_enough

REQUIRED = ("rpm", "depth_mm")
OPTIONAL = ("label", "weight", "chatter_hz")


def _number(text: str, field: str, line: int, path: Path) -> float:
    return parse_number(text, f"{path.name} line {line}, {field}")


def read_points(path: PathLike) -> PointSet:
    """Read a point set CSV (format in the module docstring), or a packaged example points file
    with ``"example:NAME"`` (e.g. ``"example:ex3_points"``, see :mod:`millstab.datasets`).

    Raises:
        InputError: missing file, empty file, missing or unknown column, a non-number (with the
            line number), speed/depth/weight/chatter frequency ≤ 0, unknown label, a chatter
            frequency on a stable cut or a boundary point.
    """
    if str(path).startswith("example:"):  # the CLI hands it over as a Path; str() keeps the text
        from millstab.io.examples import points_path

        path = points_path(str(path).split(":", 1)[1])
    p = Path(path)
    if not p.is_file():
        raise InputError("points file", str(p), "file does not exist")
    text = read_text(p, "points file", "text CSV file")  # spreadsheets and Notepad often write a BOM
    return parse_points(text, p)


def parse_points(text: str, source: PathLike = "points.csv") -> PointSet:
    """Parse point-set CSV text (an upload, a string in a notebook) with the same checks as
    :func:`read_points`; ``source`` names it in messages (its file name) and becomes ``PointSet.source``.

    Raises:
        InputError: as :func:`read_points`.
    """
    p = Path(source)
    text = text.lstrip("\ufeff")
    rows = [(i + 1, row) for i, row in enumerate(csv.reader(text.splitlines()))
            if row and any(c.strip() for c in row) and not row[0].lstrip().startswith("#")]
    if not rows:
        raise InputError("points file", str(p), f"is empty; expected a header {','.join(REQUIRED + OPTIONAL)} and rows")
    header_line, header = rows[0]
    names = [h.strip().lower() for h in header]
    check_comma_separated(names, f"{p.name} line {header_line}", ",".join(header), ",".join(REQUIRED + OPTIONAL))
    allowed = REQUIRED + OPTIONAL
    for h in names:
        if h not in allowed:
            raise InputError(f"{p.name} header", h, f"unknown column; allowed columns: {', '.join(allowed)} "
                                                    f"(required: {', '.join(REQUIRED)})")
    if len(set(names)) != len(names):
        raise InputError(f"{p.name} header", ",".join(names), "a column name appears twice")
    for r in REQUIRED:
        if r not in names:
            raise InputError(f"{p.name} header", ",".join(names), f"missing column {r!r}; required columns: "
                                                                  f"{', '.join(REQUIRED)} (optional: {', '.join(OPTIONAL)})")
    if len(rows) == 1:
        raise InputError("points file", str(p), "has a header but no points")
    col = {h: i for i, h in enumerate(names)}
    rpm, depth, label, weight, hz = [], [], [], [], []
    for line, row in rows[1:]:
        if len(row) > len(names):
            # "5500,1,2" under a two-column header is most often a decimal comma (1,2 mm)
            comma = f"; if a number has a decimal comma: {COMMA_ADVICE}" if re.search(r"\d,\d", ",".join(row)) else ""
            raise InputError(f"{p.name} line {line}", ",".join(row),
                             f"has {len(row)} cells but the header has {len(names)}{comma}")
        cells = [c.strip() for c in row] + [""] * (len(names) - len(row))
        r = _number(cells[col["rpm"]], "rpm", line, p)
        d = _number(cells[col["depth_mm"]], "depth_mm", line, p)
        if r <= 0:
            raise InputError(f"{p.name} line {line}, rpm", cells[col["rpm"]], "spindle speed must be > 0 rev/min")
        if d <= 0:
            raise InputError(f"{p.name} line {line}, depth_mm", cells[col["depth_mm"]], "depth of cut must be > 0 mm")
        lab = cells[col["label"]].lower() if "label" in col else ""
        if lab not in ("",) + LABELS:
            raise InputError(f"{p.name} line {line}, label", cells[col["label"]], LABEL_RULE)
        w = 1.0
        if "weight" in col and cells[col["weight"]]:
            w = _number(cells[col["weight"]], "weight", line, p)
            if w <= 0:
                raise InputError(f"{p.name} line {line}, weight", cells[col["weight"]], "weight must be > 0")
        f = math.nan
        if "chatter_hz" in col and cells[col["chatter_hz"]]:
            f = _number(cells[col["chatter_hz"]], "chatter_hz", line, p)
            if f <= 0:
                raise InputError(f"{p.name} line {line}, chatter_hz", cells[col["chatter_hz"]], "chatter frequency must be > 0 Hz")
            if lab not in ("chatter", "marginal"):
                raise InputError(f"{p.name} line {line}, chatter_hz", cells[col["chatter_hz"]],
                                 f"a chatter frequency belongs to a chatter or marginal cut, not to a "
                                 f"{lab or 'boundary'} point")
        hz.append(f)
        rpm.append(r)
        depth.append(d)
        label.append(lab)
        weight.append(w)
    return PointSet(np.array(rpm), np.array(depth), np.array(label, dtype=object), np.array(weight), p, np.array(hz))


def write_points(path: PathLike, points: PointSet, protect: Iterable[PathLike] = ()) -> Path:
    """Write a point set as CSV (rpm, depth_mm, label, weight, and chatter_hz when any is measured;
    floats written exactly). Atomic; see results."""
    header = ["rpm", "depth_mm", "label", "weight"]
    cols = [points.rpm, points.depth_mm, list(points.label), points.weight]
    if not np.isnan(points.chatter_hz).all():
        header.append("chatter_hz")
        cols.append(points.chatter_hz)
    return write_csv(path, header, cols, protect)


__all__ = ["LABELS", "PointSet", "check_enough", "parse_points", "read_points", "write_points"]
