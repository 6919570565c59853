"""A plug-in engine for tests: the zero-order engine under another name, a complete engine by the contract
(stability.base.CONTRACT) whose entries a test may then replace (to scale, trace or choose settings)."""

from __future__ import annotations

import types

from millstab.stability import get_engine


def zoa_plugin(name: str) -> types.ModuleType:
    """A module-like engine called ``name`` with zoa's entries and the capabilities of a cheap engine that takes
    measured FRFs and tells no lobe type, no progress, no chatter frequency; not registered."""
    zoa = get_engine("zoa")
    m = types.ModuleType(f"{name}_engine")
    m.name = name
    m.exact_xy_exchange = m.accepts_measured_frf = m.cheap = True
    m.reports_lobe_type = m.reports_progress = m.time_averaged = m.reports_chatter_frequency = False
    m.depth_accuracy = 1e-6
    m.chunk_rows = zoa.chunk_rows
    m.envelope = zoa.envelope
    m.envelope_batch = zoa.envelope_batch
    return m
