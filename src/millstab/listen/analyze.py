"""Listen to a cut: chatter, its frequency and its onset from a microphone or accelerometer signal.

The steps, with every threshold and the reason for it:

1. **Cut window.** ``start``/``end`` [s] when given; else the frames (20 ms, and at least 4 tooth periods) where
   the tooth-passing comb (k·f_T, k = 1, 2, ... while a ±``SPEED_TOL`` speed error keeps the line within a bin)
   holds more than ``WINDOW_LEVEL`` = 0.1 of its median power over the frames where the teeth are heard (the comb
   ``CUT_SNR`` = 4× over the frame's own background beside its lines; all frames when fewer than 8 are, or when
   the heard frames make a window under ``MIN_WINDOW_FRAMES`` frames): the comb is the forced vibration, there
   only while the teeth cut; air cutting, the idle spindle and hum are left out, and chatter that starts late
   does not move the window (a broadband RMS would). The median, not a high percentile: a ringing entry transient
   leaks into the comb's 50 Hz-wide frame bins and would otherwise set the level and cut the steady cut away
   (measured: a four-tooth slot at 3 154 rpm kept 0.02-0.46 s of a 2 s cut and heard the speed 2.7 % off). The
   median of the heard frames, not of all: a recording more than half air had the air's median, and the air
   joined the window (2-4 s of an idle spindle before a 2 s stable cut: its tooth line switching on within the
   window was heard as "chatter" at f_T). A window under ``MIN_CUT_S`` = 0.1 s is refused (one periodogram: no
   label can be heard), one under 0.4 s (< ``MIN_AVERAGES`` = 7 Welch averages) noted; a recording with no line
   at any spindle harmonic ``PROMINENCE`` over the floor (silence, noise, a speed far off) is refused, not called
   stable. The window is then trimmed by ``TRIM`` = 3 % of its length at each end: the entry and exit transients
   (an impact rings every mode, which is no chatter).
2. **Spectrum.** Welch average of the window: Blackman-Harris segments (side lobes −92 dB, so a line
   60-70 dB over the floor leaks nothing beyond ±4 bins), a quarter of the window long, 0.1-2 s
   (≥ 7 averages; ≤ 0.5 Hz bins on an 8 s window, so a chatter line a few Hz from a spindle line
   stays apart), 50 % overlap, zero-padded twice. Chatter is searched from ``F_LO`` = 40 Hz to
   min(0.45 fs, ``F_HI`` = 8 kHz).
3. **Speed.** The speed given can be off (an override knob, a rounded value): the tooth-passing
   frequency f_s = rpm/60 is the comb k·f_s over the spindle harmonics up to ``COMB_HARMONICS`` = 3
   tooth-passing harmonics (k ≤ 3N: tooth passing and runout lines), in ±``SPEED_TOL`` = 1.5 %, with
   the largest sum of its lines' prominences (log power over the floor, counted only at a local
   maximum, at most ``COMB_CLIP`` = 8 each). Only up to 3 f_T: slotting with two teeth has lines at
   f_T and 2 f_T only (slotting with four, hardly any: there the runout lines carry the speed), while a
   saturated chatter fills the spectrum with combination tones j f_T ± m f_c, 50 dB over the floor,
   that a 30-harmonic comb drifting by 1 % walks along (measured on ex1 at 8 mm: −1.4 %). Refined by
   least squares on the interpolated peaks of the prominent spindle harmonics up to k = 30 (±2 bins).
   Both on the full-window spectrum (bins of 1/(2T), 4× finer than the Welch segments'): a chatter
   family 2-3 Hz beside the spindle harmonics pulled a comb scored on Welch bins to it (0.2-1.4 % off
   on 3 of 204 benchmark cuts, each then a chatter-frequency miss). Then refined to the lines' own
   frequencies (``_refine_spindle``): on the unwindowed DFT of a whole number of revolutions every
   spindle harmonic sits on a bin; each line within ±``SYNC_SEARCH_BINS`` bins of k f_s is placed to a
   fraction of a bin by its neighbours (X[b∓1]/X[b] ≈ ±e), and f_s moves by the power-weighted fit
   of these offsets over the lines within a quarter bin of the offset most lines agree with (each
   votes its log-prominence, at most ``COMB_CLIP``: a chatter line stronger than a runout line beside
   it is one vote). Measured: the speed from the peaks was 1e-6 to 7e-6 off (0.01-0.07 bins at the
   30th harmonic of a 2 s window), refined 1e-8 to 2e-7.
4. **Synchronous lines** (masked): every multiple of the spindle frequency f_s = f_T/N (tooth-passing
   harmonics, runout once per revolution and its harmonics) ±(``LINE_BINS`` = 4.5 bins + k·2e-4 f_s).
   One exception: with an even number of teeth, a line at an odd multiple of f_T/2 from 1.5 f_T up
   (1.5 f_T = 3 f_s included: a two-tooth slot's flip chatter sits there; masking it made the 2.5 f_T
   member heard instead on 4 of 38 chatter cuts of the benchmark at 100 cuts)
   ``FLIP_RATIO`` = 4× stronger (in power) than every runout line below 1.5 f_T, and at least
   ``FLIP_TOOTH`` = 1/3 (−5 dB) of its neighbouring tooth-passing lines, stays a chatter candidate:
   period-doubling (flip) chatter falls exactly on a spindle harmonic there, and runout falls with
   its order instead of peaking near a mode. (On the benchmark's stable two- and four-tooth cuts the
   1.5 f_T line stood at most 1.3 dB over the runout below it; flip chatter 7-39 dB. Runout varying
   the tooth pulses' heights, lifted by a resonance between two tooth harmonics, can reach the
   tooth lines' level: hence the second rule, from tests/listen_shop.py.) Once the chatter heard is
   a flip line (an odd multiple of f_T/2), the other odd multiples standing ``FLIP_RATIO`` over the
   runout join its family (step 7) even under ``FLIP_TOOTH`` of their tooth lines: the second rule
   keeps resonant runout from being heard as chatter on its own, but here another member has made it
   flip chatter (bench_listen --seed 1: a two-tooth flip chatter at 1.5 f_T, 10 dB under the tooth
   line f_T, had its 2.5 f_T member heard instead on 3 cuts). Likewise, once the cut is chatter by a
   line that is no flip member (a Hopf line, a quasi-periodic hump), such a flip line (``FLIP_RATIO`` over
   the runout, masked only by ``FLIP_TOOTH``) stronger in displacement (excess / f⁴) than the line heard is
   reported instead (``_flip_over_heard``; the label, score and trend stay the line heard's): bench_listen
   --seed 1 cut 145 and --seed 2 cut 145, two-tooth flips at 1.5 f_T 9 dB over every other line of the
   displacement but 8 dB under the tooth line f_T in the microphone, had a weaker hump near the mode heard.
5. **Mains** (masked): lines at h·50 and h·60 Hz (h ≤ 8) standing ``MAINS_PROMINENCE`` = 4× over
   the floor within ±0.3 Hz + 1 bin, unless (h ≥ 4) ``MAINS_OVER_HUM`` = 2× louder than the hum at
   h = 1-3 (then it is no hum: a chatter line that happens to fall on a mains harmonic stays).
   These Welch masks are ±4.5 segment bins wide (±9 Hz on a 2 s cut); what they hide is looked at
   again in step 7 at the full window's resolution.
6. **Floor**: the ``FLOOR_PERCENTILE`` = 25th percentile of the unmasked log-power in blocks of
   ``FLOOR_BLOCK_HZ`` = 100 Hz, interpolated between block centres: it follows broadband and 1/f
   noise and the hump of a mode excited by noise (no chatter), and a broad modulated chatter hump
   filling half a block leaves it alone (a median would rise with it).
7. **Chatter line**: the largest excess power (PSD − floor) among local maxima standing
   ``PROMINENCE`` = 10 (10 dB) over the floor: with ≥ 7 averages of two degrees of freedom a noise
   bin passes 10 × the 25th percentile with probability ~1e-7. Its frequency is refined on the
   full-window spectrum (finer bins) by a parabola through log-magnitudes. Its power is the excess
   over its contiguous region above twice the floor (a modulated chatter is a hump), at least its
   peak density times the window's noise bandwidth (a line beside a masked one).
   **Beside a masked line**: the full-window periodogram (Blackman-Harris, bins of 1/(2T)) inside the
   Welch masks, beyond ±``NEAR_BINS`` = 4/T of the masked line's own peak (its main lobe: side lobes
   −92 dB), gives further candidates: a local maximum ``NEAR_PROMINENCE`` = 30× over the floor (one
   exponential variable per bin: noise passes with probability ~e⁻²⁴) parted from the masked line by a
   dip below 1/``NEAR_DIP`` = 1/4 of it (a line of its own, not the skirt of the masked one). So
   chatter 3 Hz from a runout line or a mains harmonic is heard on a 2-3 s cut (the Welch masks alone
   hid it to ±9 Hz). Its power is its peak density × the full window's noise bandwidth; it competes
   with the Welch candidates in Welch-density units (× segment length / window length).
   **On a spindle line** (inside its own main lobe, ±4/T, where the two above cannot look): the
   steady spindle lines are fitted by least squares at their exact frequencies k f_s (f_s refined,
   step 3) and taken out (``_sync_residual``: on the unwindowed DFT of whole revolutions each line is
   one bin, orthogonal to the others; a tone δ Hz away leaks sinc(δT) into it: nothing at whole
   bins, −22 dB from 2.5 bins on), and the Blackman-Harris spectrum of the residual (bins 1/T) is
   searched within ±(``NEAR_BINS`` + 2)/T of each line: a local maximum ``NEAR_PROMINENCE`` over the
   floor, at least ``SYNC_MIN_BINS`` = 1.5/T from the line (closer, one window cannot part them),
   ``SYNC_MIRROR`` = 4× over the residual mirrored about the line (what a removed line leaves, from a
   speed error or a slow drift of its amplitude, is symmetric about it; a chatter line beside it is
   not), and not on a mains line found (±0.3 Hz + 1.5/T: hum 1.7 Hz from a spindle harmonic was heard
   as chatter otherwise). Its trend is taken on the residual (the runout line beside it out).
   Measured on hand-made cuts (listen_synth and listen_shop, 2-5 s, chatter 1-3 Hz from runout lines,
   0.25-1 × the forced vibration): 199 of 288 right before, 285 after (the 3 left: a two-tooth
   2.5 f_T runout line lifted by a resonance, kept as a flip candidate and louder than the chatter).
   Chatter exactly on a spindle line (closer than 1.5/T) stays unheard: a steady one cannot be told
   from runout.
   One chatter sounds as a family f_c + k f_T and its mirrors k f_T − f_c (the tooth passing modulates
   it; a lower sideband below zero folds over); the chatter frequency
   of the lobe theory is the member near the mode, the strongest in *displacement*. A microphone and an
   accelerometer both follow acceleration, whose power is f⁴ times the displacement's, so of the
   family's prominent members (|k| ≤ ``FAMILY_ORDERS`` = 8) the one with the largest power / f⁴ is
   reported. A member counts from ``FAMILY_SHARE_FAR`` = 1 % of the loudest's power, except the
   loudest's first-order sidebands |f ± f_T| (f_T − f folded below zero), which count from
   ``FAMILY_SHARE`` = 10 %, as do lines on a spindle harmonic (a flip candidate may be resonant
   runout: at 1 % one 2 Hz from a sideband f_c − 2 f_T of a chatter beside a spindle harmonic won by
   f⁴, bench_listen_near --seed 1, case 25): those sidebands are where
   a tone amplitude-modulated by the tooth passing puts its sidebands (up to 60 % modulation stays
   out, which a low f − f_T would otherwise win by f⁴), while further orders and mirrors are no
   sidebands of one tone. (10 % for every member lost a two-tooth Hopf chatter at 1.332 f_T holding 7.9 %
   of the power of its mirror 4 f_T − f_c, the loudest line: bench_listen --seed 1, cut 60; the 1 %
   changed nothing else on seeds 0-2.) On virtual recordings the loudest member was the upper
   neighbour f_c + f_T in 6 of 73 chatter cuts; with |k| ≤ 3 a two-tooth slot's loudest line 5 f_T −
   f_c was not linked to f_c.
   **The structure known** (``structure``: a config's, ``listen --config``, ``update``): a sensor's
   path (a room's reflections: notches 12-19 dB deep) can make another member louder than f⁴ allows,
   and no rule on the recording alone can undo it. For a flip chatter (even teeth, the line an odd
   multiple of f_T/2) the members heard (odd multiples of f_T/2 from ``FAMILY_SHARE_FAR`` of its
   power) are all spindle harmonics, their levels mixed with runout as well; of them the one where the
   structure is most flexible (Σ|G_ij|², ``_flip_member_at_mode``) is reported: the period doubling of
   the mode. Measured on bench_listen (seeds 0, 1, 2): 2 flip misses turned into hits, none lost. Every
   odd multiple of f_T/2 from 1.5 f_T up counts as a member here, heard as a candidate or not (its line's
   excess over the floor, runout included): a room's notch can put the member at the mode under the
   runout test (bench_listen --seed 1 cut 96: 2.5 f_T, the displacement's peak, 17.6 dB deeper in the
   notch than 1.5 f_T; --seed 2 cut 66 alike). The spindle frequency itself (0.5 f_T with two teeth)
   is not: it is the first runout line, and its flexibility is the static one. Not
   for a Hopf chatter: the member nearest the mode by |G| (or by |G|^β × power / f⁴, β = 0.5-2) lost
   more than it won (a two-tooth slot's Hopf at 1.33 f_T, 300 Hz under the mode, has members 150 Hz
   either side of it as flexible; ex3's two modes made a mirror below them look flexible).
   **A sensor path measured** (``tap``: :mod:`millstab.listen.tap`, ``listen --tap``): a tap recorded by the
   same sensor gives the path's weight W(f) (recording power per displacement power, f⁴ × the room's gain),
   which replaces f⁴ in every ranking above: the chatter heard is the candidate strongest as the source sounds
   (power × f⁴ / W), the family's shares are taken on that power, its member reported is the one with the
   largest power / W, and a flip line passes the runout and tooth-line tests on either the recorded or the
   equalised power (the tap adds flip candidates, never removes one). Derivation and limits in
   :mod:`millstab.listen.tap`. The tap chooses the frequency, never the label (see :func:`listen`).
   **A spread chatter** (``_hump_centroid``): when the line heard is one of a hump of comparable lines
   (a quasi-periodic chatter), the hump's power-weighted centroid is reported, and with an even number
   of teeth the odd multiple of f_T/2 near it (period doubling spread by a slow modulation); the
   trend is still taken on the hump's loudest line.
8. **Score** = A_c / A_s: the RMS amplitude of the chatter line over that of all synchronous lines
   (forced vibration and runout), times the ratio of its RMS amplitude over the last ``LATE_SHARE``
   = 40 % of the window to that over the whole window (chatter that starts late is scored as it
   sounds at the end). Scale: 0 no chatter line; 0.05 = chatter 26 dB below the forced vibration;
   1 as loud; 4 = 12 dB louder.
9. **Trend and onset**: the amplitude at f_c in 16-64 frames of ~``TREND_FRAME_S`` = 0.1 s (Hann
   projection, noise floor subtracted), after the steady spindle and mains lines within
   ``TREND_REACH`` = 4 frame bins of f_c (±40 Hz) are subtracted (each fitted over the whole window at
   its own refined frequency: a hum line 3 Hz away otherwise leaks into every 0.1 s frame and a
   chatter 4× weaker than the forced vibration that starts late showed a trend of 1.6-3, no onset);
   early and late levels are the medians of the first and last 20 %. trend = late / early. Chatter
   *starts* during the recording if trend > ``ONSET_RATIO`` = 4;
   the onset is where the amplitude first reaches half its late level (interpolated between frames).
10. **Label**: ``chatter`` if the line grows fourfold within the cut (trend > ``ONSET_RATIO``:
    chatter building up, however weak yet: the simulation's detector calls a clear growth chatter
    too); ``stable`` if no line is prominent, or the score is below ``SCORE_MARGINAL`` = 0.02 (−34 dB:
    a stable cut's non-synchronous sound is a mode rung by noise, further down), or the line decays,
    trend < ``DECAY`` = 0.5 (the ringing of a transient dies, chatter does not); ``chatter`` if score ≥
    ``SCORE_CHATTER`` = 0.05: a chatter line 4× weaker than the forced vibration (score 0.25) is
    plainly chatter; ``marginal`` otherwise (a steady line 34-26 dB below the forced vibration: a cut at
    the edge of a lobe).
    The thresholds were set on virtual recordings (``benchmarks/bench_listen.py``: 0.05 keeps every
    stable cut's score below it, while saturated chatter in a microphone's weighting can fall to 0.07).

11. **Checks** (``_harmonic_checks``) on a chatter or marginal line at a harmonic of a spindle, which
    regenerative chatter never is: another speed's comb within ±``SPEED_WIDE`` = 20 % holding it refuses
    the speed given (an override at 103 % was "chatter" at its tooth line), another count of teeth whose
    tooth lines hold it and the given tooth lines at the runout's level refuses the teeth, a tooth-passing
    harmonic of the speed heard is noted (``Listening.notes``).

Units: seconds, Hz, rev/min; the signal in any unit (only ratios are used).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from millstab.errors import InputError

FRAME_S = 0.02
WINDOW_LEVEL = 0.1
TRIM = 0.03
F_LO = 40.0
F_HI = 8000.0
SPEED_TOL = 0.015
#: the cut window's frames where the tooth-passing comb stands this much (6 dB) over the frame's background beside
#: its lines set the level (measured on 3000 frames of white, 1/f and hum noise: median 0-1 dB, 99th percentile
#: 3-7 dB; the frames of a cut 9-28 dB, a chatter's sidebands between the lines lowering it)
CUT_SNR = 4.0
#: a cut window found from the heard frames shorter than this many frames (8 × FRAME_S = 0.16 s) is no cut told from
#: the air: the window falls back to the level of every frame
MIN_WINDOW_FRAMES = 8
#: the shortest cut window [s]: the Welch segments' shortest (below, one periodogram: a noise bin passes the
#: 10 dB prominence with probability 0.06, and the line masks, ±4.5 bins of 1/T, cover most of the spectrum)
MIN_CUT_S = 0.1
#: fewer Welch averages than this (a window under 0.4 s) and the label is noted as less sure
MIN_AVERAGES = 7
#: the speed given is checked against the spindle lines over ±SPEED_WIDE (an override knob at 103 % or a speed
#: mistyped is outside the ±SPEED_TOL the analysis searches: its tooth line went unmasked and was heard as "chatter")
SPEED_WIDE = 0.20
MAX_COMB = 30
#: most a harmonic adds to the comb score [log power over the floor] (e⁸ = 35 dB)
COMB_CLIP = 8.0
#: harmonics of the comb search: the tooth-passing lines are strongest at the first few (slotting
#: with two teeth has hardly any beyond 2 f_T), while a saturated chatter fills the spectrum with
#: combination tones j f_T ± m f_c that a long comb drifting by 1 % walks along
COMB_HARMONICS = 3
FLIP_RATIO = 4.0
#: a flip line stands at least this share of the power of its neighbouring tooth-passing lines (−5 dB)
FLIP_TOOTH = 1.0 / 3.0
MAINS = (50.0, 60.0)
MAINS_HARMONICS = 8
#: a line at a mains harmonic h ≥ 4 louder than this × the hum at h = 1-3 is not hum
MAINS_OVER_HUM = 2.0
MAINS_PROMINENCE = 4.0
FLOOR_BLOCK_HZ = 100.0
#: the floor is this percentile of a block's unmasked log-power (a broad, modulated chatter hump
#: filling half a block leaves it alone; a median would rise with it)
FLOOR_PERCENTILE = 25.0
PROMINENCE = 10.0
LATE_SHARE = 0.4
TREND_FRAMES = 16
#: preferred length of a trend frame [s] (16-64 frames)
TREND_FRAME_S = 0.1
#: steady lines (spindle, mains) within this many frame bins (1/frame length) of the chatter are
#: subtracted before the trend frames (a Hann frame's leakage beyond 4 bins is under −50 dB)
TREND_REACH = 4.0
DECAY = 0.5
ONSET_RATIO = 4.0
SCORE_CHATTER = 0.05
SCORE_MARGINAL = 0.02
#: half-width of a line mask in Welch bins (Blackman-Harris main lobe: ±4 bins, side lobes −92 dB)
LINE_BINS = 4.5
#: a chatter-family member f + k f_T (|k| ≤ FAMILY_ORDERS) counts with ≥ FAMILY_SHARE of the strongest's power
FAMILY_ORDERS = 8
FAMILY_SHARE = 0.1
#: ... and the other members (further orders, mirrors) with ≥ FAMILY_SHARE_FAR
FAMILY_SHARE_FAR = 0.01
#: equivalent noise bandwidth of the Blackman-Harris window [bins of fs / segment]
ENBW_BINS = 2.004
#: near a masked line: the full-window spectrum's mask half-width around the line's own peak [bins of 1/T]
#: (Blackman-Harris main lobe ±4 bins, side lobes −92 dB)
NEAR_BINS = 4.0
#: a line near a masked one stands this much over the floor in the full-window periodogram (one
#: exponential variable per bin: a noise bin passes 30 × the 25th percentile with probability ~e⁻²⁴)
NEAR_PROMINENCE = 30.0
#: ... and is its own line: between it and the masked line the spectrum dips below 1/NEAR_DIP of it
NEAR_DIP = 4.0
#: Welch segments: the window / SEGMENTS, at most SEGMENT_MAX_S
SEGMENTS = 4.0
SEGMENT_MAX_S = 2.0
#: a line beside a spindle line: the spindle lines are fitted over ±SYNC_FIT_BINS bins of 1/T ...
SYNC_FIT_BINS = 16
#: ... the speed refined on the lines with at least this share of the strongest one's power ...
SYNC_STRONG = 1e-4
#: ... each sought within this many bins of where the speed found puts it (0.1 % at k = 10, T = 2 s: 3 bins)
SYNC_SEARCH_BINS = 4
#: ... and a chatter line is sought at least SYNC_MIN_BINS (of 1/T) from the line, where it stands
#: SYNC_MIRROR times over the residual mirrored about the line
SYNC_MIN_BINS = 1.5
SYNC_MIRROR = 4.0
#: a spread chatter (``_hump_centroid``): the hump is the bins over HUMP_LEVEL × the floor; spread when
#: the peak holds less than HUMP_SHARE of it and it has HUMP_LINES comparable local maxima
HUMP_LEVEL = 2.0
HUMP_SHARE = 0.5
HUMP_LINES = 2
#: ... with even teeth, an odd multiple of f_T/2 within this share of the hump's width of its centroid is reported
HUMP_FLIP = 0.25
SCORE_SCALE = ("amplitude of the chatter line / amplitude of all spindle-synchronous lines, on the last 40 % "
               "of the cut: 0 none, >= 0.02 marginal, >= 0.05 chatter (26 dB below the forced vibration), 1 as loud")


@dataclass(frozen=True, eq=False)
class Listening:
    """What ``listen`` heard in one recording.

    Attributes:
        label: ``"stable"``, ``"marginal"`` or ``"chatter"``.
        chatter_hz: the dominant non-synchronous frequency [Hz] (NaN when no line stands out).
        score: chatter amplitude over synchronous amplitude (scale in :data:`SCORE_SCALE`) [-].
        prominence_db: the chatter line over the noise floor [dB].
        onset_s: time in the recording [s] where a growing chatter reached half its final level (NaN if
            it does not grow during the recording).
        trend: late / early chatter amplitude [-].
        rpm, rpm_heard: the speed given and the speed found from the tooth-passing comb [rev/min].
        teeth, tooth_hz (found) [Hz]; window_s: (start, end) of the analysed cut [s].
        mains_hz: tuple of the mains line frequencies masked [Hz].
        freq_hz, psd, floor, synchronous: the Welch spectrum, its floor and the mask (for plots).
        times_s, chatter_amp: the chatter amplitude per frame (for plots).
        notes: what makes the result less sure (a short window, a speed or teeth that the lines do not fit, a
            line heard on a tooth-passing harmonic), one sentence each; () when none.
    """

    label: str
    chatter_hz: float
    score: float
    prominence_db: float
    onset_s: float
    trend: float
    rpm: float
    rpm_heard: float
    teeth: int
    tooth_hz: float
    window_s: tuple[float, float]
    mains_hz: tuple[float, ...]
    fs: float
    freq_hz: np.ndarray = field(repr=False)
    psd: np.ndarray = field(repr=False)
    floor: np.ndarray = field(repr=False)
    synchronous: np.ndarray = field(repr=False)
    times_s: np.ndarray = field(repr=False)
    chatter_amp: np.ndarray = field(repr=False)
    notes: tuple[str, ...] = ()
    score_scale: str = SCORE_SCALE
    schema: str = "millstab.listen.listening/1"

    def summary(self) -> dict[str, Any]:
        """The scalar results (no arrays)."""
        skip = {"freq_hz", "psd", "floor", "synchronous", "times_s", "chatter_amp"}
        return {k: getattr(self, k) for k in self.__dataclass_fields__ if k not in skip}

    def to_dict(self) -> dict[str, Any]:
        from millstab.io.results import to_jsonable

        return to_jsonable({k: getattr(self, k) for k in self.__dataclass_fields__})


# ---------------------------------------------------------------------------------------------------


def _check(signal, fs, rpm, teeth, start, end) -> tuple[np.ndarray, float]:
    x = np.asarray(signal, dtype=float)
    if x.ndim != 1 or x.size < 1024:
        raise InputError("signal", f"{x.size} samples", "one channel of at least 1024 samples")
    if not np.all(np.isfinite(x)):
        raise InputError("signal", "NaN/inf", "finite samples")
    if float(np.ptp(x)) == 0.0:  # nothing to hear: "stable" (and a speed "heard") would be made up
        raise InputError("signal", "silent (every sample the same)", "a recording of the cut: no tooth-passing "
                         "sound was heard (a muted or unplugged microphone?)")
    if not (math.isfinite(fs) and 500 <= fs <= 192000):
        raise InputError("fs", fs, "a sample rate from 500 to 192000 Hz")
    if not (math.isfinite(rpm) and rpm > 0):
        raise InputError("--rpm", rpm, "the spindle speed in rev/min, > 0")
    if not (isinstance(teeth, (int, np.integer)) and 1 <= teeth <= 100):
        raise InputError("--teeth", teeth, "a whole number of teeth from 1 to 100")
    dur = x.size / fs
    s = 0.0 if start is None else float(start)
    e = dur if end is None else float(end)
    if not (0 <= s < dur):
        raise InputError("--start", start, f"a time in the recording, 0 to {dur:.3g} s")
    if not (s < e <= dur + 1e-9):
        raise InputError("--end", end, f"a time after --start ({s:g} s) and within the recording ({dur:.3g} s)")
    f_t = teeth * rpm / 60.0
    if f_t * (1 + SPEED_TOL) > 0.45 * fs:
        raise InputError("--rpm", rpm, f"a tooth-passing frequency below 0.45 × the sample rate ({0.45 * fs:g} Hz)")
    return x, dur


def cut_window(x: np.ndarray, fs: float, f_t: float, start: float | None = None,
               end: float | None = None) -> tuple[int, int]:
    """Sample range (i0, i1) of the cut: the given times, or the frames where the tooth-passing comb
    (the forced vibration: there only while the teeth cut) is loud (module docstring)."""
    if start is not None or end is not None:
        i0 = int(round((start or 0.0) * fs))
        i1 = x.size if end is None else min(x.size, int(round(end * fs)))
        return i0, i1
    n = max(int(FRAME_S * fs), 64, int(4 * fs / f_t))  # ≥ 4 tooth periods per frame: the comb resolves
    nf = x.size // n
    if nf < 8:
        return 0, x.size
    fr = x[: nf * n].reshape(nf, n)
    spec = np.abs(np.fft.rfft((fr - fr.mean(axis=1, keepdims=True)) * np.hanning(n), axis=1)) ** 2
    # harmonics whose place is known to a bin despite a speed off by SPEED_TOL (at least 3)
    k_max = max(3, int(1.0 / (SPEED_TOL * f_t * n / fs)))
    k = np.arange(1, int(min(k_max, MAX_COMB, 0.45 * fs / f_t)) + 1)
    b = np.rint(k * f_t * n / fs).astype(int)
    cols = np.clip(np.concatenate([b - 1, b, b + 1]), 0, spec.shape[1] - 1)
    comb = spec[:, cols].sum(axis=1)
    # the frames where the teeth are heard: the comb CUT_SNR over the frame's own background beside its lines
    # (the median of the bins 2 to spacing/2 from each line: a coloured background cancels); at least 8 such. The
    # level is WINDOW_LEVEL of their median, not of every frame's: when air (idle spindle, noise) is most of the
    # recording the median of all frames is the air's, and the air joined the window (a 2 s cut after 4 s of
    # air was heard over 0.12-6.12 s, its tooth line switching on heard as "chatter" at f_T)
    h = max(2, int(f_t * n / fs / 2))
    offs = np.r_[np.arange(-h, -1), np.arange(2, h + 1)]
    bg = np.median(spec[:, np.clip(b[:, None] + offs[None, :], 0, spec.shape[1] - 1)], axis=2).sum(axis=1)
    heard = comb >= CUT_SNR * 3.0 * bg
    loud = np.flatnonzero(comb >= WINDOW_LEVEL * (np.median(comb[heard]) if heard.sum() >= 8 else np.median(comb)))
    if loud[-1] + 1 - loud[0] < MIN_WINDOW_FRAMES:
        # a quiet cut whose comb stands over its background in a few frames only (chance peaks of the noise: a
        # stable ex2 cut of the listen benchmark was cut to 0.08 s and refused): no frames tell the cut from the
        # air there, so the level is the median of every frame's, as before the air rule
        loud = np.flatnonzero(comb >= WINDOW_LEVEL * np.median(comb))
    f0, f1 = int(loud[0]), int(loud[-1]) + 1
    trim = max(1, int(round(TRIM * (f1 - f0))))
    if f1 - f0 > 4 * trim:
        f0, f1 = f0 + trim, f1 - trim
    return f0 * n, min(f1 * n, x.size)


def _welch(x: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray, int]:
    """One-sided PSD (Welch: Blackman-Harris segments, 50 % overlap, zero-padded twice), frequencies, and
    the segment length. Written out with numpy (scipy.signal.welch costs twice as much here: its
    detrending and scaling pass over every segment again)."""
    from scipy import fft as sfft
    from scipy.signal import windows

    dur = x.size / fs
    nper = min(int(min(max(dur / SEGMENTS, 0.1), SEGMENT_MAX_S) * fs), x.size)
    step = max(nper // 2, 1)
    seg = np.lib.stride_tricks.sliding_window_view(x, nper)[::step]
    win = windows.blackmanharris(nper, sym=False)
    spec = sfft.rfft((seg - seg.mean(axis=1, keepdims=True)) * win, 2 * nper, axis=1)
    p = (spec.real**2 + spec.imag**2).mean(axis=0) * (2.0 / (fs * np.sum(win**2)))
    p[0] /= 2.0
    return np.arange(p.size) * (fs / (2 * nper)), p, nper


def _interp_peak(logp: np.ndarray, i: int) -> float:
    """Sub-bin offset of a peak at bin i from a parabola through three log values."""
    if 0 < i < logp.size - 1:
        a, b, c = logp[i - 1], logp[i], logp[i + 1]
        den = a - 2 * b + c
        if den < 0:
            return float(np.clip(0.5 * (a - c) / den, -0.5, 0.5))
    return 0.0


def _floor(f: np.ndarray, p: np.ndarray, masked: np.ndarray) -> np.ndarray:
    """Noise floor (PSD units): the FLOOR_PERCENTILE-th percentile of the unmasked log-power per block of
    FLOOR_BLOCK_HZ (≥ 32 bins), interpolated between block centres (flat beyond the end ones). Blocks
    less than a quarter unmasked are skipped. A percentile of log-power sits below the mean power by a
    constant factor (chi-square statistics), the same for every bin, so prominences stay comparable."""
    df = f[1] - f[0]
    nb = max(32, int(round(FLOOR_BLOCK_HZ / df)))
    nblk = max(1, f.size // nb)
    lp = np.where(masked, np.nan, np.log(np.maximum(p, 1e-300)))[: nblk * nb].reshape(nblk, nb)
    ok = np.isfinite(lp).sum(axis=1) >= nb // 4
    if not ok.any():
        return np.full_like(p, np.median(p))
    level = np.nanpercentile(lp[ok], FLOOR_PERCENTILE, axis=1)
    centres = f[: nblk * nb].reshape(nblk, nb).mean(axis=1)[ok]
    return np.exp(np.interp(f, centres, level))


def _spindle_hz(f: np.ndarray, p: np.ndarray, floor: np.ndarray, f_s0: float, teeth: int, f_max: float) -> float:
    """Spindle frequency found near f_s0 on the full-window spectrum (f, p; floor: the Welch floor there):
    comb search on the spindle harmonics up to COMB_HARMONICS tooth-passing harmonics, then least
    squares on the prominent peaks. On the full window's bins (1/(2T)), not the Welch segments' (4×
    coarser): a chatter family sitting 2-3 Hz beside the spindle harmonics pulled a comb scored within
    ±1 Welch bin to it (measured: 0.2-1.4 % off on 3 of 204 benchmark cuts)."""
    df = f[1] - f[0]
    K = int(max(1, min(MAX_COMB, f_max // (f_s0 * (1 + SPEED_TOL)))))
    k = np.arange(1, K + 1)
    kc = k[: COMB_HARMONICS * teeth]
    n_c = int(2 * SPEED_TOL * f_s0 * 2 * kc.size / df) + 1
    cand = f_s0 * (1 + np.linspace(-SPEED_TOL, SPEED_TOL, max(n_c, 3)))
    lp = np.log(np.maximum(p, 1e-300))
    score = _comb_scores(f, p, floor, cand, kc)
    best = np.flatnonzero(score >= score.max() - 1e-9)
    ft = float(cand[best[np.argmin(np.abs(cand[best] - f_s0))]])  # ties: the speed given
    # least squares on the prominent harmonics, f_k = k f_s (up to k = 30): each line is sought within
    # ±2 bins of k times the comb's estimate (good to k·(step + its own error) < 2 bins at least for the
    # first harmonics); a wider search would catch a strong chatter line beside a harmonic
    num = den = 0.0
    for kk in k:
        i = int(round(kk * ft / df))
        lo, hi = max(i - 2, 1), min(i + 3, f.size - 1)
        if hi - lo < 5:
            continue
        j = lo + int(np.argmax(p[lo:hi]))
        if not (p[j] >= p[j - 1] and p[j] >= p[j + 1]) or p[j] < NEAR_PROMINENCE * floor[j]:
            continue
        fk = f[j] + _interp_peak(lp, j) * df
        num += kk * fk
        den += kk * kk
    return num / den if den > 0 else ft


def _comb_scores(f: np.ndarray, p: np.ndarray, floor: np.ndarray, cand: np.ndarray, kc: np.ndarray) -> np.ndarray:
    """Score of each candidate spindle frequency ``cand`` [Hz]: over its harmonics ``kc``, the sum of each line's
    log-prominence over the floor (spectrum f [Hz], p, floor), only at a local maximum (a line, not the skirt of
    a chatter hump) and at most COMB_CLIP (so one strong chatter line that a wrong comb happens to hit cannot
    outvote the tooth-passing lines), taken within ±1 bin of k × cand."""
    df = f[1] - f[0]
    lp = np.log(np.maximum(p, 1e-300))
    loc = np.ones(f.size, bool)
    for sh in (1, 2):
        loc[sh:] &= p[sh:] >= p[:-sh]
        loc[:-sh] &= p[:-sh] >= p[sh:]
    a = np.where(loc, np.clip(lp - np.log(floor), 0.0, COMB_CLIP), 0.0)
    b = np.maximum(a, np.maximum(np.r_[0.0, a[:-1]], np.r_[a[1:], 0.0]))
    idx = np.clip(np.rint(np.outer(cand, kc) / df).astype(int), 0, f.size - 1)
    return b[idx].sum(axis=1)


def _speed_elsewhere(f: np.ndarray, p: np.ndarray, floor: np.ndarray, f_s0: float, f_s: float, teeth: int,
                     f_max: float) -> float | None:
    """A spindle frequency [Hz] within ±SPEED_WIDE of the given f_s0 but beyond ±SPEED_TOL of it whose comb
    (:func:`_comb_scores`, the first COMB_HARMONICS tooth-passing harmonics' spindle harmonics, on the full-window
    spectrum f [Hz], p, floor) outscores the comb of the speed heard ``f_s`` by at least COMB_CLIP (one more line
    35 dB over the floor); else None. Such a recording was made at another speed than the one given: its tooth
    and runout lines are not where the analysis masked them."""
    df = f[1] - f[0]
    kc = np.arange(1, COMB_HARMONICS * teeth + 1)
    kc = kc[kc * f_s0 * (1 + SPEED_WIDE) <= f_max]
    if kc.size == 0:
        return None
    n_c = int(2 * SPEED_WIDE * f_s0 * 2 * kc.size / df) + 1
    cand = f_s0 * (1 + np.linspace(-SPEED_WIDE, SPEED_WIDE, max(n_c, 3)))
    score = _comb_scores(f, p, floor, cand, kc)
    i = int(np.argmax(score))
    here = float(_comb_scores(f, p, floor, np.array([f_s]), kc)[0])
    if abs(cand[i] / f_s0 - 1.0) <= SPEED_TOL or score[i] < here + COMB_CLIP:
        return None
    return _spindle_hz(f, p, floor, float(cand[i]), teeth, f_max)  # refined on its lines, as the speed heard is


def _amp_at(x: np.ndarray, fs: float, f0: float, n_frames: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Amplitude of the sinusoid at f0 in n_frames equal frames (Hann projection), the frame centres [s]
    relative to the segment start, and the frame length [s]."""
    n = x.size // n_frames
    seg = x[: n * n_frames].reshape(n_frames, n)
    w = np.hanning(n)
    ph = np.exp(-2j * math.pi * f0 * np.arange(n) / fs)
    z = (seg - seg.mean(axis=1, keepdims=True)) * w @ ph
    t = (np.arange(n_frames) + 0.5) * n / fs
    return 2.0 * np.abs(z) / w.sum(), t, n / fs


def listen(signal, fs: float, rpm: float, teeth: int, *, start: float | None = None,
           end: float | None = None, structure=None, tap=None) -> Listening:
    """Label one recording of a cut at ``rpm`` [rev/min] with ``teeth`` teeth (module docstring). ``tap``: the
    sensor path measured by a tap (:func:`millstab.listen.tap.sensor_path`, same sample rate): the chatter
    heard is then the line strongest as the source sounds (the path divided out) and the family's members are
    ranked by the recording's power over the path's weight instead of f⁴. The tap chooses the frequency
    reported, never the label: label, score, trend and onset are those of the recording heard without it (a
    quasi-periodic hump's lines differ by 1-2 dB, within the path's error; letting the tap pick the line whose
    trend labels the cut heard bench_listen --seed 0 cut 25, a chatter, stable)."""
    if tap is not None and abs(float(tap.fs) - float(fs)) > 1e-9 * fs:
        raise InputError("tap: sample rate", f"{tap.fs:g} Hz", f"the cut's, {fs:g} Hz: a tap recorded by another "
                         "chain does not measure the cut's sensor path")
    res = _listen(signal, fs, rpm, teeth, start, end, structure, None)
    if tap is None or res.label == "stable":
        return res
    heard = _listen(signal, fs, rpm, teeth, start, end, structure, tap)
    if heard.label == "stable" or not math.isfinite(heard.chatter_hz):
        return res
    return replace(res, chatter_hz=heard.chatter_hz)


def _listen(signal, fs: float, rpm: float, teeth: int, start, end, structure, tap) -> Listening:
    """:func:`listen` with the path of ``tap`` (None: flat, f⁴) in every step."""
    x, dur = _check(signal, float(fs), float(rpm), teeth, start, end)
    weight = _f4 if tap is None else (lambda ff: tap.weight(ff, structure))
    f_hi = min(0.45 * fs, F_HI)
    f_t0 = teeth * rpm / 60.0
    i0, i1 = cut_window(x, fs, f_t0, start, end)
    if (i1 - i0) < 1024 or (i1 - i0) < MIN_CUT_S * fs:
        given = start is not None or end is not None
        raise InputError("--start/--end" if given else "recording", f"a cut of {(i1 - i0) / fs:.3g} s",
                         f"a cut window of at least {MIN_CUT_S:g} s and 1024 samples (shorter, the spectrum is one "
                         "periodogram and its line masks cover it: no label can be heard; record 1 s or more)")
    notes: list[str] = []
    w = x[i0:i1] - x[i0:i1].mean()
    f, p, nper = _welch(w, fs)
    n_avg = (w.size - nper) // max(nper // 2, 1) + 1
    if n_avg < MIN_AVERAGES:
        notes.append(f"short: a cut of {w.size / fs:.2f} s gives {n_avg} spectrum averages (< {MIN_AVERAGES}: the "
                     "prominence test's noise odds are not met), so the label is less sure; record 1 s or more")
    df = f[1] - f[0]
    band = (f >= F_LO) & (f <= f_hi)
    fF, pF = _full_spectrum(w, fs)
    floor_allF = np.interp(fF, f, _floor(f, p, np.zeros(f.size, bool)))
    f_s = _spindle_hz(fF, pF, floor_allF, rpm / 60.0, teeth, f_hi)
    f_s = _refine_spindle(w, fs, f_s, f_hi)
    f_t = teeth * f_s
    # synchronous masks: every spindle harmonic
    half = LINE_BINS * fs / nper  # Hz
    ks = np.arange(1, int(f_hi / f_s) + 2)
    dfs = 2e-4 * f_s  # uncertainty of the refined spindle frequency (measured: < 1e-4 on 2 s windows)
    line_f = ks * f_s
    sync = np.zeros(f.size, bool)
    # mask by ranges (cheap): bins within half + k·dfs of each line
    lo = np.searchsorted(f, line_f - half - ks * dfs)
    hi = np.searchsorted(f, line_f + half + ks * dfs, side="right")
    line_pow = np.zeros(ks.size)
    for j in range(ks.size):
        sync[lo[j]:hi[j]] = True
        if hi[j] > lo[j]:
            line_pow[j] = p[lo[j]:hi[j]].max()
    # flip candidates: odd multiples of f_T/2 (even teeth only) from 1.5 f_T up, far above the runout
    keep = np.zeros(ks.size, bool)
    over_runout = keep
    if teeth % 2 == 0:
        # the runout lines below any flip candidate (1.5 f_T itself is a candidate: flip chatter of a
        # two-tooth slot sits there, at 3 f_s; measured: 4 of 38 chatter cuts of bench_listen at 100 cuts)
        below = line_f < (1.5 * teeth - 0.5) * f_s
        runout = (ks % teeth != 0) & below
        ref = float(line_pow[runout].max()) if runout.any() else 0.0
        half_order = 2 * ks / teeth  # line frequency in units of f_T/2
        odd = (np.abs(half_order - np.round(half_order)) < 1e-9) & (np.round(half_order) % 2 == 1)
        # ... and not far under its neighbouring tooth-passing lines: runout that varies the tooth pulses'
        # heights by ±e puts (e/2)² of a tooth harmonic's power beside it (−16 dB for e = 30 %), but a
        # resonance between two tooth harmonics lifts it (Q = 25: up to 28 dB; measured on the pulse-train
        # recordings of tests/listen_shop.py, a stable two-tooth cut heard as flip chatter below −5 dB)
        kt = ks // teeth * teeth  # the tooth harmonic below each line (in spindle orders)
        pw = dict(zip(ks.tolist(), line_pow.tolist()))
        near_tooth = np.array([max(pw.get(int(a), 0.0), pw.get(int(a) + teeth, 0.0)) for a in kt])
        over_runout = odd & ~below & (line_pow > FLIP_RATIO * ref)
        keep = over_runout & (line_pow > FLIP_TOOTH * near_tooth)
        if tap is not None:
            # with a tap, a line also passes both tests as the source sounds (the path's comb divided out: a flip
            # line in a room notch 19 dB deep stood under the runout test, bench_listen --seed 1 cut 145); the tap
            # adds flip candidates, never takes one away (the tests were set on recordings: taking the equalised
            # tests alone masked a flip chatter's members, --seed 1 cut 175)
            src = line_pow * _f4(line_f) / np.maximum(weight(line_f), 1e-300)
            ref_s = float(src[runout].max()) if runout.any() else 0.0
            pw_s = dict(zip(ks.tolist(), src.tolist()))
            near_s = np.array([max(pw_s.get(int(a), 0.0), pw_s.get(int(a) + teeth, 0.0)) for a in kt])
            over_s = odd & ~below & (src > FLIP_RATIO * ref_s)
            keep = keep | (over_s & (src > FLIP_TOOTH * near_s))
            over_runout = over_runout | over_s
        for j in np.flatnonzero(keep):
            sync[lo[j]:hi[j]] = False
    spindle_pow = line_pow  # (line_pow is the chatter line's power further down)
    # mains lines
    floor0 = _floor(f, p, sync)
    # no line at any spindle harmonic (tooth passing or runout): noise, hum, another machine, or a speed far off;
    # a "stable" and a "speed heard" would be made up (an all-noise file was "stable" at 9121 rpm heard)
    lf0 = np.interp(line_f, f, floor0)
    if not np.any((line_pow >= PROMINENCE * lf0) & (line_f <= f_hi)):
        raise InputError("recording", "no tooth-passing sound", f"a recording of the cut: no line at a harmonic of "
                         f"the spindle frequency {rpm / 60.0:.4g} Hz ({rpm:g} rpm; teeth or runout) stands "
                         f"{10 * math.log10(PROMINENCE):.0f} dB over the noise (noise only, or the speed far off?)")
    mains = []
    mask = sync.copy()
    for fm in MAINS:
        hum = 0.0
        for h in range(1, MAINS_HARMONICS + 1):
            fh = h * fm
            if fh > f_hi:
                break
            a = np.searchsorted(f, fh - 0.3 - df)
            b = np.searchsorted(f, fh + 0.3 + df, side="right")
            top = p[a:b].max() if b > a else 0.0
            if h <= 3:
                hum = max(hum, top)
            elif top > MAINS_OVER_HUM * hum:
                continue  # far louder than the hum itself: not hum
            if b > a and top > MAINS_PROMINENCE * floor0[a:b].max():
                if not np.any(np.abs(ks[keep] * f_s - fh) < half):
                    ma = np.searchsorted(f, fh - 0.3 - half)
                    mb = np.searchsorted(f, fh + 0.3 + half, side="right")
                    mask[ma:mb] = True
                    if fm not in mains:
                        mains.append(fm)
    floor = _floor(f, p, mask)
    # chatter candidates: the Welch spectrum's peaks outside the masks ...
    excess = np.where(mask | ~band, 0.0, p - floor)
    ratio = np.where(mask | ~band, 0.0, p / floor)
    peaks = np.flatnonzero((excess[1:-1] >= excess[:-2]) & (excess[1:-1] >= excess[2:]) &
                           (ratio[1:-1] >= PROMINENCE)) + 1
    # ... and the full-window spectrum's peaks inside them, beside the line that was masked
    mains_lines = [h * fm for fm in mains for h in range(1, MAINS_HARMONICS + 1) if h * fm <= f_hi]
    near = _near_line_peaks(fF, pF, np.interp(fF, f, floor), np.interp(fF, f, mask.astype(float)) > 0.5,
                            line_f[~keep], ks[~keep] * dfs, np.asarray(mains_lines), T=w.size / fs, f_lo=F_LO,
                            f_hi=f_hi)
    # one list, in Welch-density units: a line's peak density is its power / the noise bandwidth
    to_welch = float(nper) / w.size  # ENBW of the Welch segment / ENBW of the full window (Hz)
    dfF = fF[1] - fF[0]
    # ... and, within a spindle line's own main lobe, the lines left when the steady synchronous lines are
    # fitted at their exact frequencies and taken out
    k_in = ks[~keep][(ks[~keep] * f_s >= F_LO - 10.0) & (ks[~keep] * f_s <= f_hi + 10.0)]
    Xr, _, T_r, nu = _sync_residual(w, fs, f_s, k_in)
    fb, pb, flb = _beside_sync_peaks(Xr, fs, T_r, nu, lambda ff: np.interp(ff, f, floor), F_LO, f_hi,
                                     np.asarray(mains_lines))
    n_r = 2 * (Xr.size - 1)
    cand_f = np.concatenate([f[peaks], fF[near], fb])
    cand_e = np.concatenate([excess[peaks], (pF[near] - np.interp(fF[near], f, floor)) * to_welch,
                             (pb - flb) * (float(nper) / n_r)])
    sync_pow = float(np.sum(np.where(sync & (f <= f_hi), np.maximum(p - floor, 0.0), 0.0)) * df)
    nan = float("nan")
    n_fr = int(np.clip(w.size / fs / TREND_FRAME_S, TREND_FRAMES, 4 * TREND_FRAMES))
    if cand_f.size == 0:
        times = np.zeros(0)
        return Listening("stable", nan, 0.0, nan, nan, nan, float(rpm), float(60.0 * f_s), int(teeth), float(f_t),
                         (i0 / fs, i1 / fs), tuple(mains), float(fs), f, p, floor, mask, times, np.zeros(0),
                         tuple(notes))
    g2 = None if structure is None else _flexibility(structure)
    # the chatter heard: the strongest line (with a tap, as the source sounds: the path's comb divided out)
    src_e = cand_e if tap is None else cand_e * _f4(cand_f) / np.maximum(weight(cand_f), 1e-300)
    w_tap = None if tap is None else weight  # None: f⁴, exactly as without a tap
    c = _family_member(cand_f, cand_e, int(np.argmax(src_e)), f_t, 2.0 * fs / nper, f_s, w_tap)
    lpF = np.log(np.maximum(pF, 1e-300))
    # flip chatter heard at an odd multiple of f_T/2: the other odd multiples standing FLIP_RATIO over the
    # runout join its family even when under FLIP_TOOTH of their tooth lines (that rule keeps resonant
    # runout from being heard as chatter; here the chatter is established by another member)
    extra = np.flatnonzero(over_runout & ~keep & (line_f <= f_hi))
    n_std = cand_f.size
    added = np.zeros(0, int)  # the spindle lines (indices into line_f) appended to the candidates

    def on_flip(fr: float) -> bool:
        return abs(fr / (0.5 * f_t) - 2 * round((fr / (0.5 * f_t) - 1) / 2) - 1) * 0.5 * f_t <= 2.0 * fs / nper

    def append(idx: np.ndarray) -> None:
        nonlocal cand_f, cand_e, added
        ex_f = np.array([_refine(fF, lpF, float(line_f[j]), 2.0 * fs / nper) for j in idx])
        ex_e = np.maximum(spindle_pow[idx] - np.interp(line_f[idx], f, floor), 0.0)
        cand_f, cand_e = np.concatenate([cand_f, ex_f]), np.concatenate([cand_e, ex_e])
        added = np.concatenate([added, idx])

    if extra.size and on_flip(float(cand_f[c])):
        append(extra)
        c = _family_member(cand_f, cand_e, int(np.argmax(src_e[:n_std])), f_t, 2.0 * fs / nper, f_s, w_tap)
    if g2 is not None and teeth % 2 == 0:
        if on_flip(float(cand_f[c])):
            # with the structure known, every odd multiple of f_T/2 from 1.5 f_T up is a member of the flip
            # chatter heard, whatever its level against the runout: a sensor's path can notch the member at
            # the mode 13-19 dB (bench_listen --seed 1 cut 96: 2.5 f_T, the displacement's peak, in a notch
            # of the room 17.6 dB deeper than at 1.5 f_T, under the runout test, so never a candidate)
            heard_at = np.min(np.abs(line_f[:, None] - cand_f[None, :]), axis=1) <= 2.0 * fs / nper
            more = np.flatnonzero(odd & ~below & (line_f <= f_hi) & ~heard_at)
            if more.size:
                append(more)
        c = _flip_member_at_mode(cand_f, cand_e, c, f_t, 2.0 * fs / nper, g2)
    f_report = None
    if c >= n_std:  # a flip line on a spindle harmonic (on the Welch spectrum: its mask's largest bin)
        jx = int(added[c - n_std])
        fl0 = float(np.interp(line_f[jx], f, floor))
        prom = float(line_pow[jx] / fl0)
        line_pow = float(line_pow[jx] - fl0) * ENBW_BINS * fs / nper
        fc = float(cand_f[c])
    elif c < peaks.size:
        j = int(peaks[c])
        prom = float(ratio[j])
        # the line's power: its contiguous region above twice the floor (a modulated chatter is a hump)
        a_ = j
        while a_ > 0 and not mask[a_ - 1] and p[a_ - 1] > 2.0 * floor[a_ - 1]:
            a_ -= 1
        b_ = j + 1
        while b_ < f.size and not mask[b_] and p[b_] > 2.0 * floor[b_]:
            b_ += 1
        # ... or, for a line next to a masked one, its peak density × the window's noise bandwidth
        line_pow = max(float(np.sum(p[a_:b_] - floor[a_:b_])) * df,
                       float(p[j] - floor[j]) * ENBW_BINS * fs / nper)
        # refine on the full-window spectrum (finer bins); a spread hump: its centroid
        lp = np.log(np.maximum(p, 1e-300))
        fc = _refine(fF, lpF, float(f[j] + _interp_peak(lp, j) * df), fs / nper)
        hump = _hump_centroid(f, p, floor, mask, j)
        if hump is not None:  # reported; the trend stays on the hump's loudest line
            f_report, h_lo, h_hi = hump
            if teeth % 2 == 0:  # even teeth: a hump spread about an odd multiple of f_T/2 is flip chatter
                fl_ = (2 * round((f_report / (0.5 * f_t) - 1) / 2) + 1) * 0.5 * f_t
                if abs(fl_ - f_report) <= HUMP_FLIP * (h_hi - h_lo):
                    f_report = fl_
    elif c >= peaks.size + near.size:  # beside a spindle line: on the residual
        i = c - peaks.size - near.size
        prom = float(pb[i] / flb[i])
        line_pow = float(pb[i] - flb[i]) * ENBW_BINS / T_r
        fc = float(fb[i])
    else:
        jF = int(near[c - peaks.size])
        fl = float(np.interp(fF[jF], f, floor))
        prom = 1.0 + float(cand_e[c]) / fl
        line_pow = float(pF[jF] - fl) * ENBW_BINS * fs / w.size  # the full window's noise bandwidth
        fc = float(fF[jF] + _interp_peak(lpF, jF) * dfF)
    # short-time amplitude at fc, with the steady lines beside it taken out first (a hum or runout line
    # a few Hz away leaks into 0.1 s frames and hides the growth of a chatter that starts late)
    reach = TREND_REACH * n_fr * fs / w.size
    lines = np.concatenate([line_f[~keep], np.asarray(mains_lines)])
    tols = np.concatenate([ks[~keep] * dfs, np.full(len(mains_lines), 0.3)])
    near_fc = (np.abs(lines - fc) < reach) & (np.abs(lines - fc) > NEAR_BINS * fs / w.size)
    if peaks.size + near.size <= c < n_std:  # the spindle lines fitted at their exact frequencies are out already
        from scipy import fft as sfft

        wt = sfft.irfft(Xr, n_r)
    elif near_fc.any():
        wt = _without_lines(w, fs, fF, pF, np.interp(fF, f, floor), lines[near_fc], tols[near_fc])
    else:
        wt = w
    amp, tc, tf = _amp_at(wt, fs, fc, n_fr)
    noise_amp = math.sqrt(2.0 * float(np.interp(fc, f, floor)) * 1.5 / tf)  # Hann ENBW 1.5 bins of 1/tf
    a_c = np.sqrt(np.maximum(amp**2 - noise_amp**2, 0.0))
    m = max(1, int(round(0.2 * n_fr)))
    early, late = float(np.median(a_c[:m])), float(np.median(a_c[-m:]))
    late_part = a_c[-max(1, int(round(LATE_SHARE * n_fr))):]
    all_rms = float(np.sqrt(np.mean(a_c**2)))
    late_gain = float(np.sqrt(np.mean(late_part**2))) / all_rms if all_rms > 0 else 1.0
    score = math.sqrt(line_pow / sync_pow) * late_gain if sync_pow > 0 else math.inf
    trend = late / early if early > 0 else (math.inf if late > 0 else 1.0)
    onset = nan
    if trend > ONSET_RATIO:
        k = int(np.argmax(a_c >= 0.5 * late))
        t_k = float(tc[k])
        if k > 0:  # linear interpolation of the crossing between frame centres
            a0, a1 = a_c[k - 1], a_c[k]
            t_k = float(tc[k - 1] + (tc[k] - tc[k - 1]) * (0.5 * late - a0) / (a1 - a0))
        onset = i0 / fs + t_k
    if trend > ONSET_RATIO:
        label = "chatter"  # a line growing fourfold within the cut: chatter building up, however weak yet
    elif trend < DECAY or score < SCORE_MARGINAL:
        label = "stable"  # the ringing of a transient, or a line too weak to mark the surface
    elif score >= SCORE_CHATTER:
        label = "chatter"
    else:
        label = "marginal"
    if f_report is not None:
        fc = f_report
    if label == "chatter" and c < n_std:
        fc = _flip_over_heard(fc, float(cand_e[c]), f_t, 2.0 * fs / nper, line_f, spindle_pow, over_runout & ~keep,
                              lambda ff: np.interp(ff, f, floor), fF, lpF, f_hi, w_tap)
    if label != "stable":
        notes += _harmonic_checks(fc, rpm, f_s, teeth, 2.0 * fs / nper, fF, pF, floor_allF, f_hi, spindle_pow, lf0)
    # Python floats, not numpy scalars (a numpy bool from comparing them is never ``is False``: bench_listen went
    # blind to a miss that way)
    return Listening(label, float(fc), float(score), 10 * math.log10(prom), float(onset), float(trend), float(rpm),
                     float(60.0 * f_s), int(teeth), float(f_t), (i0 / fs, i1 / fs), tuple(mains), float(fs), f, p,
                     floor, mask,
                     i0 / fs + tc, a_c, tuple(notes))


def _harmonic_checks(fc: float, rpm: float, f_s: float, teeth: int, tol: float, fF: np.ndarray, pF: np.ndarray,
                     floorF: np.ndarray, f_hi: float, line_pow: np.ndarray, line_floor: np.ndarray) -> list[str]:
    """Notes on a chatter (or marginal) line heard at ``fc`` [Hz] that sits on a harmonic of the spindle; raises
    InputError where the recording shows the speed ``rpm`` [rev/min] or the ``teeth`` given to be wrong.

    Regenerative chatter is never at a harmonic of the tooth-passing frequency: there the teeth meet the wave
    of the tooth before in phase, the top of a lobe, the stablest speed. So a line heard on the harmonic of a
    spindle is that spindle's own (forced vibration, runout), heard because the speed or teeth given put the
    masks elsewhere, or because its level changed within the window (air, an entry inside it):

    * another speed within ±SPEED_WIDE (:func:`_speed_elsewhere`: its comb outscores the speed heard's by a
      line 35 dB over the floor) with ``fc`` on one of its harmonics (± ``tol`` [Hz]): refused, the lines are
      another speed's (a 103 % override, 9270 rpm given as 9000, was "chatter at 309.0 Hz", its tooth line);
      that speed with ``fc`` elsewhere: a note (the chatter line stands; the masks and suggestion do not);
    * ``fc`` on the spindle harmonic m f_s (f_s [Hz], the speed heard) where m is no multiple of the teeth, and
      for some other count n (2 to max(2 N, 8), m a multiple of n) the first three lines of n teeth (k n f_s)
      are all lines (``line_pow`` over ``line_floor``, Welch, index k - 1 for k f_s) 6 dB over every line
      of N teeth that n teeth do not share, which are no more than 6 dB over the runout at f_s: refused, the
      cutter has n teeth (a 3-flute cut given 2 was flip "chatter" at 1.5 f_T = 450 Hz, its tooth line; a
      real flip chatter leaves the tooth lines of N, the forced vibration, far over the runout);
    * ``fc`` on a tooth-passing harmonic of the speed heard: a note (a line whose level changes within the
      window, its skirts heard as a hump about it)."""
    notes = []
    pct = lambda f_: 100.0 * (f_ / (rpm / 60.0) - 1.0)  # noqa: E731
    f_w = _speed_elsewhere(fF, pF, floorF, rpm / 60.0, f_s, teeth, f_hi)
    if f_w is not None:
        m = max(1, round(fc / f_w))
        if abs(fc - m * f_w) <= tol:
            raise InputError("--rpm", rpm, f"the spindle's speed: the recording's lines are the harmonics of "
                             f"{60 * f_w:.0f} rpm ({pct(f_w):+.1f} %, beyond the ±{100 * SPEED_TOL:g} % listen "
                             f"searches), and the line heard at {fc:.1f} Hz is one of them ({m} × {f_w:.2f} Hz), "
                             "no chatter: give the speed the spindle ran at (an override?) or check --teeth")
        notes.append(f"the spindle lines fit {60 * f_w:.0f} rpm ({pct(f_w):+.1f} % from {rpm:g}) better than the "
                     "speed given: check --rpm (an override?); the line heard is none of theirs, but the masks and "
                     "the suggested speed are the given speed's")
    m = round(fc / f_s)
    if m < 1 or abs(fc - m * f_s) > tol:
        return notes
    if m % teeth == 0:
        return notes + [f"heard at {fc:.1f} Hz, the tooth-passing harmonic {m // teeth} × {teeth * f_s:.2f} Hz: "
                        "regenerative chatter is never there; the forced vibration's level changing within the "
                        "window (air or the entry in it? give --start/--end) is heard so"]
    P = lambda k: float(max(line_pow[k - 1] - line_floor[k - 1], 0.0)) if k <= line_pow.size else 0.0  # noqa: E731
    floor_at = lambda k: float(line_floor[k - 1]) if k <= line_floor.size else math.inf  # noqa: E731
    for n in range(2, max(2 * teeth, 8) + 1):
        if n == teeth or m % n or 3 * n * f_s > f_hi:
            continue
        own = [P(k * n) for k in (1, 2, 3)]
        theirs = [k * teeth for k in (1, 2, 3) if (k * teeth) % n and k * teeth * f_s <= f_hi]
        if not theirs or min(own) < (PROMINENCE - 1.0) * min(floor_at(k * n) for k in (1, 2, 3)):
            continue
        top = max(P(k) for k in theirs)
        if min(own) >= FLIP_RATIO * top and top <= FLIP_RATIO * max(P(1), PROMINENCE * floor_at(teeth)):
            raise InputError("--teeth", teeth, f"the cutter's teeth: the recording's lines are those of {n} teeth "
                             f"({n} × {f_s:.2f} Hz = {n * f_s:.1f} Hz and its harmonics), the tooth-passing line of "
                             f"{teeth} ({teeth * f_s:.1f} Hz) no louder than the runout, and the line heard at "
                             f"{fc:.1f} Hz is one of theirs, no chatter: give --teeth {n}?")
    return notes


def _flip_over_heard(fc: float, e_c: float, f_t: float, tol: float, line_f: np.ndarray, line_pow: np.ndarray,
                     flip: np.ndarray, floor_hz, fF: np.ndarray, lpF: np.ndarray, f_hi: float, weight=None) -> float:
    """The frequency to report [Hz] when chatter is heard at ``fc`` (excess density ``e_c``), not on an odd
    multiple of f_T/2, while a flip line (``flip``: odd multiples of f_T/2 from 1.5 f_T up standing
    ``FLIP_RATIO`` over the runout, masked only by the ``FLIP_TOOTH`` rule) is stronger in displacement
    (excess / f⁴): that flip line. The ``FLIP_TOOTH`` rule keeps resonant runout from being heard as chatter
    on its own; once the cut is chatter by another line, a period-doubling line over the runout and stronger
    in the tool's motion is the chatter (bench_listen --seed 2, cut 145: a two-tooth flip at 1.5 f_T, 9 dB
    over every other line of the displacement, 8 dB under its tooth line f_T in the recording, had the
    weaker quasi-periodic hump near the mode heard instead)."""
    half = 0.5 * f_t
    ho = fc / half
    if abs(ho - (2 * round((ho - 1) / 2) + 1)) * half <= tol:
        return fc  # heard on a flip member already
    idx = np.flatnonzero(flip & (line_f <= f_hi))
    if idx.size == 0:
        return fc
    e = np.maximum(line_pow[idx] - floor_hz(line_f[idx]), 0.0)
    d = e / (line_f[idx] ** 4 if weight is None else weight(line_f[idx]))
    j = int(np.argmax(d))
    if d[j] <= (e_c / fc**4 if weight is None else e_c / float(weight(np.array([fc]))[0])):
        return fc
    return _refine(fF, lpF, float(line_f[idx[j]]), tol)


def _hump_centroid(f: np.ndarray, p: np.ndarray, floor: np.ndarray, mask: np.ndarray,
                   j: int) -> tuple[float, float, float] | None:
    """(power-weighted mean frequency, lower and upper end) [Hz] of the hump around Welch bin j when the
    chatter is spread over it (a modulated chatter: several comparable lines), else None (the peak is
    the frequency).

    The hump: the bins above ``HUMP_LEVEL`` × the floor around j, stepping over masked synchronous bins
    (a flip chatter's hump is centred on a spindle line); its masked bins do not count. Spread: the
    peak's ±2 segment bins (4 bins here: a single Blackman-Harris line keeps > 90 % of its power there)
    hold less than ``HUMP_SHARE`` of the hump's excess, and the hump has at least ``HUMP_LINES`` local
    maxima of at least a quarter of the peak's excess. Why: two-tooth flip chatter in the virtual
    shop (bench_listen seed 0, cuts 25 and 36) was not a period-2 line but a quasi-periodic hump
    (±25 Hz and 840-1055 Hz wide, lines 2-4 Hz apart) about 1.5 f_T, its loudest line 8-10 Hz from the
    simulation's frequency (the peak of its last 64 tooth periods: the frequency at the end of the
    cut); the centroids were 3.5 and 13 Hz from it, 1.5 f_T itself 0.3 and 4.6 Hz (hence, with an even
    number of teeth, the odd multiple of f_T/2 within ``HUMP_FLIP`` of the hump's width of the
    centroid is reported: the frequency of period doubling, which the modulation spreads)."""
    n = f.size
    ex = np.maximum(p - floor, 0.0)
    up = p > HUMP_LEVEL * floor

    def walk(i: int, step: int) -> int:
        while 0 <= i + step < n:
            q = i + step
            if mask[q]:
                while 0 <= q < n and mask[q]:
                    q += step
                if not (0 <= q < n and up[q]):
                    break
            elif not up[q]:
                break
            i = q
        return i

    a, b = walk(j, -1), walk(j, 1) + 1
    sel = np.arange(a, b)[~mask[a:b]]
    tot = float(ex[sel].sum())
    if tot <= 0:
        return None
    near = sel[np.abs(sel - j) <= 4]
    exs = np.where(mask[a:b], 0.0, ex[a:b])
    lines = int(np.sum((exs[1:-1] >= exs[:-2]) & (exs[1:-1] >= exs[2:]) & (exs[1:-1] >= 0.25 * ex[j])))
    if float(ex[near].sum()) >= HUMP_SHARE * tot or lines < HUMP_LINES:
        return None
    return float(np.sum(f[sel] * ex[sel]) / tot), float(f[a]), float(f[b - 1])


def _flexibility(structure):
    """f [Hz] → Σ_ij |G_ij(f)|² [m²/N²] of the structure's receptance (:func:`millstab.frf.structure_receptance`);
    0 outside a measured FRF's band."""
    from millstab.frf import structure_receptance

    def g2(f: np.ndarray) -> np.ndarray:
        f = np.asarray(f, float)
        inside = np.ones(f.size, bool)
        if structure.frf is not None:
            inside = (f >= structure.frf.freq_hz[0]) & (f <= structure.frf.freq_hz[-1])
        out = np.zeros(f.size)
        if inside.any():
            out[inside] = np.sum(np.abs(structure_receptance(structure, f[inside])) ** 2, axis=(1, 2))
        return out

    return g2


def _f4(f):
    """The flat sensor path's weight: recording power per displacement power ∝ f⁴ (acceleration)."""
    return np.asarray(f, float) ** 4


def _family_member(fpk: np.ndarray, epk: np.ndarray, j: int, f_t: float, tol: float, f_s: float,
                   weight=None) -> int:
    """Of the chatter family fpk[j] + k f_T (|k| ≤ FAMILY_ORDERS) and its mirrors k f_T − fpk[j] (1 ≤ k ≤
    FAMILY_ORDERS) among the candidate peaks (frequencies fpk [Hz], excess densities epk), the index of the
    member strongest in displacement: excess power / f⁴ (both sensors follow acceleration, whose power is
    f⁴ times the displacement's), counting the first-order sidebands |fpk[j] ± f_T| and lines on a spindle
    harmonic (k f_s, f_s [Hz]: a flip candidate, runout perhaps) with at least FAMILY_SHARE of the
    strongest's excess and the other members with at least FAMILY_SHARE_FAR. ``weight`` (f → recording power
    per displacement power, a tap's path: :mod:`millstab.listen.tap`) replaces f⁴; the shares are then taken
    on the power with the path's comb divided out (weight / f⁴), as the source sounds."""
    k = (fpk - fpk[j]) / f_t
    km = (fpk + fpk[j]) / f_t  # mirror members k f_T − f_j (the modulation's lower sidebands fold over)
    direct = (np.abs(k - np.round(k)) * f_t <= tol) & (np.abs(np.round(k)) <= FAMILY_ORDERS)
    mirror = (np.abs(km - np.round(km)) * f_t <= tol) & (np.round(km) >= 1) & (np.round(km) <= FAMILY_ORDERS)
    member = direct | mirror
    # where amplitude modulation of one tone puts its sidebands: f_j ± f_T (f_T − f_j folded when f_j < f_T)
    side = (direct & (np.abs(np.round(k)) == 1)) | (mirror & (np.round(km) == 1))
    ks = fpk / f_s
    on_sync = np.abs(ks - np.round(ks)) * f_s <= tol
    w = fpk**4 if weight is None else weight(fpk)
    src = epk if weight is None else epk * _f4(fpk) / w  # the power as the source sounds (the path's comb out)
    fam = np.flatnonzero(member & (src >= np.where(side | on_sync, FAMILY_SHARE, FAMILY_SHARE_FAR) * src[j]))
    if fam.size <= 1:
        return j
    return int(fam[np.argmax(epk[fam] / w[fam])])


def _flip_member_at_mode(fpk: np.ndarray, epk: np.ndarray, c: int, f_t: float, tol: float, g2) -> int:
    """With the structure known (``g2``: f → Σ|G_ij|²) and a flip chatter heard (fpk[c] an odd multiple of
    f_T/2): of the flip members heard (odd multiples of f_T/2 with at least FAMILY_SHARE_FAR of fpk[c]'s
    excess epk) the index of the one where the structure is most flexible; else c."""
    half = 0.5 * f_t
    ho = fpk / half
    odd = (np.abs(ho - np.round(ho)) * half <= tol) & (np.round(ho) % 2 == 1)
    if not odd[c]:
        return c
    fam = np.flatnonzero(odd & (epk >= FAMILY_SHARE_FAR * epk[c]))
    return int(fam[np.argmax(g2(fpk[fam]))])


def _full_spectrum(w: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """One-sided PSD of the whole window (Blackman-Harris, zero-padded twice: bins of 1/(2T)) and its
    frequencies: 4× finer than the Welch segments, to see a line a few Hz from a masked one and to refine
    the chatter frequency (on a Blackman-Harris main lobe, nearly Gaussian, a parabola through the
    log-power is within 1 % of a bin of the true frequency)."""
    from scipy import fft as sfft
    from scipy.signal import windows

    n = sfft.next_fast_len(2 * w.size, real=True)
    win = windows.blackmanharris(w.size, sym=False)
    spec = sfft.rfft(w * win, n)
    p = (spec.real**2 + spec.imag**2) * (2.0 / (fs * float(np.sum(win**2))))
    return np.arange(p.size) * (fs / n), p


def _near_line_peaks(fF: np.ndarray, pF: np.ndarray, floorF: np.ndarray, maskedF: np.ndarray,
                     line_f: np.ndarray, line_tol: np.ndarray, mains_f: np.ndarray, *, T: float, f_lo: float,
                     f_hi: float) -> np.ndarray:
    """Indices of full-window peaks that the Welch masks hid but that are lines of their own: inside a
    Welch mask, beyond ±NEAR_BINS/T of the masked line's own peak (sought within its frequency
    uncertainty: line_tol for the spindle harmonics, ±0.3 Hz for mains), NEAR_PROMINENCE over the floor,
    and parted from that line by a dip below 1/NEAR_DIP of the peak (a line, not the skirt of a
    wandering one)."""
    dfF = fF[1] - fF[0]
    half = int(NEAR_BINS / T / dfF)
    centres = np.concatenate([line_f, mains_f])
    tols = np.concatenate([line_tol, np.full(mains_f.size, 0.3)]) + 1.0 / T
    centres, tols = centres[centres <= f_hi + 10.0], tols[centres <= f_hi + 10.0]
    lo = np.searchsorted(fF, centres - tols)
    hi = np.searchsorted(fF, centres + tols, side="right")
    own = np.empty(centres.size, int)
    blocked = np.zeros(fF.size, bool)
    for i in range(centres.size):  # each masked line's own peak (a local maximum; else where it should be)
        own[i] = int(np.clip(np.searchsorted(fF, centres[i]), 0, fF.size - 1))
        if hi[i] - lo[i] > 2:
            m = lo[i] + int(np.argmax(pF[lo[i]:hi[i]]))
            if lo[i] < m < hi[i] - 1:
                own[i] = m
        blocked[max(own[i] - half, 0): own[i] + half + 1] = True
    cand = maskedF & ~blocked & (fF >= f_lo) & (fF <= f_hi) & (pF >= NEAR_PROMINENCE * floorF)
    cand[0] = cand[-1] = False
    idx = np.flatnonzero(cand)
    idx = idx[(pF[idx] >= pF[idx - 1]) & (pF[idx] >= pF[idx + 1])]
    keep = []
    for i in idx:  # parted from the nearest masked line by a dip
        o = int(own[np.argmin(np.abs(own - i))])
        a, b = (o, i) if o < i else (i, o)
        if pF[a:b + 1].min() * NEAR_DIP <= pF[i]:
            keep.append(i)
    return np.asarray(keep, dtype=int)


def _without_lines(w: np.ndarray, fs: float, fF: np.ndarray, pF: np.ndarray, floorF: np.ndarray,
                   lines: np.ndarray, tols: np.ndarray) -> np.ndarray:
    """The window w less the steady sinusoids at ``lines`` [Hz] (each sought within ± its tolerance + 1/T as
    a full-window peak NEAR_PROMINENCE over the floor, its frequency parabola-refined, its complex
    amplitude the Blackman-Harris-weighted projection over the whole window: a chatter line beyond the
    line's main lobe (±4/T) adds < −92 dB to it). Lines not standing out are left alone."""
    from scipy.signal import windows

    T = w.size / fs
    dfF = fF[1] - fF[0]
    lpF = np.log(np.maximum(pF, 1e-300))
    t = np.arange(w.size) / fs
    win = windows.blackmanharris(w.size, sym=False)
    out = w.copy()
    done: list[float] = []
    for fl, tol in zip(lines, tols):
        a = np.searchsorted(fF, fl - tol - 1.0 / T)
        b = np.searchsorted(fF, fl + tol + 1.0 / T, side="right")
        if b - a < 3:
            continue
        i = a + int(np.argmax(pF[a:b]))
        if not (a < i < b - 1) or pF[i] < NEAR_PROMINENCE * floorF[i]:
            continue
        f1 = float(fF[i] + _interp_peak(lpF, i) * dfF)
        if any(abs(f1 - d) < 1.0 / T for d in done):  # a line both a spindle and a mains harmonic
            continue
        done.append(f1)
        e = np.exp(-2j * math.pi * f1 * t)
        z = np.dot(win * out, e) / win.sum()
        out -= 2.0 * np.real(z * np.conj(e))
    return out


def _refine(fF: np.ndarray, lpF: np.ndarray, f0: float, span: float) -> float:
    """Frequency of the largest full-window log-PSD lpF within f0 ± span [Hz], parabola-refined (the Welch
    estimate f0 when the largest is at an edge: the slope of a neighbour, not a peak)."""
    dfx = fF[1] - fF[0]
    a = max(int((f0 - span) / dfx), 1)
    b = min(int((f0 + span) / dfx) + 1, lpF.size - 1)
    if b - a < 3:
        return f0
    i = a + int(np.argmax(lpF[a:b]))
    if i in (a, b - 1):
        return f0
    return float((i + _interp_peak(lpF, i)) * dfx)


#: Blackman-Harris (4-term) cosine coefficients: w_n = a0 - a1 cos(2πn/N) + a2 cos(4πn/N) - a3 cos(6πn/N)
_BH = (0.35875, 0.48829, 0.14128, 0.01168)


def _dirichlet(d: np.ndarray, n: int) -> np.ndarray:
    """DFT bin response of a unit complex tone ``d`` bins away over ``n`` samples (1 at d = 0)."""
    d = np.asarray(d, dtype=float)
    s = np.sin(np.pi * d / n)
    small = np.abs(s) < 1e-12
    ratio = np.where(small, 1.0, np.sin(np.pi * d) / (n * np.where(small, 1.0, s)))
    return ratio * np.exp(-1j * np.pi * d * (n - 1) / n)


def _whole_revolutions(size: int, fs: float, f_s: float) -> int:
    """Samples in a whole number of revolutions (at least 4) within ``size``, 0 if none: of the largest
    counts (down to 1/16 fewer revolutions, at most 64 fewer) the first with no prime factor above 13,
    else the one with the smallest remainder after those (a length with a large prime factor made each
    of the two DFTs of a 10 s, 48 kHz cut cost 110 ms instead of 20 ms)."""
    revs = math.floor(size * f_s / fs)
    if revs < 4:
        return 0
    best, best_rest = 0, math.inf
    for r in range(revs, max(4, revs - min(64, revs // 16)) - 1, -1):
        n = min(round(r * fs / f_s), size)
        rest = n
        for p in (2, 3, 5, 7, 11, 13):
            while rest % p == 0:
                rest //= p
        if rest == 1:
            return n
        if rest < best_rest:
            best, best_rest = n, rest
    return best


def _refine_spindle(w: np.ndarray, fs: float, f_s: float, f_hi: float) -> float:
    """The spindle frequency [Hz] refined on the unwindowed DFT of a whole number of revolutions of the
    window: each spindle harmonic in F_LO..f_hi is sought within ±``SYNC_SEARCH_BINS`` bins (of 1/T) of
    k f_s, placed to a fraction of a bin by its neighbours (a tone e bins off its bin b has
    X[b−1]/X[b] ≈ e, X[b+1]/X[b] ≈ −e), and f_s moves by the power-weighted least-squares fit of these
    offsets (e = k δ T) over the lines within a quarter bin of the offset most lines agree with."""
    from scipy import fft as sfft

    n = _whole_revolutions(w.size, fs, f_s)
    if n == 0:
        return f_s
    X = sfft.rfft(w[:n] - w[:n].mean())
    T = n / fs
    k = np.arange(max(1, math.ceil(F_LO / f_s)), int(f_hi / f_s) + 1)
    nu = k * f_s * T
    k, nu = k[nu + SYNC_SEARCH_BINS + 2 < X.size], nu[nu + SYNC_SEARCH_BINS + 2 < X.size]
    if k.size == 0:
        return f_s
    offs = np.arange(-SYNC_SEARCH_BINS, SYNC_SEARCH_BINS + 1)
    m = np.rint(nu).astype(int)[:, None] + offs[None, :]
    b = m[np.arange(k.size), np.argmax(np.abs(X[m]), axis=1)]
    x0 = X[b]
    pw = np.abs(x0) ** 2
    ok = pw > 0
    e = np.zeros(k.size)
    e[ok] = b[ok] + 0.5 * np.real((X[b - 1][ok] - X[b + 1][ok]) / x0[ok]) - nu[ok]
    med = max(float(np.median(np.abs(X) ** 2)), 1e-300)
    # lines, not noise: NEAR_PROMINENCE over the median bin (a recording without spindle lines keeps its speed)
    strong = ok & (pw >= SYNC_STRONG * pw.max()) & (pw >= NEAR_PROMINENCE * med)
    if not strong.any():
        return f_s
    # the offset most lines agree with (each line votes its log-prominence over the median bin, at most
    # COMB_CLIP: a strong chatter line beside a weak runout line is one vote, not a pull), then the
    # power-weighted least squares over the lines within a quarter bin of it
    vote = np.clip(np.log(pw / med), 0.0, COMB_CLIP)
    d = e[strong] / (k[strong] * T)
    agree = np.abs(e[strong][None, :] - np.outer(d, k[strong]) * T) <= 0.25
    d_med = float(d[np.argmax(agree.astype(float) @ vote[strong])])
    inl = strong & (np.abs(e - k * d_med * T) <= 0.25)
    wk = pw[inl] * k[inl] ** 2
    delta = float(np.sum(wk * e[inl] / k[inl]) / np.sum(wk)) / T if wk.sum() > 0 else d_med
    return f_s + delta


def _sync_residual(w: np.ndarray, fs: float, f_s: float,
                   k_lines: np.ndarray) -> tuple[np.ndarray, float, float, np.ndarray]:
    """The window less its steady spindle-synchronous lines k f_s (k in ``k_lines``), each fitted by least
    squares at its exact frequency (module docstring, step 7 "On a spindle line").

    The window is cut to a whole number R of revolutions (N samples): every spindle harmonic then sits on
    a bin (k R) of the unwindowed DFT, orthogonal to every other harmonic, and its least-squares fit is
    that bin's value (the rectangular window: the finest resolution, a tone δ Hz away leaks sinc(δT)
    into it, 0 at whole bins, −22 dB from 2.5 bins). The spindle frequency is refined first from the
    strong lines' own offsets (for a tone e bins off its bin, X[b∓1]/X[b] = ±e/(1±e): the speed found
    from the peaks is good to 1e-6, i.e. 0.01-0.07 bins at the 30th harmonic, which would leave a line
    60 dB over the floor standing 20-30 dB over it; refined, < 1e-3 bins). Each line is then removed as
    its Dirichlet pattern over ±``SYNC_FIT_BINS`` bins.

    Returns (residual DFT of the N samples, refined f_s [Hz], N / fs [s], line positions [bins])."""
    from scipy import fft as sfft

    n = _whole_revolutions(w.size, fs, f_s)
    if n == 0:  # too short to part anything from a line
        return sfft.rfft(w - w.mean()), f_s, w.size / fs, np.zeros(0)
    X = sfft.rfft(w[:n] - w[:n].mean())
    T = n / fs
    k = k_lines[(k_lines * f_s * T + SYNC_FIT_BINS + 2 < X.size)]
    if k.size == 0:
        return X, f_s, T, np.zeros(0)
    # refine f_s: offsets e_k = k δ T [bins] of the strong lines, weighted by their power
    b = np.rint(k * f_s * T).astype(int)
    x0, xm, xp = X[b], X[b - 1], X[b + 1]
    pw = np.abs(x0) ** 2
    ok = pw > 0
    e = np.zeros(k.size)
    e[ok] = 0.5 * np.real((xm[ok] - xp[ok]) / x0[ok]) - (k[ok] * f_s * T - b[ok])  # off the predicted place
    strong = ok & (pw >= SYNC_STRONG * pw.max())
    for _ in range(2):  # weighted fit of e = k δ T, then once more without the lines far off it (a chatter beside them)
        wk = pw[strong] * k[strong] ** 2
        delta = float(np.sum(wk * e[strong] / k[strong]) / np.sum(wk)) / T if wk.sum() > 0 else 0.0
        dev = np.abs(e - k * delta * T)
        strong = strong & (dev <= max(5.0 * float(np.median(dev[strong])), 1e-4)) if strong.sum() > 2 else strong
    f_s = f_s + delta
    nu = k * f_s * T
    b = np.rint(nu).astype(int)
    offs = np.arange(-SYNC_FIT_BINS, SYNC_FIT_BINS + 1)
    m = b[:, None] + offs[None, :]
    keep = (m.min(axis=1) >= 1) & (m.max(axis=1) < X.size)
    m, nu, b = m[keep], nu[keep], b[keep]
    kern = _dirichlet(m - nu[:, None], n)
    amp = X[b] / kern[:, SYNC_FIT_BINS]
    np.add.at(X, m.ravel(), -(amp[:, None] * kern).ravel())
    return X, f_s, T, nu


def _beside_sync_peaks(X: np.ndarray, fs: float, T: float, nu: np.ndarray, floor_hz, f_lo: float, f_hi: float,
                       mains_f: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Chatter lines within ±``NEAR_BINS`` + 1 bins (of 1/T) of a spindle line, on the Blackman-Harris
    spectrum of the residual (``_sync_residual``): a local maximum ``NEAR_PROMINENCE`` over the floor,
    at least ``SYNC_MIN_BINS`` from the line and ``SYNC_MIRROR`` times stronger than the point mirrored
    about it (what a removed line leaves, from a speed error or a slow amplitude drift, is symmetric
    about it; a chatter line beside it is not), and not a mains line (``mains_f`` [Hz], hum found: within
    0.3 Hz + SYNC_MIN_BINS/T). Returns (frequencies [Hz], PSDs, floors)."""
    a0, a1, a2, a3 = _BH
    n = 2 * (X.size - 1)
    reach = int(NEAR_BINS) + 2
    offs = np.arange(-reach - 3, reach + 4)
    m = np.rint(nu).astype(int)[:, None] + offs[None, :]
    ok = (m.min(axis=1) >= 3) & (m.max(axis=1) < X.size - 3)
    m, nu = m[ok], nu[ok]
    Y = (a0 * X[m] - 0.5 * a1 * (X[m - 1] + X[m + 1]) + 0.5 * a2 * (X[m - 2] + X[m + 2])
         - 0.5 * a3 * (X[m - 3] + X[m + 3]))
    p = np.abs(Y) ** 2 * (2.0 / (fs * n * (a0**2 + 0.5 * (a1**2 + a2**2 + a3**2))))
    f = m / T
    fl = floor_hz(f)
    inner = slice(1, -1)
    d = m - nu[:, None]
    loc = np.zeros(p.shape, bool)
    loc[:, inner] = (p[:, 1:-1] >= p[:, :-2]) & (p[:, 1:-1] >= p[:, 2:])
    mirror = np.empty_like(p)
    for r in range(p.shape[0]):  # the PSD at the point mirrored about the line
        mirror[r] = np.interp(2 * nu[r] - m[r], m[r], p[r])
    cand = (loc & (np.abs(d) >= SYNC_MIN_BINS) & (np.abs(d) <= reach) & (p >= NEAR_PROMINENCE * fl)
            & (p >= SYNC_MIRROR * mirror) & (f >= f_lo) & (f <= f_hi))
    r, c = np.nonzero(cand)
    fr = np.empty(r.size)
    for i in range(r.size):
        lp = np.log(np.maximum(p[r[i], c[i] - 1: c[i] + 2], 1e-300))
        fr[i] = (m[r[i], c[i]] + _interp_peak(lp, 1)) / T
    if mains_f.size and fr.size:
        hum = np.min(np.abs(fr[:, None] - mains_f[None, :]), axis=1) <= 0.3 + SYNC_MIN_BINS / T
        return fr[~hum], p[r, c][~hum], fl[r, c][~hum]
    return fr, p[r, c], fl[r, c]
