"""Process damping: the low-speed flank-contact damping term, shared by the engines that carry it.

Model (Altintas, Eynian & Onozuka 2008; Budak & Tunc 2010; Tyler & Schmitz 2013). At low cutting
speed the clearance face of a tooth in the cut rubs the wavy surface it has just left; the
indentation force opposes the tool's velocity normal to the surface and, for a wavelength λ = V/f
long against the contact, is a viscous damping whose coefficient grows with the depth b and falls
with the cutting speed V:

    F_d = −(C b / V) (n · u̇) n,    n = (sin φ, cos φ),   V = π D Ω / 60,

per tooth in the cut (φ its angle from +y, Altintas' convention; n the direction in which the chip
thickness grows, the same n as the cutting force's radial component), u = (x, y) the tool-tip
displacement [m], C the process-damping (indentation) coefficient [N/m], D the tool diameter [m],
Ω the spindle speed [rpm]. Summed over the teeth, the damping matrix of the cut is

    C_pd(t) = (C b / V) Σ_j g(φ_j) n_j n_jᵀ,    n nᵀ = ½ [[1 − cos 2φ, sin 2φ], [sin 2φ, 1 + cos 2φ]],

whose tooth-period average is (C b / V)(N / 2π) ∫_{φst}^{φex} n nᵀ dφ (:func:`mean_contact`). For an
even number of teeth N ≥ 4 in slotting Σ_j g n_j n_jᵀ = (N/4) I at every instant, so the
instantaneous and the averaged term coincide there (used by the tests as an exact check).

What each engine does with it (capability ``process_damping`` of the engine contract):

* ``sdm``: instantaneous per tooth, semi-discretized like the cutting force (its exact step average
  enters the current-state matrix of every step); the term depends on b and Ω, so the monodromy
  matrix is rebuilt at every depth of the limit search (it already is: the cutting force ∝ b).
* ``simulate`` (time domain): instantaneous per tooth in contact (chip > 0), in the implicit step.
* ``zoa``, ``spectral``: not carried; a cut with process damping is an :class:`InputError` there.
"""

from __future__ import annotations

import math

import numpy as np

from millstab.errors import InputError


def engines_carrying() -> list[str]:
    """Names of the registered engines whose ``process_damping`` capability is true."""
    from millstab.stability import ENGINES, get_engine

    return [n for n in ENGINES if getattr(get_engine(n), "process_damping", False)]


def reject(cutting, engine: str) -> None:
    """InputError when ``cutting`` (a Cutting, or Conditions: any of its conditions) has process damping:
    the engine ``engine`` does not carry it."""
    for c in getattr(cutting, "cuttings", (cutting,)):
        if getattr(c, "process_damping", 0.0) > 0:
            raise InputError("cutting.process_damping", f"{c.process_damping:g} N/m",
                             f"the {engine} engine does not model process damping; use an engine that does "
                             f"({', '.join(engines_carrying()) or 'sdm'}), or set process_damping = 0")


def mean_contact(cutting) -> np.ndarray:
    """(N / 2π) ∫_{φst}^{φex} n nᵀ dφ (2×2, dimensionless): the tooth-period average of Σ_j g n_j n_jᵀ,
    so the averaged process-damping matrix is (C b / V) times this."""
    a, b = cutting.entry, cutting.exit
    s = 0.5 * (math.cos(2 * a) - math.cos(2 * b))  # ∫ sin 2φ
    c = 0.5 * (math.sin(2 * b) - math.sin(2 * a))  # ∫ cos 2φ
    w = b - a
    return cutting.teeth / (2 * math.pi) * 0.5 * np.array([[w - c, s], [s, w + c]])


def equivalent_damping(cutting, rpm: float, depth_m: float) -> np.ndarray:
    """The tooth-period averaged process-damping matrix (C b / V)(N/2π)∫ n nᵀ dφ [N·s/m] in (x, y)
    at one speed [rpm] and depth [m] (the viscous damping a structure would need to match it on
    average; exact in slotting with an even N ≥ 4, see the module docstring)."""
    return float(cutting.process_damping_per_depth(rpm)) * float(depth_m) * mean_contact(cutting)
