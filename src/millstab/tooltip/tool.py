"""A tool in a holder: the tool as a stepped Timoshenko beam (shank + fluted part), coupled to the holder
face by RCSA, and the tool-tip FRF as a :class:`~millstab.model.Structure` every measured-FRF engine takes.

The tool-tip structure is a :class:`~millstab.model.MeasuredFRF` (the same xx and yy: an axisymmetric tool
in a holder with the same face receptances in x and y) sampled on a grid built for it (:func:`tip_grid`):
log-spaced over the band plus dense clusters around every resonance, so a lightly damped peak is resolved
(spacing ≤ 5e-4·fn there, i.e. ≥ 40 points across the half-power band of ζ = 0.01). An FRF, not modes,
because a measured holder gives no modes; ``identify``, ``update`` and ``design`` fit modes to it as they do
for a measured tip FRF (issue 14).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from millstab.errors import FRFWarning, InputError
from millstab.model import MeasuredFRF, Structure
from millstab.tooltip.beam import DEFAULT_ELEMENTS, Beam, Material, Section, one_blas_thread
from millstab.tooltip.holder import Holder, RigidHolder, XYHolder
from millstab.tooltip.rcsa import couple
from millstab.warnlog import quiet, warn

#: equivalent-diameter ratio of the fluted part of an end mill when none is given: the value commonly used in
#: RCSA work for 2–4 flute tools (Kops & Vo, CIRP Annals 1990, derived about 0.8 D from the bending compliance
#: of end mills). A per-flute-count table is not established in the public literature we have (the ratio
#: varies more with the flute geometry than with the count), so one default serves every count
DEFAULT_FLUTE_RATIO = 0.8


@dataclass(frozen=True)
class Tool:
    """An end mill: ``diameter`` [m], ``stickout`` [m] (holder face to tip), ``fluted_length`` [m] (0: none
    modelled), ``flute_ratio`` (equivalent diameter of the fluted part / diameter), ``material``, ``zeta``
    (resonant damping ratio of the tool's modes, as a loss factor η = 2ζ)."""

    diameter: float
    stickout: float
    material: Material
    fluted_length: float = 0.0
    flute_ratio: float = DEFAULT_FLUTE_RATIO
    zeta: float = 0.0
    elements: int = DEFAULT_ELEMENTS

    def __post_init__(self) -> None:
        if not (math.isfinite(self.diameter) and self.diameter > 0):
            raise InputError("tool.diameter", self.diameter, "must be > 0 m")
        if not (math.isfinite(self.stickout) and self.stickout > 0):
            raise InputError("tool.stickout", self.stickout, "must be > 0 m (holder face to tip)")
        if not (math.isfinite(self.fluted_length) and self.fluted_length >= 0):
            raise InputError("tool.fluted_length", self.fluted_length, "must be >= 0 m")
        if not 0.3 <= self.flute_ratio <= 1.0:
            raise InputError("tool.flute_diameter_ratio", self.flute_ratio, "must be in [0.3, 1] (typically ~0.8)")
        if not 0.0 <= self.zeta < 0.5:
            raise InputError("tool.zeta", self.zeta, "tool damping ratio must be in [0, 0.5)")

    def at(self, stickout: float) -> Tool:
        """The same tool at another stickout [m] (the fluted length is kept, clipped to the stickout)."""
        return replace(self, stickout=stickout)

    def beam(self) -> Beam:
        """The tool from the holder face to the tip: shank, then the fluted part as its equivalent solid."""
        fl = min(self.fluted_length, self.stickout)
        secs = []
        if self.stickout - fl > 1e-9 * self.stickout:
            secs.append(Section(self.stickout - fl, self.diameter, self.material))
        if fl > 0:
            secs.append(Section(fl, self.diameter * self.flute_ratio, self.material))
        return Beam(tuple(secs), eta=2.0 * self.zeta, elements=self.elements)


def tip_receptance(tool: Tool, holder: Holder, freq_hz: np.ndarray) -> np.ndarray:
    """The tool-tip receptance w/f [m/N] at ``freq_hz`` (F,): the tool coupled to ``holder`` by RCSA."""
    with one_blas_thread():
        return _tip_receptance(tool, holder, np.asarray(freq_hz, dtype=float))


def _tip_receptance(tool: Tool, holder: Holder, f: np.ndarray) -> np.ndarray:
    beam = tool.beam()
    if isinstance(holder, RigidHolder):  # clamped: the modes of the clamped tool directly (same result)
        last = 2 * (beam.mesh()[0].size - 1)
        return beam.receptance(f, [last], clamped=True)[:, 0, 0]
    return couple(beam.end_receptances(f), holder.receptance(f))[:, 0, 0]


#: background points of the tip grid, and the dense points per resonance (±0.05·fn and ±0.25·fn)
N_BACKGROUND, N_PEAK, N_SKIRT = 1200, 201, 61
#: a resonance stands out of |G| by at least this factor on both sides (a measured holder's noise does not)
PROMINENCE = 1.1
#: ... and is the strongest within this relative distance (noise near a resonance of a measured holder is not)
SEPARATION = 0.03
#: ... and reaches this share of the largest |g| (noise at an anti-resonance of a measured holder is far below)
FLOOR = 0.01
#: the most resonances refined per tip grid (the strongest)
MAX_PEAKS = 30


def _resonances(f: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Indices of the resonances of |g|, strongest first: local maxima that stand out by :data:`PROMINENCE`,
    reach :data:`FLOOR` of the largest |g| and are the strongest within ±:data:`SEPARATION`·f."""
    from scipy.signal import find_peaks

    a = np.log(np.abs(g))
    i, _ = find_peaks(a, prominence=math.log(PROMINENCE), height=float(a.max()) + math.log(FLOOR))
    kept: list[int] = []
    for j in i[np.argsort(-a[i])]:  # strongest first; at most a few dozen candidates
        if all(abs(f[j] - f[k]) > SEPARATION * f[k] for k in kept):
            kept.append(int(j))
    return np.asarray(kept, dtype=int)


def tip_band(tool: Tool, holder: Holder) -> tuple[float, float]:
    """The default band [Hz] of the tip FRF: up to 1.25× the clamped tool's second natural frequency (its
    first two bending modes; and 1.5× the highest holder mode), inside a measured holder's band."""
    lam, _ = tool.beam().modes(clamped=True)
    f_top = 1.25 * math.sqrt(lam[1]) / (2 * math.pi)
    modes = getattr(holder, "modes", ())
    if modes:
        f_top = max(f_top, 1.5 * max(m.fn for m in modes))
    lo, hi = holder.band
    f1 = math.sqrt(lam[0]) / (2 * math.pi)
    if f1 > 0.9 * hi:
        warn(f"the holder's receptances reach only {hi:g} Hz but this tool clamped rigidly has its first mode at "
             f"{f1:.5g} Hz: the tip FRF stops at {hi:g} Hz and leaves the tool's own mode out of the stability limit "
             f"(which may then be unsafe); measure the holder over a wider band, or use a longer tool", FRFWarning,
             stacklevel=3)
    f_hi = min(f_top, hi)
    f_lo = max(f_hi / 500.0, lo)
    if f_hi <= f_lo * 1.01:
        raise InputError("holder band", f"{lo:g}..{hi:g} Hz",
                         f"does not reach the tool's modes (first near {math.sqrt(lam[0]) / (2 * math.pi):.4g} Hz)")
    return f_lo, f_hi


def tip_grid(tool: Tool, holder: Holder, band: tuple[float, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(freq_hz, tip receptance) on a grid that resolves every resonance of |G| in ``band`` (default
    :func:`tip_band`): log-spaced background, then ±5 % of each peak at 201 points and ±25 % at 61."""
    with one_blas_thread():
        return _tip_grid(tool, holder, band)


def _tip_grid(tool: Tool, holder: Holder, band: tuple[float, float] | None) -> tuple[np.ndarray, np.ndarray]:
    f_lo, f_hi = band or tip_band(tool, holder)
    # log spacing 0.5 %: a measured holder's own resonances (ζ of a few %) are seen, then refined like the tool's
    f = np.geomspace(f_lo, f_hi, N_BACKGROUND)
    g = _tip_receptance(tool, holder, f)
    top = _resonances(f, g)[:MAX_PEAKS]
    extra = [fp * (1 + np.linspace(-0.05, 0.05, N_PEAK)) for fp in f[top]]
    extra += [fp * (1 + np.linspace(-0.25, 0.25, N_SKIRT)) for fp in f[top]]
    if not extra:
        return f, g
    fe = np.concatenate(extra)
    fe = fe[(fe >= f_lo) & (fe <= f_hi)]
    f_all = np.concatenate([f, fe])
    g_all = np.concatenate([g, _tip_receptance(tool, holder, fe)])  # only the new points are computed
    f_all, idx = np.unique(f_all, return_index=True)
    g_all = g_all[idx]
    keep = np.concatenate([[True], np.diff(f_all) > 1e-9 * f_all[1:]])
    return f_all[keep], g_all[keep]


def tip_structure(tool: Tool, holder: Holder | XYHolder, band: tuple[float, float] | None = None) -> Structure:
    """The tool-tip :class:`Structure` (a sampled FRF) of ``tool`` in ``holder``: xx = yy for one holder; for an
    :class:`XYHolder` xx and yy from its x and y holders on the union of their grids, in their common band."""
    if isinstance(holder, XYHolder):
        if band is None:
            bx, by = tip_band(tool, holder.x), tip_band(tool, holder.y)
            band = (max(bx[0], by[0]), min(bx[1], by[1]))
            if band[1] <= band[0] * 1.01:
                raise InputError("holder", holder.describe(), "the x and y holders share no frequency band")
        f = np.union1d(tip_grid(tool, holder.x, band)[0], tip_grid(tool, holder.y, band)[0])
        f = f[np.concatenate([[True], np.diff(f) > 1e-9 * f[1:]])]
        gx, gy = tip_receptance(tool, holder.x, f), tip_receptance(tool, holder.y, f)
    else:
        f, gx = tip_grid(tool, holder, band)
        gy = gx.copy()
    with quiet():  # computed, passive by construction
        return Structure(frf=MeasuredFRF(f, gx, gy))


def peaks(freq_hz: np.ndarray, g: np.ndarray, n: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """The ``n`` lowest resonances of |g| (local maxima standing out by :data:`PROMINENCE`): frequencies [Hz]
    (parabolic in ln|g| around each maximum) and peak |g| [m/N]; NaN where fewer exist."""
    a = np.log(np.abs(g))
    i = np.sort(_resonances(freq_hz, g))
    fn = np.full(n, np.nan)
    amp = np.full(n, np.nan)
    for k, j in enumerate(i[:n]):
        x = freq_hz[j - 1:j + 2]
        y = a[j - 1:j + 2]
        c = np.polyfit(x - x[1], y, 2)
        dx = -c[1] / (2 * c[0]) if c[0] < 0 else 0.0
        fn[k] = x[1] + float(np.clip(dx, x[0] - x[1], x[2] - x[1]))
        amp[k] = math.exp(np.polyval(c, fn[k] - x[1]))
    return fn, amp


__all__ = ["DEFAULT_FLUTE_RATIO", "Tool", "peaks", "tip_band", "tip_grid", "tip_receptance", "tip_structure"]
