"""Throughput of the batched zero-order envelope (the hot path of every parameter study).

B = 10 000 parameter sets of the seed paper's Example 1 drawn uniformly within ±10 %, S = 200
speeds over 2 000–12 000 rpm, at the engine's full accuracy (every depth root-found; tests/test_zoa.py
and tests/test_zoa_dense.py check it against a brute-force reference to 1e-6). Also streams 10^6 sets
in chunks and reports the peak memory. Run: ``.venv/bin/python benchmarks/bench_envelope.py [--million]``.
Last line: ``envelopes_per_s: N``.
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).parent))
from _machine import describe  # noqa: E402

from millstab.datasets import load_example  # noqa: E402
from millstab.params import Parameterization  # noqa: E402
from millstab.stability import zoa  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", type=int, default=10_000)
    ap.add_argument("--million", action="store_true", help="also stream 10^6 sets and report peak memory")
    args = ap.parse_args()
    cfg = load_example("ex1")
    par = Parameterization(cfg.structure)
    rng = np.random.default_rng(0)
    theta = par.theta0 * rng.uniform(0.9, 1.1, (args.sets, par.size))
    rpm = np.linspace(2000, 12000, 200)
    print(describe())
    with threadpool_limits(1):
        t = time.perf_counter()
        zoa.envelope_batch(par.batch(theta[:8]), cfg.cutting, rpm)  # compile / load the cache
        print(f"first call (compile or cache load): {time.perf_counter() - t:.2f} s")
        best = np.inf
        for _ in range(3):
            t = time.perf_counter()
            depth = zoa.envelope_batch(par.batch(theta), cfg.cutting, rpm)
            best = min(best, time.perf_counter() - t)
        assert np.isfinite(depth).all()
        print(f"B={args.sets} sets x S={rpm.size} speeds: best of 3 {best:.3f} s; "
              f"min depth {depth.min() * 1e3:.4f} mm, max {depth.max() * 1e3:.4f} mm")
        if args.million:
            n = 1_000_000
            t = time.perf_counter()
            lo = np.inf
            for start in range(0, n, 100_000):  # draw and evaluate in pieces: memory stays bounded
                th = par.theta0 * np.random.default_rng(start).uniform(0.9, 1.1, (100_000, par.size))
                for _, d in zoa.iter_envelope_chunks(par.batch(th), cfg.cutting, rpm):
                    lo = min(lo, d.min())
            dt = time.perf_counter() - t
            print(f"10^6 sets streamed: {dt:.1f} s ({n / dt:.0f} sets/s), overall min depth {lo * 1e3:.4f} mm")
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak_rss_mb: {peak_mb:.0f}")
    print(f"envelopes_per_s: {args.sets / best:.0f}")


if __name__ == "__main__":
    main()
