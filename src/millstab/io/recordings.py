"""Recordings of a cut: WAV files (a microphone, a phone) and CSV time_s,signal (an accelerometer).

* :func:`read_recording` -- (signal, sample rate [Hz]) of one channel. WAV: 8/16/24/32-bit PCM or
  32/64-bit float (``scipy.io.wavfile``), mono or the ``channel``-th of several (0 = first), 8-192 kHz;
  PCM is scaled to full scale ±1. CSV: a header ``time_s,signal`` (any name for the second column),
  equally spaced times (the rate is 1 / the median step; steps off by more than 1 % are refused: a
  spectrum needs a uniform clock).
* :func:`write_wav` -- a signal in [-1, 1] as 16-bit (or 32-bit, float) PCM, atomically, never
  over an input.
"""

from __future__ import annotations

import io as _io
from pathlib import Path
from typing import Iterable

import numpy as np

from millstab.errors import InputError
from millstab.io.results import PathLike, atomic_write_bytes

#: sample rates accepted [Hz]
FS_MIN, FS_MAX = 8000, 192000
#: the fewest samples a recording may have
MIN_SAMPLES = 1024
#: CSV (accelerometer) rates may be lower than a microphone's [Hz]
CSV_FS_MIN = 500.0


#: a WAV with at least this share of its samples (and CLIP_MIN_SAMPLES) at full scale is noted as clipped
CLIP_SHARE = 1e-4
CLIP_MIN_SAMPLES = 4
#: another channel this much louder (RMS, 6 dB) than the one read is named in the note on the channel
CHANNEL_LOUDER = 2.0


def read_recording(path: PathLike, channel: int = 0) -> tuple[np.ndarray, float]:
    """(signal as float64, sample rate [Hz]) of a WAV or CSV recording; rules in the module docstring."""
    x, fs, _ = read_recording_notes(path, channel)
    return x, fs


def read_recording_notes(path: PathLike, channel: int = 0) -> tuple[np.ndarray, float, list[str]]:
    """:func:`read_recording` and notes on the file, one sentence each: a WAV clipped (samples at full scale:
    the flattened peaks add harmonics and intermodulation lines that no cut made), the channel read of several
    (and another one louder)."""
    p = Path(path)
    if not p.exists():
        raise InputError("recording", str(path), "file does not exist")
    if p.suffix.lower() == ".csv":
        return (*_read_csv(p), [])
    return _read_wav(p, channel)


def _read_wav(p: Path, channel: int) -> tuple[np.ndarray, float, list[str]]:
    from scipy.io import wavfile

    try:
        fs, data = wavfile.read(p, mmap=False)
    except (ValueError, EOFError, OSError) as exc:
        raise InputError("recording", str(p), f"a WAV file (PCM 8/16/24/32-bit or float): {exc}") from None
    if not FS_MIN <= fs <= FS_MAX:
        raise InputError("recording", f"{p.name}: {fs} Hz", f"a sample rate from {FS_MIN} to {FS_MAX} Hz")
    notes = []
    if data.ndim == 2:
        if not 0 <= channel < data.shape[1]:
            raise InputError("--channel", channel, f"a channel from 0 to {data.shape[1] - 1} ({p.name} has "
                                                   f"{data.shape[1]})")
        # which channel was heard: a stereo phone recording can carry the cut on the other one
        rms = np.sqrt(np.mean((data.astype(float) - data.astype(float).mean(axis=0)) ** 2, axis=0))
        note = f"{p.name}: channel {channel} of {data.shape[1]} heard (--channel picks another, 0 = first)"
        loud = int(np.argmax(rms))
        if loud != channel and rms[loud] > CHANNEL_LOUDER * rms[channel]:
            note += f"; channel {loud} is {20 * np.log10(rms[loud] / max(rms[channel], 1e-300)):.0f} dB louder"
        notes.append(note)
        data = data[:, channel]
    elif channel != 0:
        raise InputError("--channel", channel, f"0 ({p.name} is mono)")
    if data.dtype.kind == "u":  # 8-bit WAV is unsigned, centred on 128
        x = (data.astype(float) - 128.0) / 128.0
        full = data.astype(int)
        at_full = (full == 0) | (full == 255)
    elif data.dtype.kind == "i":
        x = data.astype(float) / float(np.iinfo(data.dtype).max)  # scipy returns 24-bit as left-aligned int32
        # full scale within 256 of the type's ends: 24-bit PCM comes left-aligned (its low byte 0)
        info = np.iinfo(data.dtype)
        lsb = 256 if data.dtype.itemsize == 4 else 1
        at_full = (data >= info.max - lsb + 1) | (data <= info.min + lsb - 1)
    else:
        x = data.astype(float)
        at_full = np.abs(x) >= 1.0
    n_full = int(np.count_nonzero(at_full))
    if n_full >= max(CLIP_MIN_SAMPLES, CLIP_SHARE * x.size):
        notes.append(f"{p.name} is clipped: {n_full} samples ({100 * n_full / x.size:.2g} %) at full scale; the "
                     "flattened peaks add harmonics and intermodulation lines no cut made (record with less gain)")
    return (*_checked(x, float(fs), p), notes)


def _read_csv(p: Path) -> tuple[np.ndarray, float]:
    from millstab.io.text import csv_rows

    text = p.read_text(encoding="utf-8-sig")
    rows = [r for r in csv_rows(_io.StringIO(text), p.name) if r and any(c.strip() for c in r)]
    if not rows or rows[0][0].strip().lower() not in ("time_s", "t_s", "time"):
        raise InputError("recording", p.name, "a CSV with the header time_s,signal (time in seconds)")
    try:
        arr = np.array([[float(c) for c in r[:2]] for r in rows[1:]], dtype=float)
    except ValueError as exc:
        raise InputError("recording", p.name, f"numbers in the columns time_s,signal ({exc})") from None
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise InputError("recording", p.name, "two columns: time_s,signal")
    t, x = arr[:, 0], arr[:, 1]
    dt = np.diff(t)
    if t.size < 2 or not np.all(np.isfinite(dt)) or np.median(dt) <= 0:
        raise InputError("recording", p.name, "increasing times in seconds")
    step = float(np.median(dt))
    if np.max(np.abs(dt - step)) > 0.01 * step:
        raise InputError("recording", p.name, "equally spaced times (a spectrum needs a uniform clock; steps "
                                              f"from {dt.min():.3g} to {dt.max():.3g} s)")
    fs = 1.0 / step
    if not CSV_FS_MIN <= fs <= FS_MAX:
        raise InputError("recording", f"{p.name}: {fs:.6g} Hz", f"a sample rate from {CSV_FS_MIN:g} to {FS_MAX} Hz")
    return _checked(x, fs, p)


def _checked(x: np.ndarray, fs: float, p: Path) -> tuple[np.ndarray, float]:
    if x.size < MIN_SAMPLES:
        raise InputError("recording", f"{p.name}: {x.size} samples", f"at least {MIN_SAMPLES} samples")
    if not np.all(np.isfinite(x)):
        raise InputError("recording", p.name, "finite samples (it holds NaN or inf)")
    return np.ascontiguousarray(x, dtype=float), fs


def write_wav(path: PathLike, fs: int, signal: np.ndarray, bits: int = 16, protect: Iterable[PathLike] = ()) -> Path:
    """Write ``signal`` (full scale ±1) as a mono WAV: 16/32-bit PCM, or ``bits = 0`` 32-bit float."""
    from scipy.io import wavfile

    x = np.clip(np.asarray(signal, float), -1.0, 1.0)
    if bits == 0:
        data = x.astype(np.float32)
    elif bits in (16, 32):
        dt = np.int16 if bits == 16 else np.int32
        data = np.round(x * np.iinfo(dt).max).astype(dt)
    else:
        raise InputError("bits", bits, "16, 32 or 0 (float)")
    buf = _io.BytesIO()
    wavfile.write(buf, int(fs), data)
    return atomic_write_bytes(path, buf.getvalue(), protect=protect)


def write_recording_csv(path: PathLike, fs: float, signal: np.ndarray, protect: Iterable[PathLike] = ()) -> Path:
    """Write ``signal`` as CSV time_s,signal (an accelerometer's export)."""
    from millstab.io.results import write_csv

    t = np.arange(np.asarray(signal).size) / float(fs)
    return write_csv(path, ["time_s", "signal"], [t, np.asarray(signal, float)], protect=protect)


def write_recording(path: PathLike, fs: float, signal: np.ndarray, protect: Iterable[PathLike] = ()) -> Path:
    """Write a recording by its extension: .wav (16-bit PCM) or .csv (time_s,signal)."""
    if Path(path).suffix.lower() == ".csv":
        return write_recording_csv(path, fs, signal, protect=protect)
    return write_wav(path, int(round(fs)), signal, bits=16, protect=protect)


#: labels a cuts CSV may give a row without a recording
CUT_LABELS = ("stable", "marginal", "chatter")


def read_cuts_with_recordings(path: PathLike, uploads: dict[str, Path] | None = None) -> list[dict]:
    """Rows of a cuts CSV ``rpm,depth_mm[,label][,chatter_hz][,weight],recording[,tap]`` as dicts (line: the row's
    line in the file; rpm, depth_mm, label, chatter_hz, weight, recording: an existing path resolved relative to
    the CSV's folder, or None where the cell is empty; that row then needs its own label; tap: the same for a
    tap recorded by the cut's sensor, ``listen --tap``, or None). Other columns are ignored.

    With ``uploads`` (the web app: uploaded file name → where the session saved it) a recording cell may
    only be the name of a file uploaded in the same session: anything else (a server path, a name with a
    folder, a file not uploaded) is refused before any file is looked at or opened."""
    p = Path(path)
    if not p.exists():
        raise InputError("cuts", str(path), "file does not exist")
    from millstab.io.text import csv_rows, read_text

    rows = list(csv_rows(_io.StringIO(read_text(p, "cuts", "CSV file")), p.name))
    rows = [r for r in rows if r and any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
    if not rows:
        raise InputError("cuts", str(path), "a header rpm,depth_mm,...,recording and one row per cut")
    head = [h.strip().lower() for h in rows[0]]
    for need in ("rpm", "depth_mm", "recording"):
        if need not in head:
            raise InputError("cuts", p.name, f"a '{need}' column (header: {','.join(head)})")
    col = {h: i for i, h in enumerate(head)}
    out = []
    for line, r in enumerate(rows[1:], start=2):
        cell = {h: (r[i].strip() if i < len(r) else "") for h, i in col.items()}

        def num(name: str, required: bool):
            text = cell.get(name, "")
            if text == "":
                if required:
                    raise InputError(f"{p.name}:{line} {name}", text, "a number")
                return None
            try:
                return float(text)
            except ValueError:
                raise InputError(f"{p.name}:{line} {name}", text, "a number") from None

        def resolve(name: str):
            given = cell.get(name, "")
            if not given:
                return None
            if uploads is not None:
                if given not in uploads or Path(given).name != given:
                    have = ", ".join(sorted(uploads)) or "none yet"
                    raise InputError(f"{p.name}:{line} {name}", given,
                                     f"the name of a recording uploaded in the same session (uploaded: {have})")
                return uploads[given]
            found = Path(given) if Path(given).is_absolute() else p.parent / given
            if not found.exists():
                raise InputError(f"{p.name}:{line} {name}", given, f"an existing file (looked for {found})")
            if not is_recording_path(found):
                raise InputError(f"{p.name}:{line} {name}", given, "a .wav or .csv recording")
            return found

        label = cell.get("label", "").lower()
        rp = resolve("recording")
        if rp is None and label not in CUT_LABELS:
            raise InputError(f"{p.name}:{line} label", cell.get("label", ""),
                             f"a row without a recording needs a label: {', '.join(CUT_LABELS)}")
        hz = num("chatter_hz", False)
        out.append({"rpm": num("rpm", True), "depth_mm": num("depth_mm", True), "label": label,
                    "chatter_hz": float("nan") if hz is None else hz, "weight": num("weight", False),
                    "recording": rp, "tap": resolve("tap") if rp is not None else None, "line": line})
    if not out:
        raise InputError("cuts", p.name, "at least one cut below the header")
    return out


def has_recording_column(path: PathLike) -> bool:
    """Whether a cuts CSV's header names a ``recording`` column (False for a missing, empty or binary file:
    the ordinary reader then says what is wrong)."""
    from millstab.io.text import read_text

    p = Path(path)
    if not p.is_file():
        return False
    try:  # as every reader of users' text: UTF-8 or UTF-16 with a byte-order mark (Excel's "Unicode text")
        text = read_text(p, "cuts", "CSV file")
    except InputError:  # not text: the ordinary reader says so
        return False
    for line in text.splitlines():
        if line.strip() and not line.lstrip().startswith("#"):
            return "recording" in [h.strip().lower() for h in line.split(",")]
    return False


def is_recording_path(path: PathLike) -> bool:
    """Whether a path names a recording this module reads (.wav or .csv)."""
    return Path(path).suffix.lower() in (".wav", ".csv")


__all__ = ["has_recording_column", "read_cuts_with_recordings", "read_recording", "read_recording_notes", "write_wav",
           "write_recording", "write_recording_csv", "is_recording_path"]
