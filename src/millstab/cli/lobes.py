"""``millstab lobes``: the stability lobe diagram of a config."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from millstab.api import ENGINES
from millstab.cli.app import app, engine_progress, progress_bar
from millstab.cli.options import condition_options

#: speed range when neither the command line nor the config gives one [rpm]
FALLBACK_RPM = (2000.0, 12000.0, 20.0)

# --- the cutting condition of the SLD (the names of map/recommend/predict's target options, api.config_in_condition:
# the config's tool and structure in another condition) ---
LobesImmersionOpt, LobesMillingOpt, LobesEntryOpt, LobesExitOpt, LobesTeethOpt = condition_options(
    "Draw the lobes", "the config's", "Cutting condition (default: the config's)")


@app.command()
def lobes(
    config: str = typer.Argument(..., help="TOML config file, or example:NAME (ex1, ex2, ex3, fourflute)."),
    rpm: Optional[str] = typer.Option(None, "--rpm", help="Speeds START:STOP:STEP (rev/min); START = STOP is that one "
                                                          "speed."),
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
    radial_immersion: LobesImmersionOpt = None,
    milling: LobesMillingOpt = None,
    entry_deg: LobesEntryOpt = None,
    exit_deg: LobesExitOpt = None,
    teeth: LobesTeethOpt = None,
) -> None:
    """Compute the stability limit b_lim(Ω) of CONFIG and write it as CSV and/or a figure."""
    from millstab import api
    from millstab.cli import emit
    from millstab.io import read_points
    from millstab.io.outputs import check_outputs, config_inputs

    base = api.config(config)
    # another condition than the config's (the same options as map/recommend/predict): the same tool and structure
    cfg, note = api.config_in_condition(base, radial_immersion=radial_immersion, milling=milling, entry_deg=entry_deg,
                                        exit_deg=exit_deg, teeth=teeth)
    speeds = api.speeds(rpm, cfg, FALLBACK_RPM, rpm_file=rpm_file)
    pts = read_points(points, labels_option=False) if points else None  # lobes has no --labels
    inputs = {**config_inputs(cfg), "--points": points, "--rpm-file": rpm_file}
    check_outputs(inputs, {"--out": out, "--plot": plot}, figures=("--plot",))  # before the work
    protect = [p for p in inputs.values() if p]
    with progress_bar("speeds") as update:
        result = api.lobes(cfg, speeds, engine=engine, compare=compare, progress=engine_progress(update))
    typer.echo(result.summary())
    if note:
        typer.echo(note)
    emit.csv(out, result.table(), protect)
    if plot:
        # the SLD is one condition: the points cut in it
        drawn, skipped = api.points_drawn(pts, base, None if note is None else cfg.cutting)
        if skipped:
            typer.echo(skipped)
        emit.figure(plot, lambda: api.lobes_figure(result, points=drawn, raw=raw), protect)
