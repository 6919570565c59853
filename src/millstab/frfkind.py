"""Which quantity a measured drive-point FRF holds: receptance (m/N), mobility ((m/s)/N) or accelerance
((m/s²)/N), told from its phase and its frequency slope, and the conversion to the receptance the fit needs.

Why it can be told (millstab's convention x(t) = Re(G F e^{iωt}), :mod:`millstab.model`). A passive drive
point dissipates energy at every frequency, so its receptance has Im G ≤ 0 everywhere (for a mode,
Im G = −2ζr/(k((1 − r²)² + (2ζr)²))): the phase stays in (−180°, 0°). Mobility iωG then has Re ≥ 0 (phase in
(−90°, 90°)) and accelerance −ω²G has Im ≥ 0 (phase in (0°, 180°)): the sign of the dissipative part names
the quantity up to the conjugate (a negated imaginary column, or the e^{−iωt} convention). A conjugated
receptance and an accelerance both have Im > 0, and a conjugated accelerance looks like a receptance; they
differ by ω², i.e. by 2 in the log-log slope of |H| across the band: a receptance is flat below its modes
and falls like ω⁻² above them (end-to-end slope between about −2 and 0 for a band around the modes), an
accelerance rises like ω² below them and is flat above (slope about 0..+2). The slope of each reading
after conversion to receptance decides between the twins.

:func:`frf_kind` scores the six readings (three quantities, each plain or conjugated) after conversion to
receptance: the share of the measured |H|² (the resonances) whose imaginary part is ≤ 0 (1 for the right
reading, noise aside; a reading below :data:`PASSIVE_SHARE` is out), then one point each for a stiffness-like
low end (median Re > 0 over the lowest 10 % of lines: below the modes G → 1/k), a mass-like high end (Re < 0
over the highest 10 %: above them G → −1/(mω²)) and an end-to-end slope within :data:`RECEPTANCE_SLOPE`. A band
on one side of its modes still has one end and usually the slope to tell the twins apart. Ties go to the
plain receptance. Cross (transfer) FRFs, whose modes have either sign, pass none of the readings and are
left to the fit's own drive-point check. Checked on synthetic FRFs of each kind, plain and conjugated, on
bands around, below, above and narrowly about the modes, and with 2 % noise (tests/test_cli_reliability.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: a reading is passive (a drive point's receptance after conversion) when this share of |H| has Im ≤ 0
PASSIVE_SHARE = 0.9
#: the end-to-end log-log slope of a drive-point receptance over a band around its modes lies about here
RECEPTANCE_SLOPE = (-2.5, 0.5)
#: the three quantities: name → (power p of iω in H = (iω)^p G, unit of H)
KINDS = {"receptance": (0, "m/N"), "mobility": (1, "(m/s)/N"), "accelerance": (2, "(m/s²)/N")}
#: how H of each kind becomes the receptance G (the text of the conversion)
CONVERSION = {"receptance": "G = H", "mobility": "integrate once: G = H/(iω)",
              "accelerance": "integrate twice: G = −H/ω²"}


@dataclass(frozen=True)
class FRFKind:
    """What a drive-point FRF holds.

    Attributes:
        kind: ``"receptance"``, ``"mobility"`` or ``"accelerance"``; ``None`` when no reading is passive (a
            cross FRF, or too noisy to tell).
        conjugated: the imaginary part has the opposite sign convention (negated column, e^{−iωt}).
        passive: the winning reading's passive share (0..1).
        slope: end-to-end log-log slope of |H| as given (per decade of frequency, e.g. +2 for ∝ ω²).
    """

    kind: str | None
    conjugated: bool
    passive: float
    slope: float

    @property
    def unit(self) -> str:
        return KINDS[self.kind][1] if self.kind else "?"

    def describe(self) -> str:
        """E.g. ``accelerance ((m/s²)/N)`` or ``receptance (m/N) with its imaginary part negated``."""
        if self.kind is None:
            return "no drive-point FRF of any kind (a cross FRF, or noise)"
        conj = " with its imaginary part negated (or the e^{-iωt} convention)" if self.conjugated else ""
        return f"{self.kind} ({self.unit}){conj}"


def to_receptance(freq_hz: np.ndarray, h: np.ndarray, kind: str, conjugated: bool = False) -> np.ndarray:
    """The receptance G [m/N] from H of ``kind`` (SI units) at ``freq_hz`` [Hz]: G = H/(iω)^p, conjugated
    first when ``conjugated``."""
    if kind not in KINDS:
        from millstab.errors import InputError

        raise InputError("--frf-type", kind, f"must be one of {', '.join(KINDS)}")
    h = np.asarray(h, dtype=complex)
    if conjugated:
        h = np.conj(h)
    w = 2 * np.pi * np.asarray(freq_hz, dtype=float)
    return h / (1j * w) ** KINDS[kind][0]


def _end_slope(freq_hz: np.ndarray, mag: np.ndarray) -> float:
    """log-log slope between the median |H| of the lowest and of the highest 10 % of the lines."""
    n = max(1, freq_hz.size // 10)
    lo_f, hi_f = np.median(freq_hz[:n]), np.median(freq_hz[-n:])
    lo_m, hi_m = np.median(mag[:n]), np.median(mag[-n:])
    if not (lo_m > 0 and hi_m > 0 and hi_f > lo_f):
        return float("nan")
    return float(np.log(hi_m / lo_m) / np.log(hi_f / lo_f))


def frf_kind(freq_hz: np.ndarray, h: np.ndarray) -> FRFKind:
    """Tell receptance, mobility and accelerance apart (module docstring: how and why)."""
    f = np.asarray(freq_hz, dtype=float)
    h = np.asarray(h, dtype=complex)
    ok = np.isfinite(f) & (f > 0) & np.isfinite(h)
    f, h = f[ok], h[ok]
    if f.size < 4:
        return FRFKind(None, False, 0.0, float("nan"))
    slope = _end_slope(f, np.abs(h))
    n = max(1, f.size // 10)
    # every reading weighs the lines alike, by the measured |H|²: the resonances, where the signal stands
    # above the noise, decide (a reading's own |G| would give the lowest lines of an ω^-2 conversion all the
    # say, where a receptance's imaginary part is nearly zero and its sign is the noise's)
    weight = np.abs(h) ** 2
    total = float(np.sum(weight))
    if not total > 0:
        return FRFKind(None, False, 0.0, slope)
    best = None
    for kind, (p, _) in KINDS.items():
        for conj in (False, True):
            g = to_receptance(f, h, kind, conj)
            passive = float(np.sum(weight[g.imag <= 0]) / total)
            s = slope - p  # dividing by ω^p lowers the slope by p
            # a receptance is stiffness-like (Re > 0) below its modes and mass-like (Re < 0) above them, and its
            # end-to-end slope lies in RECEPTANCE_SLOPE; its ω² twin fails all three where the band allows
            score = (int(np.median(g.real[:n]) > 0) + int(np.median(g.real[-n:]) < 0)
                     + int(RECEPTANCE_SLOPE[0] <= s <= RECEPTANCE_SLOPE[1]))
            key = (passive < PASSIVE_SHARE, -score, p, conj)  # ties: plain before converted, then unconjugated
            if best is None or key < best[0]:
                best = (key, kind, conj, passive)
    if best is None or best[0][0]:
        return FRFKind(None, False, 0.0 if best is None else best[3], slope)
    return FRFKind(best[1], best[2], best[3], slope)


#: how to undo a whole sign flip (the text of the advice)
NEGATE_BOTH = ("negate both the real and the imaginary column (the hammer's or the sensor's polarity is reversed: "
               "G = −H)")


def _stiffness_line_above_peaks(g: np.ndarray) -> bool:
    """Whether the lowest 2 % of the lines of ``g`` [m/N] are a coherent stiffness line (real part positive and
    most of |g|) standing above every other line of the band.

    A drive-point receptance cannot do that: below its modes it tends to Σ 1/k_m, which lies below its resonance
    peaks 1/(2ζk) for any structural damping, so a reading whose low end outgrows its peaks was divided by ω² once
    too often (a sign-flipped receptance read as an accelerance: −(−G)/ω² = G/ω²). The coherence test (real part
    at least half of |g|) keeps the ω²-amplified noise at the low end of a true accelerance out of it.
    """
    n = max(3, g.size // 50)  # the lowest 2 %: a stiffness line divided by ω² falls 1.4x over 100..120 Hz already
    low, rest = g[:n], g[n:]
    if rest.size == 0:
        return False
    size = float(np.median(np.abs(low)))
    return bool(np.median(low.real) > 0.5 * size and size > float(np.max(np.abs(rest))))


def negated_receptance(f: np.ndarray, h: np.ndarray, seen=None) -> str | None:
    """``"yes"`` when the drive-point FRF ``h`` at ``f`` [Hz] is a receptance [m/N] with both columns negated (a
    reversed hammer or sensor: G = −H), ``"maybe"`` when the data fit that reading and an accelerance equally
    well, ``None`` otherwise.

    Why a separate test: −G has its phase in 0..180 deg like an accelerance −ω²G (both have Im > 0 at the
    resonances and Re < 0 below them), so :func:`frf_kind`, which weighs receptance, mobility
    and accelerance each plain or conjugated but never negated, calls it an accelerance (and advises a
    conversion that gives G/ω², or, given ``--frf-type receptance``, the fit advises negating the imaginary
    column). The two readings, −H and −H/ω², differ only by the real factor ω²: the one whose end-to-end slope
    lies in :data:`RECEPTANCE_SLOPE` and whose low end is no stiffness line above its peaks
    (:func:`_stiffness_line_above_peaks`) scores a point for each; −H must score more to be called a sign flip.
    """
    seen = seen if seen is not None else frf_kind(f, h)
    if seen.kind != "accelerance" or seen.conjugated:
        return None
    flipped = frf_kind(f, -h)
    if flipped.kind != "receptance" or flipped.conjugated:
        return None
    w2 = (2 * np.pi * np.asarray(f, float)) ** 2
    lo, hi = RECEPTANCE_SLOPE
    score_neg = int(lo <= seen.slope <= hi) + int(not _stiffness_line_above_peaks(-h))
    score_acc = int(lo <= seen.slope - 2 <= hi) + int(not _stiffness_line_above_peaks(-h / w2))
    return "yes" if score_neg > score_acc else "maybe" if score_neg == score_acc else None


__all__ = ["CONVERSION", "FRFKind", "KINDS", "NEGATE_BOTH", "PASSIVE_SHARE", "RECEPTANCE_SLOPE", "frf_kind",
           "negated_receptance", "to_receptance"]
