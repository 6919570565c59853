"""Stability engines behind one interface: ``envelope(structure, cutting, rpm)`` → Envelope and
``envelope_batch(batch, cutting, rpm)`` → (B, S) depths [m].

* ``zoa`` -- zero-order (Altintas–Budak), fast, exact for time-invariant directional matrices;
* ``sdm`` -- semi-discretization (Insperger–Stépán), time domain, captures flip lobes at low immersion;
* ``spectral`` -- spectral-element collocation of the cutting intervals (time domain, exact free flight):
  as accurate as converged SDM, flip and Hopf lobes, far faster; the engine for low radial immersion.
"""

from __future__ import annotations

from types import ModuleType

from millstab.errors import InputError

ENGINES = ("zoa", "sdm", "spectral")


def get_engine(name: str) -> ModuleType:
    """The engine module by name (``zoa``, ``sdm`` or ``spectral``)."""
    if name == "zoa":
        from millstab.stability import zoa

        return zoa
    if name == "sdm":
        from millstab.stability import sdm

        return sdm
    if name == "spectral":
        from millstab.stability import spectral

        return spectral
    raise InputError("engine", name, f"must be one of {', '.join(ENGINES)}")
