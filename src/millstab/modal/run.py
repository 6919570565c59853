"""From FRF files to a modal structure: read each direction, cut the band, fit, and check the SLD.

One file per direction (``FRF_X`` is the xx drive point, ``FRF_Y`` the yy one), in any format
:mod:`millstab.io.frf_files` reads (CSV in m/N, CutPro ``.frf``, UFF58 with ``record``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from millstab.errors import InputError
from millstab.frfkind import NEGATE_BOTH, negated_receptance
from millstab.io.frf_files import load_measured_frf
from millstab.model import Cutting, MeasuredFRF, Mode, Structure
from millstab.modal.fit import MIN_LINES, DirectionFit, FittedMode, fit_direction
from millstab.errors import FRFWarning
from millstab.warnlog import quiet, warn


def parse_band(text: str | None) -> tuple[float, float] | None:
    """``"A:B"`` [Hz] → (A, B), or None for the whole file."""
    if text is None:
        return None
    parts = str(text).split(":")
    try:
        lo, hi = (float(p) for p in parts)
    except ValueError:
        raise InputError("--band", text, "expected A:B in Hz, e.g. 200:2500") from None
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 <= lo < hi):
        raise InputError("--band", text, "need 0 <= A < B (Hz)")
    return lo, hi


def parse_modes(text: str | int | None) -> tuple[int | str, int | str]:
    """``auto`` / ``N`` / ``NX,NY`` → the mode count for x and for y."""
    if text is None or str(text).strip().lower() == "auto":
        return "auto", "auto"
    parts = [p.strip() for p in str(text).split(",")]
    if len(parts) not in (1, 2):
        raise InputError("--modes", text, "expected auto, N or NX,NY (modes per direction)")
    out = []
    for p in parts:
        if p.lower() == "auto":
            out.append("auto")
            continue
        try:
            n = int(p)
        except ValueError:
            raise InputError("--modes", text, "expected auto, N or NX,NY with whole numbers >= 1") from None
        if not 1 <= n <= 10:
            raise InputError("--modes", text, "a direction takes 1 to 10 modes")
        out.append(n)
    return (out[0], out[0]) if len(out) == 1 else (out[0], out[1])


#: what ``--frf-type`` takes: ``auto`` detects (and refuses mobility/accelerance, saying how to convert)
FRF_TYPES = ("auto", "receptance", "mobility", "accelerance")


#: the phase range of a passive drive point's FRF of each kind [deg] (millstab's e^{iωt} convention)
PHASE_DEG = {"receptance": (-180, 0), "mobility": (-90, 90), "accelerance": (0, 180)}


def check_frf_type(frf_type: str) -> str:
    """``frf_type`` lower-cased when it is one of :data:`FRF_TYPES`, else InputError."""
    t = str(frf_type).strip().lower()
    if t not in FRF_TYPES:
        raise InputError("--frf-type", frf_type, f"must be one of {', '.join(FRF_TYPES)}")
    return t


def as_receptance(f: np.ndarray, h: np.ndarray, frf_type: str, label: str, path) -> np.ndarray:
    """The receptance [m/N] of a drive-point FRF ``h`` at ``f`` [Hz] read from ``path``.

    ``frf_type``: ``auto`` tells the quantity from the phase and slope (:func:`millstab.frfkind.frf_kind`)
    and refuses a mobility or an accelerance, naming it and the conversion (the fit would otherwise read an
    accelerance as a conjugated receptance and advise negating its imaginary part), and a receptance with both
    columns negated (:func:`negated_receptance`), naming that; ``receptance`` takes ``h`` as it is unless it
    is such a sign-flipped receptance; ``mobility``/``accelerance`` convert (G = H/(iω), G = −H/ω²) and refuse
    data that do not then look like a receptance.

    Raises:
        InputError: naming ``label``, the file, what the data look like and how to convert.
    """
    from millstab.frfkind import CONVERSION, KINDS, frf_kind, to_receptance

    t = check_frf_type(frf_type)
    name = Path(str(path)).name
    seen = frf_kind(f, h)
    flipped = negated_receptance(f, h, seen)
    why = f"|H| changes like f^{seen.slope:+.1f} from {f[0]:g} to {f[-1]:g} Hz"
    if seen.kind is not None:
        lo, hi = PHASE_DEG[seen.kind]
        lo, hi = (-hi, -lo) if seen.conjugated else (lo, hi)
        why = (f"its phase stays within {lo:+d}..{hi:+d} deg at the lines carrying {100 * seen.passive:.0f} % of "
               f"|H|² and {why}")
    flip_text = (f"looks like a receptance (m/N) with both columns negated, not an accelerance ({why}; −H has a "
                 f"receptance's slope and stiffness line, −H/ω² has not); {NEGATE_BOTH}")
    if flipped == "yes":
        given = "" if t == "auto" else f"--frf-type {t} was given but the file "
        raise InputError(label, name, given + flip_text + ("" if t == "receptance" else
                                                           ", then fit it as a receptance"))
    maybe = (f"; or, if it is a receptance whose hammer or sensor polarity was reversed (both columns negated), "
             f"{NEGATE_BOTH.split(' (')[0]}" if flipped == "maybe" else "")
    if t == "receptance":
        return h
    if t == "auto":
        if seen.kind in ("mobility", "accelerance"):
            raise InputError(label, name, f"looks like {seen.describe()}, not receptance (m/N) ({why}); "
                                          f"{CONVERSION[seen.kind]}, or pass --frf-type {seen.kind} to have it "
                                          f"converted{maybe}")
        return h
    g = to_receptance(f, h, t)
    after = frf_kind(f, g)
    other = f"pass --frf-type {seen.kind or 'auto'}" if seen.kind != t else "check the file's units and sign"
    if after.kind not in (None, "receptance"):
        raise InputError(label, name, f"--frf-type {t} was given but the file looks like {seen.describe()} ({why}); "
                                      f"after converting it is no receptance (m/N); {other}{maybe}")
    if after.kind is None or (seen.kind and seen.kind != t):
        raise InputError(label, name, f"--frf-type {t} was given but the file looks like {seen.describe()} ({why}); "
                                      f"{KINDS[t][1]} data would have the other phase and slope{maybe}")
    return g


def read_direction(path, direction: str, band: tuple[float, float] | None, record: int | None = None,
                   label: str | None = None, frf_type: str = "auto") -> tuple[np.ndarray, np.ndarray]:
    """One direction's drive-point receptance [Hz, m/N] from a file, cut to ``band`` [Hz]; ``frf_type``: what
    the file holds (:func:`as_receptance`)."""
    from millstab.warnlog import collect, emit

    label = label or f"FRF_{direction.upper()}"
    src = {"file": str(path), "record": record} if record is not None else str(path)
    term = "xx" if direction == "x" else "yy"
    with collect() as said:  # held back: an accelerance trips the sign-convention warning (negate Im: wrong advice)
        frf = load_measured_frf(**{term: src}, field=label, receptance_only=False)
    f, h = frf.freq_hz, as_receptance(frf.freq_hz, getattr(frf, term), frf_type, label, path)
    if check_frf_type(frf_type) in ("auto", "receptance"):  # converted data: the raw file's warnings do not apply
        for record_ in said:
            emit(record_)
    if band is not None:
        keep = (f >= band[0]) & (f <= band[1])
        if np.count_nonzero(keep) < MIN_LINES:
            raise InputError("--band", f"{band[0]:g}:{band[1]:g}",
                             f"holds {np.count_nonzero(keep)} of the {f.size} lines of {label} ({Path(path).name}, "
                             f"{f[0]:g}..{f[-1]:g} Hz); the fit needs at least {MIN_LINES} lines")
        f, h = f[keep], h[keep]
    return f, h


def same_file(a, b) -> bool:
    """Whether two FRF paths name the same file, or files with the same bytes (a copy)."""
    pa, pb = Path(str(a)), Path(str(b))
    try:
        if pa.resolve() == pb.resolve() or pa.samefile(pb):
            return True
        from millstab.io.frf_files import same_content

        return same_content(pa, pb)
    except OSError:
        return False


#: the schema tag of :meth:`ModalResult.to_json`
MODAL_RESULT_SCHEMA = "millstab.modal.result/1"


@dataclass(frozen=True)
class ModalResult:
    """The fits of both directions and the structure they make.

    Attributes:
        fits: ``{"x": DirectionFit, "y": DirectionFit}`` (a direction without a file is absent: rigid).
        structure: the fitted modal :class:`Structure`.
        band: the band given [Hz], or None (each file's whole range).
    """

    fits: dict[str, DirectionFit]
    structure: Structure
    band: tuple[float, float] | None

    def summary(self) -> str:
        """What ``millstab modal`` prints: per direction its file, band, modes and misfit, then each mode's fn [Hz],
        k [N/µm], ζ, peak over noise and the model orders at which it was stable; a direction without a file is
        said to be rigid."""
        lines = []
        for d, fit in self.fits.items():
            lines.append(f"{d} ({fit.source}, {fit.freq_hz[0]:g}..{fit.freq_hz[-1]:g} Hz, {fit.freq_hz.size} lines): "
                         f"{len(fit.modes)} mode(s), RMS misfit {100 * fit.nrmse:.2f} % of max|H|")
            lines += [f"  fn {m.fn:10.4f} Hz   k {m.k / 1e6:9.4f} N/um   zeta {m.zeta:.5f}   "
                      f"peak/noise {m.peak_to_noise:8.3g}   stable {m.stable_orders}/{m.orders}" for m in fit.modes]
        lines += [f"{d}: no FRF given: rigid (no modes)" for d in ("x", "y") if d not in self.fits]
        return "\n".join(lines)

    def table(self) -> tuple[list[str], list]:
        """(header, columns), one row per fitted mode: direction, fn [Hz], k [N/µm], ζ, the phase deviation
        [deg], peak over noise, the orders at which it was stable and of how many, the local misfit."""
        from millstab.units import SHOWN

        rows = [(d, m) for d, fit in self.fits.items() for m in fit.modes]
        k_factor = SHOWN["N/m"][0]  # N/µm
        header = ["direction", "fn_hz", "k_N_per_um", "zeta", "phase_deg", "peak_to_noise",
                  "stable_orders", "orders", "local_error"]
        cols = [[d for d, _ in rows], [m.fn for _, m in rows], [m.k * k_factor for _, m in rows],
                [m.zeta for _, m in rows], [m.phase_deg for _, m in rows], [m.peak_to_noise for _, m in rows],
                [m.stable_orders for _, m in rows], [m.orders for _, m in rows], [m.local_error for _, m in rows]]
        return header, cols

    def figure(self, ax=None, *, check: SLDCheck | None = None):
        """Measured and fitted magnitude and phase and the stabilisation diagram per direction, and with
        ``check`` the SLDs beside each other (:func:`millstab.plot.modal.plot_modal_fit`); into ``ax``'s
        place or a new figure."""
        from millstab.plot.modal import plot_modal_fit

        return plot_modal_fit(self, check, ax=ax)

    def to_json(self) -> dict:
        """``{"schema": "millstab.modal.result/1", "band", "structure", "fits": {direction: …}}``: every fit
        whole (the measured and fitted receptances as ``{"re", "im"}`` [m/N], the modes and their quality, the
        residuals, the stabilisation diagram), so that :meth:`from_json` rebuilds it bit for bit. The command
        line's side file is the shorter report :func:`millstab.modal.output.quality` (``millstab.modal/1``)."""
        from millstab.jsondoc import complex_out, floats_out, plain, structure_out

        def one(fit: DirectionFit) -> dict:
            st = fit.stabilisation
            return {"direction": fit.direction, "source": fit.source, "freq_hz": floats_out(fit.freq_hz, "freq_hz"),
                    "h": complex_out(fit.h, "h"), "h_fit": complex_out(fit.h_fit, "h_fit"),
                    "modes": [plain(dataclasses.asdict(m), "modes") for m in fit.modes],
                    **{k: float(getattr(fit, k)) for k in ("upper", "lower", "nrmse", "noise")},
                    "stabilisation": {"orders": plain(st.orders, "orders"), "fn": plain(st.fn, "fn"),
                                      "zeta": plain(st.zeta, "zeta"), "stable": plain(st.stable, "stable")}}

        return {"schema": MODAL_RESULT_SCHEMA, "band": None if self.band is None else [float(b) for b in self.band],
                "structure": structure_out(self.structure), "fits": {d: one(f) for d, f in self.fits.items()}}

    @classmethod
    def from_json(cls, doc, source: str = "modal result") -> ModalResult:
        """Rebuild from :meth:`to_json` output. Raises InputError (wrong schema, missing or bad field)."""
        from millstab.jsondoc import check_schema, complex_in, floats_in, int_in, ints_in, need, number_in, structure_in
        from millstab.modal.lscf import Stabilisation

        check_schema(doc, MODAL_RESULT_SCHEMA, source)

        def one(d: str, rec) -> DirectionFit:
            at = f"{source}: fits.{d}"
            st = need(rec, "stabilisation", at, dict)
            ragged = {k: need(st, k, f"{at}.stabilisation", list) for k in ("fn", "zeta", "stable")}
            stab = Stabilisation(ints_in(need(st, "orders", f"{at}.stabilisation", list), f"{at}.stabilisation.orders"),
                                 [floats_in(v, f"{at}.stabilisation.fn") for v in ragged["fn"]],
                                 [floats_in(v, f"{at}.stabilisation.zeta") for v in ragged["zeta"]],
                                 [ints_in(v, f"{at}.stabilisation.stable") for v in ragged["stable"]])
            modes = []
            for i, m in enumerate(need(rec, "modes", at, list)):
                w = f"{at}.modes[{i}]"
                modes.append(FittedMode(*(number_in(need(m, k, w), f"{w}.{k}") for k in
                                          ("fn", "k", "zeta", "phase_deg", "peak_to_noise")),
                                        int_in(need(m, "stable_orders", w), f"{w}.stable_orders"),
                                        int_in(need(m, "orders", w), f"{w}.orders"),
                                        number_in(need(m, "local_error", w), f"{w}.local_error")))
            return DirectionFit(need(rec, "direction", at, str), need(rec, "source", at, str),
                                floats_in(need(rec, "freq_hz", at, list), f"{at}.freq_hz"),
                                complex_in(need(rec, "h", at, dict), f"{at}.h"),
                                complex_in(need(rec, "h_fit", at, dict), f"{at}.h_fit"), tuple(modes),
                                *(number_in(need(rec, k, at), f"{at}.{k}") for k in ("upper", "lower", "nrmse",
                                                                                    "noise")), stab)

        band = need(doc, "band", source, (list, type(None)))
        with quiet():  # a soft fitted k was warned about when it was fitted
            structure = structure_in(need(doc, "structure", source), f"{source}: structure")
        return cls({d: one(d, rec) for d, rec in need(doc, "fits", source, dict).items()}, structure,
                   None if band is None else tuple(float(b) for b in floats_in(band, f"{source}: band")))


def fit_files(frf_x, frf_y=None, *, band: tuple[float, float] | None = None, modes=("auto", "auto"),
              records: tuple[int | None, int | None] = (None, None), frf_type: str = "auto") -> ModalResult:
    """Fit the drive-point FRF files of x (and y) to modes; see :func:`millstab.modal.fit.fit_direction`.
    ``frf_type``: what the files hold (:func:`as_receptance`). The same file (or a copy) for x and y is
    warned about: y then equals x, true only of an axisymmetric tool."""
    fits: dict[str, DirectionFit] = {}
    if frf_x is not None and frf_y is not None and records[0] == records[1] and same_file(frf_x, frf_y):
        names = Path(str(frf_x)).name + ("" if str(frf_x) == str(frf_y) else ", " + Path(str(frf_y)).name)
        warn(f"FRF_Y is the same measurement as FRF_X ({names}): "
             f"y is fitted equal to x, which holds only for a tool that is symmetric about its axis; tap y "
             f"separately (hammer and sensor along y) unless it is", FRFWarning, stacklevel=2)
    for d, path, n, rec in (("x", frf_x, modes[0], records[0]), ("y", frf_y, modes[1], records[1])):
        if path is None:
            continue
        f, h = read_direction(path, d, band, rec, frf_type=frf_type)
        fits[d] = fit_direction(f, h, direction=d, source=Path(path).name, modes=n)
    with quiet():  # a soft fitted k is what was measured; the report shows it in N/um
        structure = Structure(**{d: tuple(Mode(m.fn, m.k, m.zeta, f"structure.{d}[{i}]")
                                          for i, m in enumerate(fit.modes))
                                 for d, fit in fits.items()})
    return ModalResult(fits, structure, band)


def measured_structure(frf_x, frf_y=None, band: tuple[float, float] | None = None,
                       records: tuple[int | None, int | None] = (None, None), frf_type: str = "auto") -> Structure:
    """The measured FRFs as a :class:`Structure` (direct terms only, on x's axis), cut to ``band``;
    ``frf_type`` as for :func:`fit_files`."""
    src = {}
    for term, path, rec in (("xx", frf_x, records[0]), ("yy", frf_y, records[1])):
        if path is not None:
            src[term] = {"file": str(path), "record": rec} if rec is not None else str(path)
    with quiet():  # already warned when the directions were read
        frf = load_measured_frf(**src, field="FRF", receptance_only=False)
    if check_frf_type(frf_type) in ("mobility", "accelerance"):
        from millstab.frfkind import to_receptance

        conv = {t: None if getattr(frf, t) is None else to_receptance(frf.freq_hz, getattr(frf, t), frf_type)
                for t in ("xx", "yy")}
        with quiet():
            frf = MeasuredFRF(frf.freq_hz, conv["xx"], conv["yy"])
    if band is not None:
        keep = (frf.freq_hz >= band[0]) & (frf.freq_hz <= band[1])
        frf = MeasuredFRF(frf.freq_hz[keep], None if frf.xx is None else frf.xx[keep],
                          None if frf.yy is None else frf.yy[keep])
    return Structure(frf=frf)


@dataclass(frozen=True)
class SLDCheck:
    """The SLD from the fitted modes beside the SLD from the measured FRF.

    Attributes:
        rpm: speeds [rev/min].  fitted_mm, measured_mm: limiting depths [mm].
        min_fitted_mm, min_measured_mm: their minima [mm];  min_difference: min_fitted/min_measured − 1.
        worst_difference: the largest |fitted/measured − 1| over the speeds;  worst_rpm: where.
    """

    rpm: np.ndarray
    fitted_mm: np.ndarray
    measured_mm: np.ndarray
    min_fitted_mm: float
    min_measured_mm: float
    min_difference: float
    worst_difference: float
    worst_rpm: float

    def summary(self) -> str:
        """One line: the minimum depths of the fit and of the measured FRF, their difference and the worst one."""
        r = self.rpm
        return (f"SLD check (zoa, {r.size} speeds {r.min():g}..{r.max():g} rpm): minimum depth "
                f"{self.min_fitted_mm:.4g} mm from the fit vs {self.min_measured_mm:.4g} mm from the measured FRF "
                f"({100 * self.min_difference:+.2f} %); worst difference {100 * self.worst_difference:.1f} % at "
                f"{self.worst_rpm:.6g} rpm")


def sld_check(fitted: Structure, measured: Structure, cutting: Cutting, rpm: np.ndarray) -> SLDCheck:
    """Both limits by the zoa engine at ``rpm``, their minima and their worst relative difference."""
    from millstab.stability import engine_with

    # an engine that accepts a measured FRF (zoa): the fit checked on the tap test itself
    zoa = engine_with(accepts_measured_frf=True)
    a = zoa.envelope(fitted, cutting, rpm)
    b = zoa.envelope(measured, cutting, rpm)
    ok = np.isfinite(a.depth) & np.isfinite(b.depth) & (b.depth > 0)
    if not ok.any():
        raise InputError("--config", "cutting conditions", "no speed gives a finite limit for both structures")
    rel = np.abs(a.depth[ok] / b.depth[ok] - 1)
    i = int(np.argmax(rel))
    ma, mb = float(np.min(a.depth_mm[ok])), float(np.min(b.depth_mm[ok]))
    return SLDCheck(np.asarray(rpm, float), a.depth_mm, b.depth_mm, ma, mb, ma / mb - 1, float(rel[i]),
                    float(np.asarray(rpm)[ok][i]))


__all__ = ["FRF_TYPES", "ModalResult", "NEGATE_BOTH", "SLDCheck", "as_receptance", "check_frf_type", "fit_files",
           "fitted_config", "measured_structure", "negated_receptance", "parse_band", "parse_modes", "read_direction",
           "same_file", "sld_check"]


def fitted_config(cfg, modes: int | str = "auto"):
    """``cfg`` itself when its structure is modal; else a copy whose structure is fitted from its measured
    direct terms (xx → x modes, yy → y modes), and a one-line note saying so (``None`` when nothing was done).

    Cross terms (xy, yx) of the measured FRF are not part of the modal form and are left out (said in the note).
    """
    import dataclasses

    if cfg.structure.is_modal:
        return cfg, None
    frf = cfg.structure.frf
    fits = {d: fit_direction(frf.freq_hz, getattr(frf, t), direction=d, source=f"structure.frf.{t}", modes=modes)
            for d, t in (("x", "xx"), ("y", "yy")) if getattr(frf, t) is not None}
    with quiet():
        structure = Structure(**{d: tuple(Mode(m.fn, m.k, m.zeta, f"structure.{d}[{i}]") for i, m in enumerate(f.modes))
                                 for d, f in fits.items()})
    parts = [f"{d}: " + ", ".join(f"{m.fn:.5g} Hz {m.k / 1e6:.4g} N/um zeta {m.zeta:.4g}" for m in f.modes)
             for d, f in fits.items()]
    cross = "; its cross terms are left out" if frf.xy is not None or frf.yx is not None else ""
    note = (f"{cfg.name}: the structure is a measured FRF; fitted its modes first ({'; '.join(parts)}){cross}, and "
            f"what follows uses the fit (`millstab modal` writes it as a [structure] section)")
    return dataclasses.replace(cfg, structure=structure), note
