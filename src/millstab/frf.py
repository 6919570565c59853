"""Frequency response functions: from modes (vectorized over many parameter sets) and measured.

Receptances are in m/N, frequencies in Hz at the interface (rad/s only inside formulas).
:class:`ModalBatch` is the array form of B modal structures that every parameter study passes to
the batched stability engine.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from millstab.errors import InputError
from millstab.model import SUSPICIOUS_STIFFNESS, MeasuredFRF, Mode, Structure
from millstab.warnlog import quiet

PARAMS = ("fn", "k", "zeta")


@dataclass(frozen=True, eq=False)
class ModalBatch:
    """B modal structures with the same number of modes per direction, as arrays.

    Attributes (shape (B, Mx) for x, (B, My) for y; My or Mx may be 0 for a rigid direction):
        fn_x, fn_y: natural frequencies [Hz];  k_x, k_y: stiffnesses [N/m];  zeta_x, zeta_y: damping [-].
    """

    fn_x: np.ndarray
    k_x: np.ndarray
    zeta_x: np.ndarray
    fn_y: np.ndarray
    k_y: np.ndarray
    zeta_y: np.ndarray

    def __post_init__(self) -> None:
        shapes = {}
        for d in ("x", "y"):
            arrs = [np.ascontiguousarray(np.atleast_2d(np.asarray(getattr(self, f"{p}_{d}"), dtype=float)))
                    for p in PARAMS]
            for p, arr in zip(PARAMS, arrs):
                object.__setattr__(self, f"{p}_{d}", arr)
            if len({a.shape for a in arrs}) != 1:
                raise InputError(f"batch.{d}", [a.shape for a in arrs], "fn, k and zeta must have the same shape")
            shapes[d] = arrs[0].shape
        bx, by = shapes["x"][0], shapes["y"][0]
        if shapes["x"][1] == 0:
            bx = by
        if shapes["y"][1] == 0:
            by = bx
        if bx != by:
            raise InputError("batch", (shapes["x"], shapes["y"]), "x and y need the same number of parameter sets")
        if shapes["x"][1] + shapes["y"][1] == 0:
            raise InputError("batch", "no modes", "at least one mode in x or y is required")
        # a rigid direction is stored as (B, 0) so the batch size is always readable
        for d in ("x", "y"):
            if shapes[d][1] == 0 and shapes[d][0] != bx:
                for p in PARAMS:
                    object.__setattr__(self, f"{p}_{d}", np.zeros((bx, 0)))
        self.validate()

    @property
    def size(self) -> int:
        """Number of parameter sets B."""
        return self.fn_x.shape[0]

    def validate(self) -> None:
        """Reject any set with fn ≤ 0, k ≤ 0, ζ outside (0, 1) or a non-finite value, naming it."""
        checks = (
            ("fn", lambda v: v > 0, "natural frequency must be > 0 Hz"),
            ("k", lambda v: v > 0, "stiffness must be > 0 N/m"),
            ("zeta", lambda v: (v > 0) & (v < 1), "damping ratio must be in (0, 1)"),
        )
        for d in ("x", "y"):
            for p, ok, allowed in checks:
                arr = getattr(self, f"{p}_{d}")
                bad = ~(np.isfinite(arr) & ok(arr))
                if bad.any():
                    b, m = np.argwhere(bad)[0]
                    raise InputError(f"{p}_{d} (set {b}, mode {m})", float(arr[b, m]),
                                     f"{allowed}; {int(bad.sum())} value(s) out of range in the batch")

    @classmethod
    def from_structures(cls, structures: Sequence[Structure]) -> ModalBatch:
        """Stack modal structures that have the same number of modes per direction."""
        if not structures:
            raise InputError("structures", "[]", "need at least one structure")
        first = structures[0]
        for s in structures:
            if not s.is_modal:
                raise InputError("structure", "measured FRF", "a modal batch needs modal structures")
            if len(s.x) != len(first.x) or len(s.y) != len(first.y):
                raise InputError("structures", "different mode counts",
                                 "all structures in a batch need the same number of modes per direction")
        arr = {f"{p}_{d}": np.array([[getattr(m, p) for m in getattr(s, d)] for s in structures],
                                    dtype=float).reshape(len(structures), -1)
               for d in ("x", "y") for p in PARAMS}
        return cls(**arr)

    def structure(self, i: int = 0) -> Structure:
        """Parameter set ``i`` as a :class:`Structure`."""
        with quiet():  # values already validated; a batch may legitimately hold soft values
            modes = {d: tuple(Mode(getattr(self, f"fn_{d}")[i, m], getattr(self, f"k_{d}")[i, m],
                                   getattr(self, f"zeta_{d}")[i, m], f"structure.{d}[{m}]")
                              for m in range(getattr(self, f"fn_{d}").shape[1]))
                     for d in ("x", "y")}
        return Structure(x=modes["x"], y=modes["y"])


def modal_receptance(freq_hz: np.ndarray, fn: np.ndarray, k: np.ndarray, zeta: np.ndarray) -> np.ndarray:
    """Direct receptance Σ_m 1/(k_m(1 − r² + 2iζ_m r)) [m/N], r = f/fn_m, vectorized.

    Args:
        freq_hz: frequencies (F,) [Hz].
        fn, k, zeta: modal parameters (..., M) [Hz, N/m, -]; leading dimensions are a batch.

    Returns:
        Complex array (..., F). Zero when M = 0 (a rigid direction).
    """
    f = np.asarray(freq_hz, dtype=float)
    fn, k, zeta = (np.asarray(v, dtype=float)[..., None, :] for v in (fn, k, zeta))
    r = f[:, None] / fn
    return np.sum(1.0 / (k * (1.0 - r * r + 2j * zeta * r)), axis=-1)


def structure_receptance(structure: Structure, freq_hz: np.ndarray) -> np.ndarray:
    """The 2×2 receptance matrix of a structure at ``freq_hz`` (F,), shape (F, 2, 2) [m/N].

    Modal structures give a diagonal matrix; measured FRFs are interpolated (see :func:`interpolate`).
    """
    f = np.asarray(freq_hz, dtype=float)
    if structure.frf is not None:
        return interpolate(structure.frf, f)
    g = np.zeros((f.size, 2, 2), dtype=complex)
    for i, d in enumerate(("x", "y")):
        modes = getattr(structure, d)
        if modes:
            g[:, i, i] = modal_receptance(f, *(np.array([getattr(m, p) for m in modes]) for p in PARAMS))
    return g


def interpolate(frf: MeasuredFRF, freq_hz: np.ndarray) -> np.ndarray:
    """A measured FRF linearly interpolated (real and imaginary parts) at ``freq_hz``, (F, 2, 2).

    Raises:
        InputError: when a requested frequency lies outside the measured band (no extrapolation).
    """
    f = np.asarray(freq_hz, dtype=float)
    lo, hi = frf.freq_hz[0], frf.freq_hz[-1]
    if f.size and (f.min() < lo * (1 - 1e-12) or f.max() > hi * (1 + 1e-12)):
        raise InputError("frequency", f"{f.min():g}..{f.max():g} Hz",
                         f"must lie inside the measured band {lo:g}..{hi:g} Hz")
    g = frf.matrix()
    out = np.empty((f.size, 2, 2), dtype=complex)
    for i in range(2):
        for j in range(2):
            out[:, i, j] = np.interp(f, frf.freq_hz, g[:, i, j].real) + 1j * np.interp(f, frf.freq_hz, g[:, i, j].imag)
    return out


def measured_from_structure(structure: Structure, freq_hz: np.ndarray, cross: bool = False) -> MeasuredFRF:
    """Sample a modal structure's receptance as if measured (for tests and examples)."""
    g = structure_receptance(structure, freq_hz)
    return MeasuredFRF(np.asarray(freq_hz, float), g[:, 0, 0] if structure.x else None,
                       g[:, 1, 1] if structure.y else None,
                       g[:, 0, 1] if cross else None, g[:, 1, 0] if cross else None)


__all__ = ["ModalBatch", "SUSPICIOUS_STIFFNESS", "interpolate", "measured_from_structure", "modal_receptance",
           "structure_receptance"]
