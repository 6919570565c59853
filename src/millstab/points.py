"""Point sets: stability-boundary points and labelled test cuts, the model type that identification,
updating and design take. Read from and written to CSV by :mod:`millstab.io.points` (format there).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from millstab.errors import InputError
from millstab.model import Cutting
from millstab.units import is_quantity, quantity_values

LABELS = ("stable", "chatter", "marginal")
LABEL_RULE = ("must be 'stable', 'chatter', 'marginal' (or 'uncertain'/'unsure' = marginal), a probability of "
              "chatter in [0, 1], or empty (boundary point)")
#: the graded label of each written label: how strongly it says "chatter"
GRADE = {"stable": 0.0, "marginal": 0.5, "chatter": 1.0}
#: words a shop writes for "near the limit, I cannot tell": read as marginal
SYNONYMS = {"uncertain": "marginal", "unsure": "marginal"}
#: the class of a graded label: below this stable, above 1 − this chatter, else marginal (the nearest of 0, ½, 1)
CLASS_EDGE = 1.0 / 3.0


def label_of_grade(grade) -> np.ndarray:
    """The nearest written class of graded labels (n,): < ⅓ stable, > ⅔ chatter, else marginal; NaN → ``""``."""
    g = np.atleast_1d(np.asarray(grade, dtype=float))
    out = np.where(g < CLASS_EDGE, "stable", np.where(g > 1 - CLASS_EDGE, "chatter", "marginal")).astype(object)
    out[np.isnan(g)] = ""
    return out


def parse_label_codes(text: str | None, field: str = "--labels") -> dict[str, float]:
    """A code mapping ``"0=stable,1=marginal,2=chatter"`` → {code (lower case): grade}; targets are
    stable | marginal | chatter (or uncertain/unsure) or a probability of chatter in [0, 1]. ``None`` or
    ``""`` → {}.

    Raises:
        InputError: an item without ``=``, an empty code, a code given twice, a target that is neither.
    """
    out: dict[str, float] = {}
    if not text or not str(text).strip():
        return out
    for item in str(text).split(","):
        code, eq, target = item.partition("=")
        code, target = code.strip().lower(), target.strip().lower()
        if not eq or not code or not target:
            raise InputError(field, text, "a list CODE=LABEL separated by commas, e.g. 0=stable,1=marginal,2=chatter")
        if code in out:
            raise InputError(field, text, f"the code {code!r} is mapped twice")
        target = SYNONYMS.get(target, target)
        if target in GRADE:
            out[code] = GRADE[target]
            continue
        try:
            g = float(target)
        except ValueError:
            g = math.nan
        if not 0 <= g <= 1:
            raise InputError(field, item.strip(), "each code maps to stable, marginal, chatter or a probability of "
                                                  "chatter in [0, 1]")
        out[code] = g
    return out


#: the end of an invalid-label message where the command has no --labels option to map codes or words
NO_LABELS_OPTION = "write one of these in the file (this command has no --labels option to map other words or codes)"


def grade_of_cell(text: str, codes: dict[str, float] | None = None, labels_option: bool = True) -> float:
    """The graded label [0, 1] of one written label cell; NaN for an empty cell.

    Order: a code of ``codes`` (from :func:`parse_label_codes`, matched as written, case-insensitive, or
    as the same number: "2.0" matches the code "2"); stable | marginal | chatter and the marginal
    synonyms uncertain | unsure; a number in [0, 1] (or a percentage "70 %") = the probability of
    chatter as written.

    Raises:
        ValueError: with the reason (the caller names the file, line and column): a number outside
            [0, 1] without a mapping (a code: suggests ``--labels``), a number that is none of the codes where
            ``codes`` maps numbers (a code left out of ``--labels``), yes/no (which way is "yes"?), any other word.
            With ``labels_option=False`` (a command without ``--labels``, e.g. identify) the message says what
            the file may hold instead of suggesting an option the command lacks.
    """
    s = str(text).strip().lower()
    if not s:
        return math.nan
    if codes:
        if s in codes:
            return codes[s]
        x = _float(s)
        if not math.isnan(x):
            for k, g in codes.items():
                if _float(k) == x:
                    return g
            if any(not math.isnan(_float(k)) for k in codes):  # "1" with --labels 0=stable,2=chatter: a code left
                # out of the mapping, not a probability of chatter of 1
                raise ValueError(f"{s!r} is not one of the codes of --labels ({', '.join(codes)}): map every code "
                                 "the file uses, e.g. --labels 0=stable,1=marginal,2=chatter")
    s2 = SYNONYMS.get(s, s)
    if s2 in GRADE:
        return GRADE[s2]
    pct = s.endswith("%")
    x = _float(s[:-1] if pct else s)
    if not math.isnan(x):
        x = x / 100 if pct else x
        if 0 <= x <= 1:
            return x
        if not labels_option:
            raise ValueError(f"{LABEL_RULE}; {NO_LABELS_OPTION}")
        if codes:
            raise ValueError(f"{LABEL_RULE}; {s!r} is not one of the codes of --labels ({', '.join(codes)})")
        raise ValueError(f"{LABEL_RULE}; a number outside [0, 1] looks like a code: map the codes with --labels, "
                         "e.g. --labels 0=stable,1=marginal,2=chatter")
    if not labels_option:
        raise ValueError(f"{LABEL_RULE}; {NO_LABELS_OPTION}")
    if s in ("yes", "no", "y", "n", "true", "false"):
        raise ValueError(f"{LABEL_RULE}; yes/no does not say which way (chattered? stable?): map it with --labels, "
                         "e.g. --labels yes=chatter,no=stable")
    unknown = ""
    if s.strip("?") == "" or s in ("n/a", "na", "-", "--", "unknown", "not sure", "dunno", "idk"):  # "I cannot tell"
        # a guessed example (?=stable) would read a doubt as a verdict: the two readings it may have are named
        unknown = (f"; {s!r} reads as 'cannot tell': write marginal there (near the limit), leave the cell empty (no "
                   f"label from this rater), or map it, e.g. --labels {s}=marginal")
    if codes:
        raise ValueError(f"{LABEL_RULE}, or one of the codes of --labels ({', '.join(codes)}){unknown}")
    if unknown:
        raise ValueError(f"{LABEL_RULE}{unknown}")
    # a shop's own words (OK / NOK, light chatter, ...) are mapped, not guessed
    raise ValueError(f"{LABEL_RULE}; map your own words with --labels, e.g. --labels {_code_example(s)}")


def _code_example(word: str) -> str:
    """A --labels example for a word a reader does not know, shaped like the word: 'ok=stable,nok=chatter'."""
    w = word.replace(",", " ").replace("=", " ").strip() or "ok"
    if any(k in w for k in ("light", "slight", "some", "maybe")):
        return f"{w}=marginal,ok=stable"
    if any(k in w for k in ("nok", "bad", "fail", "chatter", "noise", "loud")):
        return f"{w}=chatter,ok=stable"
    return f"{w}=stable,nok=chatter"


def _float(s: str) -> float:
    try:
        x = float(s)
    except ValueError:
        return math.nan
    return x if math.isfinite(x) else math.nan


#: how a PointSet array given as a pint Quantity is converted: {unit of the field: (dimension, factor from SI)}
_QUANTITY = {"rev/min": ("frequency", 60.0), "mm": ("length", 1e3), "Hz": ("frequency", 1.0),
             "": ("dimensionless", 1.0)}


def _floats(name: str, values, unit: str) -> np.ndarray:
    """``values`` as a 1-D float array in ``unit`` (a pint Quantity converted from its own unit: numpy would strip it,
    reading 2 mm given in m as 0.002 mm); an InputError naming ``points.NAME[i]`` and the value where one is not a
    number (``"5000x"``, a dict), where numpy would raise its own ValueError naming no field."""
    if is_quantity(values):
        dimension, factor = _QUANTITY[unit]
        return np.atleast_1d(quantity_values(values, f"points.{name}", dimension) * factor)
    try:
        return np.atleast_1d(np.asarray(values, dtype=float))
    except (TypeError, ValueError):
        pass
    seq = values if isinstance(values, (list, tuple, np.ndarray)) else [values]
    for i, v in enumerate(seq):
        try:
            float(v)
        except (TypeError, ValueError):
            raise InputError(f"points.{name}[{i}]", v, f"must be a number {unit}".rstrip()) from None
    raise InputError(f"points.{name}", values, f"a 1-D sequence of numbers {unit}".rstrip())


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
        grade: (n,) graded label in [0, 1] of each test cut: how strongly the written label(s) say
            "chatter" (stable 0, marginal ½, chatter 1, a probability as written, the mean over several
            raters); NaN for boundary points. ``None`` = from ``label``.
        batch: (n,) str: the test day or session of each cut (``""`` = none); ``None`` = all ``""``.
        ratings: (n, R) graded labels of each of R raters (operators, label columns), NaN where a rater
            wrote nothing; ``None`` = one rater, the grade itself (R = 1).
        raters: the R raters' names (``"label"`` for a single label column); ``None`` = ``("label",)``.
        extra: {column name: (n,) str} columns of the file that millstab does not use (feed, notes),
            kept as read; ``None`` = none.
        conditions: {column: (n,) values} the per-cut cutting conditions (:data:`CONDITION_COLUMNS`) the
            file gives: floats (NaN = empty cell: the config's value) and ``milling`` as str (``""``
            empty); only the columns present. ``None`` = none (every cut in the config's condition).
            :func:`cut_conditions` turns them into one :class:`~millstab.model.Cutting` per distinct condition.
        columns: the file's column names in the file's order (lower case, as the reader knows them), so that an
            output keeps the input's columns where they were (:func:`millstab.io.points.input_columns`);
            ``None`` = not read from a file (a default order).
    """

    rpm: np.ndarray
    depth_mm: np.ndarray
    label: np.ndarray | None = None
    weight: np.ndarray | None = None
    source: Path | None = None
    chatter_hz: np.ndarray | None = None
    grade: np.ndarray | None = None
    batch: np.ndarray | None = None
    ratings: np.ndarray | None = None
    raters: tuple[str, ...] | None = None
    extra: dict = field(default=None)
    conditions: dict = field(default=None)
    columns: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        rpm = _floats("rpm", self.rpm, "rev/min")
        depth = _floats("depth_mm", self.depth_mm, "mm")
        n = rpm.size
        label = (np.full(n, "", dtype=object) if self.label is None
                 else np.atleast_1d(np.asarray(self.label, dtype=object)))
        weight = np.ones(n) if self.weight is None else _floats("weight", self.weight, "")
        hz = np.full(n, np.nan) if self.chatter_hz is None else _floats("chatter_hz", self.chatter_hz, "Hz")
        for name, arr in (("depth_mm", depth), ("label", label), ("weight", weight), ("chatter_hz", hz)):
            if arr.ndim != 1 or arr.size != n:
                raise InputError(f"points.{name}", f"{arr.size} values", f"need one value per speed ({n})")
        for name, arr, unit in (("rpm", rpm, "rev/min"), ("depth_mm", depth, "mm"), ("weight", weight, "")):
            bad = ~(np.isfinite(arr) & (arr > 0))
            if bad.any():
                i = int(np.argmax(bad))
                raise InputError(f"points.{name}[{i}]", float(arr[i]), f"must be a finite number > 0 {unit}".rstrip())
        label = np.array([SYNONYMS.get(t, t) for t in (str(s).strip().lower() for s in label)], dtype=object)
        for i, s in enumerate(label):
            if s not in ("",) + LABELS:
                raise InputError(f"points.label[{i}]", s, "must be 'stable', 'chatter', 'marginal' (or 'uncertain'/"
                                                          "'unsure' = marginal) or empty (boundary point)")
        given = ~np.isnan(hz)
        bad = given & ~(np.isfinite(hz) & (hz > 0))
        if bad.any():
            i = int(np.argmax(bad))
            raise InputError(f"points.chatter_hz[{i}]", float(hz[i]), "must be a finite frequency > 0 Hz (or empty)")
        odd = given & ~np.isin(label, ("chatter", "marginal"))
        if odd.any():
            i = int(np.argmax(odd))
            raise InputError(f"points.chatter_hz[{i}]", float(hz[i]),
                             "a chatter frequency belongs to a chatter or marginal cut, not to a "
                             f"{label[i] or 'boundary'} point")
        if self.grade is None:
            grade = np.array([GRADE.get(s, np.nan) for s in label], dtype=float)
        else:
            grade = np.atleast_1d(np.asarray(self.grade, dtype=float))
            if grade.ndim != 1 or grade.size != n:
                raise InputError("points.grade", f"{grade.size} values", f"need one value per speed ({n})")
            bad = (label != "") & ~((grade >= 0) & (grade <= 1))
            bad |= (label == "") & ~np.isnan(grade)
            if bad.any():
                i = int(np.argmax(bad))
                raise InputError(f"points.grade[{i}]", float(grade[i]),
                                 "a test cut's graded label is a number in [0, 1] (0 stable, 1 chatter); "
                                 "a boundary point has none")
        batch = (np.full(n, "", dtype=object) if self.batch is None
                 else np.atleast_1d(np.asarray(self.batch, dtype=object)))
        if batch.ndim != 1 or batch.size != n:
            raise InputError("points.batch", f"{batch.size} values", f"need one value per speed ({n})")
        batch = np.array([str(b).strip() for b in batch], dtype=object)
        if self.ratings is None:
            ratings = grade[:, None].copy()
            raters = tuple(self.raters or ("label",))
        else:
            ratings = (np.asarray(self.ratings, dtype=float).reshape(n, -1) if n
                       else np.zeros((0, len(self.raters or ()))))
            raters = tuple(str(r) for r in (self.raters or (f"rater{j + 1}" for j in range(ratings.shape[1]))))
            bad = ~np.isnan(ratings) & ~((ratings >= 0) & (ratings <= 1))
            if bad.any():
                i, j = np.argwhere(bad)[0]
                raise InputError(f"points.ratings[{i}, {j}]", float(ratings[i, j]),
                                 "a rater's graded label is in [0, 1] or NaN")
        if len(raters) != ratings.shape[1]:
            raise InputError("points.raters", list(raters), f"need one name per column of ratings ({ratings.shape[1]})")
        extra = {}
        for name, col in (self.extra or {}).items():
            col = np.atleast_1d(np.asarray(col, dtype=object))
            if col.ndim != 1 or col.size != n:
                raise InputError(f"points.extra[{name!r}]", f"{col.size} values", f"need one value per speed ({n})")
            extra[str(name)] = col.astype(str) if n else np.array([], dtype="<U1")
        conditions = check_conditions(self.conditions, n, self.source)
        # fixed-width unicode array: comparisons like label == "chatter" give boolean masks
        object.__setattr__(self, "rpm", rpm)
        object.__setattr__(self, "depth_mm", depth)
        object.__setattr__(self, "label", label.astype("<U8") if n else np.array([], dtype="<U8"))
        object.__setattr__(self, "chatter_hz", hz)
        object.__setattr__(self, "weight", weight)
        object.__setattr__(self, "grade", grade)
        object.__setattr__(self, "batch", batch.astype(str) if n else np.array([], dtype="<U1"))
        object.__setattr__(self, "ratings", ratings)
        object.__setattr__(self, "raters", raters)
        object.__setattr__(self, "extra", extra)
        object.__setattr__(self, "conditions", conditions)
        if self.columns is not None:
            object.__setattr__(self, "columns", tuple(str(c) for c in self.columns))
        if self.source is not None:
            object.__setattr__(self, "source", Path(self.source))
        check_plausible(self)  # a speed of 0.001 rpm or a chatter frequency of 10 MHz: refused, whichever the door

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
        return PointSet(self.rpm[m], self.depth_mm[m], self.label[m], self.weight[m], self.source, self.chatter_hz[m],
                        self.grade[m], self.batch[m], self.ratings[m], self.raters,
                        {k: v[m] for k, v in self.extra.items()}, {k: v[m] for k, v in self.conditions.items()},
                        self.columns)

    @property
    def has_conditions(self) -> bool:
        """True when any cut names a condition of its own (a non-empty condition cell)."""
        return any(_given(v).any() for v in self.conditions.values())


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


def check_speeds(rpm: np.ndarray, n_free: int, source=None) -> int:
    """The number of distinct boundary-point speeds; InputError when fewer than ``n_free``.

    The boundary is one depth per speed: repeated tests at one speed measure that depth again (its
    scatter), not another point of the curve, so P parameters need at least P different speeds — all
    points at one speed determine at most one parameter.
    """
    r = np.asarray(rpm, dtype=float)
    distinct = int(np.unique(r[np.isfinite(r)]).size)
    if distinct < n_free:
        where = f" in {source.name}" if source is not None else ""
        at = f"all at {r[0]:g} rpm" if distinct == 1 else f"at {distinct} distinct speeds"
        raise InputError("points", f"{r.size} boundary points{where} {at}",
                         f"{n_free} free parameters need boundary points at {n_free} or more different spindle speeds "
                         "(repeats at one speed only re-measure its depth); measure at other speeds, or free fewer "
                         "parameters (--free)")
    return distinct


def check_plausible(points: PointSet) -> PointSet:
    """``points`` itself when every speed lies within :data:`millstab.bounds.MIN_RPM`..``MAX_RPM`` and every
    chatter frequency is at most :data:`millstab.bounds.MAX_CHATTER_HZ` (module :mod:`millstab.bounds`: why).

    Raises:
        InputError: naming the file (when known), the data row (1 = the first row after the header,
            comment and blank lines not counted), the column and the value.
    """
    from millstab.bounds import MAX_CHATTER_HZ, MAX_RPM, MIN_RPM, speed_rule

    where = f"{points.source.name} " if points.source is not None else ""
    slow = (points.rpm < MIN_RPM) | (points.rpm > MAX_RPM)
    if slow.any():
        i = int(np.argmax(slow))
        raise InputError(f"{where}data row {i + 1}, column rpm", float(points.rpm[i]), speed_rule())
    high = points.chatter_hz > MAX_CHATTER_HZ  # NaN (not measured) compares False
    if high.any():
        i = int(np.argmax(high))
        raise InputError(f"{where}data row {i + 1}, column chatter_hz", float(points.chatter_hz[i]),
                         f"a chatter frequency is a vibration of the tool, holder or spindle: at most "
                         f"{MAX_CHATTER_HZ:,.0f} Hz (is it in Hz? a rate in rpm or a sample rate?)")
    return points


# --- per-cut cutting conditions (issue 27) ----------------------------------------------------------------
#: the optional per-cut condition columns of a cuts or points file; an empty cell takes the config's value
CONDITION_COLUMNS = ("radial_immersion", "radial_width_mm", "milling", "entry_deg", "exit_deg", "feed_per_tooth_mm",
                     "teeth")
MILLING = ("up", "down")
#: the other names shops write for a milling direction: climb milling is down milling, conventional is up
MILLING_SYNONYMS = {"climb": "down", "conventional": "up"}
#: what a milling cell or option may say, for error messages
MILLING_RULE = "up or down (climb = down, conventional = up)"


def milling_word(text) -> str:
    """A written milling direction as ``"up"`` or ``"down"`` ("Down milling", "climb", "conventional-milling" too:
    case, a trailing "milling" and :data:`MILLING_SYNONYMS` are read); any other text comes back stripped and lower
    case, for the caller to refuse (``""`` for an empty cell)."""
    s = " ".join(str(text).strip().lower().replace("-", " ").split())
    if s.endswith(" milling"):
        s = s[:-len(" milling")]
    return MILLING_SYNONYMS.get(s, s)


#: angles [rad] closer than this are one condition: a shop writes a/D to 3–4 digits (ex3's 126.9° entry is a/D
#: 0.19979, written 0.1998: 2.5e-5 rad apart, a limit ~3e-5 relative apart), and such a cut was another condition,
#: printed the same ("a/D 0.1998"), never drawn on the config's SLD and called "never cut"; 1e-4 rad (0.006°) is far
#: below any engagement a tool tells apart, and above the 4-digit rounding of an a/D (≤ 5e-5 / sin φ rad)
ANGLE_TOL = 1e-4
#: a radial width [mm] and an a/D (or entry/exit angles) given together agree when they differ by at most this
#: fraction of the tool diameter (a/D 0.333 and 4 mm on a 12 mm tool do; 0.25 and 6 mm do not)
WIDTH_TOL = 1e-3
#: significant digits of an a/D or an angle written for users: a/D 0.5 up milling is 0.5, not the round trip
#: (1 − cos(arccos(0)))/2 = 0.49999999999999994
SHOWN_DIGITS = 12


def _given(col: np.ndarray) -> np.ndarray:
    """Mask of the non-empty cells of a condition column (a float NaN or ``""`` is empty)."""
    if col.dtype.kind in "fi":
        return ~np.isnan(col.astype(float))
    return np.array([str(v) != "" for v in col], dtype=bool)


def check_conditions(conditions: dict | None, n: int, source=None, lines=None) -> dict:
    """The condition columns as arrays (floats; ``milling`` "up" | "down" | "" (the config's), read by
    :func:`milling_word`), each cell checked. ``lines``: each row's line in the file it was read from (a reader's
    errors then name the line, as its own do), else the data row is named.

    Raises:
        InputError: naming the line or data row (1 = the first row after the header), the column, the value and
            what is allowed: an unknown column, a value out of range (a/D in (0, 1], widths, feeds > 0,
            angles in [0, 180] deg with entry < exit, teeth a positive integer, milling up | down), or
            columns that contradict each other on one row (a/D and radial_width_mm; a/D, width or milling
            with entry_deg/exit_deg; entry_deg without exit_deg).
    """
    where = f"{Path(source).name} " if source is not None else ""

    def row_name(i: int) -> str:
        return f"line {lines[i]}" if lines is not None else f"data row {i + 1}"

    out: dict[str, np.ndarray] = {}
    for name, col in (conditions or {}).items():
        if name not in CONDITION_COLUMNS:
            raise InputError("points.conditions", name, f"one of {', '.join(CONDITION_COLUMNS)}")
        col = np.atleast_1d(np.asarray(col, dtype=object))
        if col.ndim != 1 or col.size != n:
            raise InputError(f"points.conditions[{name!r}]", f"{col.size} values", f"need one value per speed ({n})")
        if name == "milling":
            written = ["" if v is None or (isinstance(v, float) and math.isnan(v)) else str(v) for v in col]
            col = np.array([milling_word(v) for v in written], dtype=object).astype(str) if n else np.array(
                [], dtype="<U4")
            bad = ~np.isin(col, ("",) + MILLING)
            if bad.any():
                i = int(np.argmax(bad))
                raise InputError(f"{where}{row_name(i)}, column milling", written[i].strip(),
                                 f"{MILLING_RULE}, or empty: the config's")
        else:
            col = np.array([math.nan if v is None or str(v).strip() == "" else v for v in col], dtype=float)
        out[name] = col
    nan = np.full(n, np.nan)

    def bad_row(mask, name, allowed):
        if mask.any():
            i = int(np.argmax(mask))
            value = out[name][i] if name in out else None
            raise InputError(f"{where}{row_name(i)}, column {name}", str(value) if name == "milling" else float(value),
                             allowed)

    ri, w = out.get("radial_immersion", nan), out.get("radial_width_mm", nan)
    en, ex = out.get("entry_deg", nan), out.get("exit_deg", nan)
    ft, teeth = out.get("feed_per_tooth_mm", nan), out.get("teeth", nan)
    mill = out.get("milling", np.full(n, ""))
    with np.errstate(invalid="ignore"):
        bad_row(~np.isnan(ri) & ~((ri > 0) & (ri <= 1)), "radial_immersion",
                "the radial immersion a/D is in (0, 1] (1 = slot; a width in mm goes in radial_width_mm)")
        bad_row(~np.isnan(w) & ~(w > 0), "radial_width_mm", "a radial width > 0 mm")
        bad_row(~np.isnan(ft) & ~(ft > 0), "feed_per_tooth_mm", "a feed per tooth > 0 mm")
        bad_row(~np.isnan(teeth) & ~((teeth >= 1) & (teeth == np.round(teeth))), "teeth", "a positive integer")
        for name, a in (("entry_deg", en), ("exit_deg", ex)):
            bad_row(~np.isnan(a) & ~((a >= 0) & (a <= 180)), name, "an angle in [0, 180] deg (0..180: slot)")
        bad_row(np.isnan(ex) & ~np.isnan(en), "entry_deg", "entry_deg and exit_deg are given together on a row")
        bad_row(np.isnan(en) & ~np.isnan(ex), "exit_deg", "entry_deg and exit_deg are given together on a row")
        bad_row(~np.isnan(en) & (en >= ex), "entry_deg", "the entry angle is less than the exit angle of its row")
        bad_row(~np.isnan(ri) & ~np.isnan(w), "radial_width_mm",
                "give radial_immersion or radial_width_mm on a row, not both")
        width = ~np.isnan(ri) | ~np.isnan(w)
        bad_row(~np.isnan(en) & width, "entry_deg",
                "give entry_deg/exit_deg or radial_immersion (or radial_width_mm) with milling on a row, not both")
        if "milling" in out:
            bad_row(~np.isnan(en) & (mill != ""), "milling",
                    "give entry_deg/exit_deg or milling with radial_immersion on a row, not both")
    return out


def _direction(c: Cutting) -> tuple[float | None, str | None]:
    """(a/D, milling) of a condition written in angles: slot (1, None); down (exit π), up (entry 0); else
    (None, None): general angles, no a/D."""
    if c.is_slotting:
        return 1.0, None
    if c.exit >= math.pi - ANGLE_TOL:
        return (1 + math.cos(c.entry)) / 2, "down"
    if c.entry <= ANGLE_TOL:
        return (1 - math.cos(c.exit)) / 2, "up"
    return None, None


def _shown(x: float) -> float:
    """``x`` to :data:`SHOWN_DIGITS` significant digits (0.49999999999999994 → 0.5)."""
    return float(f"{x:.{SHOWN_DIGITS}g}")


def _shown_deg(rad: float) -> float:
    """An angle [rad] in degrees, to :data:`SHOWN_DIGITS` digits where those give back the same angle exactly
    (a record's angles rebuild its condition: ``millstab.update.campaign``), else all of them."""
    deg = math.degrees(rad)
    short = _shown(deg)
    return short if math.radians(short) == rad else deg


def describe_condition(c: Cutting) -> dict:
    """The condition as a record for results and JSON: teeth, entry_deg, exit_deg and, where the angles
    are an a/D and a direction, radial_immersion and milling ("slot" for full immersion); the a/D to
    :data:`SHOWN_DIGITS` significant digits (the angles' round trip leaves 0.49999999999999994 for 0.5)."""
    ri, mill = _direction(c)
    out = {"teeth": c.teeth, "entry_deg": _shown_deg(c.entry), "exit_deg": _shown_deg(c.exit)}
    if ri is not None:
        out["radial_immersion"] = _shown(ri)
        out["milling"] = mill or "slot"
    return out


def radial_width(entry: float, exit: float, diameter_mm: float) -> float:
    """The radial width of cut [mm] between the entry and exit angles [rad] on a tool of ``diameter_mm``:
    D/2 (cos φ_entry − cos φ_exit) (a/D · D in up or down milling, D in a slot)."""
    return diameter_mm / 2 * (math.cos(entry) - math.cos(exit))


def condition_text(c: Cutting) -> str:
    """One line: "a/D 0.25 up milling, 4 teeth", "slot, 2 teeth" or "entry 30°–150°, 3 teeth"."""
    return described_text(describe_condition(c))


def described_text(d: dict) -> str:
    """:func:`condition_text` of a condition as :func:`describe_condition` writes it (a result file's
    ``computed_for``, a next test's ``condition``)."""
    if d.get("milling") == "slot":
        head = "slot"
    elif "radial_immersion" in d:
        head = f"a/D {d['radial_immersion']:.4g} {d['milling']} milling"
    else:
        head = f"entry {d['entry_deg']:.4g}°–{d['exit_deg']:.4g}°"
    return f"{head}, {d.get('teeth')} teeth"


def never_cut_note(trained) -> str:
    """The note on a condition none of a posterior's cuts was made in, naming the conditions they were made in
    (``trained``, :attr:`millstab.update.Posterior.trained_conditions`): "never cut: the cuts were in slot,
    2 teeth; a/D 0.5 down milling, 2 teeth". One text for every door that says it (the condition line of map and
    recommend, :func:`millstab.api.condition_line`; the predictions' rows, :func:`millstab.api.predict`)."""
    return f"never cut: the cuts were in {'; '.join(condition_text(c) for c in trained)}"


def same_condition(a: Cutting, b: Cutting) -> bool:
    """True when two cuttings are one condition (teeth, coefficients, process damping, entry and exit within
    :data:`ANGLE_TOL`)."""
    return (a.teeth == b.teeth and a.kt == b.kt and a.kr == b.kr and abs(a.entry - b.entry) <= ANGLE_TOL
            and abs(a.exit - b.exit) <= ANGLE_TOL
            and getattr(a, "process_damping", 0.0) == getattr(b, "process_damping", 0.0))


def condition_of(base: Cutting, *, radial_immersion: float | None = None, radial_width_mm: float | None = None,
                 milling: str | None = None, entry_deg: float | None = None, exit_deg: float | None = None,
                 teeth: int | None = None, diameter_mm: float | None = None, field: str = "condition") -> Cutting:
    """The cutting condition of one cut or decision: ``base`` (the config's) with what is given replaced.

    Rules: entry/exit angles [deg] replace the angles (given together); a/D (or a radial width [mm] with
    the tool's ``diameter_mm``) with ``milling`` (else the base's direction) gives the angles by
    :meth:`Cutting.from_immersion`; ``milling`` alone flips the base's direction at its a/D; ``teeth``
    replaces the number of teeth. Kt and Kr stay the base's (one tool family, one material).

    Raises:
        InputError: ``field`` names the option or cell: a width without a diameter or wider than the tool,
            a/D < 1 or ``milling`` alone where the base (slot or general angles) has no direction or a/D.
    """
    from dataclasses import replace

    n = base.teeth if teeth is None else teeth
    if entry_deg is not None or exit_deg is not None:
        if entry_deg is None or exit_deg is None:
            raise InputError(f"{field} entry_deg/exit_deg", (entry_deg, exit_deg), "give both angles")
        # replace: the tool's other properties (process damping, diameter) stay the base's
        return replace(base, teeth=n, entry=math.radians(entry_deg), exit=math.radians(exit_deg))
    ri0, mill0 = _direction(base)
    if radial_width_mm is not None:
        if diameter_mm is None:
            raise InputError(f"{field} radial_width_mm", radial_width_mm,
                             "a radial width needs the tool diameter: add diameter = \"12 mm\" to [cutting] (or give "
                             "radial_immersion = a/D)")
        if not 0 < radial_width_mm <= diameter_mm * (1 + 1e-12):
            raise InputError(f"{field} radial_width_mm", radial_width_mm,
                             f"a radial width in (0, {diameter_mm:g}] mm (the tool diameter of the config)")
        radial_immersion = min(radial_width_mm / diameter_mm, 1.0)
    if radial_immersion is None and milling is None:
        return base if n == base.teeth else replace(base, teeth=n)
    if radial_immersion is None:
        if ri0 is None:
            raise InputError(f"{field} milling", milling, "milling alone needs a config given by radial_immersion "
                                                          "and milling; give radial_immersion too (or entry/exit "
                                                          "angles)")
        radial_immersion = ri0
    mill = milling or mill0
    if mill is None:
        if radial_immersion >= 1:
            mill = "down"
        else:
            raise InputError(f"{field} milling", None, f"missing: a/D {radial_immersion:g} needs up or down (the "
                                                       "config's cutting is a slot or general angles)")
    c = Cutting.from_immersion(n, base.kt, base.kr, float(radial_immersion), mill)
    return replace(base, teeth=n, entry=c.entry, exit=c.exit)


def in_condition(points: PointSet, base: Cutting, target: Cutting, diameter_mm: float | None = None) -> np.ndarray:
    """Boolean mask (n,) of the points cut in ``target`` (:func:`same_condition`), each point's condition read
    from its columns with ``base`` (the config's cutting) filling empty cells: what a plot of ``target``'s limits
    may draw (a slot's chatter at 2 mm says nothing direct about a finishing pass whose limit is 10 mm)."""
    conds, idx = cut_conditions(points, base, diameter_mm)
    return np.array([same_condition(c, target) for c in conds], dtype=bool)[idx]


def cut_conditions(points: PointSet, base: Cutting, diameter_mm: float | None = None
                   ) -> tuple[tuple[Cutting, ...], np.ndarray]:
    """(conditions, index (n,) int): one :class:`Cutting` per distinct condition of the points, in order of
    first appearance, and each point's index into them; ``base`` (the config's cutting) fills empty cells.
    Without condition columns: ((base,), zeros).

    Raises:
        InputError: as :func:`condition_of`, naming the file, data row and column.
    """
    n = len(points)
    if not points.has_conditions:
        return (base,), np.zeros(n, dtype=np.int64)
    cols = points.conditions
    where = f"{points.source.name} " if points.source is not None else ""

    def cell(name, i):
        if name not in cols:
            return None
        v = cols[name][i]
        if name == "milling":
            return v or None
        return None if math.isnan(v) else float(v)

    conds: list[Cutting] = []
    index = np.empty(n, dtype=np.int64)
    memo: dict[tuple, int] = {}
    for i in range(n):  # a cuts file is tens of rows: a plain loop, outside every hot path
        key = tuple(cell(name, i) for name in CONDITION_COLUMNS if name != "feed_per_tooth_mm")
        if key not in memo:
            kw = dict(zip([c for c in CONDITION_COLUMNS if c != "feed_per_tooth_mm"], key))
            t = kw.pop("teeth")
            c = condition_of(base, **kw, teeth=None if t is None else int(t), diameter_mm=diameter_mm,
                             field=f"{where}data row {i + 1}, column")
            j = next((k for k, o in enumerate(conds) if same_condition(o, c)), None)
            if j is None:
                conds.append(c)
                j = len(conds) - 1
            memo[key] = j
        index[i] = memo[key]
    return tuple(conds), index


def cut_feeds(points: PointSet, default_mm: float) -> np.ndarray:
    """Feed per tooth [mm] of each point (n,): its ``feed_per_tooth_mm`` cell, else ``default_mm``."""
    f = points.conditions.get("feed_per_tooth_mm")
    return np.full(len(points), float(default_mm)) if f is None else np.where(np.isnan(f), float(default_mm), f)


__all__ = ["ANGLE_TOL", "CONDITION_COLUMNS", "MILLING", "MILLING_RULE", "MILLING_SYNONYMS", "SHOWN_DIGITS",
           "WIDTH_TOL", "milling_word", "check_conditions", "condition_of", "condition_text", "cut_conditions",
           "cut_feeds", "describe_condition", "described_text", "in_condition", "never_cut_note", "radial_width",
           "same_condition",
           "CLASS_EDGE", "GRADE", "LABELS", "LABEL_RULE", "PointSet", "SYNONYMS", "check_enough", "check_plausible",
           "check_speeds", "grade_of_cell", "label_of_grade", "parse_label_codes"]
