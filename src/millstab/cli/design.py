"""``millstab design``: the speeds at which the next boundary-point tests pin the modal parameters best."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from millstab.cli.app import app
from millstab.cli.options import seed_option

#: the command's help (rich reflows each paragraph; square brackets would be read as markup)
HELP = (
    "Plan N boundary-point tests: the speeds whose limiting depths best determine the modal parameters.\n\n"
    "Without --fit the plan averages over a prior spread around the config's structure (fn 5 %, k and ζ 30 %). "
    "After a first identification pass give its --fit (and the --points it used): the plan then adds what those "
    "points lack. The fit must come from the same config (cutting conditions and modes).\n\n"
    "The plan minimises the sum of the squared relative standard errors of the target parameters, averaged over "
    "the parameters' uncertainty; it is never worse by that measure than the same number of evenly spaced tests, "
    "though a single parameter can be (the table shows each). Stiffness is shown in N/µm."
)


@app.command(help=HELP)
def design(
    config: str = typer.Argument(...,
                                 help="TOML config (cutting conditions, starting structure, speeds table), or "
                                      "example:NAME."),
    n: int = typer.Option(20, "--n", help="Number of tests to plan (a speed may get several: independent repeats)."),
    points: Optional[Path] = typer.Option(None, "--points",
                                          help="Boundary points already measured (CSV rpm,depth_mm[,label][,weight])."),
    fit: Optional[Path] = typer.Option(None, "--fit",
                                       help="A fit JSON (millstab identify --out): plan around its estimate, "
                                            "covariance and alternatives."),
    rpm: Optional[str] = typer.Option(None, "--rpm",
                                      help="Candidate speeds START:STOP:STEP in rev/min (default: the range of the "
                                           "config's speeds table)."),
    target: Optional[str] = typer.Option(None, "--target",
                                         help="Parameters to pin, e.g. fn_x,fn_y (default: every free one)."),
    free: Optional[str] = typer.Option(None, "--free",
                                       help="Free parameters without --fit, e.g. fn_x,k_x,zeta_x (default: all)."),
    axisymmetric: bool = typer.Option(False, "--axisymmetric", help="Tie x and y (without --fit)."),
    noise: float = typer.Option(0.02, "--noise",
                                help="Relative standard deviation of a measured limiting depth (0.02 = 2 %)."),
    speed_noise: float = typer.Option(0.005, "--speed-noise",
                                      help="Relative uncertainty of the boundary's speed (0.005 = 0.5 %)."),
    samples: int = typer.Option(16, "--samples", help="Parameter samples the plan averages over."),
    seed: int = seed_option(0, "Seed of the parameter samples (same seed, same plan)."),
    engine: Optional[str] = typer.Option(None, "--engine", help="Stability engine of the plan's sensitivities and "
                                         "predicted depths: zoa, sdm, spectral (default: the --fit's own, else zoa; "
                                         "at low radial immersion plan with the engine the fit used)."),
    out: Optional[Path] = typer.Option(None, "--out", help="Write the plan as CSV: rpm,tests,predicted_depth_mm."),
    plot: Optional[Path] = typer.Option(None, "--plot",
                                        help="The SLD with the planned and measured speeds (.png/.svg/.pdf)."),
) -> None:
    """``millstab design`` (help: :data:`HELP`)."""
    from rich.console import Console

    from millstab import api
    from millstab.cli import emit
    from millstab.io import read_points
    from millstab.io.outputs import config_inputs
    from millstab.io.results import read_json

    cfg = api.config(config)
    protect = emit.checked({**config_inputs(cfg), "--points": points, "--fit": fit}, {"--out": out, "--plot": plot},
                           figures=("--plot",))  # fail before the work, not after
    cfg, note = api.modal(cfg)  # a measured FRF: plan around its fitted modes (issue 14)
    if note:
        typer.echo(note)
    pts = read_points(points) if points is not None else None
    fit_doc = read_json(fit) if fit is not None else None
    plan = api.design(cfg, n=n, points=pts, fit=fit_doc, fit_source=str(fit),
                      rpm=api.parse_rpm_range(rpm) if rpm else None,
                      target=target, free=free, axisymmetric=axisymmetric, noise=noise, speed_noise=speed_noise,
                      samples=samples, seed=seed, engine=engine)
    console = Console()
    header, rows, caption = plan.errors()
    emit.table(console, f"{cfg.name}: {n} planned tests", header, rows, caption)
    console.print(plan.summary())
    emit.csv(out, plan.table(), protect, console.print)
    emit.figure(plot, lambda: api.design_figure(plan, cfg, pts, fit_doc, str(fit)), protect, console.print)
