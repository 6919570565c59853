"""Monte Carlo of Example 1 on a local Dask cluster: parallel efficiency, client memory, total time.

The study is the seed paper's Algorithm 2 (t = 0.1, ε = 1 %) around Ex.1's predicted values, S = 200
speeds 2000–12000 rpm, 7 envelopes per path. Both wall-clock and CPU time are measured, because on a
shared machine the wall clock says little: with the kernel's autogroup scheduling (printed on the first
lines) all processes of one login session share ONE fair share of the CPUs, so adding workers there cannot
shorten the wall time however well the work parallelises. CPU time is what the work costs wherever it runs.

Figures printed:

* ``in-process``: paths per CPU-second of this process without dask (numba on one thread): the
  reference "one process doing the same work";
* the main run, ``--paths`` on ``--workers`` worker processes: wall time, paths/s, and the CPU-seconds of
  every process involved (the workers, measured inside them; the client, which also hosts the scheduler);
* ``cpu_efficiency`` = (paths per CPU-second of the whole cluster) / (paths per CPU-second in-process):
  dask's overhead and any work done twice; on dedicated cores with workers never idle (the client keeps
  three tasks per worker queued) it is the parallel efficiency T_1 / (W · T_W);
* ``wall_efficiency`` = (paths/s on W workers) / (W · paths/s in-process wall): meaningful only on an
  otherwise idle machine;
* ``idle cluster``: CPU-seconds per wall-second the cluster burns with nothing to do (event loops,
  heartbeats, memory monitors), timed after the main run; on a crowded machine the run's wall time is
  stretched and this background with it, so it is removed from the study's CPU and added back at the
  dedicated-core wall time: ``dedicated_time`` = (study CPU) / (W − idle rate), and the projected
  parallel efficiency T_1 / (W · T_W) with T_1 the in-process CPU time of the same paths;
* the client's peak RSS (it runs no engine work before the end of the main run) and the tracemalloc peak;
* the per-core rate (envelopes per second of a dedicated core: the study's own CPU, less the background)
  and the time it predicts for 10^8 envelopes on 256 cores.

Run: ``python benchmarks/bench_dask.py [--paths 1000000] [--workers 2] [--serial-paths 2000]``.
``--sweep [zoa spectral sdm] [--samples 4000]`` instead times one Bayesian likelihood sweep per engine here
and on the cluster, and prints what the rule of :func:`millstab.cluster.sample_limits` decides.
Progress lines (``progress:``) every 10 % of the main run keep the partial rates of an interrupted run.
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


def _autogroup() -> str:
    try:
        on = Path("/proc/sys/kernel/sched_autogroup_enabled").read_text().strip() == "1"
    except OSError:
        return "autogroup scheduling: unknown"
    return f"autogroup scheduling: {'ON (one fair CPU share per login session)' if on else 'off'}"


def _client_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _worker_cpu(client) -> float:
    return float(sum(client.run(time.process_time).values()))


def study(client, n: int, seed: int, progress=None):
    cfg = load_example("ex1")
    return monte_carlo(cfg.structure, cfg.cutting, RPM, n=n, seed=seed, theta=predicted_theta("ex1"), client=client,
                       progress=progress)


def sweep(engines: list[str], samples: int, workers: int, repeats: int = 1) -> None:
    """Where the cluster pays for the Bayesian likelihood: one sweep (all particles at the cut speeds, as
    one Metropolis move of ``millstab update``) here and on ``workers`` local worker processes (forced
    out, PAYS_SECONDS = 0), for each engine; CPU-seconds here, wall both ways, the rule's decision."""
    from millstab import cluster
    from millstab.update import make_prior
    from millstab.update.likelihood import limits

    cfg = load_example("ex1")
    prior = make_prior(cfg.structure, cfg.cutting)
    rpm = np.array([4500.0, 6000.0, 7500.0, 9000.0, 10500.0])  # five test cuts' speeds
    u = prior.sample(samples, np.random.default_rng(0))
    with open_client(workers=workers) as client:
        for eng in engines:
            n = samples if eng == "zoa" else max(2 * workers, samples // {"spectral": 10, "sdm": 200}[eng])
            limits(prior, u[:2], rpm, eng)  # compile here
            c0, t0 = time.thread_time(), time.perf_counter()
            for _ in range(repeats):
                here = limits(prior, u[:n], rpm, eng)[0]
            cpu, wall = (time.thread_time() - c0) / repeats, (time.perf_counter() - t0) / repeats
            sec = cluster.seconds_per_row(client, eng, prior.par, prior.cutting, rpm)
            decided = "cluster" if sec * samples >= cluster.PAYS_SECONDS else "here"  # sample_limits' rule
            old, cluster.PAYS_SECONDS = cluster.PAYS_SECONDS, 0.0
            try:
                t0 = time.perf_counter()
                for _ in range(repeats):
                    there = cluster.sample_limits(client, prior, u[:n], rpm, eng)[0]
                wall_c = (time.perf_counter() - t0) / repeats
            finally:
                cluster.PAYS_SECONDS = old
            assert np.array_equal(here, there)
            print(f"sweep {eng}: {n} samples x {rpm.size} speeds: here {cpu:.3f} CPU-s ({wall:.3f} s wall) = "
                  f"{1e3 * cpu / n:.3f} ms per sample; on {workers} workers {wall_c:.3f} s wall (ratio "
                  f"{wall / wall_c:.2f}); {samples} samples would take {cpu / n * samples:.2f} CPU-s per sweep: the "
                  f"rule (probe {1e3 * sec:.3f} ms per sample on a worker, ≥ {cluster.PAYS_SECONDS} s) says {decided}",
                  flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--paths", type=int, default=1_000_000, help="paths of the main run (10^6)")
    ap.add_argument("--workers", type=int, default=2, help="worker processes of the main run")
    ap.add_argument("--serial-paths", type=int, default=2_000, help="paths of the in-process reference run")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--idle-seconds", type=float, default=20.0, help="idle cluster timed after the main run")
    ap.add_argument("--sweep", nargs="*", default=None, metavar="ENGINE",
                    help="instead: time one likelihood sweep per engine (zoa spectral sdm) here and on the cluster")
    ap.add_argument("--samples", type=int, default=4000, help="particles of a --sweep (spectral runs 1/10, sdm 1/200)")
    args = ap.parse_args()
    print(describe())
    if args.sweep is not None:
        print("load average (1, 5, 15 min) at start: " + ", ".join(f"{v:.1f}" for v in os.getloadavg()))
        with threadpool_limits(1):
            import numba

            numba.set_num_threads(1)
            sweep(args.sweep or ["zoa", "spectral", "sdm"], args.samples, args.workers)
        return
    print(f"{_autogroup()}; load average (1, 5, 15 min) at start: " + ", ".join(f"{v:.1f}" for v in os.getloadavg()))
    print(f"Monte Carlo of Ex.1, {RPM.size} speeds, {ENVELOPES_PER_PATH} envelopes per path; every worker and the "
          "in-process reference run numba on 1 thread", flush=True)
    with threadpool_limits(1):
        with open_client(workers=args.workers) as client:
            study(client, 20, args.seed)  # compile / load on every worker, outside the timing
            w0, c0 = _worker_cpu(client), _client_cpu()
            marks = [0.1 * k * args.paths for k in range(1, 10)]
            t0 = time.perf_counter()

            def progress(done: int, total: int) -> None:
                if marks and done >= marks[0]:
                    while marks and done >= marks[0]:
                        marks.pop(0)
                    dt = time.perf_counter() - t0
                    print(f"progress: {done} paths in {dt:.0f} s ({done / dt:.1f} paths/s wall)", flush=True)

            tracemalloc.start()
            t0 = time.perf_counter()
            res = study(client, args.paths, args.seed, progress)
            wall = time.perf_counter() - t0
            _, traced = tracemalloc.get_traced_memory()
            tracemalloc.stop()
            cpu_workers, cpu_client = _worker_cpu(client) - w0, _client_cpu() - c0
            # what the cluster burns doing nothing (event loops, heartbeats, memory monitors), per wall-second:
            # on a crowded machine the run's wall time, and with it this share of its CPU, is stretched
            w1, c1, t1 = _worker_cpu(client), _client_cpu(), time.perf_counter()
            time.sleep(args.idle_seconds)
            idle = (_worker_cpu(client) - w1 + _client_cpu() - c1) / (time.perf_counter() - t1)
        peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # the client alone so far
        import numba

        numba.set_num_threads(1)
        study(None, 20, args.seed)
        t1, c1 = time.perf_counter(), time.thread_time()
        study(None, args.serial_paths, args.seed)
        wall_1, cpu_1 = time.perf_counter() - t1, time.thread_time() - c1
    cpu = cpu_workers + cpu_client
    per_cpu_1, per_cpu_w = args.serial_paths / cpu_1, args.paths / cpu
    eff_cpu = per_cpu_w / per_cpu_1
    eff_wall = (args.paths / wall) / (args.workers * args.serial_paths / wall_1)
    print(f"in-process (no dask), {args.serial_paths} paths: {per_cpu_1:.1f} paths per CPU-s; wall {wall_1:.1f} s "
          f"({args.serial_paths / wall_1:.1f} paths/s)")
    print(f"{args.workers} workers, {args.paths} paths ({ENVELOPES_PER_PATH * args.paths} envelopes): "
          f"wall {wall:.1f} s "
          f"= {wall / 60:.2f} min ({args.paths / wall:.1f} paths/s); CPU {cpu:.1f} s (workers {cpu_workers:.1f}, "
          f"client+scheduler {cpu_client:.1f}) = {per_cpu_w:.1f} paths per CPU-s")
    print("mean MSE [mm^2]: " + ", ".join(f"{n} {m:.5f}" for n, m in zip(res.names, res.mean)))
    print(f"cpu_efficiency: {eff_cpu:.3f}; wall_efficiency: {eff_wall:.3f} (wall: only on an idle machine)")
    work = cpu - idle * wall  # the study's own CPU-seconds (tasks, transfers, scheduling), background removed
    wall_d = work / (args.workers - idle)  # W dedicated cores, less the background the cluster burns meanwhile
    eff_d = (args.paths / per_cpu_1) / (args.workers * wall_d)
    print(f"idle cluster: {idle:.3f} CPU-s per wall-second (all {args.workers} workers + client/scheduler); "
          f"the study's own CPU without it: {work:.1f} s = {args.paths / work:.1f} paths per CPU-s")
    print(f"dedicated_time: {wall_d / 60:.2f} min projected on {args.workers} dedicated cores (study CPU / "
          f"({args.workers} - idle rate)); projected parallel efficiency T_1 / ({args.workers} T_{args.workers}): "
          f"{eff_d:.3f}")
    env_core = args.paths / work * ENVELOPES_PER_PATH * (1 - idle / args.workers)  # per dedicated core, background in
    print(f"peak_client_mb: {peak_mb:.0f} (peak RSS of the client to the end of the main run); "
          f"tracemalloc peak of the main run: {traced / 2**20:.0f} MB")
    print(f"per-core rate: {env_core:.0f} envelopes/s per dedicated core at {RPM.size} speeds (study CPU, less the "
          "idle background); "
          f"1e8 envelopes on 256 cores: {1e8 / (256 * env_core) / 60:.1f} min")
    print("load average (1, 5, 15 min) at end: " + ", ".join(f"{v:.1f}" for v in os.getloadavg()))
    print(f"total_seconds: {wall:.1f}")


if __name__ == "__main__":
    main()
