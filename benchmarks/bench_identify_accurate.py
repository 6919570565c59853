"""Success rate of the global least-squares identification with the accurate (spectral) engine at a/D 0.1
(issue 28): does the search find the global minimum from random starts, on random structures, with noise?

Pairs (case, start), all seeded: ``--cases`` random structures (millstab.identify.synthetic.random_case
with the radial immersion fixed at ``--immersion``, default a/D 0.1; fn 300–5000 Hz, fn_y within ×/÷ 1.5,
k 2–50 N/µm, ζ 0.005–0.08, 2–6 teeth, up or down milling; ``--speeds`` evenly spaced speeds whose
tooth-passing frequencies span 0.1–0.6 of the lower natural frequency), each with ``--starts`` random
starting structures (every parameter the truth's × U(0.7, 1.3)). The boundary points are the spectral
engine's limiting depths at the truth with Gaussian relative noise whose level is drawn per case
log-uniformly in 0.1–1 % (seeded). A case is kept only if the points determine all six parameters
(smallest singular value of ∂ln b/∂ln θ ÷ √n at the truth ≥ 0.01, as bench_identify_robustness).

**Success** = the fit explains the points as well as the truth does:
``RSS(fit) ≤ RSS(truth) · (1 + p/(n − p) F_{p, n−p}(0.95))``. The truth is one point of the parameter box,
so the global minimum has RSS ≤ RSS(truth): a solver that finds it always succeeds, whatever the noise
(no statistical luck enters the criterion). The margin is Beale's (1960) 95 % joint-confidence factor: a
parameter set within it is statistically indistinguishable from the truth on these points (it covers the
non-identifiable case of an equivalent fit, and local minima next to the truth left by the non-smooth
boundary). A wrong basin is far outside it (RMS log residual 4–5 % against 0.1–1 % noise: RSS 20–2 000×
the truth's). The line of each pair also prints the largest parameter error against the truth in
standard errors of the fit and in %, for information.

Each pair is a pure function of (``--seed``, case, start): ``--jobs N`` runs the pairs in a process pool
of N workers (numba and BLAS on one thread each) and the figures do not depend on N.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/bench_identify_accurate.py [--cases 20 --starts 2]
[--jobs 16] [--speeds 30] [--zoa-basins 8] [--no-merge]``; ``--no-merge`` leaves out the merged-mode stage
(millstab.identify.lsq.merge_modes, the search before it); ``--zoa-basins K`` turns on the opt-in stage that starts the
accurate LM from K zero-order basins (millstab.identify.lsq.basin_search; default 0, the default search).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy import stats
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).parent))
from _machine import describe, pool_of  # noqa: E402

from millstab.identify import fit_lsq, make_problem  # noqa: E402
from millstab.identify.accuracy import rel_error  # noqa: E402
from millstab.identify.synthetic import boundary_points, identifiability, random_case  # noqa: E402
from millstab.model import Cutting, Mode, Structure  # noqa: E402
from millstab.params import Parameterization  # noqa: E402


def draw_case(seed: int, i: int, immersion: float, n: int):
    """Case ``i`` (its own stream: (seed, i, redraw)): a random_case at the fixed immersion, re-drawn
    until identifiable; returns (case, noise level, redraws)."""
    for redraw in range(100):
        rng = np.random.default_rng([seed, i, redraw])
        c = random_case(rng, n=n)
        milling = "up" if c.cutting.entry == 0.0 else "down"  # random_case: up milling enters at 0
        cut = Cutting.from_immersion(c.cutting.teeth, c.cutting.kt, c.cutting.kr, immersion, milling)
        if identifiability(c.structure, cut, c.rpm, engine="spectral") >= 1e-2:
            noise = math.exp(rng.uniform(math.log(1e-3), math.log(1e-2)))
            return c.structure, cut, c.rpm, noise, redraw
    raise RuntimeError(f"case {i}: no identifiable draw in 100")


def start_of(truth: Structure, seed: int, i: int, j: int, spread: float = 0.3) -> Structure:
    """Start ``j`` of case ``i``: every parameter of the truth × U(1 − spread, 1 + spread), seeded."""
    f = np.random.default_rng([seed, i, 1000 + j]).uniform(1 - spread, 1 + spread, 6)
    m = [Mode(md.fn * f[3 * d], md.k * f[3 * d + 1], md.zeta * f[3 * d + 2], f"structure.{x}[0]")
         for d, (x, md) in enumerate((("x", truth.x[0]), ("y", truth.y[0])))]
    return Structure(x=(m[0],), y=(m[1],))


def run_pair(seed: int, i: int, j: int, immersion: float, n: int, zoa_basins: int, merge: bool = True) -> dict:
    """One (case, start) pair: points, fit, score (a pure function of its arguments)."""
    from millstab.cluster import one_thread

    one_thread()
    with threadpool_limits(1):
        truth_s, cut, rpm, noise, redraws = draw_case(seed, i, immersion, n)
        pts = boundary_points(truth_s, cut, rpm, noise=noise, seed=10_000 * seed + i, engine="spectral")
        prob = make_problem(start_of(truth_s, seed, i, j), cut, pts, engine="spectral")
        truth = Parameterization(truth_s).theta0
        rss_truth = float(prob.rss(prob.predict_mm(truth[None]))[0])
        t = time.process_time()
        fit = fit_lsq(prob, seed=j, zoa_basins=zoa_basins, merge=merge)
        cpu = time.process_time() - t
    p, m = prob.p, prob.n
    margin = 1 + p / (m - p) * stats.f.ppf(0.95, p, m - p)
    ok = fit.rss <= rss_truth * margin
    err = rel_error(fit.estimate, truth, None)
    z = np.abs(np.log(fit.estimate / truth)) / np.maximum(fit.std_errors / fit.estimate, 1e-300)
    line = (f"case {i:2d} start {j}: {cut.teeth} teeth {'up' if cut.entry == 0.0 else 'down':>4}, fn "
            f"{truth[0]:5.0f}/{truth[3]:5.0f} Hz, noise {100 * noise:.2f} %: RSS/RSS(truth) {fit.rss / rss_truth:8.3g} "
            f"(margin {margin:.2f}) {'ok' if ok else 'WRONG BASIN'}; max err {100 * err.max():6.2f} % ({z.max():5.1f} "
            f"σ); RMS {math.sqrt(fit.rss / m):.2e}; {fit.evaluations} SLDs, {cpu:.0f} s CPU; re-seeding rounds "
            f"{fit.settings['rounds_run']}{', zero-order basin won' if fit.settings.get('zoa_basin_won') else ''}"
            f"{', merged modes won' if fit.settings.get('merge_won') else ''}")
    return {"ok": bool(ok), "cpu": cpu, "evaluations": fit.evaluations, "err": float(err.max()),
            "z": float(z.max()), "line": line}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=20)
    ap.add_argument("--starts", type=int, default=2, help="random starts per case")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--speeds", type=int, default=30, help="boundary points per case")
    ap.add_argument("--immersion", type=float, default=0.1, help="radial immersion a/D")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (the figures do not depend on it)")
    ap.add_argument("--first-case", type=int, default=0, help="run cases first-case .. first-case + cases - 1")
    ap.add_argument("--zoa-basins", type=int, default=0,
                    help="start the accurate LM from this many zero-order basins too")
    ap.add_argument("--no-merge", action="store_true",
                    help="leave out the merged-mode stage (millstab.identify.lsq.merge_modes): the old search")
    a = ap.parse_args()
    print(describe())
    pairs = [(a.seed, i, j, a.immersion, a.speeds, a.zoa_basins, not a.no_merge)
             for i in range(a.first_case, a.first_case + a.cases) for j in range(a.starts)]
    print(f"{len(pairs)} (case, start) pairs at a/D {a.immersion}, {a.speeds} speeds each, spectral engine, "
          f"zero-order basins {a.zoa_basins}, merged modes {'off' if a.no_merge else 'on'}; {a.jobs} job(s)",
          flush=True)
    t0 = time.perf_counter()
    if a.jobs <= 1:
        recs = []
        for args in pairs:
            recs.append(run_pair(*args))
            print(recs[-1]["line"], flush=True)
    else:
        recs = []
        with pool_of(a.jobs) as pool:  # spawned: numba's OpenMP forbids fork after use
            for r in pool.map(run_pair, *zip(*pairs)):  # in order, each as soon as it and those before it are done
                recs.append(r)
                print(r["line"], flush=True)
    n_ok = sum(r["ok"] for r in recs)
    cpu = np.array([r["cpu"] for r in recs])
    print(f"success (RSS within the 95 % margin of the truth's): {n_ok}/{len(recs)} = {100 * n_ok / len(recs):.1f} %; "
          f"within 1 % of the truth in every parameter: {sum(r['err'] < 0.01 for r in recs)}/{len(recs)}")
    print(f"CPU per fit: median {np.median(cpu):.0f} s, max {cpu.max():.0f} s; evaluations median "
          f"{np.median([r['evaluations'] for r in recs]):.0f}; wall {time.perf_counter() - t0:.0f} s")
    print(f"identify_accurate_success: {n_ok}/{len(recs)}")


if __name__ == "__main__":
    main()
