"""``millstab lobes``: the stability lobe diagram of a config."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import numpy as np
import typer

from millstab.cli.app import app, engine_progress, progress_bar, select_rpm
from millstab.errors import InputError
from millstab.stability import ENGINES

#: speed range when neither the command line nor the config gives one [rpm]
FALLBACK_RPM = (2000.0, 12000.0, 20.0)


@app.command()
def lobes(
    config: str = typer.Argument(..., help="TOML config file, or example:NAME (ex1, ex2, ex3, fourflute)."),
    rpm: Optional[str] = typer.Option(None, "--rpm", help="Speeds START:STOP:STEP (rev/min)."),
    rpm_file: Optional[Path] = typer.Option(None, "--rpm-file", help="Speeds, one per line or an 'rpm' CSV column."),
    out: Optional[Path] = typer.Option(None, "--out", help="CSV: rpm,blim_mm,lobe,chatter_hz."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Figure (.png, .svg or .pdf)."),
    points: Optional[Path] = typer.Option(None, "--points", help="Measured points CSV rpm,depth_mm[,label] to overlay."),
    engine: str = typer.Option("zoa", "--engine", help=f"Stability engine: {', '.join(ENGINES)}."),
    compare: Optional[str] = typer.Option(None, "--compare", help=f"Overlay a second engine ({', '.join(ENGINES)}) and report the difference."),
    raw: bool = typer.Option(False, "--raw-lobes", help="Draw the individual lobes (zoa) under the envelope."),
) -> None:
    """Compute the stability limit b_lim(Ω) of CONFIG and write it as CSV and/or a figure."""
    from millstab.io import load_config, read_points, write_csv
    from millstab.io.outputs import check_outputs, config_inputs

    if compare and compare == engine:
        raise InputError("--compare", compare, f"must differ from --engine ({engine})")
    cfg = load_config(config)
    speeds = select_rpm(rpm, rpm_file, cfg.rpm, FALLBACK_RPM)
    pts = read_points(points) if points else None
    inputs = {**config_inputs(cfg), "--points": points, "--rpm-file": rpm_file}
    check_outputs(inputs, {"--out": out, "--plot": plot}, figures=("--plot",))  # before the work
    protect = [p for p in inputs.values() if p]
    env = _envelope(engine, cfg, speeds)
    finite = np.isfinite(env.depth)
    i_min = int(np.argmin(np.where(finite, env.depth, np.inf)))
    typer.echo(f"{cfg.name}: {speeds.size} speeds {speeds.min():g}..{speeds.max():g} rpm ({engine}); "
               f"minimum limit {env.depth_mm[i_min]:.4g} mm at {speeds[i_min]:.6g} rpm")
    others = []
    if compare:
        other = _envelope(compare, cfg, speeds)
        ok = np.isfinite(other.depth) & finite
        rel = np.abs(other.depth[ok] / env.depth[ok] - 1)
        typer.echo(f"{compare} vs {engine}: max |difference| {100 * rel.max():.2f} % at "
                   f"{speeds[ok][np.argmax(rel)]:.6g} rpm, mean {100 * rel.mean():.2f} %")
        others.append((f"{compare} limit", speeds, other.depth_mm))
    if out:
        cols = {"rpm": speeds, "blim_mm": env.depth_mm, "lobe": env.lobe, "chatter_hz": env.chatter_hz}
        if compare:
            cols[f"blim_mm_{compare}"] = others[0][2]
        write_csv(out, list(cols), list(cols.values()), protect=protect)
        typer.echo(f"wrote {out}")
    if plot:
        from millstab.io.figures import save_figure
        from millstab.plot.sld import plot_sld
        from millstab.stability import zoa

        raw_lobes = zoa.lobes(cfg.structure, cfg.cutting, speeds.min(), speeds.max()) if raw else None
        fig = plot_sld(speeds, env.depth_mm, label=f"{engine} limit", lobes=raw_lobes, points=pts, others=others,
                       title=f"{cfg.name}: {cfg.cutting.teeth} teeth, Kt {cfg.cutting.kt / 1e6:g} MPa, Kr {cfg.cutting.kr:g}")
        save_figure(fig, plot, protect=protect)
        typer.echo(f"wrote {plot}")


def _envelope(engine: str, cfg, speeds: np.ndarray):
    """The engine's envelope; the semi-discretization (seconds to minutes) with a progress bar on a terminal."""
    from millstab.stability import get_engine

    eng = get_engine(engine)
    if not eng.reports_progress:
        return eng.envelope(cfg.structure, cfg.cutting, speeds)
    with progress_bar(f"{engine}: speeds") as update:
        return eng.envelope(cfg.structure, cfg.cutting, speeds, **engine_progress(update))
