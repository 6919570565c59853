"""Monte Carlo sensitivity (the seed paper's Algorithm 2 / Table 6) through the batched engine.

N = 10 000 paths around the paper's Ex.1 predicted values (910.4 Hz, 13.44 N/µm, 0.0287 / 0.0286),
Ex.1 cutting conditions, t = 0.1, ε = 1 %: 70 000 envelopes at S = 200 speeds (2 000–12 000 rpm by
default). Prints the table beside the paper's and the fn/k ratio; with ``--million`` also runs
N = 10^6 in chunks and reports its time; peak RSS of the process at the end (resource.ru_maxrss).
With ``--speed-study`` it repeats the N = 10 000 table over a few plausible speed sets (the paper
does not give its own).

Run: ``.venv/bin/python benchmarks/bench_sensitivity.py [--n 10000] [--million] [--speed-study]``.
Last lines: ``mc_seconds: T`` (the N-path run) and ``peak_rss_mb: M``.
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).parent))
from _machine import describe  # noqa: E402

from millstab.datasets import load_example  # noqa: E402
from millstab.sensitivity import monte_carlo, predicted_theta, table6  # noqa: E402

#: plausible speed sets for the paper's unstated one [rpm]
SPEED_SETS = {
    "2000-12000 rpm, 200 speeds (bench default)": np.linspace(2000, 12000, 200),
    "3000-15000 rpm step 10 (ex1 config default, 1201 speeds)": np.arange(3000, 15000 + 5, 10.0),
    "3000-15000 rpm, 200 speeds": np.linspace(3000, 15000, 200),
    "5000-25000 rpm, 200 speeds (incl. the k=0 lobe)": np.linspace(5000, 25000, 200),
    "2000-30000 rpm, 400 speeds": np.linspace(2000, 30000, 400),
    "1000-10000 rpm, 200 speeds": np.linspace(1000, 10000, 200),
}


def table(res, paper) -> str:
    rows = [f"{'':<14}" + "".join(f"{n:>10}" for n in res.names),
            f"{'mean':<14}" + "".join(f"{v:>10.5f}" for v in res.mean),
            f"{'sd (1/N)':<14}" + "".join(f"{v:>10.5f}" for v in res.sd),
            f"{'sem':<14}" + "".join(f"{v:>10.5f}" for v in res.sem),
            f"{'paper mean':<14}" + "".join(f"{paper[n]['mean']:>10.5f}" for n in res.names),
            f"{'paper sd':<14}" + "".join(f"{paper[n]['sd']:>10.5f}" for n in res.names)]
    rx, ry = res.ratio("fn_x", "k_x"), res.ratio("fn_y", "k_y")
    px, py = paper["fn_x"]["mean"] / paper["k_x"]["mean"], paper["fn_y"]["mean"] / paper["k_y"]["mean"]
    rows.append(f"fn/k ratio of means: x {rx:.1f}, y {ry:.1f} (paper x {px:.1f}, y {py:.1f})")
    return "\n".join(rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=10_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--million", action="store_true", help="also run N = 10^6 in chunks (a few minutes)")
    ap.add_argument("--speed-study", action="store_true", help="repeat N paths over several speed sets")
    args = ap.parse_args()
    cfg = load_example("ex1")
    theta = predicted_theta("ex1")
    paper = table6()
    rpm = SPEED_SETS["2000-12000 rpm, 200 speeds (bench default)"]
    print(describe())
    with threadpool_limits(1):
        t0 = time.perf_counter()
        monte_carlo(cfg.structure, cfg.cutting, rpm, n=2, theta=theta)  # compile / load the cache
        print(f"first call (compile or cache load): {time.perf_counter() - t0:.2f} s")
        t0 = time.perf_counter()
        res = monte_carlo(cfg.structure, cfg.cutting, rpm, n=args.n, seed=args.seed, theta=theta)
        dt = dt_main = time.perf_counter() - t0
        print(f"N={args.n} paths ({7 * args.n} envelopes) x S={rpm.size} speeds 2000-12000 rpm: {dt:.2f} s "
              f"({7 * args.n / dt:.0f} envelopes/s)")
        print(table(res, paper))
        if args.speed_study:
            for label, r in SPEED_SETS.items():
                t0 = time.perf_counter()
                s = monte_carlo(cfg.structure, cfg.cutting, r, n=args.n, seed=args.seed, theta=theta)
                print(f"\n[{label}] {time.perf_counter() - t0:.1f} s")
                print(table(s, paper))
        if args.million:
            n = 1_000_000
            t0 = time.perf_counter()
            big = monte_carlo(cfg.structure, cfg.cutting, rpm, n=n, seed=args.seed, theta=theta)
            dt = time.perf_counter() - t0
            print(f"\nN=10^6 paths (7e6 envelopes) in chunks: {dt:.1f} s ({7 * n / dt:.0f} envelopes/s); "
                  f"MSE array kept {big.mse_mm2.nbytes / 2**20:.0f} MB")
            print(table(big, paper))
    print(f"mc_seconds: {dt_main:.2f}  (N = {args.n})")
    print(f"peak_rss_mb: {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f}")


if __name__ == "__main__":
    main()
