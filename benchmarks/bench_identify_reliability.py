"""Reliability figures of identification and test planning (issue 10, item 2).

1. **Degrees of freedom.** The paper's Example 3 (six free parameters), n = 6, 7, 8 and 20 evenly spaced
   boundary points over 3 000–21 000 rpm with 2 % Gaussian relative depth noise, ``--draws`` seeded draws
   each. Per n: the largest |estimate − truth|/σ over the parameters, with the standard errors as they
   were (σ̂ = √(RSS/max(n − p, 1))) and as they are now (:func:`millstab.identify.quality.error_sigma`:
   an assumed 2 % below 10 degrees of freedom), and how often the truth lies within 3σ in every
   parameter. Draws whose fit lists alternative solutions are counted apart (a different structure
   explaining the points as well: no standard error can cover that).
2. **Planning.** Example 3 and four random cases (millstab.identify.synthetic.random_case, seed 5),
   200 candidate speeds, n = 6, 10, 20 tests, 16 prior samples: the criterion of the continuous design,
   of its plain largest-remainder rounding (what the plan was before), and of the plan now (rounding,
   then single-test exchanges; even spacing if better), each divided by that of n evenly spaced tests;
   and the plan's efficiency bound against the best continuous design.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/bench_identify_reliability.py [--draws 12]`` (a few minutes).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).parent))
from _machine import describe  # noqa: E402

import millstab.identify.design as design  # noqa: E402
from millstab.datasets import load_example  # noqa: E402
from millstab.identify import identify  # noqa: E402
from millstab.identify.synthetic import boundary_points, random_case  # noqa: E402
from millstab.params import Parameterization  # noqa: E402


def dof_study(draws: int) -> None:
    cfg = load_example("ex3")
    truth = Parameterization(cfg.structure).theta0
    print("1. degrees of freedom: Example 3, 6 free parameters, 2 % noise; max over parameters of |error|/σ")
    print(f"{'n':>3} {'dof':>4} {'draws':>5} {'alt.':>4} | {'old: median':>11} {'max':>9} {'≤3σ':>5} | "
          f"{'now: median':>11} {'max':>7} {'≤3σ':>5}")
    for n in (6, 7, 8, 20):
        z_old, z_new, n_alt = [], [], 0
        for seed in range(draws):
            pts = boundary_points(cfg.structure, cfg.cutting, np.linspace(3000, 21000, n), noise=0.02, seed=seed)
            fit = identify(cfg, pts, seed=0)
            if fit.alternatives:
                n_alt += 1
                continue
            z = np.abs(fit.estimate - truth) / fit.std_errors
            sig_old = np.sqrt(fit.rss / max(fit.dof, 1))
            z_new.append(z.max())
            z_old.append(z.max() * fit.noise["sigma"] / max(sig_old, 1e-300))
        if not z_new:
            print(f"{n:>3} {n - 6:>4} {draws:>5} {n_alt:>4} | (every draw has alternatives)")
            continue
        zo, zn = np.array(z_old), np.array(z_new)
        print(f"{n:>3} {n - 6:>4} {draws:>5} {n_alt:>4} | {np.median(zo):>11.3g} {zo.max():>9.3g} "
              f"{np.mean(zo <= 3):>5.0%} | {np.median(zn):>11.3g} {zn.max():>7.3g} {np.mean(zn <= 3):>5.0%}")


def plan_study() -> None:
    cases = []
    cfg = load_example("ex3")
    cases.append(("ex3", Parameterization(cfg.structure), cfg.cutting, np.linspace(3000, 21000, 200)))
    rng = np.random.default_rng(5)
    for i in range(4):
        c = random_case(rng)
        cases.append((f"random {i}", Parameterization(c.structure), c.cutting, np.linspace(c.rpm[0], c.rpm[-1], 200)))
    print("\n2. planning: criterion / criterion of n evenly spaced tests (lower is better; > 1 is worse than even)")
    print(f"{'case':>9} {'n':>3} | {'continuous':>10} {'rounded (before)':>16} {'plan now':>8} {'even chosen':>11} | "
          f"{'efficiency ≥':>12}")
    seen: dict[str, np.ndarray] = {}
    crit = design.criterion

    def spy(jac, counts, info0, target, ridge=0.0):  # the one call with (n·w, rounded, even) stacked
        v = crit(jac, counts, info0, target, ridge)
        if np.ndim(counts) == 2 and np.shape(counts)[0] == 3:
            seen["v"] = np.asarray(v)
        return v

    improve = design.improve_counts
    for name, par, cut, cand in cases:
        for n in (6, 10, 20):
            design.criterion, design.improve_counts = spy, (lambda jac, c, *a, **k: c)
            design.design_speeds(par, cut, cand, n, seed=0)
            cont, rounded, even = seen["v"]
            design.criterion, design.improve_counts = crit, improve
            plan = design.design_speeds(par, cut, cand, n, seed=0)
            print(f"{name:>9} {n:>3} | {cont / even:>10.3f} {rounded / even:>16.3f} "
                  f"{plan.criterion_design / plan.criterion_uniform:>8.3f} {str(plan.uniform):>11} | "
                  f"{plan.efficiency:>12.3f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--draws", type=int, default=12)
    ap.add_argument("--skip-dof", action="store_true")
    ap.add_argument("--skip-plan", action="store_true")
    args = ap.parse_args()
    print(describe())
    with threadpool_limits(1):
        if not args.skip_dof:
            dof_study(args.draws)
        if not args.skip_plan:
            plan_study()


if __name__ == "__main__":
    main()
