"""``millstab reproduce``: every table and figure of the seed paper into one report."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Optional

import typer

from millstab.cli.app import app, stage_bar
from millstab.cli.options import seed_option

#: the kinds of file the report writes into its folder (report.md/.html, tables as CSV, figures as PNG)
REPORT_KINDS = (".md", ".html", ".csv", ".png")


@app.command()
def reproduce(
    out: Path = typer.Option(Path("millstab-report"), "--out",
                             help="Output folder for report.md/.html, figures, CSVs."),
    quick: bool = typer.Option(False, "--quick",
                               help="Smaller Monte Carlo, fewer identification starts, SDM only on coarse grids (no "
                                    "SDM cross-check of the examples): a faster run."),
    points: Optional[Path] = typer.Option(None, "--points",
                                          help="The four-flute chatter tests, if you have them (CSV "
                                               "rpm,depth_mm[,label])."),
    seed: int = seed_option(0, "Seed of every random process in the run."),
) -> None:
    """Reproduce the seed paper's tables and figures, our values beside the paper's."""
    from millstab import api
    from millstab.cli import emit
    from millstab.io import read_points

    # fail before the work: a bad points file or report folder must not wait for the minutes of steps 1-2
    if points is not None:
        read_points(points)
    emit.checked({"--points": points}, {"--out": out}, folders={"--out": REPORT_KINDS})
    t0 = time.perf_counter()
    with stage_bar("starting", total=len(api.reproduce_steps()), transient=False,
                   count="{task.completed}/{task.total} steps") as progress:
        rep = api.reproduce(out, quick=quick, seed=seed, points=points, progress=progress)
    failed = [c for c in rep.checks if not c.ok]
    typer.echo(f"wrote {out / 'report.md'} and {out / 'report.html'} ({len(rep.files)} figures and tables)")
    for c in rep.checks:
        tag = "compared" if c.kind == "comparison" else ("ok" if c.ok else "FAIL")  # a comparison has no verdict
        typer.echo(f"  [{tag}] {c.claim}: {c.measured}")
    typer.echo(f"total time {time.perf_counter() - t0:.1f} s")
    if failed:
        raise typer.Exit(1)
