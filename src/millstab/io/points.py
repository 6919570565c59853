"""Point sets: stability-boundary points and labelled test cuts, read from and written to CSV.

File format (UTF-8 CSV, header required, columns in any order, names case-insensitive)::

    rpm,depth_mm,label,weight,chatter_hz
    5500,1.20,,,           <- boundary point (no label): the limiting depth at that speed
    5600,1.50,chatter,2,1012   <- test cut that chattered (at 1012 Hz), counted twice in weighted objectives
    5600,1.00,stable,,     <- test cut that was stable
    5700,1.25,marginal,,   <- test cut at the edge of chatter (light marks, growing sound)

* ``rpm`` [rev/min] and ``depth_mm`` [mm] are required, both > 0.
* ``label`` (optional column): a test cut's written label; an empty cell marks a boundary point (the lines are named
  in a warning where other rows are labelled: a forgotten label reads the same).
  A cell may be ``stable``, ``chatter`` or ``marginal`` (``uncertain`` and ``unsure`` read as
  marginal), a probability of chatter in [0, 1] (``0.7`` or ``70 %``), or a code mapped by the
  ``labels`` argument (``--labels 0=stable,1=marginal,2=chatter``; a number outside [0, 1] without a
  mapping is an error that suggests the option; ``yes``/``no`` must be mapped too: they do not say
  which way). The cut's **grade** (``PointSet.grade``) is that number (stable 0, marginal ½, chatter 1)
  and its **label** the nearest class: grade < ⅓ stable, > ⅔ chatter, else marginal.
* Several raters: one column per rater, ``label_NAME`` (or ``rater_NAME``, ``labelN``), e.g.
  ``label_op1,label_op2``; each cell as above, empty = that rater wrote nothing. The grade is the mean of
  the grades present on the row (a row no rater labelled is a boundary point); each rater's grade is kept
  in ``PointSet.ratings`` (n × R, NaN = not rated) with the names in ``PointSet.raters``.
* ``weight`` (optional column): > 0, default 1 (also for an empty cell).
* ``chatter_hz`` (optional column): the measured chatter frequency [Hz] of a chatter (or marginal)
  cut, > 0; an empty cell means not measured. Given on a stable cut or a boundary point it is an error.
* ``batch`` (or ``date``, ``day``, ``session``; the first of these present): the test day or session
  of each cut, as written (``PointSet.batch``).
* Any other column (feed, notes, tool, ...) is kept as text in ``PointSet.extra`` and ignored, with
  one warning naming the columns. A column that looks like a misspelt known column that is absent
  (``lable``, ``weigth``, ``depht_mm``, ``stickout`` for the kept ``stickout_mm``; a rater's ``lable_op2`` that
  holds labels) is an error, since a silently
  ignored label column would turn every cut into a boundary point (a column only somewhat like one, such as
  ``chatter_frequency``, is named in the warning with the column it may stand for); so is a file without a label
  column whose other column holds label words (``result``: stable, chatter); a column of codes alone (0/1/2) there
  is warned about.
* Per-cut cutting conditions (optional columns; an empty cell or a missing column takes the config's
  value; docs/updating.md, "Many conditions"): ``radial_immersion`` (a/D in (0, 1], or ``25 %``) or
  ``radial_width_mm`` (needs ``diameter`` in the config's ``[cutting]``), ``milling`` (up | down),
  ``entry_deg``/``exit_deg`` (together, instead of a/D and milling), ``feed_per_tooth_mm``, ``teeth``.
  Kept in ``PointSet.conditions``; contradicting cells on one row (a/D and width, a/D and angles) are errors.
* Blank lines and lines starting with ``#`` are skipped (comments).
"""

from __future__ import annotations

import difflib
import math
import re
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from millstab.errors import InputError
from millstab.io.results import PathLike, write_csv
from millstab.io.text import COMMA_ADVICE, check_comma_separated, csv_rows, looks_like, parse_number, read_text
# the model type lives below io (import it from millstab.points, its one home)
from millstab.points import (CONDITION_COLUMNS, GRADE, LABELS, SYNONYMS, PointSet, check_conditions, check_enough,
                              grade_of_cell, label_of_grade, parse_label_codes)
from millstab.warnlog import warn

REQUIRED = ("rpm", "depth_mm")
OPTIONAL = ("label", "weight", "chatter_hz", "batch") + CONDITION_COLUMNS
#: columns that name the test day or session (PointSet.batch), in order of preference
BATCH_COLUMNS = ("batch", "date", "day", "session")
#: a rater's label column: label, label_NAME / labelN, rater_NAME / raterN
RATER_COLUMN = re.compile(r"^(?:label|rater)(?:[_\- ](?P<name>\w.*)|(?P<num>\d+))?$")


def _number(text: str, field: str, line: int, path: Path) -> float:
    return parse_number(text, f"{path.name} line {line}, {field}")


def read_points(path: PathLike, labels: str | dict | None = None, *, labels_option: bool = True) -> PointSet:
    """Read a point set CSV (format in the module docstring), or a packaged example points file
    with ``"example:NAME"`` (e.g. ``"example:ex3_points"``, see :mod:`millstab.datasets`).

    ``labels``: codes of the label cells, ``"0=stable,1=marginal,2=chatter"`` or its
    :func:`~millstab.points.parse_label_codes` dict (the CLI's ``--labels``). ``labels_option=False``: the
    caller has no ``--labels`` (identify, lobes, simulate), so an unknown label's message says what the file
    may hold rather than suggesting that option.

    Raises:
        InputError: missing file, empty file, missing or misspelt column, a non-number (with the
            line number), speed/depth/weight/chatter frequency ≤ 0, an unknown label (a code without
            ``labels``), a chatter frequency on a stable cut or a boundary point.
    Warns:
        UserWarning: once, naming the columns millstab does not use (kept in ``PointSet.extra``).
    """
    if str(path).startswith("example:"):  # the CLI hands it over as a Path; str() keeps the text
        from millstab.io.examples import points_path

        path = points_path(str(path).split(":", 1)[1])
    p = Path(path)
    if not p.is_file():
        raise InputError("points file", str(p), "file does not exist")
    text = read_text(p, "points file", "text CSV file")  # spreadsheets and Notepad often write a BOM
    return parse_points(text, p, labels, labels_option=labels_option)


#: depth_mm outside this range [mm] for every cut of a file is warned about: a file of metres (0.002 = 2 mm) or of
#: micrometres (2000 = 2 mm); micromilling's shallowest tests (~0.02 mm) and long-reach cuts lie inside it
DEPTH_SCALE_MM = (0.02, 300.0)
#: columns kept as text in ``PointSet.extra`` for a reader of their own, so not "ignored": the tool stickout of each
#: cut (:mod:`millstab.io.stickout`, a posterior over the holder), the recording a cut is labelled from by listening
#: and a tap recorded by its sensor (:func:`millstab.io.recordings.read_cuts_with_recordings`)
KEPT_COLUMNS = ("stickout_mm", "recording", "tap")


def _columns(names: list[str], p: Path) -> tuple[list[tuple[str, int]], str | None, list[str], dict[str, str]]:
    """(rater columns [(rater name, index)], the batch column or None, the unused columns, {unused column: the
    absent known column it may stand for}) of a header; a misspelt known column (close to one that is absent) is
    an error, anything else unknown is unused."""
    raters = []
    for i, h in enumerate(names):
        m = RATER_COLUMN.match(h)
        if m:
            raters.append(((m.group("name") or m.group("num") or h).strip(), i))
    batch = next((b for b in BATCH_COLUMNS if b in names), None)
    known = (set(REQUIRED) | {"weight", "chatter_hz"} | {names[i] for _, i in raters} | ({batch} if batch else set())
             | set(CONDITION_COLUMNS))
    unknown = [h for h in names if h not in known and h not in BATCH_COLUMNS]
    # the kept columns too: "stickout" for stickout_mm put every cut at the config's stickout with a mere warning
    absent = ([k for k in REQUIRED + ("weight", "chatter_hz") + CONDITION_COLUMNS + KEPT_COLUMNS if k not in names]
              + ([] if raters else ["label"]))
    for r in REQUIRED:
        if r not in names:
            near = difflib.get_close_matches(r, unknown, 1, 0.6)
            hint = f" (the unknown column {near[0]!r} looks like a misspelt {r!r})" if near else ""
            raise InputError(f"{p.name} header", ",".join(names), f"missing column {r!r}{hint}; required columns: "
                                                                  f"{', '.join(REQUIRED)} (optional: "
                                                                  f"{', '.join(OPTIONAL)})")
    for h in unknown:
        near = difflib.get_close_matches(h, absent, 1, 0.8)
        if near:  # "lable", "weigth": a misspelt column would silently turn every cut into a boundary point
            raise InputError(f"{p.name} header", h,
                             f"unknown column that looks like a misspelt {near[0]!r}; allowed columns: "
                             f"{', '.join(REQUIRED + OPTIONAL)}, label_NAME per rater, date, "
                             f"{', '.join(KEPT_COLUMNS)}; other columns are kept and ignored")
    unused = [h for h in names if h not in known]
    # a looser likeness is only named in the warning (chatter_frequency for chatter_hz)
    maybe = {h: near[0] for h in unused if (near := difflib.get_close_matches(h, absent, 1, 0.55))}
    return raters, batch, unused, maybe


#: a column named like a rater's label column with its prefix misspelt: lable_op2, labl_op2, lbl_2, labels_op1, rate_b
MISSPELT_RATER = re.compile(r"^(?P<prefix>[a-z]+)(?:[_\- ](?P<name>\w.*)|(?P<num>\d+))$")


def _misspelt_rater(column: str) -> str | None:
    """The rater column ``column`` may stand for (``label_op2`` for ``lable_op2``), or ``None``: its prefix is
    close to ``label`` or ``rater`` without being either."""
    m = MISSPELT_RATER.match(column)
    if not m or RATER_COLUMN.match(column):
        return None
    near = difflib.get_close_matches(m.group("prefix"), ["label", "rater"], 1, 0.75)
    if not near:
        return None
    return f"{near[0]}_{m.group('name')}" if m.group("name") else f"{near[0]}{m.group('num')}"


#: a test day written as a date: 2026-03-04, 04/03/2026, 4.3.26, 2026/3/4 (the digits' grouping is its format)
DATE_CELL = re.compile(r"^\d{1,4}([-/.])\d{1,2}\1\d{1,4}$")


def _date_formats(cells: list[str], lines: list[int]) -> dict[str, tuple[str, int]]:
    """{format: (the first cell written so, its line)} of the cells that are dates; a format is the cell with each
    digit as 9 and each run of 1-2 digits as one group (``9999-99-99``, ``99/99/9999``), so that 4.3.26 and
    04.03.26 are one format."""
    out: dict[str, tuple[str, int]] = {}
    for c, line in zip(cells, lines):
        if DATE_CELL.match(c):
            shape = re.sub(r"\d+", lambda m: "9999" if len(m.group()) > 2 else "99", c)
            out.setdefault(shape, (c, line))
    return out


def _holds_labels(cells: list[str], codes: dict[str, float]) -> bool:
    """True when a column's non-empty cells all read as label words or codes (stable | marginal | chatter and
    their synonyms, ``codes``' keys, or the 0/1/2 shops write for no / uncertain / clear chatter) and take at
    least two values: a constant column (a feed of 0.1) or one of other numbers is not mistaken for labels."""
    filled = {c.strip().lower() for c in cells if c.strip()}
    words = set(GRADE) | set(SYNONYMS) | set(codes) | {"0", "1", "2"}
    return len(filled) >= 2 and filled <= words


def _holds_words(cells: list[str]) -> bool:
    """True when some cell of a column is a label word (stable, chatter, marginal or a synonym), not only a code."""
    return any(c.strip().lower() in GRADE or c.strip().lower() in SYNONYMS for c in cells)


def parse_points(text: str, source: PathLike = "points.csv", labels: str | dict | None = None, *,
                 labels_option: bool = True) -> PointSet:
    """Parse point-set CSV text (an upload, a string in a notebook) with the same checks as
    :func:`read_points`; ``source`` names it in messages (its file name) and becomes ``PointSet.source``;
    ``labels``: codes of the label cells, ``labels_option``: whether the caller has ``--labels`` (see
    :func:`read_points`).

    Raises:
        InputError: as :func:`read_points`.
    """
    p = Path(source)
    codes = parse_label_codes(labels) if isinstance(labels, (str, type(None))) else dict(labels)
    text = text.lstrip("\ufeff")
    rows = [(i + 1, row) for i, row in enumerate(csv_rows(text.splitlines(), p.name))
            if row and any(c.strip() for c in row) and not row[0].lstrip().startswith("#")]
    if not rows:
        raise InputError("points file", str(p), f"is empty; expected a header {','.join(REQUIRED + OPTIONAL)} and rows")
    header_line, header = rows[0]
    kind = looks_like(text)
    if kind is not None and not kind.startswith("a points"):  # a config or JSON in the cuts' place: say so
        raise InputError(f"{p.name}", kind, f"not a points or cuts CSV (header {','.join(REQUIRED)},...): is the file "
                                            "in the CSV's place? (the config or posterior comes first)")
    names = [h.strip().lower() for h in header]
    check_comma_separated(names, f"{p.name} line {header_line}", ",".join(header), ",".join(REQUIRED + OPTIONAL))
    if len(set(names)) != len(names):
        raise InputError(f"{p.name} header", ",".join(names), "a column name appears twice")
    raters, batch_col, unused, maybe = _columns(names, p)
    if len(rows) == 1:
        raise InputError("points file", str(p), "has a header but no points")
    col = {h: i for i, h in enumerate(names)}
    for h in unused:  # before the rows: a row's own error (a chatter_hz on a now unlabelled cut) would hide it
        meant = _misspelt_rater(h)
        cells = [row[col[h]] if col[h] < len(row) else "" for _, row in rows[1:]]
        # an operator's labels would otherwise be dropped with a mere warning
        if meant and (_holds_labels(cells, codes) or _holds_words(cells)):
            raise InputError(f"{p.name} header", h,
                             f"unknown column that looks like a misspelt rater column {meant!r} and holds labels; "
                             "name each operator's column label_NAME (or rater_NAME, labelN), or rename it if it "
                             "is not a label column")
    rpm, depth, grades, weight, hz, batch = [], [], [], [], [], []
    extra: dict[str, list[str]] = {h: [] for h in unused}
    conds: dict[str, list] = {h: [] for h in CONDITION_COLUMNS if h in col}
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
        g = []
        for _, i in raters:
            try:
                g.append(grade_of_cell(cells[i], codes, labels_option))
            except ValueError as exc:
                raise InputError(f"{p.name} line {line}, {names[i]}", cells[i], str(exc)) from None
        grades.append(g)
        lab = label_of_grade(np.nanmean(g) if g and not np.isnan(g).all() else np.nan)[0]
        w = 1.0
        if "weight" in col and cells[col["weight"]]:
            w = _number(cells[col["weight"]], "weight", line, p)
            if w <= 0:
                raise InputError(f"{p.name} line {line}, weight", cells[col["weight"]], "weight must be > 0")
        f = math.nan
        if "chatter_hz" in col and cells[col["chatter_hz"]]:
            f = _number(cells[col["chatter_hz"]], "chatter_hz", line, p)
            if f <= 0:
                raise InputError(f"{p.name} line {line}, chatter_hz", cells[col["chatter_hz"]],
                                 "chatter frequency must be > 0 Hz")
            if lab not in ("chatter", "marginal"):
                raise InputError(f"{p.name} line {line}, chatter_hz", cells[col["chatter_hz"]],
                                 f"a chatter frequency belongs to a chatter or marginal cut, not to a "
                                 f"{lab or 'boundary'} point")
        hz.append(f)
        rpm.append(r)
        depth.append(d)
        weight.append(w)
        batch.append(cells[col[batch_col]] if batch_col else "")
        for h in unused:
            extra[h].append(cells[col[h]])
        for h in conds:
            conds[h].append(_condition_cell(cells[col[h]], h, line, p))
    ignored = [h for h in unused if h not in KEPT_COLUMNS]
    if not raters:  # every row a boundary point: say so where the file meant labels under another name
        looks = [h for h in ignored if _holds_labels(extra[h], codes)]
        many = len(looks) > 1
        rename = "" if not looks else (
            f"; the column{'s' if many else ''} {', '.join(looks)} hold{'' if many else 's'} labels: name "
            + ("them " + ", ".join(f"label_{h}" for h in looks) + " (one per operator)" if many else "it label"))
        if codes:
            raise InputError(f"{p.name} header", ",".join(names),
                             "--labels maps label codes, but the file has no label column (label, or one per "
                             f"operator: label_NAME, labelN, rater_NAME){rename}")
        worded = [h for h in looks if _holds_words(extra[h])]
        if worded:  # "stable"/"chatter" under another name: read as boundary points they would each say "the limit
            # is exactly here", and an update would blame the hammer test for the contradiction
            raise InputError(f"{p.name} header", ",".join(names),
                             "no label column, so every row would be read as a boundary point (a measured limit)"
                             f"{rename}; a file of boundary points holds no label words")
        if looks:
            warn(f"{p.name}: no label column, so every row is read as a boundary point (a measured limit){rename}",
                 UserWarning, stacklevel=3)
    # a row naming a recording is labelled by listening to it (millstab.api.listen.label_from_recordings), not a
    # forgotten label
    heard = [bool("recording" in col and col["recording"] < len(row) and row[col["recording"]].strip())
             for _, row in rows[1:]]
    blank = [line for (line, _), g, h in zip(rows[1:], grades, heard) if g and np.isnan(g).all() and not h]
    if raters and blank and len(blank) < len(grades):  # a forgotten label reads as a measured limit
        many = len(blank) > 1
        warn(f"{p.name}: {len(blank)} row{'s' if many else ''} without a label (line{'s' if many else ''} "
             f"{', '.join(map(str, blank[:10]))}{', …' if len(blank) > 10 else ''}) "
             + ("are read as boundary points (measured limits)" if many else
                "is read as a boundary point (a measured limit)")
             + ", the others as test cuts; write stable, marginal or chatter there if they are test cuts",
             UserWarning, stacklevel=3)
    days = _date_formats(batch, [line for line, _ in rows[1:]]) if batch_col else {}
    if len(days) > 1:  # the test day is the text as written: one day in two formats would be two days
        shown = "; ".join(f"{c} on line {line}" for c, line in days.values())
        warn(f"{p.name}: the column {batch_col} writes its dates in {len(days)} formats ({shown}): each distinct text "
             "is its own test day, so a day written two ways counts as two (in validate's leave-one-day-out folds and "
             "a batch effect); write every date in one format", UserWarning, stacklevel=3)
    if ignored:
        hints = "".join(f"; is {h!r} meant as {maybe[h]!r}? rename it" for h in ignored if h in maybe)
        warn(f"{p.name}: ignored columns: {', '.join(ignored)} (kept, not used){hints}", UserWarning, stacklevel=3)
    deepest = max(depth)
    if deepest < DEPTH_SCALE_MM[0] or deepest > DEPTH_SCALE_MM[1]:  # read as written; the user is told the scale
        hint = (f"metres? {deepest:g} m is {deepest * 1e3:g} mm" if deepest < DEPTH_SCALE_MM[0] else
                f"micrometres? {deepest:g} µm is {deepest * 1e-3:g} mm")
        warn(f"{p.name}: the deepest cut is {deepest:g} mm (column depth_mm is in mm): are the depths in {hint}",
             UserWarning, stacklevel=3)
    conds = check_conditions(conds, len(rpm), p, [line for line, _ in rows[1:]])  # errors name the file's line
    ratings = np.array(grades, dtype=float).reshape(len(rpm), len(raters))
    with np.errstate(all="ignore"):
        rated = ~np.isnan(ratings).all(axis=1)
        grade = np.full(len(rpm), np.nan)
        grade[rated] = np.nanmean(ratings[rated], axis=1)
    return PointSet(np.array(rpm), np.array(depth), label_of_grade(grade), np.array(weight), p, np.array(hz), grade,
                    np.array(batch, dtype=object), ratings, tuple(n for n, _ in raters), extra, conds, tuple(names))


def _condition_cell(text: str, name: str, line: int, p: Path):
    """One condition cell: ``""`` (milling) or NaN when empty; a/D may be a percentage ("25 %"); milling as written
    (:func:`millstab.points.check_conditions` reads it and names the line of a direction it does not know)."""
    if name == "milling":
        return text.strip()
    if not text:
        return math.nan
    pct = name == "radial_immersion" and text.endswith("%")
    x = _number(text[:-1].strip() if pct else text, name, line, p)
    return x / 100 if pct else x


def _condition_text(name: str, v) -> str:
    """A condition cell as written back: empty for NaN, teeth as an integer, floats exact (repr)."""
    if name == "milling":
        return str(v)
    if np.isnan(v):
        return ""
    return str(int(v)) if name == "teeth" else repr(float(v))


def _label_text(g: float) -> str:
    """A grade as a label cell: the class word where it is one, else the number (exact)."""
    if np.isnan(g):
        return ""
    words = {v: k for k, v in GRADE.items()}
    return words.get(float(g), repr(float(g)))


def condition_columns(points: PointSet) -> tuple[list[str], list[list[str]]]:
    """(header, columns) of the condition columns the points have, as cells (empty = the config's value)."""
    names = [n for n in CONDITION_COLUMNS if n in points.conditions]
    return names, [[_condition_text(n, v) for v in points.conditions[n]] for n in names]


def input_columns(points: PointSet) -> tuple[list[str], list]:
    """(header, columns) of every column the points were read with, in the file's order (``PointSet.columns``),
    as :func:`write_points` writes them: speeds [rpm] and depths [mm] exactly, each label column (``label``, or a
    rater's ``label_NAME``) as the grades its cells read as (the class word, else the number: a code that
    ``--labels`` mapped is written as its class), weight, chatter_hz [Hz] (empty: not measured), the test day
    under its own column name (batch, date, day or session), the condition columns as read (empty cells stay
    empty: the config's value) and the kept columns (notes, operator, ...) as read. Points not read from a file
    (``columns`` None): rpm, depth_mm, the label(s) where any point is labelled, and weight, chatter_hz, batch,
    the condition columns and the kept columns where any holds something."""
    cells: dict[str, Sequence] = {"rpm": points.rpm, "depth_mm": points.depth_mm, "weight": points.weight,
                                  "chatter_hz": points.chatter_hz}
    h_cond, c_cond = condition_columns(points)
    cells.update({**dict(zip(h_cond, c_cond)), **{k: list(v) for k, v in points.extra.items()}})
    n_raters = points.ratings.shape[1]
    if points.columns is None:
        labels = ([] if points.boundary.all() else
                  ["label"] if n_raters == 1 else [f"label_{r}" for r in points.raters])
        names = (["rpm", "depth_mm", *labels] + (["weight"] if (points.weight != 1).any() else [])
                 + (["chatter_hz"] if not np.isnan(points.chatter_hz).all() else [])
                 + (["batch"] if (points.batch != "").any() else []) + h_cond + list(points.extra))
    else:
        names = list(points.columns)
    batch = next((b for b in BATCH_COLUMNS if b in names and b not in points.extra), None)
    if batch is not None:
        cells[batch] = list(points.batch)
    raters = [h for h in names if RATER_COLUMN.match(h) and h not in points.extra]  # rater j: the j-th label column
    for j, h in enumerate(raters[:n_raters]):
        cells[h] = [_label_text(g) for g in points.ratings[:, j]]
    header = [h for h in names if h in cells]
    return header, [cells[h] for h in header]


def write_points(path: PathLike, points: PointSet, protect: Iterable[PathLike] = ()) -> Path:
    """Write a point set as CSV: rpm, depth_mm, the label (one ``label`` column, or ``label_NAME`` per
    rater when there are several; a grade that is no class word is written as its number), weight,
    chatter_hz when any is measured, batch when any is given, the condition columns as read, and the extra
    columns as read; floats
    written exactly, so :func:`read_points` gives the same point set back. Atomic; see results."""
    if points.ratings.shape[1] > 1:
        header = ["rpm", "depth_mm"] + [f"label_{r}" for r in points.raters] + ["weight"]
        labels = [[_label_text(g) for g in points.ratings[:, j]] for j in range(points.ratings.shape[1])]
    else:
        header = ["rpm", "depth_mm", "label", "weight"]
        labels = [[lab if not lab or GRADE[lab] == g else _label_text(g) for lab, g in zip(points.label, points.grade)]]
    cols = [points.rpm, points.depth_mm, *labels, points.weight]
    if not np.isnan(points.chatter_hz).all():
        header.append("chatter_hz")
        cols.append(points.chatter_hz)
    if (points.batch != "").any():
        header.append("batch")
        cols.append(list(points.batch))
    h, c = condition_columns(points)  # the per-cut conditions as read (empty cells stay empty: the config's value)
    header += h
    cols += c
    for name, col in points.extra.items():
        header.append(name)
        cols.append(list(col))
    return write_csv(path, header, cols, protect)


__all__ = ["condition_columns", "BATCH_COLUMNS", "LABELS", "check_enough", "input_columns", "parse_points",
           "read_points", "write_points"]
