"""``millstab simulate``: virtual test cuts (time-domain simulation and chatter detection).

One cut:   millstab simulate CONFIG --rpm R --depth MM [--feed-per-tooth MM] [--revs N] [--plot cut.png]
           [--out trace.csv]
Many cuts: millstab simulate CONFIG --cuts cuts.csv --out labelled.csv [--label-noise P --seed S]
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import numpy as np
import typer

from millstab.cli.app import app
from millstab.cli.options import seed_option
from millstab.errors import InputError


@app.command()
def simulate(
    config: str = typer.Argument(..., help="TOML config file, or example:NAME (ex1, ex2, ex3, fourflute)."),
    rpm: Optional[float] = typer.Option(None, "--rpm", help="Spindle speed of one cut (rev/min)."),
    depth: Optional[float] = typer.Option(None, "--depth", help="Axial depth of one cut (mm)."),
    cuts: Optional[Path] = typer.Option(None, "--cuts", help="CSV rpm,depth_mm[,label,weight] of cuts to label."),
    feed: float = typer.Option(0.1, "--feed-per-tooth", help="Feed per tooth (mm)."),
    revs: float = typer.Option(100.0, "--revs", help="Spindle revolutions per cut."),
    steps: Optional[int] = typer.Option(None, "--steps", help="Steps per tooth period (>= 20; default automatic)."),
    start: str = typer.Option("steady", "--start",
                              help="steady (engaged cut, small bump) or rest (entering at full depth)."),
    out: Optional[Path] = typer.Option(None, "--out", help="CSV: with --cuts rpm,depth_mm,label,chatter_hz; "
                                                           "else the trace t_s,x_m,y_m,fx_N,fy_N."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Figure of one cut (.png, .svg or .pdf)."),
    label_noise: float = typer.Option(0.0, "--label-noise",
                                      help="Probability that a stable/chatter label is swapped (needs --seed)."),
    marginal: str = typer.Option("keep", "--marginal", help="keep the 'marginal' label, or 'random': call it "
                                                            "stable/chatter at even odds (needs --seed)."),
    seed: Optional[int] = seed_option(None, "Seed of the label noise."),
) -> None:
    """Simulate test cuts of CONFIG in the time domain and label them stable, marginal or chatter."""
    from millstab import api
    from millstab.io import read_points, write_csv

    cfg = api.config(config)
    protect = [p for p in (cfg.path, cuts) if p]
    if cuts is not None:
        if rpm is not None or depth is not None:
            raise InputError("--cuts", str(cuts), "give either --cuts or --rpm/--depth, not both")
        if plot is not None:
            raise InputError("--plot", str(plot), "a figure is drawn for one cut (--rpm/--depth), not for --cuts")
        pts = read_points(cuts)
        lab = api.label_cuts(cfg, pts, feed_mm=feed, revs=revs, steps=steps, start=start, label_noise=label_noise,
                             marginal=marginal, seed=seed)
        counts = ", ".join(f"{int(np.sum(lab.label == k))} {k}" for k in ("stable", "marginal", "chatter"))
        typer.echo(f"{cfg.name}: {len(pts)} cuts labelled: {counts}")
        if out:
            write_csv(out, *api.labels_table(lab), protect=protect)
            typer.echo(f"wrote {out}")
        return
    if rpm is None or depth is None:
        raise InputError("--rpm/--depth", f"{rpm}/{depth}",
                         "give the speed (rev/min) and depth (mm) of one cut, or --cuts FILE")
    if label_noise or seed is not None or marginal != "keep":
        raise InputError("--label-noise", label_noise, "label noise applies to --cuts only")
    res, det = api.simulate_cut(cfg, rpm, depth, feed_mm=feed, revs=revs, steps=steps, start=start)
    hz = f" at {det.chatter_hz:.1f} Hz ({det.lobe})" if det.label != "stable" else ""
    typer.echo(f"{cfg.name}: {rpm:g} rpm, {depth:g} mm, {feed:g} mm/tooth, {res.periods} tooth periods: "
               f"{det.label}{hz}; growth {det.growth:.3g}, level {det.level:.3g}"
               + ("; the vibration diverged" if res.diverged else ""))
    if out:
        write_csv(out, ["t_s", "x_m", "y_m", "fx_N", "fy_N"], [res.t, res.x, res.y, res.fx, res.fy], protect=protect)
        typer.echo(f"wrote {out}")
    if plot:
        from millstab.io.figures import save_figure
        from millstab.plot.simulate import plot_cut

        save_figure(plot_cut(res, det, title=cfg.name), plot, protect=protect)
        typer.echo(f"wrote {plot}")
