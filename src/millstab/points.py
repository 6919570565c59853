"""Point sets: stability-boundary points and labelled test cuts, the model type that identification,
updating and design take. Read from and written to CSV by :mod:`millstab.io.points` (format there).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from millstab.errors import InputError

LABELS = ("stable", "chatter", "marginal")
LABEL_RULE = "must be 'stable', 'chatter', 'marginal' or empty (boundary point)"
#: the graded label of each written label: how strongly it says "chatter"
GRADE = {"stable": 0.0, "marginal": 0.5, "chatter": 1.0}


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
    """

    rpm: np.ndarray
    depth_mm: np.ndarray
    label: np.ndarray | None = None
    weight: np.ndarray | None = None
    source: Path | None = None
    chatter_hz: np.ndarray | None = None
    grade: np.ndarray | None = None
    batch: np.ndarray | None = None

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
                raise InputError(f"points.label[{i}]", s, LABEL_RULE)
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
        batch = np.full(n, "", dtype=object) if self.batch is None else np.atleast_1d(np.asarray(self.batch, dtype=object))
        if batch.ndim != 1 or batch.size != n:
            raise InputError("points.batch", f"{batch.size} values", f"need one value per speed ({n})")
        batch = np.array([str(b).strip() for b in batch], dtype=object)
        # fixed-width unicode array: comparisons like label == "chatter" give boolean masks
        object.__setattr__(self, "rpm", rpm)
        object.__setattr__(self, "depth_mm", depth)
        object.__setattr__(self, "label", label.astype("<U8") if n else np.array([], dtype="<U8"))
        object.__setattr__(self, "chatter_hz", hz)
        object.__setattr__(self, "weight", weight)
        object.__setattr__(self, "grade", grade)
        object.__setattr__(self, "batch", batch.astype(str) if n else np.array([], dtype="<U1"))
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
                        self.grade[m], self.batch[m])


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


__all__ = ["GRADE", "LABELS", "LABEL_RULE", "PointSet", "check_enough", "check_plausible", "check_speeds"]
