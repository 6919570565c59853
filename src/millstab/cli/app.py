"""The typer application every subcommand registers on, and the shared option parsers."""

from __future__ import annotations

import sys
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator

import numpy as np
import typer

from millstab.errors import InputError

app = typer.Typer(
    name="millstab",
    help="Milling chatter stability: lobes, in-process modal identification, sensitivity, the seed paper.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    # help texts are plain text: units and TOML tables in brackets ("[mm]", "[prior]") must be shown, not
    # read as rich markup (which silently dropped them)
    rich_markup_mode=None,
)


def read_rpm_file(path: Path) -> np.ndarray:
    """Speeds from a text/CSV file: one number per line, or the ``rpm`` column of a CSV with header."""
    import csv

    if not path.exists():
        raise InputError("--rpm-file", str(path), "file does not exist")
    from millstab.io.text import read_text

    text = read_text(path, "--rpm-file", "text file")  # a byte-order mark (Notepad, Excel) is dropped
    # (line number, cells) of the lines that hold data: blank and '#' lines are skipped
    rows = [(no, r) for no, r in enumerate(csv.reader(text.splitlines()), start=1)
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


def select_rpm(rpm: str | None, rpm_file: Path | None, default: np.ndarray | None, fallback: tuple[float, float, float]) -> np.ndarray:
    """Speeds from --rpm, or --rpm-file, or the config's [speeds], or a fallback range."""
    if rpm and rpm_file:
        raise InputError("--rpm", rpm, "give either --rpm or --rpm-file, not both")
    if rpm:
        from millstab import api

        return api.parse_rpm_range(rpm)
    if rpm_file:
        return read_rpm_file(rpm_file)
    if default is not None:
        return np.asarray(default, dtype=float)
    return np.arange(fallback[0], fallback[1] + fallback[2] / 2, fallback[2])


@contextmanager
def progress_bar(label: str) -> Iterator[Callable[[int, int], None] | None]:
    """A transient rich progress bar on stderr (only on a terminal); yields a ``(done, total)``
    callback, or None when stderr is not a terminal (pipes and logs get no bar)."""
    if not sys.stderr.isatty():
        yield None
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    with Progress(TextColumn(label), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(), TimeRemainingColumn(),
                  console=Console(stderr=True), transient=True) as bar:
        task = bar.add_task(label, total=None)

        def update(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)

        yield update


def engine_progress(update: Callable[[int, int], None] | None):
    """A ``progress(stage, done, total)`` callback (:mod:`millstab.api.progress`) that drives a bar's
    ``update(done, total)``, or None without a bar."""
    return None if update is None else (lambda stage, done, total: update(done, total))


@app.callback()
def _root() -> None:
    """millstab: milling chatter stability lobes, in-process modal identification and sensitivity.

    Quantities in configs carry units ("12.53 N/um", "556.31 MPa", "126.9 deg"); plain numbers are SI.
    """
