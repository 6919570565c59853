"""``millstab design``: the speeds at which the next boundary-point tests pin the modal parameters best."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import numpy as np
import typer

from millstab.cli.app import app, parse_rpm_range
from millstab.errors import InputError

#: candidate grid when neither --rpm nor the config gives speeds: this many evenly spaced speeds over
#: the config's [speeds] range is the finest the plan needs (the lobes of a 5 kHz mode at 20 000 rpm
#: are hundreds of rpm wide)
N_CANDIDATES = 800


@app.command()
def design(
    config: str = typer.Argument(..., help="TOML config (cutting conditions, starting structure, [speeds] range), or example:NAME."),
    n: int = typer.Option(20, "--n", help="Number of tests to plan (a speed may get several: independent repeats)."),
    points: Optional[Path] = typer.Option(None, "--points", help="Boundary points already measured (CSV rpm,depth_mm[,label][,weight])."),
    fit: Optional[Path] = typer.Option(None, "--fit", help="A fit JSON (millstab identify --out): plan around its estimate, covariance and alternatives."),
    rpm: Optional[str] = typer.Option(None, "--rpm", help="Candidate speeds START:STOP:STEP [rev/min] (default: the config's [speeds] range)."),
    target: Optional[str] = typer.Option(None, "--target", help="Parameters to pin, e.g. fn_x,fn_y (default: every free one)."),
    free: Optional[str] = typer.Option(None, "--free", help="Free parameters without --fit, e.g. fn_x,k_x,zeta_x (default: all)."),
    axisymmetric: bool = typer.Option(False, "--axisymmetric", help="Tie x and y (without --fit)."),
    noise: float = typer.Option(0.02, "--noise", help="Relative standard deviation of a measured limiting depth (0.02 = 2 %)."),
    speed_noise: float = typer.Option(0.005, "--speed-noise", help="Relative uncertainty of the boundary's speed (0.005 = 0.5 %)."),
    samples: int = typer.Option(16, "--samples", help="Parameter samples the plan averages over."),
    seed: int = typer.Option(0, "--seed", help="Seed of the parameter samples (same seed, same plan)."),
    out: Optional[Path] = typer.Option(None, "--out", help="Write the plan as CSV: rpm,tests,predicted_depth_mm."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="The SLD with the planned and measured speeds (.png/.svg/.pdf)."),
) -> None:
    """Plan N boundary-point tests: the speeds whose limiting depths best determine the modal parameters.

    Without --fit the plan averages over a prior spread around the config's structure (fn 5 %, k and ζ
    30 %); after a first identification pass its --fit (and the --points it used) so the plan adds
    what those points lack.
    """
    from rich.console import Console
    from rich.table import Table

    from millstab.identify.design import design_speeds
    from millstab.io import load_config, read_points
    from millstab.io.results import read_json, write_csv
    from millstab.params import Parameterization

    cfg = load_config(config)
    from millstab.io.outputs import check_outputs, config_inputs

    inputs = {**config_inputs(cfg), "--points": points, "--fit": fit}
    check_outputs(inputs, {"--out": out, "--plot": plot}, figures=("--plot",))  # fail before the work, not after
    protect = [p for p in inputs.values() if p]
    if not cfg.structure.is_modal:  # a measured FRF: plan around its fitted modes (issue 14)
        from millstab.modal.run import fitted_config

        cfg, note = fitted_config(cfg)
        typer.echo(note)
    if rpm:
        candidates = parse_rpm_range(rpm)
    elif cfg.rpm is not None:
        candidates = np.linspace(float(np.min(cfg.rpm)), float(np.max(cfg.rpm)), N_CANDIDATES)
    else:
        raise InputError("--rpm", None, "the config has no [speeds] range: give candidate speeds as START:STOP:STEP")
    existing = None
    if points is not None:
        pts = read_points(points)
        existing = pts.subset(pts.boundary)
    options = dict(n=n, existing_rpm=None if existing is None else existing.rpm,
                   existing_weight=None if existing is None else existing.weight,
                   target=[t.strip() for t in target.split(",") if t.strip()] if target else None,
                   noise=noise, speed_noise=speed_noise, samples=samples, seed=seed)
    if fit is not None:
        par, theta, cov, alts = _from_fit_json(read_json(fit), fit, cfg.cutting)
        plan = design_speeds(par, cfg.cutting, candidates, theta=theta, cov_u=cov, alternatives=alts, **options)
    else:
        names = tuple(s.strip() for s in free.split(",") if s.strip()) if free else ()
        par = Parameterization(cfg.structure, names, axisymmetric)
        plan = design_speeds(par, cfg.cutting, candidates, **options)

    console = Console()
    table = Table(title=f"{cfg.name}: {n} planned tests", caption=(
        f"relative standard errors at {noise:.3g} depth noise and {speed_noise:.3g} speed noise; "
        f"design efficiency ≥ {plan.efficiency:.3f}"))
    cols = ["parameter", "value"] + (["measured points"] if plan.sigma_existing is not None else []) + [
        f"+ {n} evenly spaced", f"+ {n} planned"]
    for c in cols:
        table.add_column(c, justify="left" if c == "parameter" else "right")
    for i, name in enumerate(plan.names):
        row = [name + (" *" if name in plan.target else ""), f"{plan.theta[i]:.5g}"]
        if plan.sigma_existing is not None:
            row.append(_pct(plan.sigma_existing[i]))
        row += [_pct(plan.sigma_uniform[i]), _pct(plan.sigma_design[i])]
        table.add_row(*row)
    console.print(table)
    console.print("* = the parameters the plan pins (sum of squared relative standard errors)")
    if not np.all(np.isfinite(plan.sigma_design)):
        console.print("note: at these values no boundary points can tell some parameters apart (e.g. identical x and y "
                      "modes in a symmetric cut); the plan serves the nearby structures it averages over. Use "
                      "--axisymmetric to plan for tied x and y, or --fit to plan around an identified structure.")
    tests = plan.tests()
    console.print("planned speeds, rev/min (tests): " + ", ".join(f"{r:.0f} ({c})" if c > 1 else f"{r:.0f}" for r, c, _ in tests))
    if out:
        write_csv(out, ("rpm", "tests", "predicted_depth_mm"),
                  ([round(r, 3) for r, _, _ in tests], [c for _, c, _ in tests], [d for _, _, d in tests]), protect=protect)
        console.print(f"wrote {out}")
    if plot:
        from millstab.plot import save_figure
        from millstab.plot.identify import plot_design
        from millstab.stability import zoa

        grid = np.linspace(candidates[0], candidates[-1], 800)
        sld = zoa.envelope(par.structure(plan.theta), cfg.cutting, grid).depth_mm
        save_figure(plot_design(plan, grid, sld, existing, title=f"{cfg.name}: planned tests"), plot, protect=protect)
        console.print(f"wrote {plot}")


def _pct(v: float) -> str:
    return "not determined" if not np.isfinite(v) else f"± {100 * v:.3g} %"


def _from_fit_json(doc, path: Path, cutting):
    """(Parameterization, θ, cov of ln θ or None, alternatives) from a fit JSON (millstab identify --out)."""
    from millstab.identify.design import fit_view
    from millstab.model import Mode, Structure
    from millstab.params import Parameterization

    try:
        modes = {d: tuple(Mode(m["fn"], m["k"], m["zeta"], f"structure.{d}[{i}]") for i, m in enumerate(doc["structure"][d]))
                 for d in ("x", "y")}
        names = tuple(doc["free"])
        theta = [doc["estimate"][k] for k in names]
        alts = [[a["estimate"][k] for k in names] for a in doc.get("alternatives") or []]
    except (KeyError, TypeError) as exc:
        raise InputError("--fit", str(path), f"not a millstab fit JSON (missing {exc})") from None
    par = Parameterization(Structure(**modes), names, all("_" not in k for k in names))
    se, corr = doc.get("std_errors"), doc.get("correlation")
    tied = ((doc.get("settings") or {}).get("xy_tie_test") or {}).get("chosen") == "tied"
    return fit_view(par, cutting, theta, None if not se else [se[k] for k in names], corr, alts, tied)
