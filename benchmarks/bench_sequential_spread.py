"""Does a campaign's sequential posterior narrow too far? (issue 27, docs/updating.md "Is it collapse?")

Case: the seed paper's Ex.1 tool at a/D 0.5 down milling, the truth one draw of the default prior (``--truth``), 20
cuts at random speeds in 5 000–12 000 rpm with depths 0.6–1.4 of the truth's zero-order limit, labelled by that
limit with 3 % relative depth noise (no model error: the question is the sampler's). Posteriors of the same cuts:
``--fresh`` fresh updates of ``--fresh-samples`` samples (seeds 7, 8, …) and ``--sequential`` campaigns of
``--samples`` particles that temper the cuts in one at a time (``update(start=...)``, the campaign's sequential
reuse; seeds 100·s + k). Printed: each posterior's sd of every ln θ over the first fresh run's, and its number of
distinct samples. If the sequential posteriors' ratios sit below the fresh runs' own scatter, the sequential reuse
narrows; if they scatter alike, one run against one cannot say.

Run: ``PYTHONPATH=src:benchmarks .venv/bin/python benchmarks/bench_sequential_spread.py --truth 0`` (~30 s CPU).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _machine import describe
from threadpoolctl import threadpool_limits

from millstab.io import load_config
from millstab.model import Cutting
from millstab.points import PointSet
from millstab.stability import zoa
from millstab.update import make_prior, update


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--truth", type=int, default=0, help="seed of the truth and its cuts")
    ap.add_argument("--cuts", type=int, default=20)
    ap.add_argument("--samples", type=int, default=300, help="particles of the sequential campaigns")
    ap.add_argument("--sequential", type=int, default=3, help="sequential campaigns (seeds)")
    ap.add_argument("--fresh", type=int, default=3, help="fresh updates (seeds)")
    ap.add_argument("--fresh-samples", type=int, default=4000)
    args = ap.parse_args()
    print(describe())
    cfg = load_config("example:ex1")
    cut = Cutting.from_immersion(cfg.cutting.teeth, cfg.cutting.kt, cfg.cutting.kr, 0.5, "down")
    prior = make_prior(cfg.structure, cut)
    rng = np.random.default_rng(args.truth)
    truth = prior.par.structure(np.exp(prior.sample(1, rng))[0])
    rpm = rng.uniform(5000, 12000, args.cuts)
    lim = zoa.envelope(truth, cut, rpm).depth_mm
    depth = lim * rng.uniform(0.6, 1.4, args.cuts)
    lab = np.where(depth > lim * np.exp(0.03 * rng.standard_normal(args.cuts)), "chatter", "stable")
    names = list(prior.par.free)
    p = len(names)
    print(f"truth {args.truth}: {args.cuts} cuts, {int((lab == 'chatter').sum())} chatter, a/D 0.5 down, zero-order "
          f"labels with 3 % depth noise")
    rows = []
    with threadpool_limits(1):
        for s in range(args.fresh):
            t = time.process_time()
            post = update(cfg, PointSet(rpm, depth, lab), prior=prior, samples=args.fresh_samples, seed=7 + s)
            rows.append((f"fresh {args.fresh_samples}, seed {7 + s}", post, time.process_time() - t))
        for s in range(1, args.sequential + 1):
            t = time.process_time()
            post = None
            for k in range(1, args.cuts + 1):
                post = update(cfg, PointSet(rpm[:k], depth[:k], lab[:k]), prior=prior, samples=args.samples,
                              seed=100 * s + k, start=post)
            rows.append((f"sequential {args.samples}, seeds {100 * s}+k", post, time.process_time() - t))
    sd0 = rows[0][1].u[:, :p].std(axis=0)
    print("sd of ln θ over the first fresh run's: " + " ".join(f"{n:>6}" for n in names))
    for name, post, cpu in rows:
        ratio = post.u[:, :p].std(axis=0) / sd0
        print(f"  {name:30s} " + " ".join(f"{x:6.2f}" for x in ratio) +
              f"   distinct {np.unique(post.u, axis=0).shape[0]}, {cpu:.1f} s CPU")


if __name__ == "__main__":
    main()
