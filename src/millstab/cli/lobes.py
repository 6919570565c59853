"""``millstab lobes``: the stability lobe diagram of a config."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from millstab.api import ENGINES
from millstab.cli.app import app, engine_progress, progress_bar

#: speed range when neither the command line nor the config gives one [rpm]
FALLBACK_RPM = (2000.0, 12000.0, 20.0)


@app.command()
def lobes(
    config: str = typer.Argument(..., help="TOML config file, or example:NAME (ex1, ex2, ex3, fourflute)."),
    rpm: Optional[str] = typer.Option(None, "--rpm", help="Speeds START:STOP:STEP (rev/min)."),
    rpm_file: Optional[Path] = typer.Option(None, "--rpm-file", help="Speeds, one per line or an 'rpm' CSV column."),
    out: Optional[Path] = typer.Option(None, "--out", help="CSV: rpm,blim_mm,lobe,chatter_hz."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Figure (.png, .svg or .pdf)."),
    points: Optional[Path] = typer.Option(None, "--points",
                                          help="Measured points CSV rpm,depth_mm[,label] to overlay."),
    engine: str = typer.Option("zoa", "--engine", help=f"Stability engine: {', '.join(ENGINES)}."),
    compare: Optional[str] = typer.Option(None, "--compare",
                                          help=f"Overlay a second engine ({', '.join(ENGINES)}) and report the "
                                               "difference."),
    raw: bool = typer.Option(False, "--raw-lobes", help="Draw the individual lobes (zoa) under the envelope."),
) -> None:
    """Compute the stability limit b_lim(Ω) of CONFIG and write it as CSV and/or a figure."""
    from millstab import api
    from millstab.io import read_points, write_csv
    from millstab.io.outputs import check_outputs, config_inputs

    cfg = api.config(config)
    speeds = api.speeds(rpm, cfg, FALLBACK_RPM, rpm_file=rpm_file)
    pts = read_points(points) if points else None
    inputs = {**config_inputs(cfg), "--points": points, "--rpm-file": rpm_file}
    check_outputs(inputs, {"--out": out, "--plot": plot}, figures=("--plot",))  # before the work
    protect = [p for p in inputs.values() if p]
    with progress_bar("speeds") as update:
        result = api.lobes(cfg, speeds, engine=engine, compare=compare, progress=engine_progress(update))
    typer.echo(result.summary())
    if out:
        write_csv(out, *result.table(), protect=protect)
        typer.echo(f"wrote {out}")
    if plot:
        from millstab.io.figures import save_figure

        drawn = api.in_config_condition(pts, cfg)  # the SLD is the config's condition: the points cut in it
        if pts is not None and len(drawn) < len(pts):
            typer.echo(f"{len(pts) - len(drawn)} of the {len(pts)} points were cut in other conditions than the "
                       "config's: not drawn")
        pts = drawn
        save_figure(api.lobes_figure(result, points=pts, raw=raw), plot, protect=protect)
        typer.echo(f"wrote {plot}")
