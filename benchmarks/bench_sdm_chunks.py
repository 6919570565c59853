"""What running the semi-discretization in chunks costs and buys.

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_sdm_chunks.py [--interrupt]

1. Throughput: Example 1's limiting-depth curve (40 speeds 3 000–12 000 rpm, the default accuracy-
   controlled grid) with everything in one compiled call (``CHUNK_SECONDS = None``, the code before
   chunking) and in chunks of about ``sdm.CHUNK_SECONDS``, alternated three times in the same process;
   prints each time and the median ratio chunked / one call (noise: the machine may be shared).
2. With ``--interrupt``: the latency of Ctrl-C on ``millstab lobes example:ex1 --engine sdm`` (451
   speeds): SIGINT 8 s after the start, time until the process has exited, chunked and one call
   (the latter capped at 120 s).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
from threadpoolctl import threadpool_limits

from millstab.io import load_config
from millstab.stability import sdm

RPM = np.linspace(3000.0, 12000.0, 40)
CLI = ("import sys; from millstab.stability import sdm; sdm.CHUNK_SECONDS = {chunk}; from millstab.cli import main; "
       "main(['lobes', 'example:ex1', '--engine', 'sdm', '--rpm', '3000:12000:20'])")


def throughput() -> None:
    cfg = load_config("example:ex1")
    default = sdm.CHUNK_SECONDS
    with threadpool_limits(1):
        sdm.envelope(cfg.structure, cfg.cutting, RPM[:2])  # compile or load the cache
        times: dict[str, list[float]] = {"one call": [], "chunked": []}
        ref = None
        for _ in range(3):
            for name, chunk in (("one call", None), ("chunked", default)):
                sdm.CHUNK_SECONDS = chunk
                t = time.perf_counter()
                env = sdm.envelope(cfg.structure, cfg.cutting, RPM)
                times[name].append(time.perf_counter() - t)
                ref = env.depth if ref is None else ref
                assert np.array_equal(env.depth, ref), "chunking changed the result"
        sdm.CHUNK_SECONDS = default
    for name, ts in times.items():
        print(f"{name}: " + ", ".join(f"{t:.2f}" for t in ts) + " s")
    ratio = np.median(np.array(times["chunked"]) / np.array(times["one call"]))
    print(f"sdm_chunked_over_one_call: {ratio:.3f}")


def interrupt_latency(chunk: str, after: float = 8.0, cap: float = 120.0) -> float:
    proc = subprocess.Popen([sys.executable, "-c", CLI.format(chunk=chunk)], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, env=os.environ.copy())
    time.sleep(after)
    proc.send_signal(signal.SIGINT)
    t = time.perf_counter()
    try:
        proc.wait(timeout=cap)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        return float("inf")
    return time.perf_counter() - t


if __name__ == "__main__":
    throughput()
    if "--interrupt" in sys.argv:
        for chunk in ("sdm.CHUNK_SECONDS", "None"):
            lat = interrupt_latency(chunk)
            print(f"Ctrl-C to exit, CHUNK_SECONDS = {chunk}: " + (f"{lat:.2f} s" if np.isfinite(lat) else "> 120 s"))
