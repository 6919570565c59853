"""What the x = y test of the default solver buys and costs (millstab.identify.tie).

Cut and start: the seed paper's Example 1 (slotting, 2 teeth; x and y start at 903 Hz, 12.53 N/µm,
ζ 0.03). Truth: the same, with fn_y = fn_x·(1 + d) for d = 0, 0.5, 1, 2, 4 %. 100 speeds over the
config's range, 2 % Gaussian relative noise on the depths (seeded draws). Each draw is fitted with the
test (``fit_lsq``) and without it (``tie_xy=False``). Printed per d: how often x = y is reported tied,
the p-values, and the largest fn error of each.

Run: ``.venv/bin/python benchmarks/bench_identify_tie.py [--draws 8]`` (about a minute).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).parent))
from _machine import describe  # noqa: E402

from millstab.datasets import load_example  # noqa: E402
from millstab.identify import fit_lsq, make_problem  # noqa: E402
from millstab.identify.synthetic import boundary_points, default_speeds  # noqa: E402
from millstab.identify.tie import is_tied  # noqa: E402
from millstab.model import Mode, Structure  # noqa: E402


def fn_error(fit, truth_fn: np.ndarray) -> float:
    """Largest relative fn error, x and y matched in sorted order (slotting: x ↔ y is an exact symmetry)."""
    est = np.sort(fit.estimate[[fit.names.index("fn_x"), fit.names.index("fn_y")]])
    return float(np.abs(est / np.sort(truth_fn) - 1).max())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--draws", type=int, default=8)
    args = ap.parse_args()
    print(describe())
    cfg = load_example("ex1")
    rpm = default_speeds(cfg)
    with threadpool_limits(1):
        for d in (0.0, 0.005, 0.01, 0.02, 0.04):
            truth = Structure(x=(Mode(903.0, 12.53e6, 0.03),), y=(Mode(903.0 * (1 + d), 12.53e6, 0.03),))
            fn = np.array([903.0, 903.0 * (1 + d)])
            tied, pvals, err_test, err_free = 0, [], [], []
            for seed in range(args.draws):
                prob = make_problem(cfg.structure, cfg.cutting,
                                    boundary_points(truth, cfg.cutting, rpm, noise=0.02, seed=seed))
                fit = fit_lsq(prob, seed=seed)
                tied += is_tied(fit)
                pvals.append(fit.settings["xy_tie_test"]["p_value"])
                err_test.append(fn_error(fit, fn))
                err_free.append(fn_error(fit_lsq(prob, seed=seed, tie_xy=False), fn))
            print(f"fn_y = fn_x (1 + {100 * d:g} %): tied in {tied}/{args.draws}, p-values "
                  f"{' '.join(f'{p:.2f}' for p in sorted(pvals))}; largest fn error with the test "
                  f"{100 * max(err_test):.3f} %, free fit {100 * max(err_free):.3f} %", flush=True)


if __name__ == "__main__":
    main()
