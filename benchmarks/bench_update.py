"""Speed of Bayesian updating: one update (4 000 samples, 6 free parameters, 30 cuts, zoa) and a
P(stable) map of 300 speeds × 200 depths from 4 000 samples, against the issue's targets (10 s, 2 s).

Data: the seed paper's Ex.1 config as the prior; a truth drawn from that prior (seed 1); 30 cuts at
speeds evenly spaced over 5 000–12 000 rpm, depths uniform in ±50 % of the true limit, labelled by the
truth (zoa). Also timed: one batched engine call of the same size (4 000 sets × 30 speeds), so that
the update's time can be read as "engine calls" whatever the machine's load: the update makes one
call for the prior draws plus one per MH move (3 per SMC stage). CPU time (all threads) is printed too: on a shared
machine the wall time says more about the neighbours than about the code. BLAS pinned to one thread; numba uses its
default threads.

Run: ``.venv/bin/python benchmarks/bench_update.py [--samples 4000] [--repeat 1]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numba as nb
import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).parent))
from _machine import describe  # noqa: E402

from millstab.io import load_config  # noqa: E402
from millstab.points import PointSet  # noqa: E402
from millstab.io.config import with_batch_effect  # noqa: E402
from millstab.update import make_prior, p_stable_map, update  # noqa: E402
from millstab.update.likelihood import limits  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=4000)
    ap.add_argument("--cuts", type=int, default=30)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--batch-effect", type=float, default=0.0,
                    help="σ τ of the test-day shift of ln fn ([prior] batch_effect); the cuts are dealt to --days days")
    ap.add_argument("--days", type=int, default=4)
    args = ap.parse_args()
    print(describe())
    cfg = load_config("example:ex1")
    prior = make_prior(cfg.structure, cfg.cutting)
    rng = np.random.default_rng(1)
    u_true = prior.sample(1, rng)
    rpm = np.linspace(5000, 12000, args.cuts)
    b = limits(prior, u_true, rpm)[0][0]
    depth = b * rng.uniform(0.5, 1.5, rpm.size)
    days = np.array([f"day{i % args.days}" for i in range(rpm.size)]) if args.batch_effect else None
    cuts = PointSet(rpm, depth, np.where(depth > b, "chatter", "stable"), batch=days)
    if args.batch_effect:
        cfg = with_batch_effect(cfg, args.batch_effect)
        print(f"test-day effect τ = {args.batch_effect:g}, cuts dealt to {args.days} days")
    with threadpool_limits(1):
        limits(prior, prior.sample(64, rng), rpm)  # warm-up (compilation / cache load)
        u = prior.sample(args.samples, rng)
        t = time.perf_counter()
        limits(prior, u, rpm)
        t_call = time.perf_counter() - t
        print(f"one engine call, {args.samples} sets x {rpm.size} speeds: {t_call:.2f} s")
        for r in range(args.repeat):
            t, c = time.perf_counter(), time.process_time()
            post = update(cfg, cuts, samples=args.samples, seed=r)
            t_up, c_up = time.perf_counter() - t, time.process_time() - c
            d = post.diagnostics
            print(f"update: {t_up:.2f} s wall (target 10 s), {c_up:.2f} s CPU (all threads; "
                  f"{c_up / nb.get_num_threads():.2f} s per thread = the wall time on an idle machine if the threads "
                  f"scale) = {t_up / t_call:.1f} engine calls; {d['stages']} stages, "
                  f"{d['loglik_calls']} likelihood calls, acceptance "
                  f"{min(d['acceptance']):.2f}-{max(d['acceptance']):.2f}")
        speeds, depths = np.linspace(4000, 14000, 300), np.linspace(0, 8, 200)
        t, c = time.perf_counter(), time.process_time()
        pm = p_stable_map(post, speeds, depths)
        t_map, c_map = time.perf_counter() - t, time.process_time() - c
        t = time.perf_counter()
        limits(prior, post.u, speeds)
        t_eng = time.perf_counter() - t
        print(f"map 300 x 200 from {post.samples.shape[0]} samples: {t_map:.2f} s wall (target 2 s), {c_map:.2f} s CPU "
              f"({c_map / nb.get_num_threads():.2f} s per thread); of which the engine "
              f"call alone {t_eng:.2f} s; P(stable) range {pm.min():.2f}-{pm.max():.2f}")


if __name__ == "__main__":
    main()
