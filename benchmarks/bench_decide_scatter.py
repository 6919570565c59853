"""How much an accurate recommendation scatters from sampler seed to sampler seed, under two prior tails (issue 24).

Why: under ``tails = "multivariate_t_shift"`` the a/D 0.1 case's posterior holds far modes of ~2 % mass (a lobe
alias, docs/updating.md, "Why the quantiles jumped"), which single runs weigh with heavy-tailed scatter. Whether that
moves a decision is the question this answers: the same case (``bench_decide_accurate.make_case``: Ex.1 at a/D
``--immersion``, down milling, the truth the hammer test off by a random factor per parameter, ``--cuts`` cuts labelled
by the truth's SDM boundary with 3 % depth noise), for each of ``--tails`` and each sampler seed 0 … ``--seeds`` − 1:
a fresh spectral update (``--samples``, the default sampler) and the default recommendation at ``--risk``. Printed
per tails: the recommendations (speed, depth), how many are truly stable (below the truth's SDM limit at their speed
and ±0.25 %), their productivity over the best truly stable cut (the truth's SDM limit on ``--best-speeds`` speeds,
capped at ``--max-depth``), the P(chatter) each claimed, and the spread of speed and depth over the seeds.

The truth never enters the updates or the recommendations: it only judges them. One thread per run (BLAS pinned),
``--jobs`` runs at a time in a spawned pool; every run is seeded by its own index, so the numbers do not depend on
``--jobs``.

Run: ``PYTHONPATH=src:benchmarks .venv/bin/python benchmarks/bench_decide_scatter.py --seeds 16 --jobs 2``.
"""

from __future__ import annotations

import argparse
import os
import time

if __name__ == "__main__":  # before numba starts its OpenMP threads (bench_update_accurate.py measured why)
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

from itertools import repeat

import numpy as np
from threadpoolctl import threadpool_limits

from _machine import describe, pool_of
from bench_decide_accurate import make_case
from millstab.update.decide import SPEED_TOLERANCE as TOL  # a cut is truly stable only if it is at its speed ± this


def _case(args):
    """(config, prior without tails, cuts, text, rpm range, the true limit [mm] as a function of speeds [rpm]: SDM of
    the case's true structure)."""
    from millstab.stability import sdm

    lo, hi = (float(x) for x in args.rpm.split(":"))
    cfg, prior, cuts, text, structure = make_case(args.immersion, args.case, args.cuts, (lo, hi))
    return cfg, prior, cuts, text, (lo, hi), (
        lambda rpm: sdm.envelope(structure, prior.cutting, np.asarray(rpm, dtype=float)).depth_mm)


def _run(job) -> dict:
    """One update and recommendation: ``job`` = (args, tails, seed)."""
    from millstab.update import make_prior, recommend, update
    from millstab.io.config import PriorTable

    args, tails, seed = job
    cfg, prior, cuts, _, rpm_range, truth = _case(args)
    prior = make_prior(cfg.structure, prior.cutting, PriorTable({}, sigma_depth_rel=0.05, tails=tails))
    c0 = time.process_time()
    with threadpool_limits(1):
        post = update(cfg, cuts, samples=args.samples, seed=seed, engine="spectral", prior=prior)
        rec = recommend(post, args.risk, rpm_range, seed=seed, max_depth_mm=args.max_depth)
    cpu = time.process_time() - c0
    true = float(np.min(truth(rec.rpm * np.array([1 - TOL, 1.0, 1 + TOL]))))
    return {"tails": tails, "seed": seed, "rpm": rec.rpm, "depth": rec.depth_mm, "p": rec.p_chatter,
            "true": true, "cpu": cpu, "sets": post.diagnostics.get("engine_sets", 0)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=16, help="sampler seeds per tails")
    ap.add_argument("--tails", default="multivariate_t,multivariate_t_shift")
    ap.add_argument("--samples", type=int, default=1000)
    ap.add_argument("--cuts", type=int, default=10)
    ap.add_argument("--immersion", type=float, default=0.1)
    ap.add_argument("--case", type=int, default=0, help="the case's seed (truth and cuts)")
    ap.add_argument("--rpm", default="5000:12000")
    ap.add_argument("--risk", type=float, default=0.05)
    ap.add_argument("--max-depth", type=float, default=60.0)
    ap.add_argument("--best-speeds", type=int, default=361)
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args()
    print(describe())
    from millstab.update.campaign import best_productivity

    _, _, _, text, rpm_range, truth = _case(args)
    print(f"case: {text}; {args.samples} samples, spectral engine, risk {args.risk}")
    best = best_productivity(truth, rpm_range, args.max_depth, args.best_speeds, TOL)
    jobs = [(args, t, s) for t in args.tails.split(",") for s in range(args.seeds)]
    t0 = time.perf_counter()
    with pool_of(args.jobs) as pool:
        out = list(pool.map(_run, jobs) if pool else map(_run, jobs))
    print(f"{len(jobs)} runs in {time.perf_counter() - t0:.0f} s wall; best truly stable cut {best:.0f} mm·rpm")
    for t in args.tails.split(","):
        rows = [r for r in out if r["tails"] == t]
        rpm, depth = np.array([r["rpm"] for r in rows]), np.array([r["depth"] for r in rows])
        ok = np.array([r["depth"] < r["true"] for r in rows])
        prod = rpm * depth / best
        p = np.array([r["p"] for r in rows])
        print(f"  {t}: truly stable {ok.sum()}/{ok.size}; productivity / best median {np.median(prod):.2f} "
              f"(min {prod.min():.2f}, max {prod.max():.2f}); claimed P(chatter) median {np.median(p):.3f} (max "
              f"{p.max():.3f}); speed {np.median(rpm):.0f} rpm (range {rpm.min():.0f}–{rpm.max():.0f}), depth "
              f"median {np.median(depth):.2f} mm (range {depth.min():.2f}–{depth.max():.2f}); CPU per run "
              f"{np.mean([r['cpu'] for r in rows]):.1f} s")
        for r in rows:
            flag = "" if r["depth"] < r["true"] else "  CHATTERS"
            print(f"    seed {r['seed']:2d}: {r['rpm']:8.0f} rpm {r['depth']:6.2f} mm (true limit {r['true']:6.2f}), "
                  f"P(chatter) {r['p']:.3f}, accurate sets {r['sets']}{flag}")


if __name__ == "__main__":
    main()
