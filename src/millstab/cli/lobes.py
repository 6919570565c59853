"""``millstab lobes``: the stability lobe diagram of a config."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import numpy as np
import typer

from millstab.cli.app import app, select_rpm
from millstab.errors import InputError

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
    engine: str = typer.Option("zoa", "--engine", help="Stability engine: zoa, sdm or spectral."),
    compare: Optional[str] = typer.Option(None, "--compare", help="Overlay a second engine (zoa, sdm or spectral) and report the difference."),
    raw: bool = typer.Option(False, "--raw-lobes", help="Draw the individual lobes (zoa) under the envelope."),
) -> None:
    """Compute the stability limit b_lim(Ω) of CONFIG and write it as CSV and/or a figure."""
    from millstab.io import load_config, read_points, write_csv
    from millstab.stability import get_engine

    cfg = load_config(config)
    speeds = select_rpm(rpm, rpm_file, cfg.rpm, FALLBACK_RPM)
    pts = read_points(points) if points else None
    env = get_engine(engine).envelope(cfg.structure, cfg.cutting, speeds)
    protect = [p for p in (cfg.path, points, rpm_file) if p]
    finite = np.isfinite(env.depth)
    i_min = int(np.argmin(np.where(finite, env.depth, np.inf)))
    typer.echo(f"{cfg.name}: {speeds.size} speeds {speeds.min():g}..{speeds.max():g} rpm ({engine}); "
               f"minimum limit {env.depth_mm[i_min]:.4g} mm at {speeds[i_min]:.6g} rpm")
    others = []
    if compare:
        if compare == engine:
            raise InputError("--compare", compare, f"must differ from --engine ({engine})")
        other = get_engine(compare).envelope(cfg.structure, cfg.cutting, speeds)
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
        from millstab.plot import save_figure
        from millstab.plot.sld import plot_sld
        from millstab.stability import zoa

        raw_lobes = zoa.lobes(cfg.structure, cfg.cutting, speeds.min(), speeds.max()) if raw else None
        fig = plot_sld(speeds, env.depth_mm, label=f"{engine} limit", lobes=raw_lobes, points=pts, others=others,
                       title=f"{cfg.name}: {cfg.cutting.teeth} teeth, Kt {cfg.cutting.kt / 1e6:g} MPa, Kr {cfg.cutting.kr:g}")
        save_figure(fig, plot, protect=protect)
        typer.echo(f"wrote {plot}")
