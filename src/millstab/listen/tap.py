"""A measured sensor path: what a tap (a hammer hit on the tool) heard by the cut's microphone says about how
the recording weighs the chatter family's members.

**Why.** ``listen`` reports, of one chatter's family f_c + k f_T and k f_T − f_c, the member strongest in the
tool's *displacement* (:mod:`millstab.listen.analyze`, step 7). Without more it assumes a flat sensor path: the
recording's power at a member is f⁴ × the displacement's (acceleration), so it ranks by power / f⁴. A
microphone's room is no flat path: its reflections make a comb with notches 12-29 dB deep
(:data:`millstab.simulate.record.ROOM`), and a member in a notch loses to a neighbour (docs/listen.md,
"Issue 29, third round"). A tap recorded by the same microphone at the same place measures that path.

**What a tap measures, derived.** Let R(f) be the sensor path (the room's reflections, the capsule; for an
accelerometer, its mounting), u the direction the sensor hears, G(f) the structure's receptance. A cut's
chatter member m has displacement X_m (a vector); the recording's power there is
P_cut(f_m) = (2πf_m)⁴ |uᵀX_m|² |R(f_m)|². A tap is a force impulse along d (flat spectrum up to the hammer
tip's corner: a steel tip is flat to 5-10 kHz): P_tap(f) = (2πf)⁴ |uᵀG(f) d|² |R(f)|² — the structure times
the path; a tap cannot tell the two apart, it excites the structure too. Dividing,
P_cut / P_tap = |uᵀX_m|² / |uᵀG(f_m) d|²: the room and f⁴ cancel, but so does the structure, leaving the
*force* at the member (for one mode direction v, G ≈ g vvᵀ, it is |vᵀF_m|² / |vᵀd|² with X_m = G F_m).
That is not what the ranking needs: at low immersion the force is a short pulse per tooth with a nearly
flat spectrum over the members, and the displacement peak is where |G| is largest — exactly what the
division removes. So the displacement along the sensor is

    |uᵀX_m|² = P_cut(f_m) · |uᵀG(f_m) d|² / P_tap(f_m),

and the ranking weight (recording power per displacement power) is W(f) = P_tap(f) / |uᵀG(f) d|²,
which needs the structure's part of the tap:

* **structure known** (``--config``, ``update``): |uᵀG d|² ≈ Σ_ij |G_ij(f)|² (u and d unknown: exact for a
  structure flexible in one direction, a weighting of x against y otherwise). W = P_tap / Σ|G|².
* **tap alone**: the structure's part is estimated from the tap itself as its all-pole envelope
  (``_envelope``): a linear prediction of order ``LPC_ORDER`` fitted to the tap's ring. A path of
  reflections is a sum of delayed copies — zeros only, no poles — while the structure's modes are poles;
  a low-order all-pole fit follows the resonances and passes over the comb's notches (linear prediction fits
  peaks and ignores valleys). W = f⁴ · P_tap / E, E the envelope: the tap's fine structure relative to its
  envelope is the path's comb. It cannot know the structure's own antiresonances (zeros of uᵀG d), a smooth
  tilt of the path (both land in the envelope), a reflection shorter than ``LPC_ORDER`` / ``LPC_FS`` = 2.5 ms
  (0.86 m of extra path: the all-pole fit models its comb too), nor a notch on the mode's own peak (within its
  bandwidth the fit follows the notched peak; tests/test_listen_tap.py: a notch 20 Hz from a 900 Hz mode was
  seen 8 dB deep instead of 20). Order and rate measured on taps of the benchmark's six tools at 44.1, 48 and
  96 kHz, noise 0.5-10 %: the path between 0.3 and 2.5 f_n within 0.65 dB (median error; 2.9 dB at the 90th
  percentile; a flat path, f⁴: 2.4 and 6.9 dB; the structure known: 0.35 and 1.6 dB); order 16 or 24: 1.0 dB
  (6.2, 4.5 at the 90th); order 40 fitted at 48 kHz: 1.5 dB (6.9).

**What the tap cannot know** in either case: a notch deeper than the tap's signal-to-noise ratio there (the
power is floored at the noise's); the member shares of x and y (a sensor hears one direction); a path that
moved between the tap and the cut (record the tap where the cut was recorded, same gain not needed: only
ratios are used).

**Estimation.** The hits are found as the recording's largest peaks (at least ``HIT_SHARE`` of the largest,
``HIT_GAP_S`` apart); each hit's segment runs from ``PRE_S`` before it to where its ring has died into the noise
(``_ring_samples``; at most the next hit or ``RING_MAX_S``), its last 10 % faded (Hann), zero-padded to a common
length of at least 1/``BIN_HZ`` seconds; the powers of the hits are averaged. The noise's power (Welch spectrum
of the samples outside the rings, so hum and 1/f noise count where they are) is subtracted and floors the
estimate; where the tap stands under ``RELIABLE`` × it the path is unknown and taken as its median (the member
is weighed by f⁴ there). Measured: a 0.8 s segment for a 16 ms ring, noise 10 %, put the path 5-7 dB off
between 600 and 1200 Hz (a Hopf chatter's member lost to its mirror, bench_listen --seed 1 cut 60); the ring
alone, within 1 dB. The power is then smoothed over ±``SMOOTH_HZ`` (a moving average): a chatter line is placed
to a fraction of a hertz, and the room's notch is 1 Hz wide at −26 dB (|H| grows by 2π Σ g·delay ≈ 0.05 per Hz
from its zero), so wider smoothing would fill the notches the tap is there to measure. The noise power per bin
(the robust RMS of the quiet part, × the segment's energy) is the floor of the estimate.

Bad taps get an :class:`~millstab.errors.InputError`: another sample rate than the cut's (another recording
chain: its path is not the cut's); no impulse (the largest peak under ``IMPULSE_SNR`` × the noise's robust RMS:
a recording of a cut, or hum only); clipped (the peak held by ``CLIP_RUN`` or more equal samples: the
recorder overloaded, the impulse's spectrum is not flat).

Units: Hz, seconds; the signal in any unit (only ratios are used).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from millstab.errors import InputError

#: a hit is a peak of at least this share of the largest (several hits are averaged)
HIT_SHARE = 0.3
#: ... at least this far from another hit [s]
HIT_GAP_S = 0.1
#: the largest peak stands this many times over the noise's robust RMS (26 dB; a cut: 3-5, hum: 1.4-3), else no impulse
IMPULSE_SNR = 20.0
#: a peak held by this many equal samples is clipped
CLIP_RUN = 3
#: each hit's segment starts this long before its peak [s] and lasts at most RING_MAX_S [s]
PRE_S = 0.002
RING_MAX_S = 2.0
#: the path is known where the tap's power stands at least this many times over the noise's (6 dB)
RELIABLE = 4.0
#: the ring ends where RING_QUIET frames of RING_FRAME_S [s] fall under RING_LEVEL × the noise's RMS (and lasts
#: RING_MIN_S [s] past that: the room's last reflection, 12.6 ms, and the fade)
RING_FRAME_S = 0.005
RING_QUIET = 4
RING_LEVEL = 2.0
RING_MIN_S = 0.03
#: the noise's spectrum is taken from the samples outside the rings when there are this many seconds of them
QUIET_MIN_S = 0.1
#: frequency grid of the tap's power [Hz] (segments zero-padded to 1/BIN_HZ s)
BIN_HZ = 0.25
#: the power is averaged over ±SMOOTH_HZ [Hz]
SMOOTH_HZ = 1.0
#: order of the all-pole envelope (tap alone): two poles per mode of the tools seen (≤ 4) and the tilt
LPC_ORDER = 40
#: ... fitted on the hits decimated to about this rate [Hz]
LPC_FS = 16000.0


@dataclass(frozen=True, eq=False)
class SensorPath:
    """A tap's power spectrum: ``freq_hz`` [Hz], ``power`` (smoothed, the noise's power taken out and floored at
    it; any unit; ``noise``: the median of that floor),
    ``envelope`` (its all-pole envelope, same unit), ``snr`` (the power over the noise's before it was taken
    out), ``fs`` [Hz], ``hits_s`` (the hits' times [s])."""

    fs: float
    hits_s: tuple[float, ...]
    freq_hz: np.ndarray = field(repr=False)
    power: np.ndarray = field(repr=False)
    noise: float = 0.0
    envelope: np.ndarray = field(repr=False, default=None)
    snr: np.ndarray = field(repr=False, default=None)

    def weight(self, f, structure=None) -> np.ndarray:
        """Recording power per displacement power at f [Hz] (any common scale): f⁴ ρ(f), ρ the path's gain —
        P_tap / (f⁴ Σ|G_ij|²) with the ``structure`` known, else P_tap / envelope (module docstring). Where the
        tap stands less than ``RELIABLE`` × its noise (or outside a measured FRF's band) the path is unknown and
        ρ is its median over the band where it is known (40 Hz - 8 kHz): the member is weighed as by f⁴."""
        f = np.asarray(f, float)
        grid = np.arange(40.0, min(8000.0, 0.45 * self.fs), 10.0)
        both = np.concatenate([f, grid])
        rho = self._rho(both, structure)
        ok = np.isfinite(rho) & (np.interp(both, self.freq_hz, self.snr) >= RELIABLE)
        neutral = float(np.median(rho[f.size:][ok[f.size:]])) if ok[f.size:].any() else 1.0
        return f**4 * np.where(ok[: f.size], rho[: f.size], neutral)

    def _rho(self, f: np.ndarray, structure) -> np.ndarray:
        p = np.interp(f, self.freq_hz, self.power)
        if structure is not None:
            from millstab.listen.analyze import _flexibility

            g2 = _flexibility(structure)(f)
            with np.errstate(divide="ignore", invalid="ignore"):
                return np.where(g2 > 0, p / (f**4 * np.where(g2 > 0, g2, 1.0)), np.nan)
        return p / np.interp(f, self.freq_hz, self.envelope)  # NaN beyond the envelope's band


def _hits(x: np.ndarray, fs: float) -> np.ndarray:
    a = np.abs(x)
    top = float(a.max())
    cand = np.flatnonzero(a >= HIT_SHARE * top)
    gap = int(HIT_GAP_S * fs)
    hits = []
    for grp in np.split(cand, np.flatnonzero(np.diff(cand) > gap) + 1):
        hits.append(int(grp[np.argmax(a[grp])]))
    return np.array(hits)


def sensor_path(signal, fs: float, *, cut_fs: float | None = None, name: str = "tap") -> SensorPath:
    """The sensor path measured by a tap recording ``signal`` at ``fs`` [Hz] (module docstring). ``cut_fs``: the
    cut's sample rate, which the tap's must equal. Raises InputError for a bad tap."""
    from scipy import fft as sfft

    x = np.asarray(signal, float)
    if x.ndim != 1 or x.size < 1024:
        raise InputError(name, f"{x.size} samples", "one channel of at least 1024 samples: a hit and its ring")
    if cut_fs is not None and abs(float(fs) - float(cut_fs)) > 1e-9 * fs:
        raise InputError(f"{name}: sample rate", f"{fs:g} Hz", f"the cut's, {cut_fs:g} Hz: a tap recorded by "
                         "another chain does not measure the cut's sensor path (record both with the same settings)")
    x = x - np.median(x)
    a = np.abs(x)
    i_pk = int(np.argmax(a))
    top = float(a[i_pk])
    runs = np.flatnonzero(np.abs(a - top) <= 1e-9 * top)
    if runs.size >= CLIP_RUN and np.any(np.convolve(np.diff(runs) == 1, np.ones(CLIP_RUN - 1), "valid")
                                        >= CLIP_RUN - 1):
        raise InputError(name, f"clipped at {top:.4g} (the peak held by {CLIP_RUN} or more samples)",
                         "a hit recorded without overload: lower the recording gain or hit softer")
    noise = 1.4826 * float(np.median(a))  # robust RMS of a recording that is quiet but for the hits
    if not top > IMPULSE_SNR * noise:
        raise InputError(name, f"peak {top / noise if noise > 0 else 0.0:.3g} x the noise's RMS" if noise > 0
                         else "silent", f"a hammer hit: a peak at least {IMPULSE_SNR:g} x (26 dB) over the quiet "
                         "part of the recording (a recording mostly quiet but for the hits and their rings)")
    hits = _hits(x, fs)
    pre = int(PRE_S * fs)
    starts = np.maximum(hits - pre, 0)
    ends = np.append(hits[1:] - pre, x.size)
    lens = np.array([_ring_samples(x, h, int(e), noise, fs) for h, e in zip(hits, ends)]) + (hits - starts)
    nfft = sfft.next_fast_len(max(int(lens.max()), int(fs / BIN_HZ)), real=True)
    p = 0.0
    e_w = 0.0
    quiet = np.ones(x.size, bool)
    for a0, n in zip(starts, lens):
        seg = x[a0: a0 + n]
        quiet[a0: a0 + n] = False
        m = max(int(0.1 * n), 1)
        win = np.ones(n)
        win[-m:] = 0.5 + 0.5 * np.cos(np.pi * np.arange(1, m + 1) / m)
        p = p + np.abs(sfft.rfft(seg * win, nfft)) ** 2
        e_w += float(np.sum(win**2))
    p = p / hits.size
    e_w /= hits.size
    f = np.fft.rfftfreq(nfft, 1.0 / fs)
    p = _smooth(p, max(int(round(SMOOTH_HZ / (f[1] - f[0]))), 0))
    # the noise's power in the same units (E|X_k|² = Σw² × two-sided density × fs), from the quiet samples
    # (hum and 1/f noise are no white floor); white at the robust RMS when too little is quiet
    floor = np.full(f.size, noise**2 * e_w)
    q = x[quiet]
    if q.size >= int(QUIET_MIN_S * fs):
        from scipy.signal import welch

        fq, sq = welch(q, fs, nperseg=min(q.size, int(QUIET_MIN_S * fs)))
        floor = np.maximum(np.interp(f, fq, sq) * 0.5 * fs * e_w, 1e-300)
    snr = p / floor
    p = np.maximum(p - floor, floor)  # the noise's power out; never under it (a notch deeper is not seen)
    env = _envelope(x, starts, lens, fs, f, floor)
    return SensorPath(float(fs), tuple(float(h / fs) for h in hits), f, p, float(np.median(floor)), env, snr)


def _smooth(p: np.ndarray, k: int) -> np.ndarray:
    """Moving average over ±k bins."""
    if k <= 0:
        return p
    c = np.concatenate([[0.0], np.cumsum(p)])
    lo = np.clip(np.arange(p.size) - k, 0, p.size)
    hi = np.clip(np.arange(p.size) + k + 1, 0, p.size)
    return (c[hi] - c[lo]) / (hi - lo)


def _ring_samples(x: np.ndarray, h: int, end: int, noise: float, fs: float) -> int:
    """Samples from the hit ``h`` to where its ring has died into the noise: the first of ``RING_QUIET`` frames of
    ``RING_FRAME_S`` whose RMS is under ``RING_LEVEL`` × the noise's (or ``end``, at most ``RING_MAX_S``). The
    noise of the samples after the ring would only add to the tap's power where it is weak (a segment 10× longer
    than the ring: +10 dB of noise off the modes)."""
    end = min(end, h + int(RING_MAX_S * fs))
    fr = max(int(RING_FRAME_S * fs), 1)
    n_fr = (end - h) // fr
    if n_fr < RING_QUIET + 1:
        return max(end - h, 1)
    rms = np.sqrt(np.mean(x[h: h + n_fr * fr].reshape(n_fr, fr) ** 2, axis=1))
    low = rms < RING_LEVEL * noise
    run = np.convolve(low, np.ones(RING_QUIET), "valid") >= RING_QUIET
    k = int(np.argmax(run)) if run.any() else n_fr
    return max(min(k * fr + int(RING_MIN_S * fs), end - h), 1)


def _envelope(x: np.ndarray, starts: np.ndarray, lens: np.ndarray, fs: float, f: np.ndarray,
              floor: np.ndarray) -> np.ndarray:
    """All-pole envelope of the hits' power on the grid ``f`` [Hz] (the scale of their power spectrum): linear
    prediction of order ``LPC_ORDER`` from the hits' summed autocorrelation (Levinson,
    :func:`scipy.linalg.solve_toeplitz`), on the hits decimated to about ``LPC_FS`` (the band of the modes and
    of chatter: at the full rate the poles go to the band above it and the envelope misses the modes' peaks)."""
    from scipy import fft as sfft
    from scipy import signal as sg
    from scipy.linalg import solve_toeplitz

    q = max(int(round(fs / LPC_FS)), 1)
    fs_d = fs / q
    r = 0.0
    for a0, m in zip(starts, lens):
        seg = x[a0: a0 + m]
        if q > 1:
            seg = sg.decimate(seg, q, ftype="fir", zero_phase=True)
        nfft = sfft.next_fast_len(2 * seg.size, real=True)
        r = r + sfft.irfft(np.abs(sfft.rfft(seg, nfft)) ** 2, nfft)[: LPC_ORDER + 1] * q
    r = r / starts.size
    r[0] *= 1.0 + 1e-9  # a whisker of white noise: the Toeplitz system stays positive definite
    a = solve_toeplitz(r[:-1], -r[1:])
    err = float(r[0] + np.dot(a, r[1:]))  # prediction error power × the segment's length
    n_d = sfft.next_fast_len(int(fs_d / (f[1] - f[0])), real=True)  # the polynomial on a grid as fine as f's
    a_d = np.abs(sfft.rfft(np.concatenate([[1.0], a]), n_d)) ** 2
    env = np.full(f.size, np.nan)  # beyond the decimated band: no envelope (the path is unknown there)
    inside = f < 0.45 * fs_d
    env[inside] = np.maximum(max(err, 0.0) / np.interp(f[inside], np.fft.rfftfreq(n_d, 1.0 / fs_d), a_d),
                             floor[inside])
    return env
