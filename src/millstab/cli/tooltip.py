"""``millstab tooltip``: the tool-tip FRF of a config's [tool] in its [holder] (receptance coupling), and the
"which stickout?" sweep."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from millstab.cli.app import app, engine_progress, progress_bar


@app.command()
def tooltip(
    config: str = typer.Argument(..., help="TOML config with [tool] and [holder] (docs/tooltip.md)."),
    out: Optional[Path] = typer.Option(None, "--out",
                                       help="Tip FRF CSV freq_hz,real,imag (Hz, m/N): what [structure.frf] reads (x)."),
    out_y: Optional[Path] = typer.Option(None, "--out-y",
                                         help="The y tip FRF, where [holder.x] and [holder.y] differ."),
    plot: Optional[Path] = typer.Option(None, "--plot",
                                        help="Figure (.png, .svg or .pdf): tip FRF and, with --stickout, which "
                                             "stickout."),
    stickout: Optional[str] = typer.Option(None, "--stickout",
                                           help="Stickouts START:STOP:STEP [mm]: modes and minimum limiting depth per "
                                                "stickout."),
    sweep_out: Optional[Path] = typer.Option(None, "--sweep-out",
                                             help="CSV of the sweep: stickout_mm, fn*_hz, peak*_um_per_n, min_blim_mm, "
                                                  "rpm_at_min."),
    rpm: Optional[str] = typer.Option(None, "--rpm", help="Speeds START:STOP:STEP of the sweep (rev/min)."),
    engine: str = typer.Option("zoa", "--engine",
                               help="Stability engine of the sweep (one that takes a measured FRF: zoa)."),
) -> None:
    """Predict the tool-tip FRF of CONFIG's tool in its holder; write it as CSV, and with --stickout the
    minimum limiting depth per stickout."""
    from millstab import api
    from millstab.cli import emit
    from millstab.errors import InputError
    from millstab.io.outputs import config_inputs

    cfg, tool, holder = api.tool_config(config)
    stickouts = api.stickouts_mm(stickout)
    if sweep_out and stickouts is None:
        raise InputError("--sweep-out", str(sweep_out), "needs --stickout START:STOP:STEP [mm]")
    outputs = {"--out": out, "--out-y": out_y, "--plot": plot, "--sweep-out": sweep_out}
    protect = emit.checked(config_inputs(cfg), outputs, figures=("--plot",))
    if rpm and stickouts is None:
        typer.echo("note: --rpm sets the speeds of the stickout sweep, which needs --stickout", err=True)
    speeds = api.speeds(rpm, cfg, api.TOOLTIP_FALLBACK_RPM) if stickouts is not None else None
    with progress_bar("stickouts") as update:
        result = api.tip_frf(cfg, tool, holder, stickouts=stickouts, rpm=speeds, engine=engine,
                            progress=engine_progress(update))
    typer.echo(result.summary())
    emit.csv(out, result.table(), protect)
    emit.csv(out_y, result.table("y"), protect)
    if out and not out_y and result.g_y is not None:
        typer.echo("note: the holder differs in y; --out has x only: give --out-y for the y tip FRF", err=True)
    emit.csv(sweep_out, sweep_out and result.sweep.table(), protect)
    emit.figure(plot, lambda: api.tip_figure(result), protect)
