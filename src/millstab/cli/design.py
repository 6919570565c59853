"""``millstab design``: the speeds at which the next boundary-point tests pin the modal parameters best."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import numpy as np
import typer

from millstab.cli.app import app
from millstab.parsing import parse_rpm_range
from millstab.cli.identify import show_value
from millstab.errors import InputError

#: candidate grid when neither --rpm nor the config gives speeds: this many evenly spaced speeds over
#: the config's [speeds] range is the finest the plan needs (the lobes of a 5 kHz mode at 20 000 rpm
#: are hundreds of rpm wide)
N_CANDIDATES = 800


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
    config: str = typer.Argument(..., help="TOML config (cutting conditions, starting structure, speeds table), or example:NAME."),
    n: int = typer.Option(20, "--n", help="Number of tests to plan (a speed may get several: independent repeats)."),
    points: Optional[Path] = typer.Option(None, "--points", help="Boundary points already measured (CSV rpm,depth_mm[,label][,weight])."),
    fit: Optional[Path] = typer.Option(None, "--fit", help="A fit JSON (millstab identify --out): plan around its estimate, covariance and alternatives."),
    rpm: Optional[str] = typer.Option(None, "--rpm", help="Candidate speeds START:STOP:STEP in rev/min (default: the range of the config's speeds table)."),
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
    """``millstab design`` (help: :data:`HELP`)."""
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
        doc = read_json(fit)
        check_fit_matches(doc, fit, cfg)
        par, theta, cov, alts = _from_fit_json(doc, fit, cfg.cutting)
        plan = design_speeds(par, cfg.cutting, candidates, theta=theta, cov_u=cov, alternatives=alts, **options)
    else:
        names = tuple(s.strip() for s in free.split(",") if s.strip()) if free else ()
        par = Parameterization(cfg.structure, names, axisymmetric)
        plan = design_speeds(par, cfg.cutting, candidates, **options)

    console = Console()
    table = Table(title=f"{cfg.name}: {n} planned tests", caption=(
        f"relative standard errors at {noise:.3g} depth noise and {speed_noise:.3g} speed noise: root-mean-square "
        f"over the {plan.samples} parameter samples the plan serves (the values shown and draws around them)"))
    cols = ["parameter", "value"] + (["measured points"] if plan.sigma_existing is not None else []) + [
        f"+ {n} evenly spaced", f"+ {n} planned"]
    for c in cols:
        table.add_column(c, justify="left" if c == "parameter" else "right")
    for i, name in enumerate(plan.names):
        row = [name + (" *" if name in plan.target else ""), show_value(name, plan.theta[i])]
        if plan.sigma_existing is not None:
            row.append(_pct(plan.sigma_existing_mean[i]))
        worse = plan.sigma_design_mean[i] > plan.sigma_uniform_mean[i] * (1 + 1e-9)
        row += [_pct(plan.sigma_uniform_mean[i]), _pct(plan.sigma_design_mean[i]) + (" †" if worse else "")]
        table.add_row(*row)
    console.print(table)
    console.print("* = the parameters the plan pins: it minimises the sum of their squared relative standard errors, "
                  f"averaged over {plan.samples} parameter samples")
    console.print(_criterion_line(plan))
    if np.any(plan.sigma_design_mean > plan.sigma_uniform_mean * (1 + 1e-9)):
        console.print("† = determined less well than by the evenly spaced tests: the plan gives this up for larger gains "
                      "elsewhere (use --target to pin the parameters that matter most)")
    if not np.all(np.isfinite(plan.sigma_design)):
        lost = ", ".join(nm for nm, v in zip(plan.names, plan.sigma_design) if not np.isfinite(v))
        console.print(f"note: at the values shown {lost} are not determined by any boundary points (e.g. identical x and y "
                      "modes in a symmetric cut); the plan serves the nearby structures it averages over. Use "
                      "--axisymmetric to plan for tied x and y, or --fit to plan around an identified structure.")
    tests = plan.tests()
    console.print("planned speeds, rev/min (tests): " + ", ".join(f"{r:.0f} ({c})" if c > 1 else f"{r:.0f}" for r, c, _ in tests))
    if out:
        write_csv(out, ("rpm", "tests", "predicted_depth_mm"),
                  ([round(r, 3) for r, _, _ in tests], [c for _, c, _ in tests], [d for _, _, d in tests]), protect=protect)
        console.print(f"wrote {out}")
    if plot:
        from millstab.io.figures import save_figure
        from millstab.plot.identify import plot_design
        from millstab.stability import zoa

        grid = np.linspace(candidates[0], candidates[-1], 800)
        sld = zoa.envelope(par.structure(plan.theta), cfg.cutting, grid).depth_mm
        save_figure(plot_design(plan, grid, sld, existing, title=f"{cfg.name}: planned tests"), plot, protect=protect)
        console.print(f"wrote {plot}")


def _criterion_line(plan) -> str:
    """The plan against evenly spaced tests by the plan's own criterion, and its efficiency bound."""
    ratio = plan.criterion_design / plan.criterion_uniform
    if plan.uniform:
        head = (f"criterion (expected Σ σ² of the * parameters): the {plan.rpm.size} tests evenly spaced over the "
                "candidates are as good as any plan found, so they are the plan")
    else:
        head = (f"criterion (expected Σ σ² of the * parameters): planned {plan.criterion_design:.3g}, evenly spaced "
                f"{plan.criterion_uniform:.3g} ({ratio:.2f}×)")
    return (f"{head}; efficiency of these {plan.rpm.size} tests ≥ {plan.efficiency:.3f} against the best continuous design "
            f"(that design itself ≥ {plan.efficiency_continuous:.3f})")


def check_fit_matches(doc, path: Path, cfg) -> None:
    """Refuse a fit JSON made from other cutting conditions or another mode layout than ``cfg``'s; warn
    when the file is too old to record its cutting conditions."""
    import warnings

    rec = doc.get("cutting") if isinstance(doc, dict) else None
    if rec is None:
        warnings.warn(f"--fit {path}: the file does not record the cutting conditions it was fitted under (written "
                      "by an older millstab), so it cannot be checked against this config: make sure it comes from "
                      f"{cfg.name}", UserWarning, stacklevel=2)
    else:
        from millstab.identify.result import cutting_difference

        diff = cutting_difference(rec, cfg.cutting)
        if diff:
            raise InputError("--fit", str(path), f"was fitted under other cutting conditions than {cfg.name}: {diff} "
                                                 "(the config); plan with the config the fit was made from")
    layout = {d: len((doc.get("structure") or {}).get(d) or []) for d in ("x", "y")} if isinstance(doc, dict) else {}
    want_layout = {d: len(getattr(cfg.structure, d)) for d in ("x", "y")}
    if layout and layout != want_layout:
        raise InputError("--fit", str(path),
                         f"its structure has {layout['x']} x and {layout['y']} y mode(s), the config {cfg.name} "
                         f"{want_layout['x']} and {want_layout['y']}: plan with the config the fit was made from")
    made_from = doc.get("config") if isinstance(doc, dict) else None
    if isinstance(made_from, str) and made_from != cfg.name:
        warnings.warn(f"--fit {path} was made from config {made_from!r}, this is {cfg.name!r}; their cutting conditions "
                      "and modes agree, so the plan goes ahead", UserWarning, stacklevel=2)


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
