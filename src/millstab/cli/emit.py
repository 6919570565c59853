"""What every command does around its one service call, in one place: check the output paths before the
work (and keep the input files it must never overwrite), write each output through ``millstab.io`` with
its "wrote PATH" line, and print a result's table with rich. A command body is then parse → api → these
(docs/architecture.md, "Adding a command"; ``tests/test_layers.py`` measures the bodies)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Sequence

import typer


def checked(inputs: Mapping[str, Any], outputs: Mapping[str, Path | None], figures: Iterable[str] = (),
            folders: Mapping[str, Iterable[str]] | None = None) -> list[Path]:
    """:func:`millstab.io.outputs.check_outputs` (before the work: an hour's run is not lost to a bad path);
    returns the input files given, for the writers to protect."""
    from millstab.io.outputs import check_outputs

    check_outputs(inputs, outputs, figures=figures, folders=folders)
    return [Path(p) for p in inputs.values() if p]


def wrote(path: Path | None, write: Callable[[], Any], echo: Callable[[str], Any] = typer.echo, note: str = "") -> None:
    """``write()`` (an io writer of ``path``) and "wrote PATH" when ``path`` is given; nothing otherwise."""
    if path:
        write()
        echo(f"wrote {path}{note}")


def csv(path: Path | None, table, protect: Sequence[Path], echo: Callable[[str], Any] = typer.echo) -> None:
    """A result's ``table()`` (header, columns) as CSV at ``path`` (if given)."""
    from millstab.io import write_csv

    wrote(path, lambda: write_csv(path, *table, protect=protect), echo)


def csv_or_print(path: Path | None, table, protect: Sequence[Path], echo: Callable[[str], Any] = typer.echo,
                 printed: bool = True) -> None:
    """A result's ``table()`` as CSV at ``path``, or without one as CSV text on standard output (``printed``
    False: not printed, another output, e.g. a JSON file, was asked for instead)."""
    from millstab.io.results import csv_text

    if path:
        csv(path, table, protect, echo)
    elif printed:
        typer.echo(csv_text(*table), nl=False)


def json(path: Path | None, doc: Callable[[], dict] | dict, protect: Sequence[Path],
         echo: Callable[[str], Any] = typer.echo) -> None:
    """A JSON document (or a function making it, called only when ``path`` is given) at ``path``."""
    from millstab.io import write_json

    wrote(path, lambda: write_json(path, doc() if callable(doc) else doc, protect=protect), echo)


def figure(path: Path | None, make: Callable[[], Any], protect: Sequence[Path],
           echo: Callable[[str], Any] = typer.echo) -> None:
    """The figure ``make()`` returns (drawn only when ``path`` is given) saved at ``path`` and closed."""
    from millstab.io.figures import save_figure

    wrote(path, lambda: save_figure(make(), path, protect=protect), echo)


def table(console, title: str, header: Sequence[str], rows: Iterable[Sequence[str]],
          caption: str | None = None) -> None:
    """A rich table: the first column left-aligned (names), the others right-aligned (numbers)."""
    from rich.table import Table

    t = Table(title=title, caption=caption)
    for i, col in enumerate(header):
        t.add_column(col, justify="left" if i == 0 else "right")
    for row in rows:
        t.add_row(*row)
    console.print(t)


def number(value: float, spec: str) -> str:
    """A number as a table shows it (format ``spec``); ``-`` for NaN (not computed)."""
    return "-" if value != value else format(value, spec)


def lines(console, text: str) -> None:
    """A result's ``summary()`` line by line, a line starting ``warning:`` marked in yellow."""
    for line in text.splitlines():
        console.print(line.replace("warning:", "[yellow]warning:[/yellow]", 1) if line.startswith("warning:") else line,
                      highlight=False)


#: the warnings this process has printed as they were issued (``millstab: warning: ...`` on stderr, cli.main's
#: handler): a result's own list of them (an update's) is not printed a second time after its table
SHOWN: set[str] = set()


def warnings(console, lines: Iterable[str], tag: str = "warning") -> None:
    """Each line as ``warning: ...`` in yellow (``tag`` e.g. "warning (from the update)", "note"), but for those
    already printed as they were issued (:data:`SHOWN`)."""
    for line in lines:
        if line not in SHOWN:
            console.print(f"[yellow]{tag}:[/yellow] {line}")
