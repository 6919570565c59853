"""The ``stickout_mm`` column of a cuts CSV: each cut's tool stickout (holder face to tip) [mm].

A small hook on :func:`millstab.io.points.read_points`'s result: the reader keeps columns it does not own in
``PointSet.extra`` (text cells, one per row); :func:`stickouts` turns that column into metres. An empty
cell is the config's stickout (NaN). Used by ``millstab update`` with a ``[tool]`` + ``[holder]`` config
(:mod:`millstab.update.stickout`).
"""

from __future__ import annotations

import math

import numpy as np

from millstab.errors import InputError

COLUMN = "stickout_mm"


def stickouts_mm(points) -> np.ndarray | None:
    """Each row's stickout [mm] as written (NaN: empty cell, the config's), or ``None`` without a
    ``stickout_mm`` column (the shop database stores these numbers: :mod:`millstab.shopdb.store`).

    Raises:
        InputError: a cell that is not a number of mm in (0, 1000], naming its row.
    """
    cells = (getattr(points, "extra", None) or {}).get(COLUMN)
    if cells is None:
        return None
    out = np.full(len(cells), np.nan)
    where = getattr(getattr(points, "source", None), "name", "cuts")
    for i, c in enumerate(cells):
        text = str(c).strip()
        if not text:
            continue
        try:
            v = float(text)
        except ValueError:
            raise InputError(f"{where} row {i + 1}, {COLUMN}", text,
                             "a stickout in mm, e.g. 45 (empty: the config's)") from None
        if not (math.isfinite(v) and 0 < v <= 1000):
            raise InputError(f"{where} row {i + 1}, {COLUMN}", text, "a stickout in mm, > 0 and at most 1000 "
                                                                      "(holder face to tip; mm, not m)")
        out[i] = v
    return out


def stickouts(points) -> np.ndarray | None:
    """Each row's stickout [m] (NaN: empty cell, the config's), or ``None`` without a ``stickout_mm`` column.

    Raises:
        InputError: a cell that is not a number of mm in (0, 1000], naming its row.
    """
    mm = stickouts_mm(points)
    return None if mm is None else mm * 1e-3


def stickout_cells(mm) -> np.ndarray:
    """The ``stickout_mm`` cells (str) of stickouts [mm] (NaN: ``""``), written so that :func:`stickouts_mm`
    reads back the same floats (``repr``: the shortest exact text)."""
    return np.array(["" if math.isnan(v) else repr(float(v)) for v in np.asarray(mm, dtype=float)], dtype=object)


__all__ = ["COLUMN", "stickout_cells", "stickouts", "stickouts_mm"]
