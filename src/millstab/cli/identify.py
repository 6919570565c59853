"""``millstab identify``: in-process modal parameters from measured boundary points."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from millstab.api import ENGINES
from millstab.cli.app import app, stage_bar
from millstab.cli.options import seed_option

#: relative standard error above which the command suggests planning more tests (millstab design)
LOOSE = 0.05


@app.command()
def identify(
    config: str = typer.Argument(...,
                                 help="TOML config (cutting conditions + starting modal structure), or example:NAME."),
    points: Path = typer.Argument(..., help="Points CSV rpm,depth_mm[,label][,weight]; unlabelled rows are "
                                            "boundary points."),
    method: str = typer.Option("lsq", "--method",
                               help="lsq (multi-start trust-region least squares) or newton (the paper's scheme)."),
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

    from millstab import api
    from millstab.cli import emit
    from millstab.io import read_points
    from millstab.io.outputs import config_inputs

    # identify has no --labels: an unknown label is told what the file may hold, not to use that option
    cfg, pts = api.config(config), read_points(points, labels_option=False)
    protect = emit.checked({**config_inputs(cfg), "POINTS": points}, {"--out": out, "--plot": plot, "--history-plot":
                           history_plot}, figures=("--plot", "--history-plot"))  # fail before the work, not after
    cfg, note = api.modal(cfg)  # a measured FRF: start from its fitted modes (issue 14)
    if note:
        typer.echo(note)
    with stage_bar(f"identify ({method})", quiet=quiet) as progress:
        fit = api.identify(cfg, pts, method=method, free=free, axisymmetric=axisymmetric, initial=initial,
                           engine=engine, seed=seed, loss=loss, noise=noise, progress=progress)
    con = Console()
    rows = [(n, f"{s:.5g}", f"{e:.5g}", emit.number(se, ".4g"), u) for n, s, e, se, u in zip(*fit.table()[1])]
    emit.table(con, f"{cfg.name}: {method}", ("parameter", "start", "estimate", "± std error", "unit"), rows,
               f"{fit.iterations} iterations, {fit.evaluations} SLD evaluations, {fit.time_s:.2f} s")
    emit.lines(con, fit.summary())
    if fit.std_errors is not None and (fit.alternatives or fit.loose(LOOSE)):
        con.print(f"tip: `millstab design {config} --fit {out or 'FIT.json'} --points {points}` plans the speeds of "
                  "further tests that would pin the loose parameters")
    emit.json(out, fit.to_json, protect, con.print)
    emit.figure(plot, lambda: api.fit_figure(fit, cfg, pts, engine, method), protect, con.print)
    emit.figure(history_plot, lambda: api.history_figure(fit), protect, con.print)
