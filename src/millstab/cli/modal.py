"""``millstab modal``: fit measured drive-point FRFs (a tap test) to modes and write a [structure] section."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from millstab.cli.app import app

#: speed range of the SLD check when neither --rpm nor the config gives one [rpm]
FALLBACK_RPM = (2000.0, 12000.0, 20.0)


@app.command()
def modal(
    frf_x: Path = typer.Argument(...,
                                 help="Drive-point FRF of x (.csv freq_hz,real,imag in m/N, CutPro .frf, .uff/.unv)."),
    frf_y: Optional[Path] = typer.Argument(None, help="Drive-point FRF of y (omit: y rigid)."),
    out: Path = typer.Option(..., "--out", help="TOML file with the fitted [structure] section."),
    band: Optional[str] = typer.Option(None, "--band",
                                       help="Frequency band A:B [Hz] to fit (default: the whole file)."),
    modes: str = typer.Option("auto", "--modes",
                              help="Modes per direction: auto (stabilisation diagram), N, or NX,NY. A number is "
                                   "fitted even where noisy data leave some modes unstabilised (they are named in a "
                                   "warning): state it when you know how many modes the tool has."),
    plot: Optional[Path] = typer.Option(None, "--plot",
                                        help="Figure: fit, phase, stabilisation diagram (and SLD check)."),
    json_out: Optional[Path] = typer.Option(None, "--json", help="Fit quality as JSON (schema millstab.modal/1)."),
    config: Optional[str] = typer.Option(None, "--config",
                                         help="Config whose [cutting] runs the SLD check (fit vs measured FRF)."),
    rpm: Optional[str] = typer.Option(None, "--rpm", help="Speeds START:STOP:STEP of the SLD check (rev/min)."),
    record_x: Optional[int] = typer.Option(None, "--record-x",
                                           help="UFF record of FRF_X (0-based among its dataset-58 records)."),
    record_y: Optional[int] = typer.Option(None, "--record-y", help="UFF record of FRF_Y."),
    frf_type: str = typer.Option("auto", "--frf-type", help="What the files hold: auto (told from phase and slope; "
                                 "mobility and accelerance are refused, naming the conversion), receptance (m/N), "
                                 "mobility ((m/s)/N) or accelerance ((m/s^2)/N), converted to receptance."),
) -> None:
    """Fit FRF_X (and FRF_Y) to modes (fn, k, zeta) and write them as a config's [structure] section."""
    from millstab import api
    from millstab.cli import emit
    from millstab.io import atomic_write_text
    from millstab.io.outputs import config_inputs

    frf_type = api.check_frf_type(frf_type)  # before any reading
    cfg = api.config(config) if config else None
    protect = emit.checked({"FRF_X": frf_x, "FRF_Y": frf_y, **(config_inputs(cfg) if cfg else {})},
                           {"--out": out, "--plot": plot, "--json": json_out}, figures=("--plot",))
    result = api.modal_fit(frf_x, frf_y, band=band, modes=modes, records=(record_x, record_y), frf_type=frf_type)
    typer.echo(result.summary())
    check = None
    if cfg is not None:
        check = api.modal_check(result, cfg, api.speeds(rpm, cfg, FALLBACK_RPM), frf_x, frf_y, band=band,
                                records=(record_x, record_y), frf_type=frf_type)
        typer.echo(f"{cfg.name} cutting: {check.summary()}")
    elif rpm:
        typer.echo("note: --rpm is used by the SLD check, which needs --config for the cutting conditions", err=True)
    emit.wrote(out, lambda: atomic_write_text(out, api.modal_toml(result), protect))
    emit.json(json_out, lambda: api.modal_quality(result, check), protect)
    emit.figure(plot, lambda: api.modal_figure(result, check), protect)
