"""``millstab sensitivity oat|mc|sobol|morris CONFIG``: sensitivity of the SLD to the modal parameters.

Each method is its own subcommand with its own options and help; they share one body (:func:`_run`).
"""

from __future__ import annotations

import sys
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Iterator, List, Optional

import numpy as np
import typer
from typer.core import TyperGroup

from millstab.cli.app import app, engine_progress, progress_bar, select_rpm
from millstab.cli.options import seed_callback
from millstab.bounds import check_speeds
from millstab.errors import InputError
from millstab.stability import ENGINES

#: speed range when neither the command line nor the config gives one [rpm]
FALLBACK_RPM = (2000.0, 12000.0, 50.0)
METHODS = ("oat", "mc", "sobol", "morris")


def _parse_eps_grid(text: str) -> np.ndarray:
    """``START:STOP:STEP`` or a comma list of relative changes (e.g. ``-0.2:0.2:0.05``)."""
    try:
        if ":" in text:
            start, stop, step = (float(p) for p in text.split(":"))
            if not step > 0 or stop < start:
                raise ValueError
            return np.round(start + step * np.arange(int(np.floor((stop - start) / step + 1e-9)) + 1), 12) + 0.0
        return np.array([float(p) for p in text.split(",") if p.strip()])
    except ValueError:
        raise InputError("--eps", text, "for oat: START:STOP:STEP with STEP > 0, or a comma list, e.g. -0.25:0.25:0.05") from None


def _parse_bounds(items: List[str]) -> dict[str, tuple[float, float]]:
    out = {}
    for item in items:
        name, sep, rng = item.partition("=")
        lo, sep2, hi = rng.partition(":")
        try:
            if not (sep and sep2):
                raise ValueError
            out[name.strip()] = (float(lo), float(hi))
        except ValueError:
            raise InputError("--bound", item, "expected NAME=LOWER:UPPER in SI units, e.g. fn_x=850:950") from None
    return out


def _fmt_row(label: str, values, width: int = 11) -> str:
    return f"{label:<22}" + "".join(f"{v:>{width}.5f}" if np.isfinite(v) else f"{'-':>{width}}" for v in values)


def _mc_table(res, paper: dict | None, paper_comparable: bool) -> str:
    lines = [f"{'MSE [mm^2]':<22}" + "".join(f"{n:>11}" for n in res.names),
             _fmt_row("mean (millstab)", res.mean), _fmt_row("SD 1/N (millstab)", res.sd), _fmt_row("SEM (millstab)", res.sem)]
    if paper and all(n in paper for n in res.names):
        tag = "" if paper_comparable else " [other structure]"
        lines += [_fmt_row("mean (paper Table 6)", [paper[n]["mean"] for n in res.names]) + tag,
                  _fmt_row("SD (paper Table 6)", [paper[n]["sd"] for n in res.names]) + tag]
    ratios = []
    for d in ("x", "y"):
        if f"fn_{d}" in res.names and f"k_{d}" in res.names:
            s = f"fn_{d}/k_{d} = {res.ratio(f'fn_{d}', f'k_{d}'):.1f}"
            if paper and f"fn_{d}" in paper:
                s += f" (paper {paper[f'fn_{d}']['mean'] / paper[f'k_{d}']['mean']:.1f})"
            ratios.append(s)
    if ratios:
        lines.append("ratio of mean sensitivities: " + "; ".join(ratios))
    return "\n".join(lines)


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
RpmOpt = Annotated[Optional[str], typer.Option("--rpm", help="Speeds START:STOP:STEP (rev/min).")]
RpmFileOpt = Annotated[Optional[Path], typer.Option("--rpm-file", help="Speeds, one per line or an 'rpm' CSV column.")]
OutOpt = Annotated[Optional[Path], typer.Option("--out", help="Result JSON (MSE in mm^2).")]
PlotOpt = Annotated[Optional[Path], typer.Option("--plot", help="Figure (.png, .svg or .pdf).")]
EngineOpt = Annotated[str, typer.Option("--engine", help=f"Stability engine: {', '.join(ENGINES)}.")]
SeedOpt = Annotated[int, typer.Option("--seed", help="Random seed; same seed, same numbers; 0..4294967295.",
                                      callback=seed_callback)]
TOpt = Annotated[Optional[float], typer.Option("--t", help="Neighbourhood half-width: each parameter drawn from "
                                                         "[(1-t)p, (1+t)p] (0.1).")]
BoundOpt = Annotated[List[str], typer.Option("--bound", metavar="NAME=LO:HI", help="NAME=LOWER:UPPER [SI] replacing the ±t range of one "
                                                             "parameter, e.g. fn_x=850:950; repeatable.")]
DaskOpt = Annotated[Optional[str], typer.Option(
    "--dask", metavar="ADDRESS", help="Run on the Dask cluster whose scheduler is at ADDRESS (e.g. tcp://10.0.0.5:8786); "
                                      "needs millstab[dask]. Same numbers as a local run.")]
WorkersOpt = Annotated[Optional[int], typer.Option(
    "--workers", help="Run on a local Dask cluster of N worker processes started for this run; needs millstab[dask]. "
                      "Same numbers as a local run.")]
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
    _run("oat", config, rpm, rpm_file, None, None, eps, 0, out, plot, engine, preset, [], 4)


@sensitivity_app.command("mc")
def mc_command(
    config: ConfigArg,
    rpm: RpmOpt = None,
    rpm_file: RpmFileOpt = None,
    n: Annotated[Optional[int], typer.Option("--n", help="Monte Carlo paths (10000).")] = None,
    t: TOpt = None,
    eps: Annotated[Optional[str], typer.Option("--eps", help="Relative change of a parameter on each path (0.01).")] = None,
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
    _run("mc", config, rpm, rpm_file, n, t, eps, seed, out, plot, engine, preset, [], 4, dask, workers)


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
    _run("sobol", config, rpm, rpm_file, n, t, None, seed, out, plot, engine, preset, bound, 4, dask, workers)


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
    _run("morris", config, rpm, rpm_file, n, t, None, seed, out, plot, engine, preset, bound, levels, dask, workers)


@contextmanager
def _client(dask: str | None, workers: int | None) -> Iterator:
    """The run's Dask client (None without --dask/--workers: then dask is not imported); says on stderr
    where the work goes."""
    if dask is None and workers is None:
        yield None
        return
    from millstab.cluster import CONNECT_SECONDS, open_client

    if sys.stderr.isatty():  # on a terminal only: a pipe's stderr keeps an error to one line
        typer.echo(f"Dask: connecting to {dask} (at most ~{CONNECT_SECONDS:g} s)…" if dask else
                   f"Dask: starting {workers} local workers…", err=True)
    with open_client(dask, workers) as client:
        n_workers = len(client.scheduler_info()["workers"])
        where = f"scheduler {dask}" if dask else "a local cluster started for this run"
        typer.echo(f"Dask: {n_workers} workers, {sum(client.nthreads().values())} threads ({where})", err=True)
        yield client


def _run(method: str, config: str, rpm: str | None, rpm_file: Path | None, n: int | None, t: float | None,
         eps: str | None, seed: int, out: Path | None, plot: Path | None, engine: str, preset: str | None,
         bound: List[str], levels: int, dask: str | None = None, workers: int | None = None) -> None:
    """The body every method shares: parse, check the outputs, call :func:`millstab.api.sensitivity`, print,
    save. With --dask or --workers the structures are evaluated on a Dask cluster (:mod:`millstab.cluster`);
    without, dask is not imported."""
    from millstab import api
    from millstab.io import write_json
    from millstab.io.outputs import check_outputs, config_inputs

    if preset is not None and preset not in api.SENSITIVITY_PRESETS:  # before any work
        raise InputError("--preset", preset, f"must be one of {', '.join(api.SENSITIVITY_PRESETS)}")
    if engine not in ENGINES:
        raise InputError("--engine", engine, f"must be one of {', '.join(ENGINES)}")
    if method == "oat":
        eps_val = _parse_eps_grid(eps) if eps else None
    elif method == "mc":
        try:
            eps_val = None if eps is None else float(eps)
        except ValueError:
            raise InputError("--eps", eps, "for mc: one relative change, e.g. 0.01") from None
    else:
        eps_val = None
    bounds = _parse_bounds(bound)
    cfg = api.config(config)
    speeds = select_rpm(rpm, rpm_file, cfg.rpm, FALLBACK_RPM)
    if rpm_file:  # --rpm text and [speeds] are checked where they are parsed; a file's speeds here
        check_speeds(speeds, f"--rpm-file {rpm_file.name}")
    inputs = {**config_inputs(cfg), "--rpm-file": rpm_file}
    check_outputs(inputs, {"--out": out, "--plot": plot}, figures=("--plot",))  # before a long run, not after
    protect = [p for p in inputs.values() if p]
    cfg, note = api.modal(cfg)  # a measured FRF: study its fitted modes (issue 14)
    if note:
        typer.echo(note)
    label = {"mc": f"Monte Carlo, {n or api.SENSITIVITY_DEFAULT_N['mc']} paths"}.get(method, f"{method}: evaluating structures")
    with _client(dask, workers) as client, progress_bar(label) as bar:
        study = api.sensitivity(method, cfg, speeds, n=n, t=t, eps=eps_val, seed=seed, engine=engine, preset=preset,
                                bounds=bounds, levels=levels, client=client, progress=engine_progress(bar))
    typer.echo(study.header())
    _print(study)
    if out:
        write_json(out, study.to_json(paths=False), protect=protect)
        typer.echo(f"wrote {out}")
    if plot:
        from millstab.io.figures import save_figure

        save_figure(study.figure(), plot, protect=protect + ([out] if out else []))
        typer.echo(f"wrote {plot}")


def _print(study) -> None:
    """The study's table on stdout."""
    res = study.result
    if study.method == "oat":
        typer.echo(f"{'MSE [mm^2]':<12}" + "".join(f"{n:>11}" for n in res.names))
        for k, e in enumerate(res.eps):
            typer.echo(f"eps {e:+7.3f} " + "".join(f"{v:>11.5f}" for v in res.mse_mm2[:, k]))
    elif study.method == "mc":
        typer.echo(f"Monte Carlo sensitivity: N = {res.n}, t = {res.t:g}, eps = {res.eps:g}, seed {res.seed}")
        typer.echo(_mc_table(res, study.paper, study.paper_comparable))
        if study.paper:
            typer.echo("paper Table 6: N = 10 000, t = 0.1, eps = 1 % around Ex.1 predicted values; its speed set "
                       "is not given" + ("" if study.paper_comparable else "; this run differs in centre or settings"))
    else:
        w = 15 if study.method == "sobol" else 11
        typer.echo(f"{'':<24}" + "".join(f"{nm:>{w}}" for nm in res.names))
        if study.method == "sobol":
            for oname, d in (("MSE", res.mse), ("min b_lim", res.minimum)):
                for key in ("S1", "ST"):
                    typer.echo(f"{oname + ' ' + key:<24}" + "".join(f"{v:.3f}±{c:.3f}".rjust(w) for v, c in zip(d[key], d[key + '_conf'])))
            top = np.argmax(res.blim["ST"], axis=1)
            share = {nm: int(np.sum(top == j)) for j, nm in enumerate(res.names)}
            typer.echo("largest total index of b_lim, speeds per parameter: " +
                       ", ".join(f"{k} {v}" for k, v in share.items() if v))
        else:
            for oname, d in res.outputs.items():
                typer.echo(f"{oname + ' mu*':<24}" + "".join(f"{v:>11.4g}" for v in d["mu_star"]))
                typer.echo(f"{oname + ' sigma':<24}" + "".join(f"{v:>11.4g}" for v in d["sigma"]))
