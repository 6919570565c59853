"""Listen benchmark: ``millstab listen`` on virtual recordings of simulated cuts whose truth is known.

Cuts: several tools (the 1-DOF benchmark in slotting and at a/D = 0.05, the seed paper's ex1, ex2, ex3
and the four-flute tool), random speeds, depths 0.7-1.3 × the semi-discretization limit at that speed,
a start bump of 1e-3 to 3e-2 f_t (so chatter grows during the recording, sometimes late; from a
smaller bump a cut just above the limit is chatter to the simulation by its growth while its
vibration stays 1e-3 f_t, below any sensor's noise, to the end of the recording), about
``--seconds`` of cutting each. Each cut is recorded by a random sensor model (microphone or
accelerometer, 44.1/48/96 kHz, white noise 0.5-10 %, hum 0-20 %, runout 2-10 %; see
:mod:`millstab.simulate.record`). Truth = the simulation's own label and chatter frequency
(:func:`millstab.simulate.detect` on the noise-free displacement).

Scored: a label is right when it equals the truth, or when either says marginal and the depth is within
0.9-1.1 × the limit; the chatter frequency is right within max(2 Hz, 0.5 %) on every cut both call
chatter (and, separately, how many of the misses are another member f_c + k f_T of the same chatter:
a microphone and an accelerometer weigh by ω², the simulation's truth is the displacement's peak).
The speed given to listen is off by up to ±1 %. Each cut is heard twice: from the recording alone (``millstab
listen REC``) and with the tool's structure known (``millstab listen --config``, and ``update``'s cuts
labelled by ear: a flip chatter is then reported at its member nearest the modes); both are scored.
Beside the strict truth, each is also scored against the truth set (``truth_set_hz``: the displacement's peak
in each 64-period window of the last half of the cut, with the lines within ``TIE_DB`` = 1 dB of it): a
quasi-periodic chatter's peak wanders from window to window and two members of one chatter within 1 dB are
tied, so there the strict truth is one sample of several (docs/listen.md, "When the simulation's chatter
frequency is not one frequency"). The truth is *one frequency* on a cut when every member of its set lies within
the tolerance of the strict truth (``one_frequency``); the score on those cuts alone is printed too: it is where
"every detected chatter cut right" can be asked. ``--explain`` prints, for each miss, the strict truth's family
f + k f_T and k f_T − f with the displacement's power, the structure's Σ|G|², the sensor path's (room's) gain and
the recording's power at each member. ``--cache DIR`` keeps each cut's recording and truth, so a change of
``listen`` is re-scored on the same cuts without simulating them again. ``--tap``: each cut is heard twice more
with a tap recorded by the same sensor, room and settings (:func:`millstab.simulate.record.record_tap`, hit
along the sensor's direction; made afresh, not cached: it needs only the structure), recording alone and with
the structure known (``listen --tap``, :mod:`millstab.listen.tap`); both scored as above.
Also the analysis time of a 10 s, 48 kHz recording (one core, BLAS pinned).

    python benchmarks/bench_listen.py [--cuts 200] [--seconds 2] [--seed 0] [--cache DIR] [--explain] [--tap]
                                      [--only 3,17]
    (--cuts 0: the timing only)
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import describe  # noqa: E402

from millstab import api  # noqa: E402
from millstab.model import Cutting, Mode, Structure  # noqa: E402
from millstab.simulate import detect, simulate_cut  # noqa: E402
from millstab.simulate.detect import SPECTRUM_PERIODS  # noqa: E402
from millstab.listen.tap import sensor_path  # noqa: E402
from millstab.simulate.record import record, record_tap  # noqa: E402
from millstab.stability import sdm  # noqa: E402

FN, ZETA, MASS = 922.0, 0.011, 0.03993
K = MASS * (2 * math.pi * FN) ** 2
BENCH = Structure(x=(Mode(FN, K, ZETA),))


def tools():
    """(name, structure, cutting, rpm range) of the benchmark's tools."""
    out = [("bench-slot", BENCH, Cutting(2, 6e8, 1 / 3, 0.0, math.pi), (5000.0, 25000.0)),
           ("bench-low", BENCH, Cutting.from_immersion(2, 6e8, 1 / 3, 0.05, "down"), (5000.0, 25000.0))]
    for name, rng in (("ex1", (4000.0, 15000.0)), ("ex2", (2000.0, 9000.0)), ("ex3", (4000.0, 15000.0)),
                      ("fourflute", (8000.0, 30000.0))):
        cfg = api.config(f"example:{name}")
        out.append((name, cfg.structure, cfg.cutting, rng))
    return out


def precise_truth_hz(res, det, pad: int = 16) -> float:
    """The simulation's chatter frequency [Hz] resolved finer than its detector's bins (f_T / n_per, 5-15
    Hz here, against a 2 Hz tolerance): the same non-synchronous residual (the displacement minus its
    average over the periods at each phase) of the detector's last ``det.window_periods`` periods, Hann-windowed,
    zero-padded ``pad`` times, the largest peak within ±1.5 detector bins of its frequency, refined by a
    parabola through the log-power (x and y summed). NaN when stable."""
    if not math.isfinite(det.chatter_hz):
        return float("nan")
    m = res.steps_per_tooth
    C = (res.x.size - 1) // m
    n = max(min(det.window_periods, C), 1)
    fs = m * res.tooth_hz
    L = n * m
    w = np.hanning(L + 1)[:-1]
    pw = 0.0
    for z in (res.x, res.y):
        seg = np.asarray(z[(C - n) * m: C * m], float).reshape(n, m)
        r = (seg - seg.mean(axis=0)).ravel() * w
        pw = pw + np.abs(np.fft.rfft(r, pad * L)) ** 2
    f = np.fft.rfftfreq(pad * L, 1.0 / fs)
    span = 1.5 * res.tooth_hz / n
    idx = np.flatnonzero(np.abs(f - det.chatter_hz) <= span)
    if idx.size < 3:
        return float(det.chatter_hz)
    return _parabola_hz(f, pw, int(idx[np.argmax(pw[idx])]))


class _Cached:
    """What the scoring needs of a simulated cut, read back from ``--cache``."""

    def __init__(self, **kw):
        self.__dict__.update(kw)


def _cut(cache, seed, seconds, i, st, cut, rpm, ratio, perturbation, rec_kw):
    """(result, detection, precise truth [Hz], recording) of cut i: simulated, or read from ``cache`` (a folder:
    the recording and the truth of each cut, so a change of ``listen`` is re-scored without re-simulating;
    same seed, same cuts)."""
    path = None if cache is None else Path(cache) / f"seed{seed}_s{seconds:g}" / f"cut{i}.npz"
    if path is not None and path.exists():
        z = np.load(path)
        truth = _Cached(label=str(z["label"]), chatter_hz=float(z["chatter_hz"]))
        res = _Cached(tooth_hz=float(z["tooth_hz"]))
        rec = _Cached(signal=z["signal"].astype(float), fs=int(z["fs"]))
        return res, truth, float(z["true_hz"]), rec
    limit = float(sdm.envelope(st, cut, [rpm]).depth[0])
    res = simulate_cut(st, cut, rpm, ratio * limit, 1e-4, revs=max(50.0, seconds * rpm / 60.0),
                       perturbation=perturbation)
    truth = detect(res)
    true_hz = precise_truth_hz(res, truth)
    rec = record(res, **rec_kw)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez(path, signal=rec.signal.astype(np.float32), fs=rec.fs, label=truth.label,
                 chatter_hz=truth.chatter_hz, true_hz=true_hz, tooth_hz=res.tooth_hz)
    return res, truth, true_hz, rec


#: lines of the displacement within this of a window's peak are tied with it [dB] (module docstring, "Truth")
TIE_DB = 1.0


def _window_powers(res, det, pad: int = 16):
    """(frequencies [Hz], list of non-synchronous displacement power spectra) of the windows of ``det.window_periods``
    tooth periods (the detector's own length) stepping back from the end over the last half of the cut: x and y
    powers summed (as the detector), Hann, zero-padded ``pad`` times, zero outside the detector's band
    2 f_n,max + f_T. Empty list when stable."""
    from millstab.simulate.detect import spectrum_band_hz

    if not math.isfinite(det.chatter_hz):
        return np.zeros(0), []
    m = res.steps_per_tooth
    C = (res.x.size - 1) // m
    n = max(min(det.window_periods, C), 1)
    L = n * m
    w = np.hanning(L + 1)[:-1]
    f = np.fft.rfftfreq(pad * L, 1.0 / (m * res.tooth_hz))
    band = (f > 0) & (f <= spectrum_band_hz(res.fn_max_hz, res.tooth_hz))
    out = []
    for end in range(C, C - max(C // 2, n) - 1, -n):
        if end - n < 0:
            break
        pw = 0.0
        for z in (res.x, res.y):
            seg = np.asarray(z[(end - n) * m: end * m], float).reshape(n, m)
            pw = pw + np.abs(np.fft.rfft((seg - seg.mean(axis=0)).ravel() * w, pad * L)) ** 2
        out.append(np.where(band, pw, 0.0))
    return f, out


def _parabola_hz(f: np.ndarray, pw: np.ndarray, i: int) -> float:
    lp = np.log(np.maximum(pw[i - 1: i + 2], 1e-300))
    den = lp[0] - 2 * lp[1] + lp[2]
    off = 0.5 * (lp[0] - lp[2]) / den if den < 0 else 0.0
    return float(f[i] + np.clip(off, -0.5, 0.5) * (f[1] - f[0]))


def truth_set_hz(res, det, pad: int = 16) -> np.ndarray:
    """Every frequency [Hz] that is the simulation's chatter frequency at some time of the last half of the cut:
    the peak of the non-synchronous displacement in each window of :func:`_window_powers`, with the lines of that
    window within ``TIE_DB`` of its peak (parabola-refined). Empty when stable."""
    f, windows = _window_powers(res, det, pad)
    out = []
    for pw in windows:
        loc = np.flatnonzero((pw[1:-1] > pw[:-2]) & (pw[1:-1] >= pw[2:])) + 1
        if loc.size == 0:
            continue
        top = pw[loc].max()
        out.extend(_parabola_hz(f, pw, i) for i in loc[pw[loc] >= top * 10 ** (-TIE_DB / 10)])
    return np.unique(np.round(out, 3))


def one_frequency(tset: np.ndarray, true_hz: float) -> bool:
    """Whether the simulation's chatter frequency is one frequency to the tolerance max(2 Hz, 0.5 %): every member
    of the truth set (each window's peak over the last half and its ties within ``TIE_DB``) lies within the
    tolerance of the strict truth ``true_hz``. False for a quasi-periodic chatter whose peak wanders from window to
    window and for two lines tied in the displacement: there the strict truth is one sample of several, and no
    recording of the whole cut can be held to it (docs/listen.md, "When the simulation's chatter frequency is
    not one frequency")."""
    tol = max(2.0, 0.005 * true_hz)
    return bool(tset.size == 0 or np.max(np.abs(tset - true_hz)) <= tol)


def _resimulate(st, cut, rpm, ratio, perturbation, seconds):
    """(result, detection) of a cut read from ``--cache`` (which keeps the recording, not the displacement)."""
    limit = float(sdm.envelope(st, cut, [rpm]).depth[0])
    res = simulate_cut(st, cut, rpm, ratio * limit, 1e-4, revs=max(50.0, seconds * rpm / 60.0),
                       perturbation=perturbation)
    return res, detect(res)


def _truth_set(cache, seed, seconds, i, res, det, st, cut, rpm, ratio, perturbation) -> np.ndarray:
    """:func:`truth_set_hz` of cut i (re-simulated when the cut was read from ``cache``; kept there too)."""
    path = None if cache is None else Path(cache) / f"seed{seed}_s{seconds:g}" / f"cut{i}_set.npy"
    if path is not None and path.exists():
        return np.load(path)
    if not hasattr(res, "x"):
        res, det = _resimulate(st, cut, rpm, ratio, perturbation, seconds)
    out = truth_set_hz(res, det)
    if path is not None:
        np.save(path, out)
    return out


def room_gain(f: np.ndarray, sensor: str) -> np.ndarray:
    """Power gain of the sensor's path at f [Hz]: the microphone's room (direct path and the reflections of
    :data:`millstab.simulate.record.ROOM`), 1 for an accelerometer."""
    from millstab.simulate.record import ROOM

    f = np.asarray(f, float)
    if sensor != "microphone":
        return np.ones(f.size)
    h = 1.0 + sum(g * np.exp(-2j * np.pi * f * d) for d, g in ROOM)
    return np.abs(h) ** 2


def explain(res, det, st, signal, fs, sensor, direction_deg, true_hz, heard: dict[str, float],
            tap=None) -> list[str]:
    """The lines printed for a miss (``--explain``): the chatter family of the strict truth, f + k f_T (|k| ≤ 4)
    and its mirrors k f_T − f, with, at each member [dB, each column relative to its largest]: the
    displacement's non-synchronous power (x and y, averaged over the windows of the last half), the structure's
    flexibility Σ|G_ij|² and its response along the sensor's direction, the sensor path's gain (the room), the
    recording's power and that power / f⁴ (what the displacement would be with a flat path). With ``tap`` (its
    :class:`~millstab.listen.tap.SensorPath`) also the path it measured, structure known and tap alone
    (weight / f⁴: the room's gain as the tap estimates it; compare with ``room``)."""
    from millstab.frf import structure_receptance
    from millstab.listen.analyze import _full_spectrum

    f_t = res.tooth_hz
    fd, windows = _window_powers(res, det)
    disp = np.mean(windows, axis=0) if windows else np.zeros(fd.size)
    top = float(fd[np.flatnonzero(disp > 0)[-1]]) if np.any(disp > 0) else 0.0
    mem = [(true_hz + k * f_t, f"f{k:+d}fT") for k in range(-4, 5)] + [(k * f_t - true_hz, f"{k}fT-f")
                                                                     for k in range(1, 6)]
    mem = sorted((fm, lab) for fm, lab in mem if 20.0 < fm < min(top, 0.45 * fs))
    for k, v in heard.items():  # a frequency heard that is no member: its own row
        if math.isfinite(v) and all(abs(v - x) > max(2.0, 0.005 * x) for x, _ in mem):
            mem.append((v, k.split()[0]))
    keep = []
    for fm, lab in sorted(mem):  # a flip's members f + k f_T and k' f_T - f coincide: once
        if not keep or fm - keep[-1][0] > 0.5:
            keep.append((fm, lab))
    fm = np.array([m[0] for m in keep])
    sig = np.asarray(signal, float)
    fr, pr = _full_spectrum(sig - sig.mean(), fs)

    def peak(ff, pp, f0):
        sel = np.abs(ff - f0) <= max(1.0, 2 * (ff[1] - ff[0]))
        return float(pp[sel].max()) if sel.any() else float("nan")

    d = np.array([peak(fd, disp, x) if x <= top else np.nan for x in fm])  # beyond the detector's band: --
    G = structure_receptance(st, fm)
    g2 = np.sum(np.abs(G) ** 2, axis=(1, 2))
    u = np.array([math.cos(math.radians(direction_deg)), math.sin(math.radians(direction_deg))])
    gd = np.sum(np.abs(np.einsum("i,fij->fj", u, G)) ** 2, axis=1)
    room = room_gain(fm, sensor)
    rec = np.array([peak(fr, pr, x) for x in fm])

    def db(v):
        v = np.asarray(v, float)
        with np.errstate(invalid="ignore"):
            return 10 * np.log10(np.maximum(v / np.nanmax(v), 1e-30))

    cols = [db(d), db(g2), db(gd), 10 * np.log10(room), db(rec), db(rec / fm**4)]
    if tap is not None:  # the path as the tap measures it, levelled to the room's mean over the members
        for est in (tap.weight(fm, st) / fm**4, tap.weight(fm) / fm**4):
            e = 10 * np.log10(est)
            cols.append(e - np.mean(e[np.isfinite(e)]) + np.mean(10 * np.log10(room)))
    out = [f"    truth {true_hz:.1f} Hz = {true_hz / f_t:.3f} f_T ({sensor}, direction {direction_deg:.0f} deg); "
           + "; ".join(f"{k} {v:.1f} Hz" for k, v in heard.items()),
           "      member [Hz]  order      disp   |G|^2  G_dir^2   room  record  rec/f^4"
           + ("  tap+st   tap" if tap is not None else "") + "   [dB]"]
    for q, (f0, lab) in enumerate(keep):
        tag = " <- truth" if abs(f0 - true_hz) < 0.5 else ""
        tag += "".join(f" <- {k}" for k, v in heard.items() if abs(v - f0) <= max(2.0, 0.005 * f0))
        out.append(f"      {f0:10.1f}  {lab:8s} " + " ".join(f"{c[q]:7.1f}" for c in cols) + tag)
    return out


def f_ok_strict(truth, heard, true_hz: float):
    """Frequency right within max(2 Hz, 0.5 %) of the strict truth; None unless both call chatter."""
    if truth.label != "chatter" or heard.label != "chatter":
        return None
    return bool(abs(heard.chatter_hz - true_hz) <= max(2.0, 0.005 * true_hz))


def right(truth: str, heard: str, ratio: float) -> bool:
    if truth == heard:
        return True
    return (truth == "marginal" or heard == "marginal") and 0.9 <= ratio <= 1.1


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--cuts", type=int, default=200)
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--verbose", action="store_true")
    ap.add_argument("--explain", action="store_true",
                    help="print each chatter-frequency miss's family: displacement, |G|^2, room, recording per member")
    ap.add_argument("--cache", default=None, help="folder keeping each cut's recording and truth (re-score fast)")
    ap.add_argument("--only", default=None, help="comma-separated cut numbers: hear and score these only (the same "
                    "cuts as in a full run: the others' draws are made and skipped)")
    ap.add_argument("--tap", action="store_true",
                    help="also hear each cut with a tap recorded by its own sensor and room (listen --tap)")
    a = ap.parse_args(argv)
    only = None if a.only is None else {int(v) for v in a.only.split(",")}
    print(describe())
    rng = np.random.default_rng(a.seed)
    tl = tools()
    rows = []
    taps = []  # with --tap: (label right, frequency right or None) recording alone, then structure known; one freq.
    t_sim = t_listen = 0.0
    truth_moves = []  # |zero-padded truth − detector's| [Hz]
    with threadpool_limits(1):
        for i in range(a.cuts):
            name, st, cut, (lo, hi) = tl[i % len(tl)]
            rpm = float(rng.uniform(lo, hi))
            ratio = float(rng.uniform(0.7, 1.3))
            perturbation = float(10 ** rng.uniform(-3, -1.5))
            sensor = "microphone" if rng.random() < 0.7 else "accelerometer"
            rec_kw = {"sensor": sensor, "fs": int(rng.choice([44100, 48000, 96000])),
                      "noise": float(10 ** rng.uniform(-2.3, -1)), "hum": float(rng.choice([0.0, 0.05, 0.2])),
                      "runout": float(rng.uniform(0.02, 0.1)), "mains_hz": float(rng.choice([50.0, 60.0])),
                      "direction_deg": float(rng.uniform(0, 90)), "seed": i}
            if only is not None and i not in only:
                rng.uniform(-0.01, 0.01)  # the speed read (below): the next cuts stay the same
                continue
            t0 = time.perf_counter()
            res, truth, true_hz, rec = _cut(a.cache, a.seed, a.seconds, i, st, cut, rpm, ratio, perturbation, rec_kw)
            if math.isfinite(true_hz):
                truth_moves.append(abs(true_hz - truth.chatter_hz))
            t1 = time.perf_counter()
            given = rpm * (1 + float(rng.uniform(-0.01, 0.01)))  # the speed as read, off by up to 1 %
            heard = api.listen_signal(rec.signal, rec.fs, given, cut.teeth).listening
            t2 = time.perf_counter()
            known = api.listen_signal(rec.signal, rec.fs, given, cut.teeth, structure=st).listening
            ok_k = right(truth.label, known.label, ratio)
            tapped = {}
            if a.tap:  # the same sensor, room and settings as the cut's recording: its measured path
                tr = record_tap(st, **{k: rec_kw[k] for k in ("sensor", "fs", "noise", "hum", "mains_hz",
                                                                  "direction_deg", "seed")})
                path = sensor_path(tr.signal, tr.fs, cut_fs=rec.fs)
                tapped = {"tap": api.listen_signal(rec.signal, rec.fs, given, cut.teeth, tap=path).listening,
                          "tap+structure": api.listen_signal(rec.signal, rec.fs, given, cut.teeth, structure=st,
                                                             tap=path).listening}
            tap_ok = {k: (bool(abs(v.chatter_hz - true_hz) <= max(2.0, 0.005 * true_hz))
                          if truth.label == "chatter" and v.label == "chatter" else None) for k, v in tapped.items()}
            # bool(): a numpy bool is never ``is False`` (a miss whose heard frequency was a numpy float went unprinted)
            fk_ok = (bool(abs(known.chatter_hz - true_hz) <= max(2.0, 0.005 * true_hz))
                     if truth.label == "chatter" and known.label == "chatter" else None)
            tset = None  # the cut's truth set, on every cut both call chatter (is its truth one frequency?)
            if (f_ok_strict(truth, heard, true_hz) is not None or fk_ok is not None
                    or any(v is not None for v in tap_ok.values())):
                tset = _truth_set(a.cache, a.seed, a.seconds, i, res, truth, st, cut, rpm, ratio, perturbation)
            one = tset is None or one_frequency(tset, true_hz)
            tol_set = max(2.0, 0.005 * true_hz)

            def in_set(hz, tset=tset, tol=tol_set) -> bool:
                return bool(tset is not None and tset.size and np.min(np.abs(tset - hz)) <= tol)

            t_sim += t1 - t0
            t_listen += t2 - t1
            ok = right(truth.label, heard.label, ratio)
            f_ok = fam_ok = None
            if truth.label == "chatter" and heard.label == "chatter":
                tol = max(2.0, 0.005 * true_hz)
                f_ok = bool(abs(heard.chatter_hz - true_hz) <= tol)
                # the same chatter seen through the tooth-passing modulation: f + k f_T
                d = (heard.chatter_hz - true_hz) / res.tooth_hz
                dm = (heard.chatter_hz + true_hz) / res.tooth_hz  # or a mirror member k f_T − f
                fam_ok = (abs(d - round(d)) * res.tooth_hz <= tol + abs(round(d)) * 0.005 * res.tooth_hz
                          or abs(dm - round(dm)) * res.tooth_hz <= tol + abs(round(dm)) * 0.005 * res.tooth_hz)
            rows.append((name, rpm, ratio, sensor, truth.label, true_hz, heard.label, heard.chatter_hz,
                         heard.score, heard.trend, ok, f_ok, heard.rpm_heard / rpm - 1, fam_ok, ok_k, fk_ok,
                         f_ok if f_ok is not False else in_set(heard.chatter_hz),
                         fk_ok if fk_ok is not False else in_set(known.chatter_hz), one))
            if tapped:
                taps.append(tuple((right(truth.label, v.label, ratio), tap_ok[k]) for k, v in tapped.items()) + (one,))
                for k, v in tapped.items():
                    base = (ok, f_ok) if k == "tap" else (ok_k, fk_ok)
                    ok_t = right(truth.label, v.label, ratio)
                    if (ok_t, tap_ok[k]) != base:
                        print(f"  cut {i}, {k}: heard {v.label} {v.chatter_hz:.1f} Hz "
                              f"({'right' if ok_t and tap_ok[k] is not False else 'wrong'})")
            if a.explain and (f_ok_strict(truth, heard, true_hz) is False or fk_ok is False
                              or any(v is False for v in tap_ok.values())):
                if not hasattr(res, "x"):
                    res_x, det_x = _resimulate(st, cut, rpm, ratio, perturbation, a.seconds)
                else:
                    res_x, det_x = res, truth
                for line in explain(res_x, det_x, st, rec.signal, rec.fs, sensor, rec_kw["direction_deg"], true_hz,
                                    {"heard": heard.chatter_hz, "structure known": known.chatter_hz,
                                     **{k: v.chatter_hz for k, v in tapped.items()}}, path if tapped else None):
                    print(line)
            if (f_ok is False and in_set(heard.chatter_hz)) or (fk_ok is False and in_set(known.chatter_hz)):
                print(f"  cut {i}: the simulation's chatter frequency wanders or ties (truth set "
                      f"{', '.join(f'{v:.1f}' for v in tset)} Hz over the last half)")
            if (ok_k, fk_ok) != (ok, f_ok):
                print(f"  cut {i}, structure known: heard {known.label} {known.chatter_hz:.1f} Hz "
                      f"({'right' if ok_k and fk_ok is not False else 'wrong'})")
            if a.verbose or not ok or f_ok is False or abs(heard.rpm_heard / rpm - 1) > 5e-4:
                print(f"{'  ' if ok and f_ok is not False else '! '}cut {i:3d} {name:10s} {rpm:7.0f} rpm "
                      f"{ratio:4.2f}x {sensor:13s} truth {truth.label:8s} {true_hz:7.1f} Hz "
                      f"(detector {truth.chatter_hz:7.1f}) | heard {heard.label:8s} "
                      f"{heard.chatter_hz:7.1f} Hz score {heard.score:.3g} trend {heard.trend:.3g} "
                      f"speed {100 * (heard.rpm_heard / rpm - 1):+.3f} % (given {100 * (given / rpm - 1):+.2f} %)")
    n = len(rows)
    if n == 0:  # --cuts 0: the timing only
        return _timing()
    acc = sum(r[10] for r in rows) / n
    fr = [r for r in rows if r[11] is not None]
    errs = np.array([abs(r[7] - r[5]) for r in fr])
    print(f"{n} cuts ({sum(r[4] == 'chatter' for r in rows)} chatter, {sum(r[4] == 'marginal' for r in rows)} "
          f"marginal, {sum(r[4] == 'stable' for r in rows)} stable by the simulation)")
    print(f"labels right: {acc:.1%}")
    if fr:
        print(f"chatter frequency within max(2 Hz, 0.5 %): {sum(r[11] for r in fr)}/{len(fr)}; "
              f"error median {np.median(errs):.2f} Hz, max {errs.max():.2f} Hz; another member f + k f_T or k f_T - f "
              f"of the same chatter family: {sum(bool(r[13]) and not r[11] for r in fr)}")
    fk = [r for r in rows if r[15] is not None]
    if fr:
        print(f"against the truth set (the displacement's peak in each {SPECTRUM_PERIODS}-period window of the last "
              f"half, ties within {TIE_DB:g} dB): recording alone {sum(r[16] for r in fr)}/{len(fr)}, structure "
              f"known {sum(r[17] for r in fk)}/{len(fk)}")
    print(f"with the structure known (listen --config, update): labels right {sum(r[14] for r in rows) / n:.1%}; "
          f"chatter frequency within max(2 Hz, 0.5 %): {sum(r[15] for r in fk)}/{len(fk)}")
    f1, k1 = [r for r in fr if r[18]], [r for r in fk if r[18]]
    many = sorted({rows.index(r) for r in fr + fk if not r[18]})
    print(f"on the cuts whose truth is one frequency (every window's peak of the last half and its {TIE_DB:g} dB "
          f"ties within the tolerance): recording alone {sum(r[11] for r in f1)}/{len(f1)}, structure known "
          f"{sum(r[15] for r in k1)}/{len(k1)}; not one frequency (wanders or ties): cuts "
          f"{', '.join(map(str, many)) or 'none'}")
    if taps:
        for q, k in enumerate(("tap (listen --tap)", "tap and structure (listen --tap --config)")):
            fq = [t for t in taps if t[q][1] is not None]
            f1 = [t for t in fq if t[-1]]
            print(f"with the {k}: labels right {sum(t[q][0] for t in taps) / len(taps):.1%}; chatter frequency within "
                  f"max(2 Hz, 0.5 %): {sum(t[q][1] for t in fq)}/{len(fq)}; on the cuts whose truth is one "
                  f"frequency {sum(t[q][1] for t in f1)}/{len(f1)}")
    if truth_moves:
        print(f"truth: the detector's chatter frequency re-resolved zero-padded 16x moves by at most "
              f"{max(truth_moves):.2f} Hz (median {np.median(truth_moves):.2f} Hz) on {len(truth_moves)} cuts")
    sp = np.abs([r[12] for r in rows])
    print(f"speed heard (given off by up to 1 %): error median {np.median(sp):.1e}, max {sp.max():.1e}; "
          f"{np.mean(sp < 5e-4):.1%} within 0.05 %")
    print(f"time: simulate+record {t_sim:.1f} s, listen {t_listen:.1f} s ({t_listen / n * 1e3:.0f} ms per cut)")
    return _timing()


def _timing() -> int:
    """The analysis time of one 10 s, 48 kHz recording (one core, BLAS pinned)."""
    st, cut = BENCH, Cutting(2, 6e8, 1 / 3, 0.0, math.pi)
    rpm = 18333.0
    res = simulate_cut(st, cut, rpm, 1.05 * float(sdm.envelope(st, cut, [rpm]).depth[0]), 1e-4, revs=10 * rpm / 60)
    rec = record(res, fs=48000)
    tap = record_tap(st, fs=48000, seconds=2.0)
    for what, kw in (("listen", {}), ("listen --tap (a 2 s tap read, then the cut)", {"tap": tap})):
        with threadpool_limits(1):
            _listen_timed(rec, rpm, **kw)
            ts, cs = [], []
            for _ in range(5):
                t0, c0 = time.perf_counter(), time.process_time()
                _listen_timed(rec, rpm, **kw)
                ts.append(time.perf_counter() - t0)
                cs.append(time.process_time() - c0)
        print(f"10 s at 48 kHz ({rec.signal.size} samples): {what} {min(ts) * 1e3:.0f} ms wall (best of 5), "
              f"median {np.median(ts) * 1e3:.0f} ms; CPU time best {min(cs) * 1e3:.0f} ms, "
              f"median {np.median(cs) * 1e3:.0f} ms")
    return 0


def _listen_timed(rec, rpm, tap=None):
    path = None if tap is None else sensor_path(tap.signal, tap.fs, cut_fs=rec.fs)
    return api.listen_signal(rec.signal, rec.fs, rpm, 2, tap=path)


if __name__ == "__main__":
    raise SystemExit(main())
