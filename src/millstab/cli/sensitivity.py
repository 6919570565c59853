"""``millstab sensitivity oat|mc|sobol|morris CONFIG``: sensitivity of the SLD to the modal parameters.

Each method is its own subcommand with its own options and help; they share one body (:func:`_run`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, List, Optional

import typer
from typer.core import TyperGroup

from millstab.api import ENGINES
from millstab.cli.app import app, engine_progress, progress_bar
from millstab.cli.options import DaskOpt, WorkersOpt, seed_callback
from millstab.cli.options import dask_client as _client
from millstab.errors import InputError

#: speed range when neither the command line nor the config gives one [rpm]
FALLBACK_RPM = (2000.0, 12000.0, 50.0)
METHODS = ("oat", "mc", "sobol", "morris")


class _MethodGroup(TyperGroup):
    """The ``sensitivity`` group: an unknown METHOD is an InputError (one line, exit 2), as before the
    methods became subcommands, not a usage panel."""

    def resolve_command(self, ctx, args):
        if args and not args[0].startswith("-") and args[0] not in self.commands:
            raise InputError("METHOD", args[0], f"must be one of {', '.join(METHODS)}")
        return super().resolve_command(ctx, args)


sensitivity_app = typer.Typer(
    cls=_MethodGroup, no_args_is_help=True, add_completion=False, pretty_exceptions_enable=False, rich_markup_mode=None,
    help="Sensitivity of the stability lobe diagram of CONFIG to each modal parameter (MSE in mm^2): "
         "oat (one at a time, the paper's Fig. SENS), mc (Monte Carlo, the paper's Table 6), sobol or morris.")
app.add_typer(sensitivity_app, name="sensitivity")

# options every method takes (typer.Option objects are shared read-only between the commands)
ConfigArg = Annotated[str, typer.Argument(help="TOML config file, or example:NAME (ex1, ex2, ex3, fourflute).")]
RpmOpt = Annotated[Optional[str], typer.Option("--rpm", help="Speeds START:STOP:STEP (rev/min); START = STOP is that "
                                                               "one speed.")]
RpmFileOpt = Annotated[Optional[Path], typer.Option("--rpm-file", help="Speeds, one per line or an 'rpm' CSV column.")]
OutOpt = Annotated[Optional[Path], typer.Option("--out", help="Result JSON (MSE in mm^2).")]
PlotOpt = Annotated[Optional[Path], typer.Option("--plot", help="Figure (.png, .svg or .pdf).")]
EngineOpt = Annotated[str, typer.Option("--engine", help=f"Stability engine: {', '.join(ENGINES)}.")]
SeedOpt = Annotated[int, typer.Option("--seed", help="Random seed; same seed, same numbers; 0..4294967295.",
                                      callback=seed_callback)]
TOpt = Annotated[Optional[float], typer.Option("--t", help="Neighbourhood half-width: each parameter drawn from "
                                                         "[(1-t)p, (1+t)p] (0.1).")]
BoundOpt = Annotated[List[str], typer.Option("--bound", metavar="NAME=LO:HI",
                                             help="NAME=LOWER:UPPER [SI] replacing the ±t range of one "
                                                  "parameter, e.g. fn_x=850:950; repeatable.")]
_CENTRE = "centre on the paper's predicted parameters (its Table 3, Newton results) when CONFIG is its Ex.1, 2 or 3"


@sensitivity_app.command("oat")
def oat_command(
    config: ConfigArg,
    rpm: RpmOpt = None,
    rpm_file: RpmFileOpt = None,
    eps: Annotated[Optional[str], typer.Option("--eps", help="Relative changes: START:STOP:STEP or a comma list "
                                                             "(-0.25:0.25:0.05).")] = None,
    preset: Annotated[Optional[str], typer.Option("--preset", help=f"paper: the paper's grid -0.20:0.20:0.05 and "
                                                                   f"{_CENTRE}.")] = None,
    engine: EngineOpt = "zoa",
    out: OutOpt = None,
    plot: PlotOpt = None,
) -> None:
    """One at a time (the paper's Fig. SENS): the MSE between the SLD and the SLD with one parameter
    changed by each relative change in --eps, the others kept."""
    _run("oat", config, rpm=rpm, rpm_file=rpm_file, eps=eps, out=out, plot=plot, engine=engine, preset=preset)


@sensitivity_app.command("mc")
def mc_command(
    config: ConfigArg,
    rpm: RpmOpt = None,
    rpm_file: RpmFileOpt = None,
    n: Annotated[Optional[int], typer.Option("--n", help="Monte Carlo paths (10000).")] = None,
    t: TOpt = None,
    eps: Annotated[Optional[str],
                   typer.Option("--eps", help="Relative change of a parameter on each path (0.01).")] = None,
    seed: SeedOpt = 0,
    preset: Annotated[Optional[str], typer.Option("--preset", help=f"paper: {_CENTRE} (the defaults are the paper's "
                                                                   "N 10 000, t 0.1, eps 0.01).")] = None,
    engine: EngineOpt = "zoa",
    out: OutOpt = None,
    plot: PlotOpt = None,
    dask: DaskOpt = None,
    workers: WorkersOpt = None,
) -> None:
    """Monte Carlo (the paper's Algorithm 2 and Table 6): mean and SD over --n random structures within
    ±t of the centre of the MSE caused by a relative change --eps of each parameter."""
    _run("mc", config, rpm=rpm, rpm_file=rpm_file, n=n, t=t, eps=eps, seed=seed, out=out, plot=plot, engine=engine,
         preset=preset, dask=dask, workers=workers)


@sensitivity_app.command("sobol")
def sobol_command(
    config: ConfigArg,
    rpm: RpmOpt = None,
    rpm_file: RpmFileOpt = None,
    n: Annotated[Optional[int], typer.Option("--n", help="Base sample, a power of 2 (1024).")] = None,
    t: TOpt = None,
    bound: BoundOpt = [],  # noqa: B006 (typer's default for a repeatable option)
    seed: SeedOpt = 0,
    preset: Annotated[Optional[str], typer.Option("--preset", help=f"paper: {_CENTRE}.")] = None,
    engine: EngineOpt = "zoa",
    out: OutOpt = None,
    plot: PlotOpt = None,
    dask: DaskOpt = None,
    workers: WorkersOpt = None,
) -> None:
    """Sobol' indices (first order S1 and total ST) of the MSE, the minimum limiting depth and b_lim
    at each speed, with parameters uniform within ±t of the centre (or --bound)."""
    _run("sobol", config, rpm=rpm, rpm_file=rpm_file, n=n, t=t, seed=seed, out=out, plot=plot, engine=engine,
         preset=preset, bound=bound, dask=dask, workers=workers)


@sensitivity_app.command("morris")
def morris_command(
    config: ConfigArg,
    rpm: RpmOpt = None,
    rpm_file: RpmFileOpt = None,
    n: Annotated[Optional[int], typer.Option("--n", help="Trajectories (50).")] = None,
    levels: Annotated[int, typer.Option("--levels", help="Grid levels (even).")] = 4,
    t: TOpt = None,
    bound: BoundOpt = [],  # noqa: B006
    seed: SeedOpt = 0,
    preset: Annotated[Optional[str], typer.Option("--preset", help=f"paper: {_CENTRE}.")] = None,
    engine: EngineOpt = "zoa",
    out: OutOpt = None,
    plot: PlotOpt = None,
    dask: DaskOpt = None,
    workers: WorkersOpt = None,
) -> None:
    """Morris elementary effects (mu* and sigma) of the MSE and the minimum limiting depth: a cheap
    screening of which parameters matter, with parameters within ±t of the centre (or --bound)."""
    _run("morris", config, rpm=rpm, rpm_file=rpm_file, n=n, t=t, seed=seed, out=out, plot=plot, engine=engine,
         preset=preset, bound=bound, levels=levels, dask=dask, workers=workers)


def _run(method: str, config: str, *, rpm: str | None = None, rpm_file: Path | None = None, n: int | None = None,
         t: float | None = None, eps: str | None = None, seed: int = 0, out: Path | None = None,
         plot: Path | None = None, engine: str = "zoa", preset: str | None = None, bound: List[str] = (),
         levels: int = 4, dask: str | None = None, workers: int | None = None) -> None:
    """The body every method shares: parse, check the outputs, call :func:`millstab.api.sensitivity`, print,
    save. With --dask or --workers the structures are evaluated on a Dask cluster (:mod:`millstab.cluster`);
    without, dask is not imported."""
    from millstab import api
    from millstab.cli import emit
    from millstab.io.outputs import config_inputs

    if preset is not None and preset not in api.SENSITIVITY_PRESETS:  # before any work
        raise InputError("--preset", preset, f"must be one of {', '.join(api.SENSITIVITY_PRESETS)}")
    api.check_engine_name(engine)
    eps_val, bounds = api.parse_eps(method, eps), api.parse_bounds(bound)
    cfg = api.config(config)
    speeds = api.speeds(rpm, cfg, FALLBACK_RPM, rpm_file=rpm_file)
    protect = emit.checked({**config_inputs(cfg), "--rpm-file": rpm_file}, {"--out": out, "--plot": plot},
                           figures=("--plot",))  # before a long run, not after
    cfg, note = api.modal(cfg)  # a measured FRF: study its fitted modes (issue 14)
    if note:
        typer.echo(note)
    label = {"mc": f"Monte Carlo, {n or api.SENSITIVITY_DEFAULT_N['mc']} paths"}.get(
        method, f"{method}: evaluating structures")
    with _client(dask, workers) as client, progress_bar(label) as bar:
        study = api.sensitivity(method, cfg, speeds, n=n, t=t, eps=eps_val, seed=seed, engine=engine, preset=preset,
                                bounds=bounds, levels=levels, client=client, progress=engine_progress(bar))
    typer.echo(study.summary())
    emit.json(out, study.report_json, protect)
    emit.figure(plot, study.figure, protect + ([out] if out else []))
