"""``millstab update``, ``map`` and ``recommend``: Bayesian updating from test cuts, P(stable) maps and
the recommended cut."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Optional

import numpy as np
import typer

from millstab.cli.app import app, parse_rpm_range
from millstab.errors import InputError
from millstab.stability import ENGINES

_SHOW = {"Hz": (1.0, "Hz"), "N/m": (1e-6, "N/µm"), "-": (1.0, ""), "N/m^2": (1e-6, "MPa")}


def _range(text: str, option: str, unit: str, parts_wanted: int) -> tuple[float, ...]:
    """``A:B`` or ``A:B:S`` → floats, with a one-line error naming the option."""
    parts = text.split(":")
    form = "LOW:HIGH" if parts_wanted == 2 else "START:STOP:STEP"
    if len(parts) != parts_wanted:
        raise InputError(option, text, f"expected {form} in {unit}")
    try:
        vals = tuple(float(p) for p in parts)
    except ValueError:
        raise InputError(option, text, f"{form} must be numbers ({unit})") from None
    if not all(math.isfinite(v) for v in vals) or not 0 <= vals[0] < vals[1] or (parts_wanted == 3 and vals[2] <= 0):
        raise InputError(option, text, f"need 0 <= {form.split(':')[0]} < {form.split(':')[1]}" +
                         (" and STEP > 0" if parts_wanted == 3 else ""))
    return vals


def _load_posterior(path: Path):
    from millstab.io import read_json
    from millstab.update import Posterior

    return Posterior.from_json(read_json(path), str(path))


@app.command("update")
def update_cmd(
    config: str = typer.Argument(..., help="TOML config: cutting conditions, hammer-test modes (the prior), optional [prior]."),
    cuts: Path = typer.Argument(..., help="Cuts CSV rpm,depth_mm,label[,chatter_hz]; label stable|chatter|marginal."),
    points: Optional[Path] = typer.Option(None, "--points", help="Boundary points CSV to use as well."),
    engine: str = typer.Option("zoa", "--engine", help=f"Stability engine: {', '.join(ENGINES)} (zoa: fast, and the "
                                                       "only one whose chatter frequencies are used)."),
    samples: int = typer.Option(4000, "--samples", help="Posterior samples (SMC particles)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the sampler (same seed, same samples)."),
    out: Path = typer.Option(..., "--out", help="Posterior JSON (schema millstab.posterior/1)."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Pair plot of the posterior (.png/.svg/.pdf)."),
    start: Optional[Path] = typer.Option(None, "--start", help="Posterior JSON of the first cuts of CUTS (from an "
                                         "earlier update): only the later cuts are tempered in (faster)."),
) -> None:
    """Update the modal parameters from labelled test CUTS (Bayesian; tempered SMC)."""
    from rich.console import Console
    from rich.table import Table

    from millstab.io import check_outputs, config_inputs, load_config, read_points, write_json
    from millstab.update import update

    cfg = load_config(config)
    c = read_points(cuts)
    p = read_points(points) if points is not None else None
    inputs = {**config_inputs(cfg), "CUTS": cuts, "--points": points, "--start": start}
    check_outputs(inputs, {"--out": out, "--plot": plot}, figures=("--plot",))
    protect = [v for v in inputs.values() if v]
    if samples < 100:
        raise InputError("--samples", samples, "need at least 100 samples")
    if not cfg.structure.is_modal:  # a measured FRF: the prior centres on its fitted modes (issue 14)
        from millstab.modal.run import fitted_config

        cfg, note = fitted_config(cfg)
        typer.echo(note)
    post = update(cfg, c, p, engine=engine, samples=samples, seed=seed,
                  start=_load_posterior(start) if start is not None else None)
    doc = post.to_json()
    doc["config"] = cfg.name
    write_json(out, doc, protect=protect)
    con = Console()
    d = post.diagnostics
    table = Table(title=f"{cfg.name}: posterior ({len(post.samples)} samples, {engine})",
                  caption=f"{d['stages']} tempering stages, acceptance {min(d['acceptance']):.2f}-{max(d['acceptance']):.2f}, "
                          f"{d['loglik_calls']} likelihood calls, {d['time_s']:.1f} s")
    for col in ("parameter", "prior", "mean", "sd", "5 %", "95 %", "unit"):
        table.add_column(col, justify="left" if col == "parameter" else "right")
    for j, (name, unit) in enumerate(zip(post.names, post.prior.units())):
        sc, shown = _SHOW[unit]
        s = doc["parameters"][name]
        table.add_row(name, f"{post.prior.median[j] * sc:.5g}", *(f"{s[k] * sc:.5g}" for k in ("mean", "sd", "q05", "q95")), shown)
    con.print(table)
    for w in doc["warnings"]:
        con.print(f"[yellow]warning:[/yellow] {w}")
    con.print(f"wrote {out}")
    if plot:
        from millstab.plot import save_figure
        from millstab.plot.update import plot_corner

        save_figure(plot_corner(post.samples, post.names, post.prior.units()), plot, protect=protect)
        con.print(f"wrote {plot}")


@app.command("map")
def map_cmd(
    posterior: Path = typer.Argument(..., help="Posterior JSON from millstab update."),
    rpm: str = typer.Option(..., "--rpm", help="Speeds START:STOP:STEP [rpm]."),
    depth: str = typer.Option(..., "--depth", help="Depths START:STOP:STEP [mm], e.g. 0:6:0.05."),
    out: Path = typer.Option(..., "--out", help="CSV rpm,depth_mm,p_stable."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="P(stable) map with the 5/50/95 % boundaries (.png/.svg/.pdf)."),
) -> None:
    """The probability of a stable cut on a speed × depth grid, from posterior samples."""
    from rich.console import Console

    from millstab.io import check_outputs, write_csv
    from millstab.update import p_stable_map

    speeds = parse_rpm_range(rpm)
    d0, d1, ds = _range(depth, "--depth", "mm", 3)
    depths = d0 + ds * np.arange(int(math.floor((d1 - d0) / ds + 1e-9)) + 1)
    if depths.size * speeds.size > 5_000_000:
        raise InputError("--depth", depth, f"{speeds.size} speeds × {depths.size} depths is too many cells (max 5e6)")
    post = _load_posterior(posterior)
    check_outputs({"POSTERIOR": posterior}, {"--out": out, "--plot": plot}, figures=("--plot",))
    _warn_outside(post, speeds.min(), speeds.max())
    pm = p_stable_map(post, speeds, depths)
    R, D = np.meshgrid(speeds, depths, indexing="ij")
    write_csv(out, ["rpm", "depth_mm", "p_stable"], [R.ravel(), D.ravel(), pm.ravel()], protect=[posterior])
    con = Console()
    con.print(f"wrote {out} ({speeds.size} speeds × {depths.size} depths, {post.samples.shape[0]} samples)")
    if plot:
        from millstab.plot import save_figure
        from millstab.plot.update import plot_pmap
        from millstab.stability import get_engine

        prior_sld = get_engine(post.engine).envelope(post.prior.par.base, post.prior.cutting, speeds).depth_mm
        fig = plot_pmap(speeds, depths, pm, speeds, prior_sld, post.cuts, title=f"P(stable) from {posterior.name}")
        save_figure(fig, plot, protect=[posterior])
        con.print(f"wrote {plot}")


def _warn_outside(post, lo: float, hi: float) -> None:
    import warnings

    r = np.asarray(post.cuts.get("rpm") or [], float)
    if r.size and (lo < 0.9 * r.min() or hi > 1.1 * r.max()):
        warnings.warn(f"speeds {lo:g}-{hi:g} rpm reach beyond the tested speeds ({r.min():g}-{r.max():g} rpm): "
                      "there the answer leans on the prior", UserWarning, stacklevel=2)


@app.command("recommend")
def recommend_cmd(
    posterior: Path = typer.Argument(..., help="Posterior JSON from millstab update."),
    risk: float = typer.Option(0.05, "--risk", help="Tolerated probability of chatter, in (0, 1)."),
    rpm: str = typer.Option(..., "--rpm", help="Speed range LOW:HIGH [rpm]."),
    max_depth: Optional[float] = typer.Option(None, "--max-depth", help="Deepest allowed cut [mm]."),
    radial_width: Optional[float] = typer.Option(None, "--radial-width", help="Radial width of cut [mm] (for cm³/min)."),
    feed_per_tooth: Optional[float] = typer.Option(None, "--feed-per-tooth", help="Feed per tooth [mm] (for cm³/min)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the next-test subsample."),
    out: Path = typer.Option(..., "--out", help="Recommendation JSON."),
) -> None:
    """The most productive cut whose probability of chatter is at most RISK, and the next test cut."""
    from rich.console import Console

    from millstab.io import check_outputs, write_json
    from millstab.update import recommend

    if not 0 < risk < 1:
        raise InputError("--risk", risk, "the tolerated probability of chatter must be in (0, 1), e.g. 0.05")
    lo, hi = _range(rpm, "--rpm", "rpm", 2)
    if lo <= 0:
        raise InputError("--rpm", rpm, "need 0 < LOW < HIGH rev/min")
    post = _load_posterior(posterior)
    check_outputs({"POSTERIOR": posterior}, {"--out": out})
    rec = recommend(post, risk, (lo, hi), max_depth_mm=max_depth, width_mm=radial_width, feed_mm=feed_per_tooth, seed=seed)
    write_json(out, rec.to_json(), protect=[posterior])
    con = Console()
    mrr = f", {rec.mrr_cm3_per_min:.4g} cm³/min" if rec.mrr_cm3_per_min is not None else ""
    con.print(f"recommended: {rec.rpm:.0f} rpm, {rec.depth_mm:.3f} mm (P(chatter) {rec.p_chatter:.3f} ≤ {risk:g}, "
              f"limited by {rec.limited_by}{mrr})")
    nt = rec.next_test
    con.print(f"next test: {nt['rpm']:.0f} rpm, {nt['depth_mm']:.3f} mm (P(chatter) {nt['p_chatter']:.2f}; {nt['why']})")
    con.print(f"wrote {out}")
