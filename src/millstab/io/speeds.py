"""A speeds file (``--rpm-file``): one number per line, or the ``rpm`` column of a CSV with a header."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from millstab.errors import InputError
from millstab.io.text import csv_rows, read_text


def read_rpm_file(path: Path) -> np.ndarray:
    """Speeds from a text/CSV file: one number per line, or the ``rpm`` column of a CSV with header."""
    if not path.exists():
        raise InputError("--rpm-file", str(path), "file does not exist")
    text = read_text(path, "--rpm-file", "text file")  # a byte-order mark (Notepad, Excel) is dropped
    # (line number, cells) of the lines that hold data: blank and '#' lines are skipped
    rows = [(no, r) for no, r in enumerate(csv_rows(text.splitlines(), path.name), start=1)
            if r and not r[0].lstrip().startswith("#")]
    if not rows:
        raise InputError("--rpm-file", str(path), "no speeds in the file")
    col, header = 0, None
    if not _is_number(rows[0][1][0]):
        header = [h.strip().lower() for h in rows[0][1]]
        if "rpm" not in header:
            raise InputError("--rpm-file", str(path), "a CSV with a header needs an 'rpm' column")
        col, rows = header.index("rpm"), rows[1:]
    out = []
    for lineno, r in rows:
        cell = r[col] if col < len(r) else ""
        if header is None and any(c.strip() for c in r[1:]):  # "5000,5" is a decimal comma, not 5000 and a stray 5
            raise InputError(f"--rpm-file line {lineno}", ",".join(r), "one speed per line, written with a decimal "
                                                                       "point (5000.5, not 5000,5)")
        if not _is_number(cell):
            raise InputError(f"--rpm-file line {lineno}", cell, "must be a number (rev/min)")
        out.append(float(cell))
    return np.array(out)


def _is_number(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False


__all__ = ["read_rpm_file"]
