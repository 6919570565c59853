"""``millstab simulate``: virtual test cuts (time-domain simulation and chatter detection).

One cut:   millstab simulate CONFIG --rpm R --depth MM [--feed-per-tooth MM] [--revs N] [--plot cut.png]
           [--out trace.csv] [--record cut.wav [--sensor microphone|accelerometer] [--noise X] [--seed S]]
           [--record-tap tap.wav]   (a tap on the tool heard by the same sensor: for listen --tap)
Many cuts: millstab simulate CONFIG --cuts cuts.csv [--out labelled.csv] [--label-noise P --seed S]
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from millstab.cli.app import app
from millstab.cli.options import condition_options, seed_option

# the condition of the simulated cut(s): the config's tool and structure in another condition (a cuts file's condition
# columns still decide on their rows)
SimImmersionOpt, SimMillingOpt, SimEntryOpt, SimExitOpt, SimTeethOpt = condition_options(
    "Simulate the cut(s)", "the config's; a cuts file's condition columns decide on their rows",
    "Cutting condition (default: the config's)")


@app.command()
def simulate(
    config: str = typer.Argument(..., help="TOML config file, or example:NAME (ex1, ex2, ex3, fourflute)."),
    rpm: Optional[float] = typer.Option(None, "--rpm", help="Spindle speed of one cut (rev/min)."),
    depth: Optional[float] = typer.Option(None, "--depth", help="Axial depth of one cut (mm)."),
    cuts: Optional[Path] = typer.Option(None, "--cuts", help="CSV rpm,depth_mm[,label,weight] of cuts to label; "
                                                             "condition columns (radial_immersion, milling, ...) "
                                                             "per cut."),
    feed: Optional[float] = typer.Option(None, "--feed-per-tooth", help="Feed per tooth (mm; default: the config's "
                                                                        "feed_per_tooth, else 0.1; a cuts file's "
                                                                        "feed_per_tooth_mm column per cut)."),
    revs: float = typer.Option(100.0, "--revs", help="Spindle revolutions per cut."),
    steps: Optional[int] = typer.Option(None, "--steps", help="Steps per tooth period (>= 20; default automatic)."),
    start: str = typer.Option("steady", "--start",
                              help="steady (engaged cut, small bump) or rest (entering at full depth)."),
    out: Optional[Path] = typer.Option(None, "--out", help="CSV: with --cuts rpm,depth_mm,label,chatter_hz "
                                                           "(without --out the table is printed); "
                                                           "else the trace t_s,x_m,y_m,fx_N,fy_N."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Figure of one cut (.png, .svg or .pdf)."),
    record: Optional[Path] = typer.Option(None, "--record", help="What a sensor would record of one cut: "
                                                                 ".wav (16-bit, 48 kHz) or .csv time_s,signal."),
    record_tap: Optional[Path] = typer.Option(None, "--record-tap", help="What the same sensor (--sensor, --noise, "
                                                                         "--seed) would record of a hammer tap on the "
                                                                         "tool: .wav or .csv, for listen --tap."),
    sensor: str = typer.Option("microphone", "--sensor", help="microphone or accelerometer (with --record)."),
    noise: float = typer.Option(0.02, "--noise", help="Sensor noise RMS relative to the vibration's (with --record)."),
    label_noise: float = typer.Option(0.0, "--label-noise",
                                      help="Probability that a stable/chatter label is swapped (needs --seed)."),
    marginal: str = typer.Option("keep", "--marginal", help="keep the 'marginal' label, or 'random': call it "
                                                            "stable/chatter at even odds (needs --seed)."),
    seed: Optional[int] = seed_option(None, "Seed of the label noise (--cuts) or of the recording's noise (--record)."),
    radial_immersion: SimImmersionOpt = None,
    milling: SimMillingOpt = None,
    entry_deg: SimEntryOpt = None,
    exit_deg: SimExitOpt = None,
    teeth: SimTeethOpt = None,
) -> None:
    """Simulate test cuts of CONFIG in the time domain and label them stable, marginal or chatter."""
    from millstab import api
    from millstab.cli import emit
    from millstab.io import read_points
    from millstab.io.outputs import config_inputs

    cfg, note = api.config_in_condition(api.config(config), radial_immersion=radial_immersion, milling=milling,
                                        entry_deg=entry_deg, exit_deg=exit_deg, teeth=teeth)
    # every output checked before the work (an hour of cuts is not lost to a bad path)
    protect = emit.checked({**config_inputs(cfg), "--cuts": cuts}, {"--out": out, "--plot": plot, "--record": record,
                                                                    "--record-tap": record_tap}, figures=("--plot",))
    if api.simulate_mode(cuts=cuts, rpm=rpm, depth=depth, plot=plot, record=record, marginal=marginal,
                         label_noise=label_noise, seed=seed, record_tap=record_tap) == "cuts":
        pts = read_points(cuts, labels_option=False)  # simulate has no --labels
        lab = api.label_cuts(cfg, pts, feed_mm=feed, revs=revs, steps=steps, start=start, label_noise=label_noise,
                             marginal=marginal, seed=seed)
        typer.echo(f"{cfg.name}: {lab.summary()}" + (f" ({note})" if note else ""))
        return emit.csv_or_print(out, api.labels_table(lab, pts), protect)  # without --out: printed
    res, det = api.simulate_cut(cfg, rpm, depth, feed_mm=feed, revs=revs, steps=steps, start=start)
    typer.echo(f"{cfg.name}: {res.summary(det)}" + (f" ({note})" if note else ""))
    emit.csv(out, res.table(), protect)
    emit.figure(plot, lambda: api.simulate_figure(res, det, title=cfg.name), protect)
    _recordings_out(cfg, res, record, record_tap, sensor, noise, seed, protect)


def _recordings_out(cfg, res, record: Path | None, record_tap: Path | None, sensor: str, noise: float,
                    seed: int | None, protect) -> None:
    """``--record`` (what the sensor hears of the cut) and ``--record-tap`` (of a tap on the tool: the same sensor,
    room and noise, for ``listen --tap``)."""
    from millstab import api
    from millstab.cli import emit
    from millstab.io.recordings import write_recording

    def write(path: Path, rec, what: str = "") -> None:
        emit.wrote(path, lambda: write_recording(path, rec.fs, rec.signal, protect=protect),
                   note=f" ({what}{rec.sensor}, {rec.seconds:.3g} s at {rec.fs} Hz)")

    seed = 0 if seed is None else seed
    if record:
        write(record, api.record_cut(res, sensor=sensor, noise=noise, seed=seed))
    if record_tap:
        write(record_tap, api.record_tap(cfg.structure, sensor=sensor, noise=noise, seed=seed),
              "a tap on the tool heard by the ")
