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
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable

import numpy as np

from millstab.errors import InputError
from millstab.io.results import PathLike, write_csv
from millstab.io.text import COMMA_ADVICE, check_comma_separated, parse_number, read_text

REQUIRED = ("rpm", "depth_mm")
OPTIONAL = ("label", "weight", "chatter_hz")
LABELS = ("stable", "chatter", "marginal")
_LABEL_RULE = "must be 'stable', 'chatter', 'marginal' or empty (boundary point)"


@dataclass(frozen=True, eq=False)
class PointSet:
    """Spindle-speed/depth points, each a boundary point (label ``""``) or a labelled test cut.

    Attributes:
        rpm: spindle speeds (n,) [rev/min], > 0.
        depth_mm: axial depths of cut (n,) [mm], > 0.
        label: (n,) str array: ``"stable"``, ``"chatter"``, ``"marginal"`` or ``""`` (boundary point).
            ``None`` = all boundary points.
        weight: (n,) weights > 0 for weighted objectives; ``None`` = all 1.
        chatter_hz: (n,) measured chatter frequencies [Hz], NaN where not measured; ``None`` = none.
        source: the file the points came from (for messages and ``protect=``), or ``None``.
    """

    rpm: np.ndarray
    depth_mm: np.ndarray
    label: np.ndarray | None = None
    weight: np.ndarray | None = None
    source: Path | None = None
    chatter_hz: np.ndarray | None = None

    def __post_init__(self) -> None:
        rpm = np.atleast_1d(np.asarray(self.rpm, dtype=float))
        depth = np.atleast_1d(np.asarray(self.depth_mm, dtype=float))
        n = rpm.size
        label = np.full(n, "", dtype=object) if self.label is None else np.atleast_1d(np.asarray(self.label, dtype=object))
        weight = np.ones(n) if self.weight is None else np.atleast_1d(np.asarray(self.weight, dtype=float))
        hz = np.full(n, np.nan) if self.chatter_hz is None else np.atleast_1d(np.asarray(self.chatter_hz, dtype=float))
        for name, arr in (("depth_mm", depth), ("label", label), ("weight", weight), ("chatter_hz", hz)):
            if arr.ndim != 1 or arr.size != n:
                raise InputError(f"points.{name}", f"{arr.size} values", f"need one value per speed ({n})")
        for name, arr, unit in (("rpm", rpm, "rev/min"), ("depth_mm", depth, "mm"), ("weight", weight, "")):
            bad = ~(np.isfinite(arr) & (arr > 0))
            if bad.any():
                i = int(np.argmax(bad))
                raise InputError(f"points.{name}[{i}]", float(arr[i]), f"must be a finite number > 0 {unit}".rstrip())
        label = np.array([str(s).strip().lower() for s in label], dtype=object)
        for i, s in enumerate(label):
            if s not in ("",) + LABELS:
                raise InputError(f"points.label[{i}]", s, _LABEL_RULE)
        given = ~np.isnan(hz)
        bad = given & ~(np.isfinite(hz) & (hz > 0))
        if bad.any():
            i = int(np.argmax(bad))
            raise InputError(f"points.chatter_hz[{i}]", float(hz[i]), "must be a finite frequency > 0 Hz (or empty)")
        odd = given & ~np.isin(label, ("chatter", "marginal"))
        if odd.any():
            i = int(np.argmax(odd))
            raise InputError(f"points.chatter_hz[{i}]", float(hz[i]),
                             f"a chatter frequency belongs to a chatter or marginal cut, not to a {label[i] or 'boundary'} point")
        # fixed-width unicode array: comparisons like label == "chatter" give boolean masks
        object.__setattr__(self, "rpm", rpm)
        object.__setattr__(self, "depth_mm", depth)
        object.__setattr__(self, "label", label.astype("<U8") if n else np.array([], dtype="<U8"))
        object.__setattr__(self, "chatter_hz", hz)
        object.__setattr__(self, "weight", weight)
        if self.source is not None:
            object.__setattr__(self, "source", Path(self.source))

    def __len__(self) -> int:
        return int(self.rpm.size)

    @property
    def boundary(self) -> np.ndarray:
        """Boolean mask of the boundary points (no label)."""
        return self.label == ""

    @property
    def stable(self) -> np.ndarray:
        """Boolean mask of the test cuts labelled stable."""
        return self.label == "stable"

    @property
    def chatter(self) -> np.ndarray:
        """Boolean mask of the test cuts labelled chatter."""
        return self.label == "chatter"

    @property
    def marginal(self) -> np.ndarray:
        """Boolean mask of the test cuts labelled marginal (at the edge of chatter)."""
        return self.label == "marginal"

    @property
    def depth_m(self) -> np.ndarray:
        """Depths in metres."""
        return self.depth_mm * 1e-3

    def subset(self, mask: np.ndarray) -> PointSet:
        """The points selected by a boolean mask (or an index array)."""
        m = np.asarray(mask)
        if m.dtype == bool and m.shape != self.rpm.shape:
            raise InputError("points mask", f"{m.size} values", f"need one value per point ({len(self)})")
        return PointSet(self.rpm[m], self.depth_mm[m], self.label[m], self.weight[m], self.source, self.chatter_hz[m])


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
        from millstab.datasets import points_path

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
            raise InputError(f"{p.name} line {line}, label", cells[col["label"]], _LABEL_RULE)
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


def check_enough(points: PointSet, n_free: int) -> int:
    """Return the number of boundary points; raise InputError if fewer than ``n_free``.

    Fitting ``n_free`` parameters to fewer boundary points is underdetermined.
    """
    n = int(np.count_nonzero(points.boundary))
    if n < n_free:
        where = f" in {points.source.name}" if points.source is not None else ""
        raise InputError("points", f"{n} boundary points{where}",
                         f"need at least {n_free} boundary points (rows without a label) to identify "
                         f"{n_free} free parameters; add points or fix (tie) parameters")
    return n


__all__ = ["LABELS", "PointSet", "check_enough", "parse_points", "read_points", "write_points"]
