"""The typer application every subcommand registers on, and the shared option parsers."""

from __future__ import annotations

import sys
from contextlib import contextmanager
from typing import Callable, Iterator

import typer

from millstab.io.speeds import read_rpm_file  # noqa: F401 (its old home)

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


@contextmanager
def progress_bar(label: str) -> Iterator[Callable[[int, int], None] | None]:
    """A transient rich progress bar on stderr (only on a terminal); yields a ``(done, total)``
    callback, or None when stderr is not a terminal (pipes and logs get no bar)."""
    if not sys.stderr.isatty():
        yield None
        return
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    with Progress(TextColumn(label), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(), TimeRemainingColumn(),
                  console=Console(stderr=True), transient=True) as bar:
        task = bar.add_task(label, total=None)

        def update(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)

        yield update


@contextmanager
def stage_bar(label: str, total: int | None = None, quiet: bool = False, transient: bool = True,
              count: str = "iteration {task.completed}") -> Iterator[Callable[[str, int, int | None], None] | None]:
    """A rich bar on stderr for work in stages (an iterative solver, the report's steps) that shows the stage
    text; yields a ``progress(stage, done, total)`` callback (:mod:`millstab.api.progress`), or None with
    ``quiet``."""
    if quiet:
        yield None
        return
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), TextColumn(count), TimeElapsedColumn(),
                  console=Console(stderr=True), transient=transient) as bar:
        task = bar.add_task(label, total=total)

        def progress(stage: str, done: int, total_: int | None) -> None:
            bar.update(task, completed=done, description=stage)

        yield progress


def engine_progress(update: Callable[[int, int], None] | None):
    """A ``progress(stage, done, total)`` callback (:mod:`millstab.api.progress`) that drives a bar's
    ``update(done, total)``, or None without a bar."""
    return None if update is None else (lambda stage, done, total: update(done, total))


@app.callback()
def _root() -> None:
    """millstab: milling chatter stability lobes, in-process modal identification and sensitivity.

    Quantities in configs carry units ("12.53 N/um", "556.31 MPa", "126.9 deg"); plain numbers are SI.
    """
