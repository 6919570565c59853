"""Chatter detection from a simulated signal, as one would from an accelerometer or a microphone.

Two signals are used, both of the tool-tip displacement (x, y) in the directions that carry modes:

* the once-per-tooth samples P_c (one per tooth period T, at the instant a tooth enters). A stable
  cut is T-periodic, so they converge to a fixed point; a Hopf chatter makes them circle
  (quasi-periodic cloud), a period-doubling (flip) chatter makes them alternate. The size of the
  tooth-to-tooth change d_c = |P_c − P_{c−1}| removes the forced (T-periodic) part exactly.
* the spectrum of the non-synchronous part of the signal: the signal minus its time-synchronous
  average over the analysed periods, i.e. with every tooth-passing harmonic removed. Its peak is the
  chatter frequency.

The last half of the cut is analysed (the first half is the transient of the entry). Two numbers:

* the trend: the per-tooth-period multiplier |μ| of the tooth-to-tooth change, exp of the
  least-squares slope of log RMS(d_c) over ``TREND_BLOCKS`` = 8 equal blocks of the last half (a
  block of several periods averages a Hopf pair's rotation, so the fit follows the envelope; a fit
  over the whole last half, not the ratio of two windows, is not thrown by a beat or by one noisy
  window). ``growth`` G = |μ|^W is its factor over W = C/4 periods (C periods in the cut);
* the level: L = RMS(d_c) over the last W periods / f_t, the vibration in units of the feed per
  tooth (the chip thickness scale: what decides whether the cut leaves marks).

Label (thresholds, and why), in this order:

* ``chatter`` if the simulation diverged (|u| beyond the bound);
* ``stable`` if L < ``LEVEL_QUIET`` = 1e-4: the samples sit on the fixed point to 0.01 % of the feed
  (10 nm at 0.1 mm/tooth, far below any sensor's noise). The trend of such a vibration is no
  evidence: a transient that decayed to 1e-15 f_t (round-off of the periodic motion) can show any
  "growth" (the 1-DOF benchmark at a/D = 0.05, 10 000 rpm, 0.85 × the limit showed G = 2.04 at
  L = 8e-15 and was called chatter before this rule came first);
* ``chatter`` if G ≥ ``GROWTH`` = 1.5: the tooth-to-tooth vibration grows by half again within W
  periods (|μ| ≥ 1.5^{1/W}, e.g. 1.008 for W = 50); a linear growth this clear will reach the chip
  thickness, so the cut chatters;
* ``stable`` if G ≤ 1/``GROWTH``: it decays clearly (the transient of a stable cut);
* ``chatter`` if L ≥ ``LEVEL_CHATTER`` = 0.1 (and neither growing nor decaying): a sustained
  tooth-to-tooth change of 10 % of the feed per tooth is a plain chatter mark on the surface (10 µm
  at 0.1 mm/tooth), ten times the default start bump (1 % of the feed), and the saturated limit
  cycle of an unstable cut sits there (L ≈ 0.2-1.5 in the benchmark: the tooth leaves the cut);
* ``marginal`` otherwise: small and neither growing nor decaying clearly within the cut. A longer
  cut (more revolutions) narrows this band: its width in |μ| is about ±ln(1.5)/W.

A run that diverged before two tooth periods has no synchronous average: its frequency and |μ| come
from a second-order linear predictor (Prony) fitted to the last half of the samples, where the
blow-up dominates; level is then the largest |u| over f_t. No output of a diverged run is NaN.

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

import numpy as np

from millstab.simulate._kernel import (CHATTER, GROWTH, LEVEL_CHATTER, LEVEL_QUIET, MARGINAL,  # noqa: F401
                                       MIN_PERIODS, SPECTRUM_PERIODS, STABLE, TREND_BLOCKS, detect_core)

LABELS = ("stable", "marginal", "chatter")
LOBES = ("", "hopf", "flip")


@dataclass(frozen=True, eq=False)
class Detection:
    """What the detector says about one cut.

    Attributes:
        label: ``"stable"``, ``"marginal"`` or ``"chatter"``.
        chatter_hz: chatter frequency [Hz] (the non-synchronous spectral peak); NaN when stable.
        lobe: ``"hopf"``, ``"flip"`` or ``""`` (stable).
        level: RMS tooth-to-tooth change over the feed per tooth on the last W periods [-].
        growth: its growth factor over W periods [-], |μ|^W (inf: from exactly zero).
        multiplier: |μ|, the fitted per-tooth-period multiplier of the tooth-to-tooth change [-].
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
    multiplier: float = float("nan")
    schema: str = "millstab.simulate.detection/1"

    def to_dict(self) -> dict[str, Any]:
        from millstab.io.results import to_jsonable

        return to_jsonable({k: getattr(self, k) for k in self.__dataclass_fields__})

    #: the ``"schema"`` of :meth:`to_json`
    SCHEMA = "millstab.simulate.detection/1"

    def table(self) -> tuple[list[str], list]:
        """(header, columns) of the spectrum the verdict was read from: freq_hz [Hz], amplitude_m [m]."""
        return ["freq_hz", "amplitude_m"], [self.freq_hz, self.amplitude_m]

    def figure(self, ax=None, *, title: str | None = None):
        """The spectrum with the tooth-passing harmonics and the chatter line, titled by the verdict
        (:func:`millstab.plot.simulate.plot_spectrum`; with the cut, :meth:`CutResult.figure` draws all three
        panels); into ``ax`` or a new figure, which it returns."""
        from millstab.plot.simulate import plot_spectrum

        return plot_spectrum(self, title=title, ax=ax)

    def summary(self) -> str:
        """One line: 'chatter at 845.0 Hz (hopf); growth 2.04 (|mu| 1.0143 per tooth period), level 0.31'
        (a metric not defined is left out, never printed as 'nan'); a stable cut settled below ``LEVEL_QUIET`` says so
        instead of its growth and multiplier, which are then those of round-off (|mu| > 1 read as unstable)."""
        text = self.label
        if self.label != "stable" and math.isfinite(self.chatter_hz):
            text += f" at {self.chatter_hz:.1f} Hz" + (f" ({self.lobe})" if self.lobe else "")
        parts = []
        if self.label == "stable" and self.level < LEVEL_QUIET:  # settled: a "growth" of round-off is no vibration
            return f"{text}; settled to round-off (level {self.level:.3g} < {LEVEL_QUIET:g}: no vibration left to grow)"
        if math.isfinite(self.growth):
            parts.append(f"growth {self.growth:.3g}" + (f" (|mu| {self.multiplier:.5g} per tooth period)"
                                                        if math.isfinite(self.multiplier) else ""))
        if math.isfinite(self.level):
            parts.append(f"level {self.level:.3g}")
        return text + ("; " + ", ".join(parts) if parts else "")

    def to_json(self) -> dict[str, Any]:
        """Every field under its own name: a growth of ∞ (from exactly zero) stays ∞ (``to_dict`` writes
        it as null, read back as NaN), NaN only where the field says "not defined"."""
        from millstab.jsondoc import fields_out

        return fields_out(self, self.SCHEMA)

    @classmethod
    def from_json(cls, doc: Any, source: str = "detection") -> Detection:
        """The detection of :meth:`to_json`; InputError naming ``source`` and the field otherwise."""
        from millstab.jsondoc import fields_in

        return fields_in(cls, doc, cls.SCHEMA, source)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Detection:
        kw = {k: d[k] for k in cls.__dataclass_fields__ if k in d}
        for k in ("chatter_hz", "level", "growth", "tooth_hz", "multiplier"):
            if k not in kw:
                continue
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
    code, hz, lobe, level, growth, n_per, mu = detect_core(result.x, result.y, n_out, m, result.feed_per_tooth_m,
                                                       result.tooth_hz, f_hi, result.diverged)
    freq, amp = _display_spectrum(result, n_per)
    return Detection(LABELS[code], float(hz), LOBES[lobe], float(level), float(growth), int(n_per),
                     result.tooth_hz, freq, amp, float(mu))


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

    A linear predictor (dynamic mode decomposition with ``order`` delays, rank-truncated) of the
    tooth-to-tooth changes d_c = P_c − P_{c−1} after the first ``skip`` share of the cut; its
    eigenvalue of largest modulus. With ``max_level`` [m] only the samples before the first change
    larger than it (after the first one below it) are used (the linear regime of a growing run).
    In the linear regime (small vibration) this is the dominant Floquet multiplier of the simulation: |μ| > 1 growing,
    arg μ the chatter frequency modulo f_T.
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
    need = 4 * order * d.shape[1]
    d = d[min(int(skip * d.shape[0]), max(d.shape[0] - need, 0)):]  # a short linear stretch: use it all
    if d.shape[0] < need:
        raise ValueError("too few tooth periods for the multiplier fit")
    d = d / np.abs(d).max()
    # Hankel states s_c = (d_c, d_{c−1}, ..., d_{c−order+1})
    H = np.concatenate([d[order - 1 - i: d.shape[0] - i] for i in range(order)], axis=1)
    # exact DMD on the data's own subspace: X = H₀ᵀ = U Σ Vᵀ (singular values below 1e-7 of the
    # largest dropped), Ã = Uᵀ Y V Σ⁻¹; a plain least-squares map would also carry arbitrary
    # eigenvalues on directions the data never visit (a growing pair alone fills 2 of qD dimensions)
    X, Y = H[:-1].T, H[1:].T
    U, sv, Vt = np.linalg.svd(X, full_matrices=False)
    r = int(np.sum(sv > 1e-7 * sv[0]))
    mu = np.linalg.eigvals(U[:, :r].T @ Y @ Vt[:r].T / sv[:r])
    mu = mu[np.argsort(-np.abs(mu))]
    top = mu[0]
    if top.imag < 0 and np.any(np.isclose(mu, np.conj(top))):
        top = np.conj(top)
    return complex(top)
