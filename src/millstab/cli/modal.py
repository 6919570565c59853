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
    frf_x: Path = typer.Argument(..., help="Drive-point FRF of x (.csv freq_hz,real,imag in m/N, CutPro .frf, .uff/.unv)."),
    frf_y: Optional[Path] = typer.Argument(None, help="Drive-point FRF of y (omit: y rigid)."),
    out: Path = typer.Option(..., "--out", help="TOML file with the fitted [structure] section."),
    band: Optional[str] = typer.Option(None, "--band", help="Frequency band A:B [Hz] to fit (default: the whole file)."),
    modes: str = typer.Option("auto", "--modes", help="Modes per direction: auto (stabilisation diagram), N, or NX,NY."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Figure: fit, phase, stabilisation diagram (and SLD check)."),
    json_out: Optional[Path] = typer.Option(None, "--json", help="Fit quality as JSON (schema millstab.modal/1)."),
    config: Optional[str] = typer.Option(None, "--config", help="Config whose [cutting] runs the SLD check (fit vs measured FRF)."),
    rpm: Optional[str] = typer.Option(None, "--rpm", help="Speeds START:STOP:STEP of the SLD check (rev/min)."),
    record_x: Optional[int] = typer.Option(None, "--record-x", help="UFF record of FRF_X (0-based among its dataset-58 records)."),
    record_y: Optional[int] = typer.Option(None, "--record-y", help="UFF record of FRF_Y."),
    frf_type: str = typer.Option("auto", "--frf-type", help="What the files hold: auto (told from phase and slope; "
                                 "mobility and accelerance are refused, naming the conversion), receptance (m/N), "
                                 "mobility ((m/s)/N) or accelerance ((m/s^2)/N), converted to receptance."),
) -> None:
    """Fit FRF_X (and FRF_Y) to modes (fn, k, zeta) and write them as a config's [structure] section."""
    from millstab import api
    from millstab.io import atomic_write_text, write_json
    from millstab.io.outputs import check_outputs, config_inputs

    frf_type = api.check_frf_type(frf_type)  # before any reading
    cfg = api.config(config) if config else None
    inputs = {"FRF_X": frf_x, "FRF_Y": frf_y, **(config_inputs(cfg) if cfg else {})}
    check_outputs(inputs, {"--out": out, "--plot": plot, "--json": json_out}, figures=("--plot",))
    protect = [p for p in inputs.values() if p]
    result = api.modal_fit(frf_x, frf_y, band=band, modes=modes, records=(record_x, record_y), frf_type=frf_type)
    for d, fit in result.fits.items():
        typer.echo(f"{d} ({fit.source}, {fit.freq_hz[0]:g}..{fit.freq_hz[-1]:g} Hz, {fit.freq_hz.size} lines): "
                   f"{len(fit.modes)} mode(s), RMS misfit {100 * fit.nrmse:.2f} % of max|H|")
        for m in fit.modes:
            typer.echo(f"  fn {m.fn:10.4f} Hz   k {m.k / 1e6:9.4f} N/um   zeta {m.zeta:.5f}   "
                       f"peak/noise {m.peak_to_noise:8.3g}   stable {m.stable_orders}/{m.orders}")
    check = None
    if cfg is not None:
        speeds = api.speeds(rpm, cfg, FALLBACK_RPM)
        check = api.modal_check(result, cfg, speeds, frf_x, frf_y, band=band, records=(record_x, record_y),
                                frf_type=frf_type)
        typer.echo(f"SLD check ({cfg.name} cutting, zoa, {speeds.size} speeds {speeds.min():g}..{speeds.max():g} rpm): "
                   f"minimum depth {check.min_fitted_mm:.4g} mm from the fit vs {check.min_measured_mm:.4g} mm from the "
                   f"measured FRF ({100 * check.min_difference:+.2f} %); worst difference {100 * check.worst_difference:.1f} % "
                   f"at {check.worst_rpm:.6g} rpm")
    elif rpm:
        typer.echo("note: --rpm is used by the SLD check, which needs --config for the cutting conditions", err=True)
    atomic_write_text(out, api.modal_toml(result), protect)
    typer.echo(f"wrote {out}")
    if json_out:
        write_json(json_out, api.modal_quality(result, check), protect)
        typer.echo(f"wrote {json_out}")
    if plot:
        from millstab.io.figures import save_figure

        save_figure(api.modal_figure(result, check), plot, protect=protect)
        typer.echo(f"wrote {plot}")
