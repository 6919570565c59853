"""What ``millstab modal`` writes: a TOML ``[structure]`` section and a quality JSON.

The TOML uses the units configs use (``fn = "903.0123 Hz"``, ``k = "12.57393 N/um"``, ``zeta`` bare) and
can replace a config's ``[structure]`` section as it is; each mode's fit quality is a comment above
it. The JSON (schema ``millstab.modal/1``) holds the same numbers in SI plus the SLD check, if run.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Iterable

from millstab.modal.run import ModalResult, SLDCheck

SCHEMA = "millstab.modal/1"


def _g(x: float, digits: int = 7) -> str:
    return f"{x:.{digits}g}"


def structure_toml(result: ModalResult, sources: dict[str, str]) -> str:
    """The ``[structure]`` section of ``result`` with the fit quality in comments."""
    band = "each file's whole range" if result.band is None else f"{result.band[0]:g}..{result.band[1]:g} Hz"
    lines = ["# Fitted by `millstab modal` (LSCF poles, least-squares residues) from "
             + ", ".join(f"FRF_{d.upper()} = {s}" for d, s in sources.items()) + f"; band {band}.",
             "# Replace a config's [structure] section with this one. A direction without modes is rigid.",
             "[structure]"]
    for d, fit in result.fits.items():
        lines.append(f"# {d}: {len(fit.modes)} mode(s), RMS misfit {100 * fit.nrmse:.2f} % of max|H|, "
                     f"residuals U = {fit.upper:.3g} m/N, L = {fit.lower:.3g} m/N")
        for i, m in enumerate(fit.modes):
            lines += ["",
                      f"# {d}[{i}]: peak/noise {m.peak_to_noise:.3g}, residue phase {m.phase_deg:+.1f} deg off -90, "
                      f"stable at {m.stable_orders}/{m.orders} orders, misfit near the peak "
                      f"{100 * m.local_error:.2f} %",
                      f"[[structure.{d}]]", f'fn = "{_g(m.fn)} Hz"', f'k = "{_g(m.k / 1e6)} N/um"',
                      f"zeta = {_g(m.zeta, 6)}"]
        lines.append("")
    lines += [f"# {d}: no FRF given: rigid (no [[structure.{d}]] modes)" for d in ("x", "y") if d not in result.fits]
    return "\n".join(lines)


def quality(result: ModalResult, sources: dict[str, str], check: SLDCheck | None = None) -> dict[str, Any]:
    """The side JSON: per direction the misfit and residuals, per mode fn/k/ζ and their quality."""
    out: dict[str, Any] = {"schema": SCHEMA, "band_hz": None if result.band is None else list(result.band),
                           "directions": {}}
    for d, fit in result.fits.items():
        out["directions"][d] = {
            "file": sources[d], "lines": int(fit.freq_hz.size),
            "band_hz": [float(fit.freq_hz[0]), float(fit.freq_hz[-1])],
            "nrmse": fit.nrmse, "noise_m_per_n": fit.noise, "upper_residual_m_per_n": fit.upper,
            "lower_residual_m_per_n": fit.lower,
            "modes": [{"fn_hz": m.fn, "k_n_per_m": m.k, "zeta": m.zeta, "residue_phase_error_deg": m.phase_deg,
                       "peak_to_noise": m.peak_to_noise, "stable_orders": m.stable_orders, "orders": m.orders,
                       "local_error": m.local_error} for m in fit.modes]}
    if check is not None:
        out["sld_check"] = {"min_fitted_mm": check.min_fitted_mm, "min_measured_mm": check.min_measured_mm,
                            "min_difference": check.min_difference, "worst_difference": check.worst_difference,
                            "worst_rpm": check.worst_rpm, "rpm_range": [float(check.rpm.min()), float(check.rpm.max())],
                            "speeds": int(check.rpm.size)}
    return out


def write_structure(path, result: ModalResult, sources: dict[str, str], protect: Iterable = ()) -> Path:
    """Write :func:`structure_toml` atomically (never over an input file)."""
    from millstab.io import atomic_write_text

    return atomic_write_text(path, structure_toml(result, sources), protect)


__all__ = ["SCHEMA", "quality", "structure_toml", "write_structure"]
