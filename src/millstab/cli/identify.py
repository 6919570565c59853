"""``millstab identify``: in-process modal parameters from measured boundary points."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Optional

import typer

from millstab.api import ENGINES
from millstab.cli.app import app
from millstab.cli.options import seed_option

#: relative standard error above which the command suggests planning more tests (millstab design)
LOOSE = 0.05


@app.command()
def identify(
    config: str = typer.Argument(..., help="TOML config (cutting conditions + starting modal structure), or example:NAME."),
    points: Path = typer.Argument(..., help="Points CSV rpm,depth_mm[,label][,weight]; unlabelled rows are boundary points."),
    method: str = typer.Option("lsq", "--method", help="lsq (multi-start trust-region least squares) or newton (the paper's scheme)."),
    free: Optional[str] = typer.Option(None, "--free", help="Free parameters, e.g. fn_x,k_x,zeta_x (default: all)."),
    axisymmetric: bool = typer.Option(False, "--axisymmetric", help="Tie x and y (parameters fn, k, zeta)."),
    initial: Optional[str] = typer.Option(None, "--initial", help="Start values in SI, e.g. fn_x=900,k_x=12e6."),
    seed: int = seed_option(0, "Seed of the random designs (same seed, same numbers)."),
    loss: str = typer.Option("linear", "--loss", help="Robust loss (lsq): linear, soft_l1, huber, cauchy, arctan."),
    engine: str = typer.Option("zoa", "--engine", help=f"Stability engine: {', '.join(ENGINES)}."),
    out: Optional[Path] = typer.Option(None, "--out", help="Write the fit as JSON."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Final SLD against the points (.png/.svg/.pdf)."),
    history_plot: Optional[Path] = typer.Option(None, "--history-plot", help="Objective against iteration."),
    quiet: bool = typer.Option(False, "--quiet", help="No progress display."),
    noise: Optional[float] = typer.Option(
        None, "--noise", help="Relative standard deviation of a measured limiting depth (0.02 = 2 %), if known: the "
        "standard errors use it and the fit is checked against it. Default: the residual scatter (an assumed 2 % "
        "with fewer than 10 degrees of freedom)."),
) -> None:
    """Identify the modal parameters whose stability boundary explains the measured POINTS."""
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
    from rich.table import Table

    from millstab import api
    from millstab.io import read_points, write_json
    from millstab.io.outputs import check_outputs, config_inputs

    cfg = api.config(config)
    pts = read_points(points)
    inputs = {**config_inputs(cfg), "POINTS": points}
    check_outputs(inputs, {"--out": out, "--plot": plot, "--history-plot": history_plot},
                  figures=("--plot", "--history-plot"))  # fail before the work, not after
    protect = [p for p in inputs.values() if p]
    console = Console(stderr=True)
    cfg, note = api.modal(cfg)  # a measured FRF: start from its fitted modes (issue 14)
    if note:
        typer.echo(note)
    options = dict(method=method, free=free, axisymmetric=axisymmetric, initial=initial, engine=engine, seed=seed,
                   loss=loss, noise=noise)
    if quiet:
        fit = api.identify(cfg, pts, **options)
    else:
        with Progress(TextColumn("[bold]{task.description}"), BarColumn(), TextColumn("iteration {task.completed}"),
                      TimeElapsedColumn(), console=console, transient=True) as bar:
            task = bar.add_task(f"identify ({method})", total=None)

            def progress(stage: str, done: int, total: int | None) -> None:
                bar.update(task, completed=done, description=stage)

            fit = api.identify(cfg, pts, progress=progress, **options)
    out_console = Console()
    table = Table(title=f"{cfg.name}: {method}",
                  caption=f"{fit.iterations} iterations, {fit.evaluations} SLD evaluations, {fit.time_s:.2f} s")
    _, columns = fit.table()
    for col in ("parameter", "start", "estimate", "± std error", "unit"):
        table.add_column(col, justify="right" if col != "parameter" else "left")
    for name, start, est, se, unit in zip(*columns):
        table.add_row(name, f"{start:.5g}", f"{est:.5g}", "-" if math.isnan(se) else f"{se:.4g}", unit)
    out_console.print(table)
    for line in fit.summary().splitlines():
        out_console.print(line.replace("warning:", "[yellow]warning:[/yellow]", 1) if line.startswith("warning:") else line,
                          highlight=False)
    if fit.std_errors is not None and (fit.alternatives or fit.loose(LOOSE)):
        out_console.print(f"tip: `millstab design {config} --fit {out or 'FIT.json'} --points {points}` plans the speeds of "
                          "further tests that would pin the loose parameters")
    if out:
        write_json(out, fit.to_json(), protect=protect)
        out_console.print(f"wrote {out}")
    if plot:
        from millstab.io.figures import save_figure

        save_figure(api.fit_figure(fit, cfg, pts, engine, method), plot, protect=protect)
        out_console.print(f"wrote {plot}")
    if history_plot:
        from millstab.io.figures import save_figure

        save_figure(api.history_figure(fit), history_plot, protect=protect)
        out_console.print(f"wrote {history_plot}")
