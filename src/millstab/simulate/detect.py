"""Chatter detection from a simulated signal, as one would from an accelerometer or a microphone.

Two signals are used, both of the tool-tip displacement (x, y) in the directions that carry modes:

* the once-per-tooth samples P_c (one per tooth period T, at the instant a tooth enters). A stable
  cut is T-periodic, so they converge to a fixed point; a Hopf chatter makes them circle
  (quasi-periodic cloud), a period-doubling (flip) chatter makes them alternate. The size of the
  tooth-to-tooth change d_c = |P_c − P_{c−1}| removes the forced (T-periodic) part exactly.
* the spectrum of the non-synchronous part of the signal: the signal minus its time-synchronous
  average over the analysed periods, i.e. with every tooth-passing harmonic removed. Its peak is the
  chatter frequency.

The last half of the cut is analysed (the first half is the transient of the entry), split into two
halves of W periods. With rms₁, rms₂ the RMS of d_c on them and f_t the feed per tooth:

    level  L = rms₂ / f_t,    growth  G = rms₂ / rms₁   (per W periods).

Label (thresholds, and why):

* ``chatter`` if the simulation diverged (|u| beyond the bound), or G ≥ ``GROWTH`` = 1.5: the
  tooth-to-tooth vibration grows by half again within W periods (|μ| ≥ 1.5^{1/W}, e.g. 1.008 for
  W = 50); a linear growth this clear will reach the chip thickness, so the cut chatters; or if
  L ≥ ``LEVEL_CHATTER`` = 0.1 and the vibration does not decay (G > 1/``GROWTH``): a sustained
  tooth-to-tooth change of 10 % of the feed per tooth is a plain chatter mark on the surface
  (10 µm at 0.1 mm/tooth), ten times the default start bump (1 % of the feed), and the saturated
  limit cycle of an unstable cut sits there (L ≈ 0.2-1.5 in the benchmark: the tooth leaves the
  cut), while a stable cut's vibration only decays from the bump.
* ``stable`` if L < ``LEVEL_QUIET`` = 1e-4 (the samples sit on the fixed point to 0.01 % of the feed,
  10 nm at 0.1 mm/tooth, far below any sensor's noise; G is meaningless there), or if the vibration
  decays, G ≤ 1/``GROWTH``.
* ``marginal`` otherwise: small and neither growing nor decaying clearly within the cut. A longer
  cut (more revolutions) narrows this band: its width in |μ| is about ±ln(1.5)/W.

Chatter frequency: the largest peak of the non-synchronous spectrum (Hann window, the analysed
periods, at most ``SPECTRUM_PERIODS`` of them, peak refined by a parabola through the log-magnitudes
of its bin and the two neighbours), searched up to twice the highest natural frequency plus the
tooth-passing frequency f_T. Lobe type: ``flip`` if that frequency is an odd multiple of f_T / 2
within 1.5 bins (the once-per-tooth samples then alternate), else ``hopf``; ``""`` for stable.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numba as nb
import numpy as np

#: growth factor of the tooth-to-tooth RMS over W periods above which a cut is chatter
GROWTH = 1.5
#: level (RMS of the tooth-to-tooth change over the feed per tooth) of a sustained chatter
LEVEL_CHATTER = 0.1
#: level below which the once-per-tooth samples are converged (stable)
LEVEL_QUIET = 1e-4
#: at most this many of the last tooth periods enter the spectrum (cost, and resolution f_T / 64)
SPECTRUM_PERIODS = 64
#: the fewest tooth periods a detection needs (two halves of 4)
MIN_PERIODS = 8

LABELS = ("stable", "marginal", "chatter")
LOBES = ("", "hopf", "flip")

STABLE, MARGINAL, CHATTER = 0, 1, 2


@nb.njit(cache=True)
def _rms_diff(x, y, m, c0, c1, lag):
    """RMS over c in [c0, c1) of |P_c − P_{c−lag}|, P_c = (x, y)[c m]."""
    s = 0.0
    for c in range(c0, c1):
        dx = x[c * m] - x[(c - lag) * m]
        dy = y[c * m] - y[(c - lag) * m]
        s += dx * dx + dy * dy
    return math.sqrt(s / max(c1 - c0, 1))


@nb.njit(cache=True)
def _peak(x, y, m, c_end, n_per, stride, k_hi):
    """(frequency in units of f_T, peak power) of the non-synchronous part of the last n_per periods.

    Residual = signal − its average over those periods at each phase (removes all harmonics of f_T);
    Hann window; DFT bins j / n_per (j = 1..k_hi, in units of f_T) on every ``stride``-th sample.
    """
    L = n_per * m
    i0 = (c_end - n_per) * m
    avg_x = np.zeros(m)
    avg_y = np.zeros(m)
    for c in range(n_per):
        for i in range(m):
            avg_x[i] += x[i0 + c * m + i]
            avg_y[i] += y[i0 + c * m + i]
    avg_x /= n_per
    avg_y /= n_per
    n_s = (L + stride - 1) // stride
    rx = np.empty(n_s)
    ry = np.empty(n_s)
    for s in range(n_s):
        i = s * stride
        w = 0.5 - 0.5 * math.cos(2.0 * math.pi * i / L)
        rx[s] = w * (x[i0 + i] - avg_x[i % m])
        ry[s] = w * (y[i0 + i] - avg_y[i % m])
    pw = np.zeros(k_hi + 2)
    for j in range(1, k_hi + 2):
        dth = 2.0 * math.pi * j * stride / L
        rot = complex(math.cos(dth), -math.sin(dth))
        e = 1.0 + 0.0j
        sx = 0.0j
        sy = 0.0j
        for s in range(n_s):
            sx += rx[s] * e
            sy += ry[s] * e
            e *= rot
        pw[j] = abs(sx) ** 2 + abs(sy) ** 2
    best = 1
    for j in range(1, k_hi + 1):
        if pw[j] > pw[best]:
            best = j
    f = float(best)
    if 1 < best and pw[best - 1] > 0 and pw[best + 1] > 0 and pw[best] > 0:
        a = math.log(pw[best - 1])
        b = math.log(pw[best])
        c = math.log(pw[best + 1])
        den = a - 2 * b + c
        if den < 0:
            f += 0.5 * (a - c) / den
    return f / n_per, pw[best]


@nb.njit(cache=True)
def detect_core(x, y, n_out, m, ft, f_tooth, f_hi, diverged):
    """Detection metrics of one simulated cut (node samples x, y, n_out of them, m per period).

    Returns (label code, chatter frequency [Hz] or NaN, lobe code, level L, growth G, spectral
    window periods). See the module docstring for the rules.
    """
    C = (n_out - 1) // m  # complete periods; once-per-tooth samples at c m, c = 0..C
    nan = np.nan
    if C < 2:
        return CHATTER if diverged else MARGINAL, nan, 0, nan, nan, 0
    if C >= MIN_PERIODS:
        W = C // 4
        c_mid = C - W
        r1 = _rms_diff(x, y, m, c_mid - W + 1, c_mid + 1, 1)
        r2 = _rms_diff(x, y, m, c_mid + 1, C + 1, 1)
    else:
        r1 = _rms_diff(x, y, m, 1, C // 2 + 1, 1)
        r2 = _rms_diff(x, y, m, C // 2 + 1, C + 1, 1)
    level = r2 / ft
    if r1 > 0:
        growth = r2 / r1
    else:
        growth = 1.0 if r2 == 0 else np.inf
    if diverged or growth >= GROWTH:
        label = CHATTER
    elif level < LEVEL_QUIET or growth <= 1.0 / GROWTH:
        label = STABLE
    elif level >= LEVEL_CHATTER:
        label = CHATTER
    else:
        label = MARGINAL
    hz = nan
    lobe = 0
    n_per = min(SPECTRUM_PERIODS, max(C // 2, 1) if C >= MIN_PERIODS else C)
    if label != STABLE:
        fs = m * f_tooth
        stride = max(1, int(fs / (2.5 * f_hi)))
        k_hi = max(2, int(f_hi / f_tooth * n_per))
        frac, pw = _peak(x, y, m, C, n_per, stride, k_hi)
        if pw > 0:
            hz = frac * f_tooth
            half = (frac % 1.0) - 0.5
            lobe = 2 if abs(half) < 1.5 / n_per else 1
    return label, hz, lobe, level, growth, n_per


@dataclass(frozen=True, eq=False)
class Detection:
    """What the detector says about one cut.

    Attributes:
        label: ``"stable"``, ``"marginal"`` or ``"chatter"``.
        chatter_hz: chatter frequency [Hz] (the non-synchronous spectral peak); NaN when stable.
        lobe: ``"hopf"``, ``"flip"`` or ``""`` (stable).
        level: RMS tooth-to-tooth change over the feed per tooth on the last W periods [-].
        growth: its growth factor over W periods [-] (inf: from exactly zero).
        window_periods: tooth periods in the spectral window.
        freq_hz, amplitude_m: the one-sided amplitude spectrum [m] of x and y together (root of the
            summed powers) over the spectral window, with the harmonics (for plotting).
        tooth_hz: tooth-passing frequency [Hz].
    """

    label: str
    chatter_hz: float
    lobe: str
    level: float
    growth: float
    window_periods: int
    tooth_hz: float
    freq_hz: np.ndarray = field(repr=False)
    amplitude_m: np.ndarray = field(repr=False)
    schema: str = "millstab.simulate.detection/1"

    def to_dict(self) -> dict[str, Any]:
        from millstab.io.results import to_jsonable

        return to_jsonable({k: getattr(self, k) for k in self.__dataclass_fields__})

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Detection:
        kw = {k: d[k] for k in cls.__dataclass_fields__ if k in d}
        for k in ("chatter_hz", "level", "growth", "tooth_hz"):
            kw[k] = float("nan") if kw[k] is None else float(kw[k])
        kw["freq_hz"] = np.asarray(kw["freq_hz"], float)
        kw["amplitude_m"] = np.asarray(kw["amplitude_m"], float)
        return cls(**kw)


def spectrum_band_hz(fn_max_hz: float, tooth_hz: float) -> float:
    """Upper end [Hz] of the chatter-frequency search: 2 fn_max + f_T."""
    return 2.0 * fn_max_hz + tooth_hz


def detect(result) -> Detection:
    """Label one simulated cut (:class:`millstab.simulate.CutResult`); rules in the module docstring."""
    m = result.steps_per_tooth
    n_out = result.x.size
    f_hi = spectrum_band_hz(result.fn_max_hz, result.tooth_hz)
    code, hz, lobe, level, growth, n_per = detect_core(result.x, result.y, n_out, m, result.feed_per_tooth_m,
                                                       result.tooth_hz, f_hi, result.diverged)
    freq, amp = _display_spectrum(result, n_per)
    return Detection(LABELS[code], float(hz), LOBES[lobe], float(level), float(growth), int(n_per),
                     result.tooth_hz, freq, amp)


def _display_spectrum(result, n_per: int) -> tuple[np.ndarray, np.ndarray]:
    """Amplitude spectrum [m] of the last n_per whole periods (Hann window, amplitude-corrected)."""
    m = result.steps_per_tooth
    C = (result.x.size - 1) // m
    n_per = max(min(n_per, C), 1) if C else 0
    if n_per == 0:
        return np.zeros(0), np.zeros(0)
    seg = slice((C - n_per) * m, C * m)
    L = n_per * m
    w = np.hanning(L + 1)[:-1]
    fx = np.fft.rfft((result.x[seg] - result.x[seg].mean()) * w)
    fy = np.fft.rfft((result.y[seg] - result.y[seg].mean()) * w)
    amp = 2.0 * np.sqrt(np.abs(fx) ** 2 + np.abs(fy) ** 2) / w.sum()
    freq = np.fft.rfftfreq(L, d=1.0 / (m * result.tooth_hz))
    return freq, amp


def growth_multiplier(result, skip: float = 0.5, order: int = 3, max_level: float | None = None) -> complex:
    """The dominant multiplier of the once-per-tooth map, fitted to the simulated samples.

    A least-squares linear predictor (dynamic mode decomposition with ``order`` delays) of the
    tooth-to-tooth changes d_c = P_c − P_{c−1} after the first ``skip`` share of the cut; its
    eigenvalue of largest modulus. With ``max_level`` [m] only the samples before the first change
    larger than it (after the first one below it) are used (the linear regime of a growing run). In the linear regime (small vibration) this is the dominant
    Floquet multiplier of the simulation: |μ| > 1 growing, arg μ the chatter frequency modulo f_T.
    For validation against the semi-discretization engine; the labels use :func:`detect`.
    """
    m = result.steps_per_tooth
    C = (result.x.size - 1) // m
    P = np.stack([result.x[::m][: C + 1], result.y[::m][: C + 1]], axis=1)
    P = P[:, [i for i, a in enumerate(result.active) if a]]
    d = np.diff(P, axis=0)
    if max_level is not None:
        over = np.abs(d).max(axis=1) > max_level
        calm = np.flatnonzero(~over)  # an entry transient above the level is not growth
        big = np.flatnonzero(over[calm[0]:]) + calm[0] if calm.size else np.zeros(0, int)
        if big.size:
            d = d[: big[0]]
    d = d[int(skip * d.shape[0]):]
    if d.shape[0] < 4 * order * d.shape[1]:
        raise ValueError("too few tooth periods for the multiplier fit")
    d = d / np.abs(d).max()
    # Hankel states s_c = (d_c, d_{c−1}, ..., d_{c−order+1})
    H = np.concatenate([d[order - 1 - i: d.shape[0] - i] for i in range(order)], axis=1)
    A, *_ = np.linalg.lstsq(H[:-1], H[1:], rcond=None)
    mu = np.linalg.eigvals(A.T)
    mu = mu[np.argsort(-np.abs(mu))]
    top = mu[0]
    if top.imag < 0 and np.any(np.isclose(mu, np.conj(top))):
        top = np.conj(top)
    return complex(top)
