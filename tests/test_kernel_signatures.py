"""Compiled kernels see writable arrays only, whatever the number of cuts, sets or speeds.

Why: numba compiles a kernel once per argument signature, and a read-only array (``np.broadcast_to`` of one
element stays read-only through ``np.ascontiguousarray``) is another signature than a writable one. ``millstab
warmup`` labels one cut; a shop's file has many: warmup then compiled the simulation for the read-only signature
and the first ``millstab simulate --cuts`` compiled it again (12 s, with the first-run notice, found 2026-11-29).
"""

from __future__ import annotations

import numpy as np
from numba import types

from millstab.model import Cutting
from millstab.simulate import label_cuts
from millstab.simulate._kernel import label_batch
from millstab.api.inputs import config


def _readonly_args(dispatcher) -> list:
    """The read-only array arguments of every signature the dispatcher was called with."""
    return [(i, t) for sig in dispatcher.signatures for i, t in enumerate(sig)
            if isinstance(t, types.Array) and not t.mutable]


def test_simulation_of_one_cut_and_of_many_share_one_signature():
    cfg = config("example:ex1")
    for n in (1, 3):
        label_cuts(cfg.structure, cfg.cutting, np.full(n, 5000.0), np.full(n, 0.5e-3), 1e-4, revs=4)
    assert _readonly_args(label_batch) == []


def test_sdm_of_one_set_at_one_speed_passes_writable_arrays():
    from millstab.stability import sdm

    cfg = config("example:ex1")
    cut = Cutting(**{**cfg.cutting.__dict__})
    cv = sdm._per_depth(cut, None, 1, np.array([5000.0]))
    assert cv.flags.writeable and cv.shape == (1, 1)


def test_expected_best_of_one_speed_passes_writable_arrays():
    from millstab.update import _gain

    blim = np.array([[2.0], [3.0], [4.0]])
    e, now = _gain.expected_best(blim, np.array([5000.0]), np.array(10.0), np.array([0]), np.array([2.5]),
                                 np.array([0.1]), 0.1, 0.02, 1.0)
    assert np.isfinite(e).all() and now >= 0.0
    for name in dir(_gain):
        obj = getattr(_gain, name)
        if hasattr(obj, "signatures"):
            assert _readonly_args(obj) == [], name
