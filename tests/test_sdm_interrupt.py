"""The semi-discretization engine runs in chunks: interruptible (Ctrl-C, a progress callback that
raises) and with progress, and the chunking changes no bit of the result."""

from __future__ import annotations

import math
import os
import signal
import threading

import numpy as np
import pytest

from millstab.frf import ModalBatch
from millstab.model import Cutting, Mode, Structure
from millstab.stability import _sdm_kernel, sdm

# the classic one-mode benchmark (Insperger & Stépán) at a/D = 0.05: cheap per speed with 20 steps
FN, ZETA, MASS = 922.0, 0.011, 0.03993
K = MASS * (2 * math.pi * FN) ** 2
BENCH = Structure(x=(Mode(FN, K, ZETA),))
OTHER = Structure(x=(Mode(1.1 * FN, 0.8 * K, 1.5 * ZETA),))
CUT = Cutting.from_immersion(2, 6e8, 1.0 / 3.0, 0.05, "down")
SPEEDS = np.linspace(8000.0, 25000.0, 37)


@pytest.fixture
def kernel_calls(monkeypatch):
    """Counts the compiled calls of the limit search and of the ρ map."""
    calls = {"limit": 0, "rho": 0}
    limit, rho = _sdm_kernel.limit_batch, _sdm_kernel.rho_grid

    def counted_limit(*args):
        calls["limit"] += 1
        return limit(*args)

    def counted_rho(*args):
        calls["rho"] += 1
        return rho(*args)

    monkeypatch.setattr(_sdm_kernel, "limit_batch", counted_limit)
    monkeypatch.setattr(_sdm_kernel, "rho_grid", counted_rho)
    return calls


@pytest.mark.slow
def test_chunked_equals_unchunked_bit_for_bit(monkeypatch, kernel_calls):
    batch = ModalBatch.from_structures([BENCH, OTHER])
    monkeypatch.setattr(sdm, "CHUNK_SECONDS", None)  # one compiled call over everything (the old way)
    one = sdm._limit(batch, CUT, SPEEDS, 20)
    rho_one = sdm.rho_map(BENCH, CUT, SPEEDS[::3], [0.2e-3, 1e-3, 3e-3], steps=20)
    assert kernel_calls == {"limit": 1, "rho": 1}
    monkeypatch.setattr(sdm, "CHUNK_SECONDS", 0.0)  # smallest chunks: one task per thread
    many = sdm._limit(batch, CUT, SPEEDS, 20)
    rho_many = sdm.rho_map(BENCH, CUT, SPEEDS[::3], [0.2e-3, 1e-3, 3e-3], steps=20)
    assert kernel_calls["limit"] > 5 and kernel_calls["rho"] > 2
    assert np.isfinite(one[0]).sum() > 30  # the comparison is about real boundaries
    np.testing.assert_array_equal(many[0], one[0])
    np.testing.assert_array_equal(many[1], one[1])
    np.testing.assert_array_equal(rho_many, rho_one)
    # the default (accuracy-controlled, Richardson) grid too, on a few speeds
    monkeypatch.setattr(sdm, "CHUNK_SECONDS", None)
    ref = sdm.envelope(BENCH, CUT, SPEEDS[:6])
    monkeypatch.setattr(sdm, "CHUNK_SECONDS", 0.0)
    got = sdm.envelope(BENCH, CUT, SPEEDS[:6])
    np.testing.assert_array_equal(got.depth, ref.depth)
    np.testing.assert_array_equal(got.chatter_hz, ref.chatter_hz)


def test_progress_reports_every_chunk(monkeypatch):
    monkeypatch.setattr(sdm, "CHUNK_SECONDS", 0.0)
    seen = []
    env = sdm.envelope(BENCH, CUT, SPEEDS, steps=20, progress=lambda *a: seen.append(a))
    assert env.depth.size == SPEEDS.size
    stages = {s for s, _, _ in seen}
    done = [d for _, d, _ in seen]
    assert len(stages) == 1 and "sdm" in stages.pop()
    assert {t for _, _, t in seen} == {SPEEDS.size}
    assert done[0] == 0 and done[-1] == SPEEDS.size and np.all(np.diff(done) > 0) and len(done) > 5
    # a batch counts (structure, speed) pairs
    seen.clear()
    sdm.envelope_batch(ModalBatch.from_structures([BENCH, OTHER]), CUT, SPEEDS[:5], steps=20,
                       progress=lambda *a: seen.append(a))
    assert seen[-1][1:] == (10, 10)


class _Stop(Exception):
    pass


def test_progress_callback_that_raises_stops_the_run(kernel_calls):
    def stop(stage, done, total):
        if done > 0:
            raise _Stop

    with pytest.raises(_Stop):
        sdm.envelope(BENCH, CUT, SPEEDS, steps=20, progress=stop)
    assert kernel_calls["limit"] == 1  # stopped after the first chunk, not after every speed


def test_ctrl_c_stops_a_long_run():
    """A real SIGINT while the compiled code runs: KeyboardInterrupt comes after the running chunk
    (about CHUNK_SECONDS), not after the whole run."""
    sdm.envelope(BENCH, CUT, SPEEDS[:2], steps=20)  # compile (or load the cache) before the clock starts
    # many seconds of work even on a fast machine (4 000 speeds took ~0.8 s on an idle 2-core one, so the
    # SIGINT at 0.3 s plus one running chunk of ~0.25 s reached 2 730 of them); the run is interrupted, so
    # its length costs nothing
    speeds = np.linspace(8000.0, 25000.0, 40000)
    seen = []
    armed = threading.Event()

    def handler(signum, frame):
        if armed.is_set():
            raise KeyboardInterrupt

    old = signal.signal(signal.SIGINT, handler)
    timer = threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT))
    try:
        armed.set()
        timer.start()
        with pytest.raises(KeyboardInterrupt):
            sdm.envelope(BENCH, CUT, speeds, steps=20, progress=lambda s, d, t: seen.append(d))
    finally:
        armed.clear()
        timer.cancel()
        timer.join()
        signal.signal(signal.SIGINT, old)
    assert 0 < seen[-1] < speeds.size / 4
