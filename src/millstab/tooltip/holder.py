"""The spindle–holder at the holder face: its receptance matrix R₃₃ = [[H, L], [N, P]] (F, 2, 2) at any
frequency, from one of

* :class:`RigidHolder` — R₃₃ = 0 (the tool clamped at the face; an upper bound on the tip stiffness);
* :class:`ModalHolder` — face modes: each mode's natural frequency, translational modal stiffness k at the
  face, damping ratio and ``slope`` (its rotation per unit displacement at the face, rad/m): with
  d = k(1 − r² + 2iζr), H = Σ 1/d, L = N = Σ s/d, P = Σ s²/d (a mass-normalised mode shape (φ_w, φ_θ) gives
  k = ω²/φ_w², s = φ_θ/φ_w);
* :class:`MeasuredHolder` — the four terms on a measured frequency axis, linearly interpolated (real and
  imaginary parts), no extrapolation. Its rotational terms come from the artifact test
  (:func:`from_artifact`, the exact inverse RCSA) or from finite differences of translational FRFs measured
  at equally spaced points along the holder (:func:`from_finite_differences`); see docs/tooltip.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from millstab.errors import InputError
from millstab.tooltip.beam import Beam
from millstab.tooltip.rcsa import decouple_artifact


@dataclass(frozen=True)
class RigidHolder:
    """A rigid holder and spindle: R₃₃ = 0."""

    band = (0.0, math.inf)

    def receptance(self, freq_hz: np.ndarray) -> None:  # noqa: ARG002 - rigid at every frequency
        return None

    def describe(self) -> str:
        return "rigid holder (tool clamped at the face)"


@dataclass(frozen=True)
class FaceMode:
    """One holder-face mode: ``fn`` [Hz], ``k`` [N/m] (translational, at the face), ``zeta`` [-], ``slope``
    [rad/m] (rotation per unit displacement of the mode shape at the face)."""

    fn: float
    k: float
    zeta: float
    slope: float = 0.0

    def __post_init__(self) -> None:
        for f, lo in (("fn", 0.0), ("k", 0.0)):
            v = getattr(self, f)
            if not (math.isfinite(v) and v > lo):
                raise InputError(f"holder mode {f}", v, "must be a finite number > 0")
        if not 0.0 < self.zeta < 1.0:
            raise InputError("holder mode zeta", self.zeta, "damping ratio must be in (0, 1)")
        if not math.isfinite(self.slope):
            raise InputError("holder mode slope", self.slope, "must be a finite number [rad/m]")


@dataclass(frozen=True)
class ModalHolder:
    """The holder face as a sum of modes (:class:`FaceMode`)."""

    modes: tuple[FaceMode, ...]
    band = (0.0, math.inf)

    def __post_init__(self) -> None:
        object.__setattr__(self, "modes", tuple(self.modes))
        if not self.modes:
            raise InputError("holder.modes", "[]", "need at least one mode")

    def receptance(self, freq_hz: np.ndarray) -> np.ndarray:
        f = np.asarray(freq_hz, dtype=float)
        fn, k, z, s = (np.array([getattr(m, a) for m in self.modes]) for a in ("fn", "k", "zeta", "slope"))
        r = f[:, None] / fn
        inv = 1.0 / (k * (1.0 - r * r + 2j * z * r))  # (F, M)
        out = np.empty((f.size, 2, 2), dtype=complex)
        out[:, 0, 0] = inv.sum(-1)
        out[:, 0, 1] = out[:, 1, 0] = (inv * s).sum(-1)
        out[:, 1, 1] = (inv * s * s).sum(-1)
        return out

    def describe(self) -> str:
        return "holder-face modes: " + ", ".join(f"{m.fn:.5g} Hz {m.k / 1e6:.4g} N/um zeta {m.zeta:.3g}"
                                                 for m in self.modes)


@dataclass(frozen=True, eq=False)
class MeasuredHolder:
    """Holder-face receptances [[H, L], [N, P]] measured (or derived) at ``freq_hz`` (F,), each (F,) complex."""

    freq_hz: np.ndarray
    h: np.ndarray
    l: np.ndarray  # noqa: E741 - the field's name for w/m
    n: np.ndarray
    p: np.ndarray
    source: str = "measured"

    def __post_init__(self) -> None:
        f = np.asarray(self.freq_hz, dtype=float)
        if f.ndim != 1 or f.size < 4 or np.any(np.diff(f) <= 0) or f[0] <= 0:
            raise InputError("holder frequencies", f"{f.size} values",
                             "need >= 4 strictly increasing frequencies > 0 Hz")
        object.__setattr__(self, "freq_hz", f)
        for t in ("h", "l", "n", "p"):
            v = np.asarray(getattr(self, t), dtype=complex)
            if v.shape != f.shape or not np.all(np.isfinite(v)):
                raise InputError(f"holder.{t}", f"{v.size} values", f"need {f.size} finite values, one per frequency")
            object.__setattr__(self, t, v)

    @property
    def band(self) -> tuple[float, float]:
        return float(self.freq_hz[0]), float(self.freq_hz[-1])

    def receptance(self, freq_hz: np.ndarray) -> np.ndarray:
        f = np.asarray(freq_hz, dtype=float)
        lo, hi = self.band
        if f.size and (f.min() < lo * (1 - 1e-12) or f.max() > hi * (1 + 1e-12)):
            raise InputError("frequency", f"{f.min():g}..{f.max():g} Hz",
                             f"must lie in the holder's measured band {lo:g}..{hi:g} Hz")
        out = np.empty((f.size, 2, 2), dtype=complex)
        for (i, j), t in zip(((0, 0), (0, 1), (1, 0), (1, 1)), ("h", "l", "n", "p")):
            v = getattr(self, t)
            out[:, i, j] = np.interp(f, self.freq_hz, v.real) + 1j * np.interp(f, self.freq_hz, v.imag)
        return out

    def describe(self) -> str:
        return f"holder-face receptances ({self.source}), {self.band[0]:g}..{self.band[1]:g} Hz"


Holder = RigidHolder | ModalHolder | MeasuredHolder


@dataclass(frozen=True)
class XYHolder:
    """A spindle–holder whose face receptances differ in x (feed) and y (cross-feed): one holder each."""

    x: Holder
    y: Holder

    @property
    def band(self) -> tuple[float, float]:
        return max(self.x.band[0], self.y.band[0]), min(self.x.band[1], self.y.band[1])

    def describe(self) -> str:
        return f"x: {self.x.describe()}; y: {self.y.describe()}"


def artifact_points(artifact: Beam, offset: float) -> list[int]:
    """FE DOFs [w₂, θ₂, w_tip, w_offset] of ``artifact``: its face end, its free end, and the point ``offset``
    [m] from the free end toward the face (a node of the artifact's mesh)."""
    L = artifact.length
    if not 0.0 < offset < L:
        raise InputError("artifact offset", offset, f"must lie inside the artifact (0 < offset < {L:g} m)")
    return [0, 1, 2 * artifact.node(L), 2 * artifact.node(L - offset)]


def from_artifact(freq_hz: np.ndarray, tip: np.ndarray, cross: np.ndarray, offset_direct: np.ndarray,
                  artifact: Beam, offset: float) -> MeasuredHolder:
    """The holder-face receptances behind an artifact test (the exact inverse RCSA of :mod:`.rcsa`).

    A cylinder of known geometry (``artifact``, coupling end at the face) is clamped in the holder; measured:
    the direct FRF at its free end (``tip``), the cross FRF between the free end and a point ``offset`` [m]
    toward the face (``cross``; either direction, reciprocity) and the direct FRF at that point
    (``offset_direct``), all [m/N] at ``freq_hz``. The artifact needs a node at the offset point: build it
    with a section boundary there (:func:`artifact_beam` does).
    """
    f = np.asarray(freq_hz, dtype=float)
    art = artifact.receptance(f, artifact_points(artifact, offset))
    r33 = decouple_artifact(art, np.stack([tip, cross, offset_direct], axis=-1))
    return MeasuredHolder(f, r33[:, 0, 0], r33[:, 0, 1], r33[:, 1, 0], r33[:, 1, 1],
                          source="artifact test, inverse RCSA")


def artifact_beam(diameter: float, length: float, offset: float, material, elements: int | None = None) -> Beam:
    """A solid cylindrical artifact (``length`` [m] out of the holder) meshed with a node ``offset`` [m] from
    its free end."""
    from millstab.tooltip.beam import DEFAULT_ELEMENTS, Section

    if not 0.0 < offset < length:
        raise InputError("artifact offset", offset, f"must lie inside the artifact (0 < offset < {length:g} m)")
    secs = (Section(length - offset, diameter, material), Section(offset, diameter, material))
    return Beam(secs, elements=elements or DEFAULT_ELEMENTS)


#: finite-difference weights of the slope at the first of equally spaced points (one-sided, toward the spindle)
_FD = {1: np.array([1.0, -1.0]), 2: np.array([1.5, -2.0, 0.5])}


def from_finite_differences(freq_hz: np.ndarray, H: np.ndarray, spacing: float, order: int = 1,
                            shear_stiffness: float | None = None) -> MeasuredHolder:
    """Holder-face receptances from translational FRFs at equally spaced points on the holder.

    ``H`` (F, n, n): H[:, i, j] = w_i/f_j at points z_i = −i·``spacing`` (i = 0 the face, going toward the
    spindle), n = 2 (``order`` 1) or 3 (``order`` 2). With the one-sided stencil c (slope ≈ Σ c_i w_i / s;
    c = [1, −1] or [3/2, −2, 1/2]) and a moment as the matching set of forces (m = s Σ c_j f_j):
    H = H₀₀, N = Σ c_i H_i0/s, L = Σ c_j H_0j/s, P = Σ c_i c_j H_ij/s² (Sattinger 1980; Duarte & Ewins
    2000). The truncation error of N and L is O(s^order), of P O(s) with either stencil (measured in
    tests/test_tooltip.py); measurement noise grows as 1/s (N, L) and 1/s² (P).

    Shear: differences of w give the slope dw/dz, but the joint couples the section rotation ψ, and
    dw/dz = ψ + V/(κGA). On a thick holder the shear angle adds 1/(κGA) to N and L and, because the forces
    that stand in for the moment shear the span between the points, c·S·c/s² ≈ 1/(s κGA) to P — an error
    that GROWS as the spacing shrinks (tests/test_tooltip.py shows it). Give the holder's ``shear_stiffness``
    κGA [N] (:attr:`Section.shear_stiffness`) and these shear parts are taken out: with the static shear
    compliance between the points S_ij = −max(i, j)·s/(κGA) (a constant drops out, Σc = 0), N −= Σ c_i S_i0/s,
    L −= Σ c_j S_0j/s, P −= Σ c_i c_j S_ij/s².
    """
    c = _FD.get(order)
    if c is None:
        raise InputError("finite-difference order", order, "must be 1 or 2")
    Hm = np.asarray(H)
    if Hm.ndim != 3 or Hm.shape[1:] != (c.size, c.size):
        raise InputError("finite-difference FRFs", Hm.shape, f"order {order} needs (F, {c.size}, {c.size})")
    if not (math.isfinite(spacing) and spacing > 0):
        raise InputError("finite-difference spacing", spacing, "must be > 0 m")
    if shear_stiffness is not None:
        if not (math.isfinite(shear_stiffness) and shear_stiffness > 0):
            raise InputError("shear stiffness", shear_stiffness, "kappa*G*A must be > 0 N")
        idx = np.arange(c.size)
        S = -np.maximum(idx[:, None], idx[None, :]) * spacing / shear_stiffness
        Hm = Hm - S[None, :, :]  # S00 = 0: H keeps its value
    h = np.asarray(H)[:, 0, 0]
    n = np.einsum("i,fi->f", c, Hm[:, :, 0]) / spacing
    l_ = np.einsum("j,fj->f", c, Hm[:, 0, :]) / spacing
    p = np.einsum("i,j,fij->f", c, c, Hm) / spacing**2
    return MeasuredHolder(np.asarray(freq_hz, float), h, l_, n, p, source=f"finite differences, order {order}")


__all__ = ["XYHolder", "FaceMode", "Holder", "MeasuredHolder", "ModalHolder", "RigidHolder", "artifact_beam",
           "artifact_points", "from_artifact", "from_finite_differences"]
