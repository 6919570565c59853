"""Stability engines behind one interface: ``envelope(structure, cutting, rpm)`` → Envelope and
``envelope_batch(batch, cutting, rpm)`` → (B, S) depths [m].

* ``zoa`` -- zero-order (Altintas–Budak), fast, exact for time-invariant directional matrices;
* ``sdm`` -- semi-discretization (Insperger–Stépán), time domain, captures flip lobes at low immersion.
"""

from __future__ import annotations

from types import ModuleType

from millstab.errors import InputError

ENGINES = ("zoa", "sdm")


def get_engine(name: str) -> ModuleType:
    """The engine module by name (``zoa`` or ``sdm``)."""
    if name == "zoa":
        from millstab.stability import zoa

        return zoa
    if name == "sdm":
        from millstab.stability import sdm

        return sdm
    raise InputError("engine", name, f"must be one of {', '.join(ENGINES)}")
