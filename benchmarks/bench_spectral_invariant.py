"""The spectral engine's hand-over of a time-invariant cutting to the zero-order boundary, timed in an update.

A slot with 4, 6, 8 … teeth has a constant directional matrix (``Cutting.time_invariant``), so its zero-order
boundary is exact; the spectral engine then takes it from the zero-order engine (``spectral.INVARIANT_BY_ZOA``,
docs/engines.md, "Time-invariant cutting") instead of collocating the whole tooth period. Case: a four-flute tool
(one mode per direction, the seed paper's x and y fundamental modes), a slot, ``--cuts`` cuts at random speeds in
6 000–19 000 rpm and depths around the truth's limit (× e^U(−0.5, 0.5): labels of both kinds), labelled by the
time-domain simulation of a truth off the hammer test; the spectral update with ``--samples`` samples with the
hand-over and without it, alternated ``--repeats`` times in one process (BLAS pinned to one thread), and the
zero-order update; the posterior medians of both spectral updates compared (the same within the collocation's
accuracy and the chains' Monte Carlo error).

Run: ``PYTHONPATH=src:benchmarks .venv/bin/python benchmarks/bench_spectral_invariant.py`` (~2 min on 2 cores).
"""

from __future__ import annotations

import argparse
import math
import time
import warnings

import numpy as np
from threadpoolctl import threadpool_limits

from _machine import describe
from millstab.model import Cutting, Mode, Structure
from millstab.points import PointSet
from millstab.simulate import label_cuts
from millstab.stability import spectral, zoa
from millstab.update import make_prior, update

HAMMER = Structure(x=(Mode(3890.0, 22.6e6, 0.0196),), y=(Mode(3872.0, 23.4e6, 0.022),))
TRUTH = Structure(x=(Mode(3700.0, 16.0e6, 0.0196),), y=(Mode(3872.0, 23.4e6, 0.030),))
SLOT = Cutting(4, 1110e6, 0.22, 0.0, math.pi)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cuts", type=int, default=12)
    ap.add_argument("--samples", type=int, default=500)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    print(describe())
    assert SLOT.time_invariant
    rng = np.random.default_rng(args.seed)
    rpm = rng.uniform(6000.0, 19000.0, args.cuts)
    depth_mm = zoa.envelope(TRUTH, SLOT, rpm).depth_mm * np.exp(rng.uniform(-0.5, 0.5, args.cuts))
    lab = label_cuts(TRUTH, SLOT, rpm, depth_mm * 1e-3, 1e-4)
    cuts = PointSet(rpm, depth_mm, list(lab.label))
    prior = make_prior(HAMMER, SLOT)
    print(f"{args.cuts} slot cuts, {sum(lab.label == 'chatter')} chatter; {args.samples} samples")
    warnings.simplefilter("ignore")
    with threadpool_limits(1):
        update(None, cuts, prior=prior, samples=100, seed=99, engine="spectral")  # compile / load
        times: dict[bool, list[float]] = {True: [], False: []}
        medians = {}
        for _ in range(args.repeats):
            for on in (True, False):
                spectral.INVARIANT_BY_ZOA = on
                t = time.perf_counter()
                post = update(None, cuts, prior=prior, samples=args.samples, seed=1, engine="spectral")
                times[on].append(time.perf_counter() - t)
                medians[on] = np.median(post.samples, axis=0)
        spectral.INVARIANT_BY_ZOA = True
        t = time.perf_counter()
        update(None, cuts, prior=prior, samples=args.samples, seed=1, engine="zoa")
        t_zoa = time.perf_counter() - t
    on, off = np.median(times[True]), np.median(times[False])
    print(f"spectral update, wall median of {args.repeats}: with the hand-over {on:.2f} s, collocating the slot "
          f"{off:.1f} s ({off / on:.0f}x); zero-order update {t_zoa:.2f} s")
    rel = np.abs(medians[True] / medians[False] - 1)
    print(f"posterior medians, largest relative difference between the two: {rel.max():.1e} "
          f"({', '.join(f'{n} {m:.4g}' for n, m in zip(prior.names, medians[True]))})")


if __name__ == "__main__":
    main()
