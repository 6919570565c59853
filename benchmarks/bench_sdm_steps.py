"""How coarse may an sdm fit of the conditions campaign be? SDM's limit error at fixed ``steps`` per tooth period.

At the conditions and speeds of ``bench_conditions_campaign.py`` (its three virtual machines: hammer test, truth
and ``--draws`` draws of the prior around the hammer test, which is what a fit evaluates; its five conditions; 4 000
to 12 000 rpm), the limiting depth with ``steps`` = 10, 15, 20, 30, 40 fixed against sdm's accuracy-controlled
default (Richardson-extrapolated, ≤ 0.23 % from the converged limit: ``millstab.stability.sdm``). Printed per
steps: the error |ln(b_steps / b_ref)| (median, 95th percentile, max), the share of (set, speed) pairs off by more
than 5 %, the share of held-out cuts it would label the other way, the same against steps = 40 (the truth's),
and the CPU time of the envelope calls (all sets and speeds), with the reference's cost.

The scale it is judged against (the campaign): training depths spread ×/÷ exp(0.5) around the belief, held-out
depths within ×/÷ 1.8 of the true limit, the likelihood's depth noise 0.05 mm (learned ×/÷ 2.3).

Run: ``nice .venv/bin/python benchmarks/bench_sdm_steps.py --draws 20 --speeds 81``
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, os.path.dirname(__file__))
from _machine import describe  # noqa: E402
from _truth import sdm_options, truth_spec  # noqa: E402
from bench_conditions_campaign import TARGETS, TRAIN, cond, machines  # noqa: E402

from millstab.stability import get_engine  # noqa: E402
from millstab.frf import ModalBatch  # noqa: E402
from millstab.update import make_prior  # noqa: E402


def structures(args) -> list[tuple[str, ModalBatch, int]]:
    """Per machine: (name, batch of hammer test + truth + prior draws, teeth)."""
    out = []
    for i, (name, (hammer, truth, teeth)) in enumerate(machines().items()):
        prior = make_prior(hammer, cond(teeth, 1.0, "down"))
        theta = np.exp(prior.sample(args.draws, np.random.default_rng(args.seed + i)))
        draws = prior.par.batch(theta)
        batch = ModalBatch.from_structures([hammer, truth] + [draws.structure(j) for j in range(args.draws)])
        out.append((name, batch, teeth))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--draws", type=int, default=20, help="prior draws per machine")
    ap.add_argument("--speeds", type=int, default=81)
    ap.add_argument("--steps", default="10,15,20,30,40,fn1",
                    type=lambda text: ",".join(truth_spec(t) for t in text.split(",")),
                    help="fixed steps, or fnF: the default's control at a highest natural frequency of F Hz (fn1: 20 "
                         "and 40 steps everywhere, extrapolated); auto: the reference itself")
    ap.add_argument("--rpm", type=float, nargs=2, default=(4000.0, 12000.0))
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    print(describe())
    print(f"load average: {os.getloadavg()[0]:.1f}")
    sdm = get_engine("sdm")
    rpm = np.linspace(*args.rpm, args.speeds)
    steps = args.steps.split(",")
    err = {s: [] for s in steps}
    err40 = {s: [] for s in steps}
    cpu = {s: 0.0 for s in steps + [0]}
    with threadpool_limits(1):
        for name, batch, teeth in structures(args):
            for ri, m in TRAIN + TARGETS:
                c = cond(teeth, ri, m)
                t0 = time.process_time()
                ref = sdm.envelope_batch(batch, c, rpm)
                cpu[0] += time.process_time() - t0
                fixed = {}
                for s in steps:
                    t0 = time.process_time()
                    fixed[s] = sdm.envelope_batch(batch, c, rpm, **sdm_options(s))
                    cpu[s] += time.process_time() - t0
                    err[s].append(log_error(fixed[s], ref))
                    print(f"  {name:7s} a/D {ri:4.2f} {m:4s} {s:>6s}: median {np.median(err[s][-1]):6.2%}, "
                          f"max {np.max(err[s][-1]):7.2%}", flush=True)
                for s in steps:
                    err40[s].append(log_error(fixed[s], fixed.get(str(TRUTH_STEPS), ref)))
    n = sum(len(e) for e in err[steps[0]])
    print(f"\n{n} (set, speed) pairs per steps (3 machines × {args.draws + 2} sets × 5 conditions × {args.speeds} "
          f"speeds); reference: the default (Richardson-extrapolated) steps, {cpu[0]:.1f} s CPU. Error: |ln(b/b_ref)|; "
          f"flips: the share of held-out cuts (depths log-uniform within ×/÷ 1.8 of the limit) labelled the other way")
    print(f"option  median    p95     max   >5 %  flips | vs steps={TRUTH_STEPS} (the old truth): median  flips"
          f" | CPU s (× reference)")
    for s in steps:
        e, e40 = np.concatenate(err[s]), np.concatenate(err40[s])
        print(f"{s:>6s} {np.median(e):6.2%} {np.percentile(e, 95):6.2%} {np.max(e):7.2%} {np.mean(e > 0.05):6.1%} "
              f"{flips(e):5.1%} | {np.median(e40):29.2%} {flips(e40):6.1%} | {cpu[s]:6.1f} ({cpu[s] / cpu[0]:.2f})")


#: the campaign's truth discretisation before 2026-11-28 (``--truth-steps 40`` of bench_conditions_campaign.py; its
#: truth is SDM's accuracy control since, :mod:`_truth`), the column the documented table compares with
TRUTH_STEPS = 40


def log_error(b: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """|ln(b / ref)| per (set, speed); 0 where both are inf (no boundary), inf where only one is."""
    both = np.isfinite(b) & np.isfinite(ref)
    e = np.abs(np.log(np.where(both, b, 1.0) / np.where(both, ref, 1.0)))
    return np.where(both, e, np.where(np.isinf(b) == np.isinf(ref), 0.0, np.inf)).ravel()


def flips(e: np.ndarray) -> float:
    """The share of cuts at depths log-uniform within ±0.6 of the reference limit (the campaign's held-out band)
    whose label differs under a limit off by ``e`` in log: min(e, 0.6)/1.2 averaged."""
    return float(np.mean(np.minimum(e, 0.6) / 1.2))


if __name__ == "__main__":
    main()
