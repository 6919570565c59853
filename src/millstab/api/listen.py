"""Listening to cuts as services: a recording → label and chatter frequency (``millstab listen``), a
simulated cut → what a sensor would record (``simulate --record``), and a cuts CSV whose ``recording``
column names a recording per cut → labelled cuts for ``update``."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from millstab.errors import InputError

#: the schema tag of :meth:`Heard.to_json`
SCHEMA = "millstab.listen.heard/1"
#: the arrays of a :class:`~millstab.listen.Listening` (its spectrum and chatter amplitude, for the figure)
_ARRAYS = ("freq_hz", "psd", "floor", "synchronous", "times_s", "chatter_amp")


@dataclass(frozen=True, eq=False)
class Heard:
    """One recording listened to: the analysis (:class:`millstab.listen.Listening`), the suggestion
    (suggested_rpm [rev/min] or NaN, its reason) and where the suggestion came from
    (``"harmonizer"``: 60 f_c/(N n); ``"recommend"``: the posterior's recommendation at that depth)."""

    listening: Any
    suggested_rpm: float
    reason: str
    source: str
    schema: str = SCHEMA

    def summary(self) -> str:
        """What ``millstab listen`` prints: the label, chatter frequency, score and onset; the window and
        the speed heard; the suggestion."""
        r = self.listening
        line = f"{r.label}"
        if math.isfinite(r.chatter_hz) and r.label != "stable":
            line += f" at {r.chatter_hz:.1f} Hz"
        line += f"; score {r.score:.3g} (chatter/forced amplitude; >= 0.05 chatter, < 0.02 stable)"
        if math.isfinite(r.onset_s):
            line += f"; starts at {r.onset_s:.2f} s"
        lines = [line, f"cut {r.window_s[0]:.2f}-{r.window_s[1]:.2f} s; speed heard {r.rpm_heard:.0f} rpm "
                       f"({100 * (r.rpm_heard / r.rpm - 1):+.2f} % from {r.rpm:g})"
                       + (f"; mains hum {', '.join(f'{m:g}' for m in r.mains_hz)} Hz masked" if r.mains_hz else "")]
        lines.append(f"suggested speed: {self.suggested_rpm:.0f} rpm ({self.reason})"
                     if math.isfinite(self.suggested_rpm) else f"suggestion: {self.reason}")
        lines += [f"note: {n}" for n in getattr(r, "notes", ())]
        return "\n".join(lines)

    def table(self) -> tuple[list[str], list]:
        """(header, columns) of one row per recording (recordings of a campaign stack into one sheet): what was
        heard (label, chatter_hz [Hz], score, prominence_db [dB], onset_s [s], trend), the speeds given and heard
        [rev/min], the tooth-passing frequency [Hz] and the suggestion (suggested_rpm, reason). NaN: not heard."""
        r = self.listening
        values = {"label": r.label, "chatter_hz": r.chatter_hz, "score": r.score, "prominence_db": r.prominence_db,
                  "onset_s": r.onset_s, "trend": r.trend, "rpm": r.rpm, "rpm_heard": r.rpm_heard, "teeth": r.teeth,
                  "tooth_hz": r.tooth_hz, "suggested_rpm": self.suggested_rpm, "reason": self.reason}
        return list(values), [[v] for v in values.values()]

    def figure(self, ax=None, *, title: str = ""):
        """The spectrum with its floor, masked lines and chatter line over the chatter amplitude in time
        (:func:`millstab.plot.listen.plot_listening`), into ``ax``'s place or a new figure."""
        from millstab.plot.listen import plot_listening

        return plot_listening(self.listening, title=title, ax=ax)

    def to_json(self, spectrum: bool = True) -> dict[str, Any]:
        """The listening's scalars (label, chatter_hz, score, …: NaN "not heard" as null), the suggestion
        (``suggested_rpm``, ``reason``, ``suggestion_from``) and ``"schema": "millstab.listen.heard/1"``; with
        ``spectrum`` also the arrays of the figure under ``"spectrum"`` (so that :meth:`from_json` rebuilds
        the result; the command line's file leaves them out: a 2 s Welch segment at 48 kHz is 48 000 lines)."""
        from millstab.jsondoc import plain

        r = self.listening
        doc = {k: plain(getattr(r, k), k, nan_ok=True) for k in r.__dataclass_fields__
               if k not in _ARRAYS + ("schema",)}
        doc.update({"suggested_rpm": plain(self.suggested_rpm, "suggested_rpm", nan_ok=True), "reason": self.reason,
                    "suggestion_from": self.source, "schema": SCHEMA})
        if spectrum:
            doc["spectrum"] = {k: plain(getattr(r, k), f"spectrum.{k}") for k in _ARRAYS}
        return doc

    def to_dict(self) -> dict[str, Any]:
        """:meth:`to_json` without the spectrum (the ``millstab listen --out`` file)."""
        return self.to_json(spectrum=False)

    @classmethod
    def from_json(cls, doc: Any, source: str = "heard") -> "Heard":
        """Rebuild from :meth:`to_json` output (with its spectrum). Raises InputError (wrong schema, a missing
        or bad field, or a file written without the spectrum)."""
        from millstab.jsondoc import check_schema, fields_in, need, number_in
        from millstab.listen import Listening

        check_schema(doc, SCHEMA, source)
        if "spectrum" not in doc:
            raise InputError(f"{source}: spectrum", "missing", "the file holds the scalars only (as `millstab listen "
                             "--out` writes them); a result rebuilds from to_json(spectrum=True)")
        arrays = need(doc, "spectrum", source, dict)
        inner = {**doc, **{k: need(arrays, k, f"{source}: spectrum") for k in _ARRAYS}, "schema": Listening.schema,
                 "synchronous": []}  # read below (booleans)
        listening = fields_in(Listening, inner, Listening.schema, source)
        sync = arrays["synchronous"]  # the mask of the synchronous lines: booleans
        if not isinstance(sync, list) or not all(isinstance(v, bool) for v in sync):
            raise InputError(f"{source}: spectrum.synchronous", "not booleans", "a list of true/false per line")
        listening = replace(listening, synchronous=np.array(sync, dtype=bool))
        return cls(listening, number_in(need(doc, "suggested_rpm", source), f"{source}: suggested_rpm", nan_ok=True),
                   need(doc, "reason", source, str), need(doc, "suggestion_from", source, str))


def _range(rpm_range, rpm: float) -> tuple[float, float]:
    if rpm_range is None:
        return 0.5 * rpm, 1.5 * rpm
    if isinstance(rpm_range, str):
        from millstab.parsing import parse_interval

        return parse_interval(rpm_range, "--rpm-range", "rev/min", positive=True)
    lo, hi = rpm_range
    return float(lo), float(hi)


def listen_signal(signal, fs: float, rpm: float, teeth: int, *, start: float | None = None, end: float | None = None,
                  rpm_range=None, post=None, depth_mm: float | None = None, risk: float = 0.1,
                  structure=None, tap=None) -> Heard:
    """Label a recorded signal and suggest a speed (:mod:`millstab.listen`). With a posterior ``post``
    (of ``update``) and the cut's ``depth_mm`` the suggestion is ``recommend``'s fastest speed with
    P(chatter) ≤ ``risk`` at that depth instead of the harmonizer rule. With the tool's ``structure``
    (a config's) a flip chatter is reported at its member nearest the structure's modes (step 7 of
    :mod:`millstab.listen.analyze`). ``tap``: a tap's recording (a path: read by :func:`tap_path`, at the cut's
    sample rate) or the :class:`~millstab.listen.tap.SensorPath` of one: the chatter family's members are ranked as
    the displacement would rank them through that path (:mod:`millstab.listen.tap`)."""
    from millstab.listen import listen, suggest_rpm

    if isinstance(tap, (str, Path)):
        tap = tap_path(tap, cut_fs=fs)
    res = listen(signal, fs, rpm, teeth, start=start, end=end, structure=structure, tap=tap)
    lo, hi = _range(rpm_range, rpm)
    if post is not None:
        if depth_mm is None or not (math.isfinite(depth_mm) and depth_mm > 0):
            raise InputError("--depth", depth_mm, "the cut's depth in mm (> 0): --post recommends a speed at it")
        from millstab.api.update import recommend

        rec = recommend(post, risk, (lo, hi), max_depth_mm=depth_mm)
        at = (f"at {depth_mm:g} mm" if rec.depth_mm >= depth_mm * (1 - 1e-6)
              else f"at {rec.depth_mm:.3g} mm (no speed in range is safe enough at {depth_mm:g} mm)")
        return Heard(res, float(rec.rpm), f"recommend: the fastest cut with P(chatter) {rec.p_chatter:.3g} <= {risk:g} "
                                          f"{at} in {lo:g}-{hi:g} rpm", "recommend")
    if res.label == "stable":
        return Heard(res, float("nan"), "stable: keep the speed", "harmonizer")
    s = suggest_rpm(res.chatter_hz, teeth, rpm, (lo, hi))
    return Heard(res, s.rpm, s.reason, "harmonizer")


def listen_file(path, rpm: float, teeth: int, *, channel: int = 0, tap=None, **kw) -> Heard:
    """:func:`listen_signal` of a WAV or CSV recording (:mod:`millstab.io.recordings`); ``tap``: a tap's
    recording (path; its first channel, at the cut's sample rate) or its :class:`~millstab.listen.tap.SensorPath`.
    The file's notes (clipped, the channel heard of several) join the listening's; a recording refused (silent,
    no tooth-passing sound, too short, another speed or teeth) is named in the error."""
    from millstab.io.recordings import read_recording_notes

    x, fs, notes = read_recording_notes(path, channel)
    try:
        heard = listen_signal(x, fs, rpm, teeth, tap=tap, **kw)
    except InputError as exc:  # named, with what the file showed (a stereo file's cut on the other channel)
        exc = _named(exc, path)
        raise (InputError(exc.field, exc.value, f"{exc.allowed}; {'; '.join(notes)}") if notes else exc) from None
    if not notes:
        return heard
    return replace(heard, listening=replace(heard.listening, notes=tuple(notes) + tuple(heard.listening.notes)))


def _named(exc: InputError, path) -> InputError:
    """``exc`` with the recording's file name before its field (a campaign of recordings: which one was refused)."""
    name = Path(path).name
    return exc if exc.field.startswith(name) else InputError(f"{name}: {exc.field}", exc.value, exc.allowed)


def tap_path(path, *, channel: int = 0, cut_fs: float | None = None):
    """The sensor path measured by a tap recorded in ``path`` (WAV or CSV; ``cut_fs``: the cut's sample rate,
    which the tap's must equal): :func:`millstab.listen.tap.sensor_path`. Raises InputError for a bad tap (no
    impulse, clipped, another sample rate)."""
    from millstab.io.recordings import read_recording
    from millstab.listen.tap import sensor_path

    x, fs = read_recording(path, channel)
    return sensor_path(x, fs, cut_fs=cut_fs, name=f"--tap {Path(path).name}")


def listen_figure(heard: Heard, title: str = ""):
    """The spectrum with its floor, the masked lines and the chatter line, and the chatter amplitude in time."""
    return heard.figure(title=title)


def record_cut(result, *, sensor: str = "microphone", noise: float = 0.02, seed: int = 0, **kw):
    """What a sensor would record of a simulated cut (:func:`millstab.simulate.record.record`)."""
    from millstab.simulate.record import record

    return record(result, sensor=sensor, noise=noise, seed=seed, **kw)


def record_tap(structure, *, sensor: str = "microphone", noise: float = 0.02, seed: int = 0, **kw):
    """What the same sensor would record of a tap on the structure (:func:`millstab.simulate.record.record_tap`):
    the recording ``listen --tap`` takes."""
    from millstab.simulate.record import record_tap as _record_tap

    return _record_tap(structure, sensor=sensor, noise=noise, seed=seed, **kw)


def read_cuts(path, labels: str | None = None, teeth: int | None = None, structure=None):
    """A cuts CSV as ``millstab update`` reads it: (PointSet, notes). With a ``recording`` column its cuts are
    labelled by listening (:func:`label_from_recordings`, ``teeth`` and ``structure`` of the config; one note
    per cut saying where its label came from); else the labels as written (``labels``: the codes of the label
    cells)."""
    from millstab.io import read_points
    from millstab.io.recordings import has_recording_column

    if has_recording_column(path):
        return label_from_recordings(path, teeth, structure=structure)
    return read_points(path, labels), []


def label_from_recordings(cuts_csv, teeth: int, *, rpm_range=None, uploads: dict | None = None, structure=None):
    """The cuts of a CSV with a ``recording`` column (a path relative to the CSV; empty: keep the row's
    own label) labelled by listening: a :class:`~millstab.points.PointSet` with label and chatter_hz
    from each recording, and one line per cut saying where its label came from. Every other column is read as
    :func:`millstab.io.read_points` reads it (``stickout_mm``, the condition columns, the test day, weight), and
    ``extra["recording"]`` holds each heard cut's recording as a reference (its absolute path; an uploaded file's
    name; ``""``: labelled in the file), which the shop database records with the rater ``listen``. With ``uploads``
    (uploaded file name → saved path, the web app) a recording may only name an uploaded file
    (:func:`millstab.io.recordings.read_cuts_with_recordings`): a server path is refused unopened. With the
    config's ``structure`` a flip chatter is reported at its member nearest the modes (:func:`listen_signal`); a
    ``tap`` column names a tap recorded by the cut's sensor (``listen --tap``: the sensor path it measures is
    divided out when the chatter's member is chosen). A cut's note also carries what the listening and the file
    noted (a short window, a speed the lines do not fit, clipping, the channel), a label written on the row that
    the heard one replaces, and a recording named on more than one row; a recording refused (silent, no
    tooth-passing sound, another speed or teeth) stops with an error naming it and its line."""
    from millstab.io import read_points
    from millstab.io.recordings import CUT_LABELS, read_cuts_with_recordings, read_recording_notes
    from millstab.listen import listen
    from millstab.points import GRADE

    rows = read_cuts_with_recordings(cuts_csv, uploads)
    # the file's other columns as `update` reads them: a cut's stickout, condition and test day were dropped here
    # before, so cuts heard at 40 and 60 mm were all updated at the config's stickout
    base = read_points(cuts_csv)
    name_of = {v: k for k, v in (uploads or {}).items()}  # saved path → the name the user uploaded
    labels, hz, notes, refs = [], [], [], []
    paths = {}  # a tap's measured path, read once for the cuts that share it
    for i, r in enumerate(rows):
        where = _cut_text(base, i)
        if r["recording"] is None:
            labels.append(r["label"])
            hz.append(r["chatter_hz"])
            refs.append("")
            notes.append(f"{where}: {r['label']} (from the file)")
            continue
        shown = name_of.get(r["recording"], Path(r["recording"]).name)
        x, fs, file_notes = read_recording_notes(r["recording"])
        tap = None
        if r["tap"] is not None:
            if (r["tap"], fs) not in paths:
                paths[r["tap"], fs] = tap_path(r["tap"], cut_fs=fs)
            tap = paths[r["tap"], fs]
        # a row's own cutter (its teeth column: a tool of the same family) is heard with its teeth, not the config's
        own = (base.conditions or {}).get("teeth")
        row_teeth = int(own[i]) if own is not None and np.isfinite(float(own[i])) else teeth
        try:
            res = listen(x, fs, r["rpm"], row_teeth, structure=structure, tap=tap)
        except InputError as exc:
            field, allowed = exc.field, exc.allowed
            if field == "--teeth":  # no such option here: the teeth come from the config or the row
                field = "teeth (the config's [cutting] teeth, or the row's teeth column)"
                allowed = re.sub(r"give --teeth (\d+)\?$", r"a cut with a \1-tooth cutter? give it a teeth column",
                                 allowed)
            raise InputError(f"{Path(cuts_csv).name}:{r['line']} recording {shown}: {field}", exc.value,
                             allowed) from None
        labels.append(res.label)
        hz.append(res.chatter_hz if res.label != "stable" else float("nan"))
        refs.append(name_of.get(r["recording"]) or str(Path(r["recording"]).resolve()))
        extra = list(file_notes) + list(res.notes)
        if r["label"] in CUT_LABELS and r["label"] != res.label:  # a person's label, replaced: say so
            extra.append(f"the row's written label '{r['label']}' is replaced by the heard one (empty its recording "
                         "cell to keep the written label)")
        notes.append(f"{where}: {res.label}"
                     + (f" at {res.chatter_hz:.1f} Hz" if res.label != "stable" else "")
                     + f" (heard in {shown}, "
                     + (f"chatter score {res.score:.3g}" if res.score > 0 else "no chatter line")
                     + (f", path measured by {name_of.get(r['tap'], Path(r['tap']).name)})" if tap else ")")
                     + "".join(f"; note: {e}" for e in extra))
    rows_of: dict = {}
    for r in rows:
        if r["recording"] is not None:
            rows_of.setdefault(Path(r["recording"]).resolve(), []).append(r)
    for same in rows_of.values():  # one recording for several cuts: a copy-paste slip, or one cut counted twice
        if len(same) > 1:
            shown = name_of.get(same[0]["recording"], Path(same[0]["recording"]).name)
            lines = ", ".join(f"{r['line']} ({r['rpm']:g} rpm, {r['depth_mm']:g} mm)" for r in same)
            notes.append(f"note: {shown} is named on lines {lines} of {Path(cuts_csv).name}: one recording labels "
                         "each of those cuts (a copy-paste slip?)")
    lab = np.array(labels, dtype=object)
    grade = np.where([bool(x) for x in refs], [GRADE.get(x, np.nan) for x in labels], base.grade)
    pts = replace(base, label=lab, chatter_hz=np.array(hz, float), grade=grade,
                  ratings=None, raters=None, extra={**base.extra, "recording": np.array(refs, dtype=object)})
    return pts, notes


def _cut_text(cuts, i: int) -> str:
    """Cut ``i`` of ``cuts`` in a note: its speed [rpm] and depth [mm], and its stickout [mm], test day and own
    condition cells where the file gives them (two cuts of one speed and depth at two stickouts read apart)."""
    text = f"{cuts.rpm[i]:g} rpm, {cuts.depth_mm[i]:g} mm"
    so = str((cuts.extra or {}).get("stickout_mm", [""] * len(cuts))[i]).strip()
    own = [f"stickout {so} mm"] if so else []
    own += [f"{k} {v[i] if k == 'milling' else format(float(v[i]), 'g')}" for k, v in cuts.conditions.items()
            if (v[i] if k == "milling" else not np.isnan(float(v[i])))]  # teeth 3, not 3.0
    own += [f"test day {cuts.batch[i]}"] if str(cuts.batch[i]) else []
    return text + (f" ({', '.join(own)})" if own else "")
