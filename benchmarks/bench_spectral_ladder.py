"""The spectral search's coarse ladder bottom against SDM's fine ladder (issue 28): the same limits, fewer evaluations.

``spectral.LADDER`` climbs every other one of SDM's rungs under 0.6 × the zero-order depth and refines such a step
into twice the parts (``_spectral_kernel.refine_parts``: REFINE parts per 0.05·b_ref), so it visits the fine ladder's
depths wherever the refinement is due. With ``sdm.FACTORS`` as the ladder the same kernel is the search before
(every step 0.05·b_ref, REFINE parts each). Random prior draws of the packaged examples at a/D 0.02–0.5, up and down,
40 random speeds each (and Ex.1's update case), both ladders in the same process: the pairs whose limits differ by
more than 1e-9 (relative), the largest difference, the evaluations per (set, speed) and the CPU of each (one thread,
6 nodes).

Run: ``PYTHONPATH=src:benchmarks .venv/bin/python benchmarks/bench_spectral_ladder.py [--scale 1]`` (about 5 min on
one core at scale 1: 175 960 pairs; ``--scale 0.1`` for a quick look).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _machine import describe
from threadpoolctl import threadpool_limits

from millstab.io import load_config
from millstab.io.config import PriorTable
from millstab.model import Cutting
from millstab.stability import sdm, spectral
from millstab.update import make_prior

#: (example, a/D, milling, prior draws at scale 1, speed range [rpm], seed): every example at five conditions, and
#: the docs/updating.md update case's speeds
CASES = [(ex, imm, mill, n if ex != "fourflute" else n // 3, (1000.0, 40000.0), 100 + 5 * i + j)
         for i, ex in enumerate(("ex1", "ex2", "ex3", "fourflute"))
         for j, (imm, mill, n) in enumerate(((0.02, "down", 300), (0.05, "up", 300), (0.1, "down", 300),
                                             (0.25, "up", 200), (0.5, "down", 100)))]
CASES.append(("ex1", 0.1, "down", 400, (5000.0, 12000.0), 999))


def limits(batch, cut, rpm, ladder):
    """(limits (B, S) [m], evaluations (B, S), CPU s) with ``ladder`` as the spectral search's ladder."""
    keep = spectral.LADDER
    spectral.LADDER = ladder
    try:
        b_ref = spectral._b_ref(batch, cut, rpm)
        t = time.process_time()
        depth, _, n_eval = spectral._solve(batch, cut, rpm, b_ref, 6)
        return depth, n_eval, time.process_time() - t
    finally:
        spectral.LADDER = keep


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", type=float, default=1.0, help="prior draws per case × this (> 0)")
    args = ap.parse_args()
    if not args.scale > 0:
        ap.error(f"--scale {args.scale}: a factor > 0")
    print(describe())
    total = differ = 0
    evals = {"fine": 0, "coarse": 0}
    cpu = {"fine": 0.0, "coarse": 0.0}
    with threadpool_limits(1):
        for ex, imm, mill, n, (lo, hi), seed in CASES:
            cfg = load_config("example:" + ex)
            cut = Cutting.from_immersion(cfg.cutting.teeth, cfg.cutting.kt, cfg.cutting.kr, imm, mill)
            prior = make_prior(cfg.structure, cut, PriorTable({}))
            rng = np.random.default_rng(seed)
            batch = prior.par.batch(np.exp(prior.sample(max(1, round(n * args.scale)), rng)))
            rpm = np.sort(rng.uniform(lo, hi, 40))
            d0, n0, t0 = limits(batch, cut, rpm, sdm.FACTORS)
            d1, n1, t1 = limits(batch, cut, rpm, spectral.LADDER)
            both = np.isfinite(d0) & np.isfinite(d1)
            rel = np.where(both, np.abs(d1 / np.where(both, d0, 1.0) - 1.0), 0.0)
            bad = ~((~np.isfinite(d0) & ~np.isfinite(d1)) | (both & (rel <= 1e-9)))
            total, differ = total + d0.size, differ + int(bad.sum())
            evals["fine"] += int(n0.sum())
            evals["coarse"] += int(n1.sum())
            cpu["fine"] += t0
            cpu["coarse"] += t1
            print(f"{ex:9s} a/D {imm:4.2f} {mill:4s} {lo:.0f}-{hi:.0f} rpm: {d0.size:6d} pairs, differ "
                  f"{int(bad.sum())}, max {rel.max():.1e}; evaluations {n0.mean():.2f} -> {n1.mean():.2f} "
                  f"({n1.mean() / n0.mean() - 1:+.1%}); "
                  f"CPU {t0:.2f} -> {t1:.2f} s", flush=True)
            for i, j in np.argwhere(bad)[:3]:
                print(f"    set {i}, {rpm[j]:.1f} rpm: fine {d0[i, j] * 1e3:.4f} mm, coarse {d1[i, j] * 1e3:.4f} mm")
    change = evals["coarse"] / evals["fine"] - 1
    print(f"all: {total} pairs, {differ} differ by more than 1e-9; evaluations {change:+.1%}, "
          f"CPU {cpu['fine']:.1f} -> {cpu['coarse']:.1f} s (one thread; the first case includes the compile)")
    print(f"spectral_ladder_pairs_differing: {differ}")


if __name__ == "__main__":
    main()
