"""What the spectral engine's node count costs and buys in the updating loop (issue 28): limiting depths of
prior samples at the cut speeds of the docs/updating.md low-immersion case with p − 4, p − 2, p, p + 2 nodes per
element (p the count a problem's ``settings`` chooses: the converged count + 2), each against p + 4 as the
reference, and the CPU time of each.

The question: would the converged count (p − 2 here) do for an update? Its depths are compared with the
reference in units of the likelihood's depth noise (σ_b, 5 % of the depth in this case): an error of 0.1 σ_b
moves a cut's probit by 0.1. Where two node counts give depths more than 1 % apart the search landed on a
different lobe or band (counted separately: those are not discretisation errors of one root).

Run: ``PYTHONPATH=src:benchmarks .venv/bin/python benchmarks/bench_spectral_nodes.py [--samples 200]``.
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
from millstab.stability import spectral
from millstab.update import make_prior


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=200)
    ap.add_argument("--immersion", type=float, default=0.1)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    print(describe())
    cfg = load_config("example:ex1")
    cut = Cutting.from_immersion(cfg.cutting.teeth, cfg.cutting.kt, cfg.cutting.kr, args.immersion, "down")
    prior = make_prior(cfg.structure, cut, PriorTable({}, sigma_depth_rel=0.05))
    rng = np.random.default_rng(args.seed)
    rpm = np.sort(rng.uniform(5000, 12000, 10))  # the cut speeds' distribution of bench_update_accurate.py
    theta, _ = prior.split(prior.sample_full(args.samples, rng))
    batch = prior.par.batch(theta)
    with threadpool_limits(1):
        p = spectral.settings(prior.par.batch(prior.median[None]), cut, rpm)["nodes"]
        out, cpu = {}, {}
        for q in (p - 4, p - 2, p, p + 2, p + 4):
            spectral.envelope_batch(prior.par.batch(theta[:2]), cut, rpm, nodes=q, near=0.0)  # compile / load
            c = time.process_time()
            out[q] = spectral.envelope_batch(batch, cut, rpm, nodes=q, near=0.0)
            cpu[q] = time.process_time() - c
    ref = out[p + 4]
    print(f"{args.samples} prior samples x {rpm.size} speeds ({np.round(rpm).astype(int).tolist()} rpm), a/D "
          f"{args.immersion}; settings' nodes p = {p}; reference p + 4 = {p + 4}")
    for q in (p - 4, p - 2, p, p + 2):
        fin = np.isfinite(ref) & np.isfinite(out[q])
        rel = np.abs(out[q][fin] / ref[fin] - 1)
        jump = rel > 0.01
        e = rel[~jump] / 0.05
        print(f"nodes {q:2d}: CPU {cpu[q]:6.2f} s ({cpu[q] / cpu[p]:.2f}x of p); |depth error| in sigma_b: median "
              f"{np.median(e):.2e}, 99 % {np.quantile(e, 0.99):.2e}, max {e.max():.2e}; > 1 % apart (another root): "
              f"{int(jump.sum())} of {fin.sum()}; finite mismatch "
              f"{int((np.isfinite(ref) != np.isfinite(out[q])).sum())}")
    print(f"reference p + 4: CPU {cpu[p + 4]:.2f} s")


if __name__ == "__main__":
    main()
