"""Measured tool-tip FRFs from files: CSV, CutPro-style ``.frf`` text and UFF58 (``.uff``/``.unv``).

Every reader returns ``(freq_hz, h)``: frequencies [Hz] and the complex receptance [m/N] of ONE
term (xx, yy, xy or yx). :func:`load_measured_frf` combines the terms into a validated
:class:`~millstab.model.MeasuredFRF`.

Accepted formats (chosen by the file extension, case-insensitive):

``.csv``
    Header required, columns ``freq_hz,real,imag`` (any order, case-insensitive); values in Hz and
    m/N. Blank lines and lines starting with ``#`` are skipped. :func:`write_frf_csv` writes it,
    with floats in their shortest exact form, so a write/read round trip is lossless.

``.frf`` (CutPro-style text)
    Whitespace-separated columns ``frequency real imaginary``, one frequency per row. Lines that
    are blank or start with ``#``, ``%``, ``!``, ``;`` or ``//`` are comments; lines before the
    first data row whose first token is not a number are header lines. CutPro writes its column
    labels after the numbers of the FIRST data row (``f re im Freq Hz Real m/N Imag Real``), so
    non-numeric tokens after three numbers are accepted as labels. Units: if the header/label
    tokens contain a receptance unit (``m/N``, ``mm/N``, ``um/N``, ``µm/N``, ``in/lbf`` ...), alone
    or in brackets (``Real(mm/N)``), the values are converted from it, otherwise m/N is assumed; a
    frequency unit token (``kHz``, ``rad/s``, ``rpm``, also ``Freq(rad/s)``) converts the frequency,
    angular ones by 1/2π, otherwise Hz. Decimal commas are not accepted (refused naming the line). Text
    that is not UTF-8 is read as Windows-1252 (CutPro's own encoding).

``.uff`` / ``.unv`` (universal file, dataset 58, read with :mod:`pyuff`)
    Function type 4 (FRF); types 0 (general) and 1 are accepted only when the data are complex
    and the abscissa is frequency, because some exporters write FRFs that way. A file with several
    dataset-58 records needs ``record=N``: the 0-based index among the file's dataset-58 records in
    file order (:func:`list_uff_records` lists them; in a config:
    ``xx = { file = "tap.uff", record = 2 }``). The ordinate may be displacement (receptance),
    velocity (mobility) or acceleration (accelerance) per its specific data type (8, 11, 12; 0 =
    unknown is read as displacement); mobility and accelerance are converted to receptance by
    dividing by iω and −ω². Units, first match wins: (1) the ordinate units labels when set, as the
    standard writes them, the numerator's (record 9, ``m``, ``mm``, ``m/s^2``, ``g`` = standard gravity) over
    the denominator's (record 10, ``N``, ``lbf``; newtons when unset), or a whole ratio in the numerator's
    label (``mm/N``, ``(m/s)/N``, ``g/N``), converted with pint; an unknown type (0) takes the quantity its
    label names, and a label that is no unit of the type's quantity per force is refused naming the file and
    record; (2) a dataset 164
    in the file (SI value = file value × force factor / length factor, as the UFF spec defines the
    factors); (3) SI. The abscissa is in Hz unless its units label names another unit of frequency
    (``kHz``; ``rad/s`` and ``rpm`` are converted as angular/rotational frequencies, not read as Hz);
    a label that is no frequency unit is ignored. Points at exactly 0 Hz are dropped (iω = 0).

Every text file may start with a byte-order mark (UTF-8 or UTF-16, as Windows editors write).
Frequencies and values must be finite (``inf``/``nan`` are refused naming the file and line or
sample), frequencies strictly increasing, and numbers written with a decimal point: a decimal
comma is refused with a message that says so, never guessed. :func:`load_measured_frf`
additionally drops a leading 0 Hz point (analyzers export one; MeasuredFRF needs f > 0), warns
when a direct term's imaginary part is positive at a resonance (a sign-convention slip, see
:class:`~millstab.model.MeasuredFRF`) and when the terms cover different bands, so that part of a
term (perhaps a mode) is ignored.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from millstab.errors import FRFWarning, InputError, UnitWarning, show
from millstab.io.results import PathLike, atomic_write_text, csv_text
from millstab.io.text import (COMMA_ADVICE, COMMA_NUMBER, check_comma_separated, csv_rows, parse_number,
                              read_text)
from millstab.model import MeasuredFRF, sign_convention_message, wrong_sign_resonance
from millstab.warnlog import quiet, warn

#: extension → format name
FORMATS = {".csv": "csv", ".frf": "cutpro", ".uff": "uff", ".unv": "uff"}
#: |H| above this [m/N] is implausible for a tool tip: probably mm/N or µm/N read as m/N. A mode's peak is
#: 1/(2ζk): tool tips measure ~1–100 N/µm (:data:`millstab.model.SUSPICIOUS_STIFFNESS`) at ζ ~0.01–0.1, peaks
#: ~5e-9–5e-5 m/N; in mm/N the same tips read ~5e-6–5e-2. At 1e-3 (before 2026-11-29) a stiff tip in mm/N (20 N/µm,
#: ζ 0.03: 8.3e-4) passed silently and fitted a 20 000 N/m mode; at 1e-4 only a tip under ~0.25 N/µm·(0.02/ζ) is
#: warned falsely, and mm/N passes only for tips stiffer than ~100 N/µm at ζ 0.05
SUSPICIOUS_RECEPTANCE = 1e-4

_COMMENT = ("#", "%", "!", ";", "//")


def _check_axis(freq: np.ndarray, h: np.ndarray, where: str) -> tuple[np.ndarray, np.ndarray]:
    if freq.size == 0:
        raise InputError(where, "no data rows", "the file contains no FRF values")
    if not np.all(np.isfinite(freq)):
        i = int(np.argmax(~np.isfinite(freq)))
        raise InputError(f"{where} sample {i}", float(freq[i]), "frequencies must be finite numbers")
    if not np.all(np.isfinite(h)):
        i = int(np.argmax(~np.isfinite(h)))
        raise InputError(f"{where} sample {i} ({freq[i]:g} Hz)", complex(h[i]), "FRF values must be finite numbers")
    if np.any(freq < 0):
        raise InputError(where, f"frequency {show(float(freq.min()))} Hz", "frequencies must be >= 0 Hz")
    d = np.diff(freq)
    if np.any(d <= 0):
        i = int(np.argmax(d <= 0))
        raise InputError(where, f"{show(float(freq[i]))} Hz followed by {show(float(freq[i + 1]))} Hz",
                         "frequencies must be strictly increasing")
    return freq, h


def _exists(path: PathLike, field: str) -> Path:
    p = Path(path)
    if not p.is_file():
        raise InputError(field, str(p), "FRF file does not exist")
    return p


# ----------------------------------------------------------------------------------------- CSV

def read_frf_csv(path: PathLike) -> tuple[np.ndarray, np.ndarray]:
    """Read a ``freq_hz,real,imag`` CSV (Hz, m/N). Returns ``(freq_hz, h)``."""
    p = _exists(path, "frf file")
    lines = read_text(p, str(p), "text CSV file").splitlines()
    rows = [(i + 1, r) for i, r in enumerate(csv_rows(lines, p.name))
            if r and any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
    required = ("freq_hz", "real", "imag")
    if not rows:
        raise InputError(str(p), "empty file", f"expected a header {','.join(required)} and rows")
    names = [c.strip().lower() for c in rows[0][1]]
    check_comma_separated(names, f"{p.name} line {rows[0][0]}", lines[rows[0][0] - 1], ",".join(required))
    for n in names:
        if n not in required:
            raise InputError(f"{p.name} header", n, f"unknown column; the columns are {', '.join(required)} (Hz, m/N)")
    for n in required:
        if n not in names:
            raise InputError(f"{p.name} header", ",".join(names),
                             f"missing column {n!r}; required: {', '.join(required)}")
    if len(set(names)) != len(names):
        raise InputError(f"{p.name} header", ",".join(names), "a column name appears twice")
    col = {n: i for i, n in enumerate(names)}
    out = np.empty((len(rows) - 1, 3))
    for k, (line, r) in enumerate(rows[1:]):
        if len(r) != len(names):
            text = lines[line - 1]
            comma = f"; {COMMA_ADVICE}" if len(r) > len(names) and re.search(r"\d,\d", text) else ""
            raise InputError(f"{p.name} line {line}", text, f"expected {len(names)} cells, found {len(r)}{comma}")
        for j, n in enumerate(required):
            out[k, j] = parse_number(r[col[n]].strip(), f"{p.name} line {line}, {n}")
    return _check_axis(out[:, 0].copy(), out[:, 1] + 1j * out[:, 2], p.name)


def frf_csv_text(freq_hz: np.ndarray, h: np.ndarray) -> str:
    """One FRF term as ``freq_hz,real,imag`` CSV text (Hz, m/N), lossless: what :func:`write_frf_csv` writes, for
    a caller that keeps the file itself (the web app's session folder)."""
    f = np.asarray(freq_hz, dtype=float).ravel()
    v = np.asarray(h, dtype=complex).ravel()
    if f.shape != v.shape:
        raise InputError("frf values", f"{v.size} values", f"need one value per frequency ({f.size})")
    return csv_text(["freq_hz", "real", "imag"], [f, v.real, v.imag])


def write_frf_csv(path: PathLike, freq_hz: np.ndarray, h: np.ndarray, protect=()) -> Path:
    """Write one FRF term as ``freq_hz,real,imag`` CSV (Hz, m/N), lossless and atomic."""
    return atomic_write_text(path, frf_csv_text(freq_hz, h), protect)


# ------------------------------------------------------------------------------------- CutPro

_FREQ_UNITS = {"hz": 1.0, "khz": 1e3, "rad/s": 1.0 / (2.0 * math.pi)}
#: a unit inside brackets in a label: "Frequency(rad/s)", "Real[mm/N]"
_BRACKETED = re.compile(r"[(\[]([^()\[\]]+)[)\]]")


def _label_units(labels: list[str]) -> tuple[set[float], set[float]]:
    """(Hz factors, m/N factors) named by label tokens, bare (``rad/s``) or in brackets (``Freq(rad/s)``)."""
    f_factors: set[float] = set()
    h_factors: set[float] = set()
    from millstab.units import frequency_factor

    for token in labels:
        for t in [token] + _BRACKETED.findall(token):
            ff = _FREQ_UNITS.get(t.lower()) if t.lower() in _FREQ_UNITS else frequency_factor(t)
            if ff is not None:
                f_factors.add(ff)
                continue
            hf = _receptance_unit(t)
            if hf is not None:
                h_factors.add(hf)
    return f_factors, h_factors


def _is_number(tok: str) -> bool:
    try:
        float(tok)
    except ValueError:
        return False
    return True


def _receptance_unit(token: str) -> float | None:
    """SI factor of a receptance unit token like ``mm/N``; None if the token is not one."""
    if "/" not in token or token.lower() in _FREQ_UNITS:
        return None
    from millstab.units import registry

    ureg = registry()
    try:
        q = ureg.Quantity(1.0, token.replace("µ", "u").replace("μ", "u").replace("^", "**"))
        return float(q.to("m/N").magnitude)
    except Exception:  # not a unit, or not length/force
        return None


def _refuse_commas(tok: list[str], where: str, line: str) -> None:
    """Refuse a row with a decimal comma (``100,5``) or comma-separated numbers (``100.5,1e-7``)."""
    for t in tok:
        if COMMA_NUMBER.fullmatch(t):
            raise InputError(where, line[:60], f"{t!r}: {COMMA_ADVICE}")
        parts = [x for x in t.split(",") if x]
        if "," in t and parts and all(_is_number(x) for x in parts):
            raise InputError(where, line[:60], "numbers separated by commas: a .frf file separates its columns "
                                               "with spaces or tabs (save comma-separated data as .csv with a "
                                               "header freq_hz,real,imag)")


def read_frf_cutpro(path: PathLike) -> tuple[np.ndarray, np.ndarray]:
    """Read a CutPro-style ``.frf`` text file (format in the module docstring). Returns ``(freq_hz, h)``."""
    p = _exists(path, "frf file")
    data: list[tuple[float, float, float]] = []
    labels: list[str] = []
    for line_no, line in enumerate(read_text(p, str(p), fallback="cp1252").splitlines(), start=1):
        s = line.strip()
        if not s or s.startswith(_COMMENT):
            continue
        tok = s.split()
        _refuse_commas(tok, f"{p.name} line {line_no}", s)
        numeric = [_is_number(t) for t in tok]
        if not numeric[0]:
            if data:
                raise InputError(f"{p.name} line {line_no}", s[:60],
                                 "text after the data rows; expected 'frequency real imag'")
            labels += tok
            continue
        n_num = next((i for i, ok in enumerate(numeric) if not ok), len(tok))
        if n_num < 3:
            raise InputError(f"{p.name} line {line_no}", s[:60],
                             "a data row needs three numbers: frequency, real, imaginary")
        if n_num > 3:
            raise InputError(f"{p.name} line {line_no}", s[:60],
                             f"found {n_num} numbers; expected three columns: frequency [Hz], real, imaginary [m/N]")
        if n_num < len(tok):
            if data:
                raise InputError(f"{p.name} line {line_no}", s[:60],
                                 "text after the numbers is only allowed on the first data row")
            labels += tok[3:]
        where = f"{p.name} line {line_no}"
        data.append(tuple(parse_number(t, f"{where}, {c}") for t, c in zip(tok, ("frequency", "real", "imaginary"))))
    if not data:
        raise InputError(str(p), "no data rows", "expected rows 'frequency real imaginary'")
    f_factors, h_factors = _label_units(labels)
    if len(h_factors) > 1 or len(f_factors) > 1:
        raise InputError(f"{p.name} labels", " ".join(labels),
                         "conflicting unit labels; give one frequency and one receptance unit")
    hf = h_factors.pop() if h_factors else 1.0
    ff = f_factors.pop() if f_factors else 1.0
    a = np.array(data)
    return _check_axis(a[:, 0] * ff, (a[:, 1] + 1j * a[:, 2]) * hf, p.name)


# ---------------------------------------------------------------------------------------- UFF

_FUNC_TYPES = {0: "general", 1: "time response", 2: "auto spectrum", 3: "cross spectrum", 4: "FRF",
               5: "transmissibility", 6: "coherence"}
#: ordinate specific data type → (name, power of iω that turns it into displacement)
_ORDINATE = {0: ("unknown (read as displacement)", 0), 8: ("displacement", 0), 11: ("velocity", 1),
             12: ("acceleration", 2)}


def _uff_sets(p: Path) -> tuple[list[dict[str, Any]], dict[str, Any] | None]:
    """All dataset-58 records of a UFF file and its first dataset 164 (units), if any."""
    import pyuff

    try:
        uff = pyuff.UFF(str(p))
        types = list(uff.get_set_types())
    except Exception as exc:  # pyuff raises assorted errors for a non-UFF file
        raise InputError(str(p), "unreadable", f"not a universal file (UFF): {exc}{_uff_comma_hint(p)}") from None
    if not types:
        raise InputError(str(p), "no datasets", "not a universal file (UFF): no datasets found")
    idx58 = [i for i, t in enumerate(types) if int(t) == 58]
    idx164 = [i for i, t in enumerate(types) if int(t) == 164]
    if not idx58:
        raise InputError(str(p), f"dataset types {sorted({int(t) for t in types})}",
                         "contains no dataset 58 (function) record")
    try:
        sets = uff.read_sets(idx58)
        units = uff.read_sets(idx164[0]) if idx164 else None
    except Exception as exc:
        raise InputError(str(p), "unreadable", f"pyuff could not read the records: {exc}{_uff_comma_hint(p)}") from None
    if isinstance(sets, dict):
        sets = [sets]
    return list(sets), units


def _uff_comma_hint(p: Path) -> str:
    """Why pyuff failed, when an ASCII UFF holds decimal commas (``1,0e-07``): names the first line."""
    try:
        text = p.read_bytes().decode("latin-1")
    except OSError:
        return ""
    for no, line in enumerate(text.splitlines(), start=1):
        if re.search(r"\d,\d", line):
            return f"; line {no} ({line.strip()[:40]!r}) has a decimal comma: {COMMA_ADVICE}"
    return ""


def _describe(i: int, s: Mapping[str, Any]) -> str:
    ft = int(s.get("func_type", 0))
    return (f"[{i}] {_FUNC_TYPES.get(ft, f'type {ft}')}, response {s.get('rsp_node')}:{s.get('rsp_dir')}, "
            f"reference {s.get('ref_node')}:{s.get('ref_dir')}, '{str(s.get('id1', '')).strip()}'")


def list_uff_records(path: PathLike) -> list[str]:
    """One line per dataset-58 record of a UFF file: ``[index] type, response node:dir, reference node:dir, id``."""
    p = _exists(path, "frf file")
    sets, _ = _uff_sets(p)
    return [_describe(i, s) for i, s in enumerate(sets)]


#: what a UFF ordinate (numerator) may hold, by its derivative order: the SI unit of the numerator alone
_NUMERATOR_SI = {0: "m", 1: "m/s", 2: "m/s**2"}
#: ... and of the whole FRF
_FRF_SI = {0: "m/N", 1: "m/s/N", 2: "m/s**2/N"}
_FRF_EXAMPLES = {0: "m/N or mm/N", 1: "(m/s)/N", 2: "(m/s^2)/N or g/N"}


def _unit_text(label: str) -> str | None:
    """A UFF units label cleaned for pint (µ → u, ^ → **), or None when it is unset (blank or ``NONE``)."""
    text = (label or "").strip()
    if not text or text.upper() == "NONE":
        return None
    return text.replace("µ", "u").replace("μ", "u").replace("^", "**")


def _si_factor(text: str, si: str, power: int) -> float | None:
    """SI factor of ``text`` as a quantity of unit ``si``, or None when pint cannot read it or its dimension differs.

    A lone ``g`` (or ``g`` before a slash) in an acceleration is standard gravity, as accelerometer software writes
    it, not pint's gram.
    """
    from millstab.units import registry

    if power == 2:
        text = re.sub(r"^\(?\s*[gG]\s*\)?(?=\s*(/|$))", "g_0", text)
    try:
        return float(registry().Quantity(1.0, text).to(si).magnitude)
    except Exception:  # not a unit, or not of this dimension
        return None


def _label_factor(num_label: str, den_label: str, power: int, where: str) -> tuple[float, int] | None:
    """(SI factor, derivative order) from a dataset-58 record's ordinate units labels, or None when unset.

    The UFF standard writes the response and the reference apart: record 9 field 6 (pyuff
    ``ordinate_axis_units_lab``) is the numerator's unit (``m``, ``mm``, ``m/s^2``, ``g``), record 10 field 6
    (``orddenom_axis_units_lab``) the denominator's (``N``, ``lbf``); some exporters put the whole ratio in the
    numerator label (``mm/N``, ``g/N``) and leave the denominator unset or ``N``. Both are read: a numerator label
    that is already a unit per force is taken whole, else numerator / denominator (newtons when the denominator is
    unset). ``power`` is the derivative order of the record's specific data type (0 displacement, 1 velocity,
    2 acceleration); with an unknown type (``power=None``) the label decides.

    Raises:
        InputError: naming ``where`` (file and record) when the labels are no unit of the record's quantity.
    """
    num, den = _unit_text(num_label), _unit_text(den_label)
    if num is None:
        return None
    powers = (0, 1, 2) if power is None else (power,)
    for p in powers:
        whole = _si_factor(num, _FRF_SI[p], p)
        if whole is not None:  # "mm/N", "g/N": the numerator label carries the whole FRF's unit
            return whole, p
        top = _si_factor(num, _NUMERATOR_SI[p], p)
        bottom = 1.0 if den is None else _si_factor(den, "N", 0)
        if top is not None and bottom is not None:
            return top / bottom, p
    written = repr(num_label.strip()) + ("" if den is None else f" per {den_label.strip()!r}")
    kind = "displacement, velocity or acceleration" if power is None else ("displacement", "velocity",
                                                                           "acceleration")[power]
    raise InputError(f"{where} ordinate units", written,
                     f"not a unit of {kind} per force; expected e.g. "
                     f"{_FRF_EXAMPLES[0 if power is None else power]} (or the numerator "
                     f"{_NUMERATOR_SI[0 if power is None else power].replace('**', '^')} with the denominator N)")


def read_frf_uff(path: PathLike, record: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Read one dataset-58 FRF record from a UFF file (rules in the module docstring).

    Args:
        path: ``.uff`` or ``.unv`` file.
        record: 0-based index among the file's dataset-58 records; may be omitted when there is one.

    Returns:
        ``(freq_hz, h)`` with h the receptance [m/N].
    """
    p = _exists(path, "frf file")
    sets, units = _uff_sets(p)
    listing = "; ".join(_describe(i, s) for i, s in enumerate(sets))
    if record is None:
        if len(sets) > 1:
            raise InputError(f"{p.name} record", None, f"the file holds {len(sets)} dataset-58 records; choose one "
                             f"with record = N (0-based): {listing}")
        record = 0
    if isinstance(record, bool) or not isinstance(record, (int, np.integer)) or not 0 <= record < len(sets):
        raise InputError(f"{p.name} record", record, f"must be an integer 0..{len(sets) - 1}: {listing}")
    s = sets[int(record)]
    where = f"{p.name} record {record}"
    ft = int(s.get("func_type", 0))
    data = np.asarray(s["data"])
    freq = np.asarray(s["x"], dtype=float)
    from millstab.units import frequency_factor

    f_unit = frequency_factor(str(s.get("abscissa_axis_units_lab", "") or ""))
    if f_unit is not None and f_unit != 1.0:
        with np.errstate(over="ignore", invalid="ignore"):
            freq = freq * f_unit
    absc = int(s.get("abscissa_spec_data_type", 0))
    if ft != 4 and not (ft in (0, 1) and np.iscomplexobj(data) and absc in (0, 18)):
        raise InputError(f"{where} function type", f"{ft} ({_FUNC_TYPES.get(ft, 'other')})",
                         "must be an FRF (function type 4) with complex data over frequency")
    if not np.iscomplexobj(data):
        raise InputError(f"{where} data", "real values", "an FRF record must hold complex data")
    if absc not in (0, 18):
        raise InputError(f"{where} abscissa type", absc, "the abscissa must be frequency (specific data type 18)")
    num = int(s.get("ordinate_spec_data_type", 0))
    den = int(s.get("orddenom_spec_data_type", 0))
    if num not in _ORDINATE:
        raise InputError(f"{where} ordinate type", num,
                         "the response must be displacement (8), velocity (11) or acceleration (12)")
    if den not in (0, 13):
        raise InputError(f"{where} denominator type", den, "the reference must be a force (13)")
    power = _ORDINATE[num][1]
    labelled = _label_factor(str(s.get("ordinate_axis_units_lab", "") or ""),
                             str(s.get("orddenom_axis_units_lab", "") or ""), None if num == 0 else power, where)
    factor = None
    if labelled is not None:
        factor, power = labelled  # an unknown type (0) takes the quantity its label names
    if factor is None and units is not None:
        factor = float(units.get("force", 1.0)) / float(units.get("length", 1.0))
    if factor is None:
        factor = 1.0
    freq, _ = _check_axis(freq, data.astype(complex), where)  # inf/nan refused before any arithmetic
    with np.errstate(over="ignore", invalid="ignore"):
        h = data.astype(complex) * factor
    freq, h = _check_axis(freq, h, where)  # overflow of a huge value times the unit factor
    if power:
        keep = freq > 0  # iω = 0 there: no receptance can be derived at 0 Hz
        freq, h = freq[keep], h[keep]
        h = h / (2j * np.pi * freq) ** power
    return freq, h


# ----------------------------------------------------------------------------------- dispatch

def read_frf(path: PathLike, record: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Read one FRF term [Hz, m/N] from a file whose format is chosen by extension (see module doc).

    Raises:
        InputError: unknown extension, missing file, malformed content; ``record`` given for a
            non-UFF file.
    """
    p = Path(path)
    fmt = FORMATS.get(p.suffix.lower())
    if fmt is None:
        raise InputError("frf file", str(p), f"unknown FRF file type {p.suffix!r}; allowed: {', '.join(FORMATS)}")
    if fmt == "uff":
        return read_frf_uff(p, record)
    if record is not None:
        raise InputError("frf record", record, f"'record' only applies to UFF files, not {p.suffix}")
    return read_frf_csv(p) if fmt == "csv" else read_frf_cutpro(p)


FRFSource = PathLike | Mapping[str, Any] | tuple


def _source(src: FRFSource, field: str, base_dir: Path | None,
            files: Mapping[str, PathLike] | None = None) -> tuple[Path, int | None]:
    """A source (path, ``{"file": .., "record": ..}`` or ``(path, record)``) → (absolute path, record).
    With ``files`` the path is only looked up there (see :func:`load_measured_frf`)."""
    record = None
    if isinstance(src, Mapping):
        unknown = set(src) - {"file", "record"}
        if unknown:
            raise InputError(f"{field}.{sorted(unknown)[0]}", src[sorted(unknown)[0]],
                             "unknown key; allowed keys: file, record")
        if "file" not in src:
            raise InputError(f"{field}.file", None, "missing; give the FRF file path")
        path, record = src["file"], src.get("record")
    elif isinstance(src, tuple):
        if len(src) != 2:
            raise InputError(field, src, "expected (path, record)")
        path, record = src
    else:
        path = src
    if not isinstance(path, (str, Path)) or not str(path).strip():
        raise InputError(field, path, "expected a file path string")
    if files is not None:  # confined: a name from this mapping or nothing; the file system is not asked
        if isinstance(path, str) and path in files:
            return Path(files[path]), record
        have = ", ".join(sorted(files)) or "none yet"
        raise InputError(field, str(path), "a config from text (a browser upload) may name only FRF files uploaded "
                                           f"in the same session, by file name (uploaded: {have})")
    p = Path(path).expanduser()
    if not p.is_absolute() and base_dir is not None:
        p = base_dir / p
    if not p.is_file():
        raise InputError(field, str(path), f"FRF file does not exist (looked for {p})")
    return p, record


def load_measured_frf(xx: FRFSource | None = None, yy: FRFSource | None = None, xy: FRFSource | None = None,
                      yx: FRFSource | None = None, *, base_dir: PathLike | None = None,
                      field: str = "structure.frf", files: Mapping[str, PathLike] | None = None,
                      receptance_only: bool = True) -> MeasuredFRF:
    """Read the FRF terms and combine them into a :class:`MeasuredFRF` on one frequency axis.

    Each term is a path, ``{"file": path, "record": N}`` or ``(path, record)``; relative paths are
    taken relative to ``base_dir`` (the config file's folder). A leading 0 Hz point is dropped.

    ``files`` confines the sources (a config that arrived as text, e.g. a browser upload): a path must
    be one of its keys exactly (a file name as uploaded) and reads the file it maps to; anything else
    (an absolute or relative path, ``~``, ``..``) is refused with an :class:`InputError` naming the
    term before any file is opened or even looked up, so an upload cannot make the server read its files.

    Frequency axis: the axis of ``xx`` (``yy`` when there is no xx). A term measured on the same
    axis (to 1e-9 relative) is used as is; a term on another axis is linearly interpolated (real and
    imaginary parts) onto it. Where the terms' bands differ, the axis is trimmed to the band all
    terms cover (never extrapolated), with an :class:`~millstab.errors.FRFWarning` whenever any
    term (in any order, cross terms included) has data outside that band, naming the terms that
    limit it and the strongest response that is ignored: a mode there is missing from the limit.

    A direct term whose imaginary part is positive at its strongest resonance (conjugated data)
    gives an :class:`~millstab.errors.FRFWarning` naming the file. A direct term that holds mobility or
    accelerance (its phase and slope, :func:`millstab.frfkind.frf_kind`) is an :class:`InputError` saying
    how to convert it, unless ``receptance_only=False`` (``millstab modal``, which converts it itself).

    Raises:
        InputError: naming the term (``structure.frf.xx``) for missing/malformed files, fewer than
            four common frequencies, or no direct term.
    """
    base = Path(base_dir) if base_dir is not None else None
    terms: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    file_names: dict[str, str] = {}
    for name, src in (("xx", xx), ("yy", yy), ("xy", xy), ("yx", yx)):
        if src is None:
            continue
        p, record = _source(src, f"{field}.{name}", base, files)
        try:
            f, h = read_frf(p, record)
        except InputError as exc:
            raise InputError(f"{field}.{name}", exc.value, f"{exc.field}: {exc.allowed}") from None
        if f[0] == 0.0:
            f, h = f[1:], h[1:]
        if name in ("xx", "yy") and receptance_only:
            _refuse_other_kind(f, h, f"{field}.{name}", p.name)
        if np.max(np.abs(h), initial=0.0) > SUSPICIOUS_RECEPTANCE:
            warn(f"{field}.{name} ({p.name}): |H| up to {np.max(np.abs(h)):.3g} m/N is very large for a tool "
                 f"tip (a 1-100 N/um tip peaks at ~5e-9 to 5e-5 m/N); is the file in mm/N or um/N? (.frf: add a "
                 f"unit label; .csv must be in m/N)",
                 UnitWarning, stacklevel=2)
        i = wrong_sign_resonance(h) if name in ("xx", "yy") else None
        if i is not None:
            warn(sign_convention_message(f"{field}.{name} ({p.name})", f[i], h[i]), FRFWarning, stacklevel=2)
        terms[name] = (f, h)
        file_names[name] = p.name
    if "xx" not in terms and "yy" not in terms:
        raise InputError(field, "no xx and no yy", "a measured FRF needs at least one direct term (xx or yy)")
    ref_name = "xx" if "xx" in terms else "yy"
    f_ref = terms[ref_name][0]
    lo = max(t[0][0] for t in terms.values())
    hi = min(t[0][-1] for t in terms.values())
    keep = (f_ref >= lo * (1 - 1e-12)) & (f_ref <= hi * (1 + 1e-12))
    if np.count_nonzero(keep) < 4:
        raise InputError(field, f"common band {lo:g}..{hi:g} Hz",
                         f"the terms must share at least 4 frequencies of the {ref_name} axis")
    coverage = _band_loss(terms, file_names, lo, hi)
    if coverage:
        warn(f"{field}: the terms cover different bands; using {lo:g}..{hi:g} Hz of the {ref_name} axis. "
             f"{coverage}", FRFWarning, stacklevel=2)
    f_common = f_ref[keep]
    out: dict[str, np.ndarray] = {}
    for name, (f, h) in terms.items():
        if f.shape == f_ref.shape and np.allclose(f, f_ref, rtol=1e-9, atol=0.0):
            out[name] = h[keep]
        else:
            out[name] = np.interp(f_common, f, h.real) + 1j * np.interp(f_common, f, h.imag)
    try:
        with quiet(FRFWarning):  # the sign convention was checked above, naming the files
            return MeasuredFRF(f_common, out.get("xx"), out.get("yy"), out.get("xy"), out.get("yx"))
    except InputError as exc:
        raise InputError(f"{field}: {exc.field}", exc.value, exc.allowed) from None


def _refuse_other_kind(freq_hz: np.ndarray, h: np.ndarray, field: str, file_name: str) -> None:
    """InputError when a direct term holds mobility or accelerance rather than receptance (told from its
    phase and slope, :func:`millstab.frfkind.frf_kind`): the engines would read it as m/N and give a
    meaningless boundary. A conjugated receptance is left to the sign-convention warning."""
    from millstab.frfkind import CONVERSION, NEGATE_BOTH, frf_kind, negated_receptance

    seen = frf_kind(freq_hz, h)
    flipped = negated_receptance(freq_hz, h, seen)
    if flipped == "yes":  # −G reads as an accelerance by its phase; its slope and low end say receptance
        raise InputError(field, file_name, f"looks like a receptance (m/N) with both columns negated, not an "
                                           f"accelerance: {NEGATE_BOTH}")
    if seen.kind in ("mobility", "accelerance"):
        maybe = (f"; or, if it is a receptance whose hammer or sensor polarity was reversed, "
                 f"{NEGATE_BOTH.split(' (')[0]}" if flipped == "maybe" else "")
        raise InputError(field, file_name,
                         f"looks like {seen.describe()}, not a receptance (m/N): {CONVERSION[seen.kind]}; "
                         f"`millstab modal {file_name} --frf-type {seen.kind}` converts it and fits its modes{maybe}")


#: an ignored response at least this share of the largest one kept is called "probably a mode"
_MODE_SHARE = 0.5


def _band_loss(terms: Mapping[str, tuple[np.ndarray, np.ndarray]], files: Mapping[str, str],
               lo: float, hi: float) -> str:
    """Why a band mismatch matters, or ``""`` when every term lies inside ``lo..hi`` Hz.

    Names the terms that limit the band and, per term that loses data, its strongest response
    outside the band, compared with its strongest inside: a peak outside is a mode the stability
    limit cannot see (an unsafe, too high limit when it is the weakest mode).
    """
    inside = {n: (f >= lo * (1 - 1e-12)) & (f <= hi * (1 + 1e-12)) for n, (f, _) in terms.items()}
    losers = [n for n in terms if not inside[n].all()]
    if not losers:
        return ""
    limits = [f"{n} ({files[n]}) covers only {terms[n][0][0]:g}..{terms[n][0][-1]:g} Hz" for n in terms
              if terms[n][0][0] >= lo * (1 - 1e-12) or terms[n][0][-1] <= hi * (1 + 1e-12)]
    parts = []
    for n in losers:
        f, h = terms[n]
        a = np.abs(h)
        out_i = int(np.argmax(np.where(inside[n], -np.inf, a)))
        peak_in = float(a[inside[n]].max(initial=0.0))
        ratio = a[out_i] / peak_in if peak_in > 0 else math.inf
        mode = "; probably a mode" if ratio >= _MODE_SHARE else ""
        parts.append(f"{n} ({files[n]}, {f[0]:g}..{f[-1]:g} Hz) is ignored outside it, where its largest response "
                     f"is |H| = {a[out_i]:.3g} m/N at {f[out_i]:g} Hz ({ratio:.3g} x its largest inside{mode})")
    return (f"{'; '.join(limits)}. " if limits else "") + "; ".join(parts) + (
        ". Modes outside the common band are left out of the stability limit, which may then be unsafe "
        "(too high): measure every term over the same band")


def same_content(a: PathLike, b: PathLike) -> bool:
    """Whether two files hold the same bytes (an FRF copied under another name for the other direction)."""
    pa, pb = Path(a), Path(b)
    if pa.stat().st_size != pb.stat().st_size:
        return False
    return pa.read_bytes() == pb.read_bytes()


__all__ = ["FORMATS", "list_uff_records", "load_measured_frf", "read_frf", "read_frf_csv", "read_frf_cutpro",
           "read_frf_uff", "same_content", "write_frf_csv"]
