"""``millstab sensitivity oat|mc|sobol|morris CONFIG``: sensitivity of the SLD to the modal parameters."""

from __future__ import annotations

import sys
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator, List, Optional

import numpy as np
import typer

from millstab.cli.app import app, select_rpm
from millstab.errors import InputError

#: speed range when neither the command line nor the config gives one [rpm]
FALLBACK_RPM = (2000.0, 12000.0, 50.0)
METHODS = ("oat", "mc", "sobol", "morris")
PRESETS = ("paper",)
#: defaults of --n per method: MC paths, Sobol base sample (power of 2), Morris trajectories
DEFAULT_N = {"mc": 10_000, "sobol": 1024, "morris": 50}


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


@contextmanager
def _progress(label: str, enabled: bool) -> Iterator:
    """A rich progress bar on stderr (only on a terminal); yields a ``(done, total)`` callback."""
    if not enabled or not sys.stderr.isatty():
        yield None
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    with Progress(TextColumn(label), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(), TimeRemainingColumn(),
                  console=Console(stderr=True), transient=True) as bar:
        task = bar.add_task(label, total=None)

        def update(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)

        yield update


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


@app.command()
def sensitivity(
    method: str = typer.Argument(..., help="oat (one-at-a-time), mc (Monte Carlo, Table 6), sobol or morris."),
    config: str = typer.Argument(..., help="TOML config file, or example:NAME (ex1, ex2, ex3, fourflute)."),
    rpm: Optional[str] = typer.Option(None, "--rpm", help="Speeds START:STOP:STEP (rev/min)."),
    rpm_file: Optional[Path] = typer.Option(None, "--rpm-file", help="Speeds, one per line or an 'rpm' CSV column."),
    n: Optional[int] = typer.Option(None, "--n", help="mc: paths (10000); sobol: base sample, power of 2 (1024); "
                                    "morris: trajectories (50)."),
    t: Optional[float] = typer.Option(None, "--t", help="Neighbourhood half-width: parameters in [(1-t)p, (1+t)p] (0.1)."),
    eps: Optional[str] = typer.Option(None, "--eps", help="mc: relative change (0.01); oat: grid START:STOP:STEP or "
                                      "comma list (-0.25:0.25:0.05)."),
    seed: int = typer.Option(0, "--seed", help="Random seed (mc, sobol, morris); same seed, same numbers."),
    out: Optional[Path] = typer.Option(None, "--out", help="Result JSON (MSE in mm^2)."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Figure (.png, .svg or .pdf)."),
    engine: str = typer.Option("zoa", "--engine", help="Stability engine: zoa, sdm or spectral."),
    preset: Optional[str] = typer.Option(None, "--preset", help="paper: the seed paper's settings (oat grid "
                                         "-0.20:0.20:0.05; N 10000, t 0.1, eps 0.01) centred on its predicted "
                                         "parameters (tab:results_fourier) when CONFIG is its Ex.1/2/3."),
    bound: List[str] = typer.Option([], "--bound", help="sobol/morris: NAME=LOWER:UPPER [SI] replacing the ±t range; "
                                    "repeatable."),
    levels: int = typer.Option(4, "--levels", help="morris: grid levels (even)."),
) -> None:
    """Sensitivity of the stability lobe diagram of CONFIG to each modal parameter (MSE in mm^2)."""
    from millstab.io import load_config, write_json
    from millstab.sensitivity import (PAPER_EPS_GRID, match_example, monte_carlo, morris, oat, predicted_theta, sobol,
                                      table6)
    from millstab.stability import ENGINES

    if method not in METHODS:
        raise InputError("METHOD", method, f"must be one of {', '.join(METHODS)}")
    if preset is not None and preset not in PRESETS:
        raise InputError("--preset", preset, f"must be one of {', '.join(PRESETS)}")
    if engine not in ENGINES:
        raise InputError("--engine", engine, f"must be one of {', '.join(ENGINES)}")
    if method in ("oat",) and (n is not None or t is not None):
        raise InputError("--n" if n is not None else "--t", n if n is not None else t, "oat takes no --n or --t (it perturbs the centre itself)")
    if method not in ("sobol", "morris") and bound:
        raise InputError("--bound", bound[0], "only sobol and morris take input bounds")
    cfg = load_config(config)
    speeds = select_rpm(rpm, rpm_file, cfg.rpm, FALLBACK_RPM)
    protect = [p for p in (cfg.path, rpm_file) if p]
    if out and plot and Path(out).resolve() == Path(plot).resolve():
        raise InputError("--plot", str(plot), "must differ from --out")
    # refuse bad output paths before a long run, not after it
    from millstab.io.results import check_not_protected
    from millstab.plot import FORMATS

    for path in (out, plot):
        if path:
            check_not_protected(path, protect)
    if plot and plot.suffix.lower() not in FORMATS:
        raise InputError("--plot", str(plot), f"extension must be one of {', '.join(FORMATS)}")
    if not cfg.structure.is_modal:
        raise InputError("structure", "measured FRF", "sensitivity studies need modal parameters (fn, k, zeta) in the config")

    example = match_example(cfg.cutting, cfg.structure)
    theta, centre_note = None, "the config's modal parameters"
    if preset == "paper":
        if example:
            theta = predicted_theta(example)
            centre_note = f"the paper's {example} predicted values (tab:results_fourier)"
        else:
            centre_note += " (not a paper example: --preset paper sets only the paper's settings)"
    t_val = 0.1 if t is None else t
    header = (f"{cfg.name}: {speeds.size} speeds {speeds.min():g}..{speeds.max():g} rpm ({engine}); "
              f"centre: {centre_note}")
    payload_extra = {"config": cfg.name, "preset": preset, "centre_source": centre_note, "paper_example": example}

    if method == "oat":
        grid = PAPER_EPS_GRID if (preset == "paper" and eps is None) else (_parse_eps_grid(eps) if eps else None)
        res = oat(cfg.structure, cfg.cutting, speeds, grid, theta=theta, engine=engine)
        typer.echo(header)
        typer.echo(f"{'MSE [mm^2]':<12}" + "".join(f"{n:>11}" for n in res.names))
        for k, e in enumerate(res.eps):
            typer.echo(f"eps {e:+7.3f} " + "".join(f"{v:>11.5f}" for v in res.mse_mm2[:, k]))
        payload = res.to_dict()
        fig_fn = None
        if plot:
            from millstab.plot.sensitivity import plot_oat

            fig_fn = lambda: plot_oat(res, title=f"{cfg.name}: one-at-a-time sensitivity ({speeds.size} speeds)")  # noqa: E731
    elif method == "mc":
        n_val = DEFAULT_N["mc"] if n is None else n
        try:
            eps_val = 0.01 if eps is None else float(eps)
        except ValueError:
            raise InputError("--eps", eps, "for mc: one relative change, e.g. 0.01") from None
        with _progress(f"Monte Carlo, {n_val} paths", True) as cb:
            res = monte_carlo(cfg.structure, cfg.cutting, speeds, n=n_val, t=t_val, eps=eps_val, seed=seed, theta=theta,
                              engine=engine, progress=cb)
        paper = table6() if set(res.names) == set(table6()) else None
        comparable = example == "ex1" and preset == "paper" and abs(t_val - 0.1) < 1e-12 and abs(eps_val - 0.01) < 1e-12
        typer.echo(header)
        typer.echo(f"Monte Carlo sensitivity: N = {res.n}, t = {res.t:g}, eps = {res.eps:g}, seed {res.seed}")
        typer.echo(_mc_table(res, paper, comparable))
        if paper:
            typer.echo("paper Table 6: N = 10 000, t = 0.1, eps = 1 % around Ex.1 predicted values; its speed set "
                       "is not given" + ("" if comparable else "; this run differs in centre or settings"))
        payload = res.to_dict(paper=paper)
        payload["paper_comparable"] = comparable
        fig_fn = None
        if plot:
            from millstab.plot.sensitivity import plot_mc_convergence

            fig_fn = lambda: plot_mc_convergence(res, paper=paper if comparable else None)  # noqa: E731
    else:
        bounds = _parse_bounds(bound)
        n_val = DEFAULT_N[method] if n is None else n
        label = f"{method}: evaluating structures"
        with _progress(label, True) as cb:
            if method == "sobol":
                res = sobol(cfg.structure, cfg.cutting, speeds, n=n_val, t=t_val, bounds=bounds, seed=seed, theta=theta,
                            engine=engine, progress=cb)
            else:
                res = morris(cfg.structure, cfg.cutting, speeds, trajectories=n_val, levels=levels, t=t_val, bounds=bounds,
                             seed=seed, theta=theta, engine=engine, progress=cb)
        typer.echo(header)
        w = 15 if method == "sobol" else 11
        typer.echo(f"{'':<24}" + "".join(f"{nm:>{w}}" for nm in res.names))
        if method == "sobol":
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
        payload = res.to_dict()
        fig_fn = None
        if plot:
            from millstab.plot.sensitivity import plot_morris, plot_sobol_speed

            fig_fn = (lambda: plot_sobol_speed(res)) if method == "sobol" else (lambda: plot_morris(res))  # noqa: E731
    payload.update(payload_extra)
    if out:
        write_json(out, payload, protect=protect)
        typer.echo(f"wrote {out}")
    if plot and fig_fn:
        from millstab.plot import save_figure

        save_figure(fig_fn(), plot, protect=protect + ([out] if out else []))
        typer.echo(f"wrote {plot}")
