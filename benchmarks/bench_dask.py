"""Monte Carlo of Example 1 on a local Dask cluster: parallel efficiency, client memory, total time.

The study is the seed paper's Algorithm 2 (t = 0.1, ε = 1 %) around Ex.1's predicted values, S = 200
speeds 2000–12000 rpm, 7 envelopes per path. Figures printed:

* ``rate_1``: paths/s of ONE worker process (a LocalCluster of 1 worker, numba on one thread) on
  ``--serial-paths`` paths, measured just before and just after the main run (mean of the two, so a
  change of the machine's load during the run shows as a spread);
* ``rate_W``: paths/s of the main run, ``--paths`` paths on ``--workers`` worker processes;
* ``efficiency = rate_W / (W · rate_1)`` (target ≥ 0.8 for W = 2);
* ``peak_client_mb``: the client process's peak RSS up to the end of the main run (it has run no engine
  work: every run so far was on workers), and the tracemalloc peak of the main run (the per-path MSE array
  N × 6 × 8 bytes plus the blocks in flight);
* the in-process rate without dask (numba on one thread), measured last: the gap to ``rate_1`` is dask's cost;
* the load average of the machine at start and end (a shared machine makes every rate noisy);
* the per-core rate in envelopes/s and the time it predicts for 10^8 envelopes on 256 cores.

Run: ``python benchmarks/bench_dask.py [--paths 1000000] [--workers 2] [--serial-paths 10000]``.
The machine is described on the first line; BLAS is pinned to one thread in every process.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).parent))
from _machine import describe  # noqa: E402

from millstab.cluster import open_client  # noqa: E402
from millstab.datasets import load_example  # noqa: E402
from millstab.sensitivity import monte_carlo, predicted_theta  # noqa: E402

RPM = np.linspace(2000.0, 12000.0, 200)
ENVELOPES_PER_PATH = 7  # the path's own SLD and one per perturbed parameter (P = 6)


def run(client, n: int, seed: int):
    cfg = load_example("ex1")
    t0 = time.perf_counter()
    res = monte_carlo(cfg.structure, cfg.cutting, RPM, n=n, seed=seed, theta=predicted_theta("ex1"), client=client)
    return time.perf_counter() - t0, res


def serial_rate(n: int, seed: int) -> float:
    """Paths/s of one worker process (warm-up excluded: a first small run compiles/loads numba)."""
    with open_client(workers=1) as client:
        run(client, 20, seed)
        dt, _ = run(client, n, seed)
    return n / dt


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--paths", type=int, default=1_000_000, help="paths of the main run (10^6)")
    ap.add_argument("--workers", type=int, default=2, help="worker processes of the main run")
    ap.add_argument("--serial-paths", type=int, default=10_000, help="paths of each 1-worker reference run")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    print(describe().replace("with", "(client process) with"))
    print("load average at start (1, 5, 15 min): " + ", ".join(f"{v:.1f}" for v in os.getloadavg()))
    print(f"Monte Carlo of Ex.1, {RPM.size} speeds, {ENVELOPES_PER_PATH} envelopes per path; workers run numba "
          "on 1 thread each")
    with threadpool_limits(1):
        r1a = serial_rate(args.serial_paths, args.seed)
        print(f"1 worker, {args.serial_paths} paths (before): {r1a:.1f} paths/s")
        with open_client(workers=args.workers) as client:
            run(client, 20, args.seed)  # compile / load on every worker, outside the timing
            tracemalloc.start()
            dt, res = run(client, args.paths, args.seed)
            _, traced = tracemalloc.get_traced_memory()
            tracemalloc.stop()
        peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # the client alone so far
        r1b = serial_rate(args.serial_paths, args.seed)
        print(f"1 worker, {args.serial_paths} paths (after): {r1b:.1f} paths/s")
        import numba

        numba.set_num_threads(1)
        run(None, 20, args.seed)
        dt0, _ = run(None, args.serial_paths, args.seed)
        print(f"no dask, this process, numba on 1 thread, {args.serial_paths} paths: "
              f"{args.serial_paths / dt0:.1f} paths/s (the cost of dask is the gap to the 1-worker rate)")
    r1 = 0.5 * (r1a + r1b)
    rw = args.paths / dt
    eff = rw / (args.workers * r1)
    env_core = r1 * ENVELOPES_PER_PATH
    print(f"{args.workers} workers, {args.paths} paths ({ENVELOPES_PER_PATH * args.paths} envelopes): {dt:.1f} s "
          f"= {dt / 60:.2f} min, {rw:.1f} paths/s")
    print(f"mean MSE [mm^2]: " + ", ".join(f"{n} {m:.5f}" for n, m in zip(res.names, res.mean)))
    print(f"parallel efficiency rate_{args.workers} / ({args.workers} x rate_1): {eff:.3f} "
          f"(rate_1 before/after {r1a:.1f}/{r1b:.1f} paths/s)")
    print(f"peak_client_mb: {peak_mb:.0f} (peak RSS of the client up to the end of the main run); "
          f"tracemalloc peak of the main run: {traced / 2**20:.0f} MB")
    print(f"per-core rate: {env_core:.0f} envelopes/s at {RPM.size} speeds; 1e8 envelopes on 256 cores at that rate "
          f"and this efficiency: {1e8 / (256 * env_core * eff) / 60:.1f} min")
    print("load average at end (1, 5, 15 min): " + ", ".join(f"{v:.1f}" for v in os.getloadavg()))
    print(f"total_seconds: {dt:.1f}")


if __name__ == "__main__":
    main()
