"""Modal fitting (``millstab modal``): the issue's must-reach figures on synthetic tap tests.

Data: 4 000 lines 0.5..2000 Hz per direction; x has modes at 520, 903, 960 Hz (30, 12.5, 20 N/um;
ζ 3, 2.5, 2 %), y two overlapping modes at 650 and 675 Hz (20, 25 N/um; ζ 2 %). Noise: additive complex
Gaussian, RMS 2 % of the direction's largest |H|, one seed per draw.

Prints:
* time of one fit of both directions from CSV files (read + fit), BLAS pinned to one thread, best and
  median of ``--repeats`` after a warm-up (target ≤ 2 s);
* over ``--seeds`` noise draws: the worst relative error of fn, k, ζ over all modes (targets 0.2 %, 5 %, 5 %)
  and of the SLD minimum (zoa, the seed paper's Ex.1 cutting, 3000..15000 rpm) against the true modes (3 %);
* when sdypy-EMA is importable (``pip install sdypy-ema``, not a millstab dependency): its LSCF+LSFD on the
  same x data with the TRUE frequencies handed to its pole picker, to show why millstab fits on its own.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/bench_modal.py [--seeds 20] [--repeats 5]``.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).parent))
from _machine import describe  # noqa: E402

from millstab.frf import modal_receptance  # noqa: E402
from millstab.io import parse_config, write_frf_csv  # noqa: E402
from millstab.modal.run import fit_files  # noqa: E402
from millstab.model import Mode, Structure  # noqa: E402
from millstab.stability import zoa  # noqa: E402

F = np.linspace(0.5, 2000.0, 4000)
TRUE = {"x": ([520.0, 903.0, 960.0], [30e6, 12.5e6, 20e6], [0.03, 0.025, 0.02]),
        "y": ([650.0, 675.0], [20e6, 25e6], [0.02, 0.02])}
CUTTING = parse_config("""[cutting]\nteeth = 2\nkt = "556.31 N/mm^2"\nkr = 0.404\nentry = "0 deg"\nexit = "180 deg"
[[structure.x]]\nfn = "903 Hz"\nk = "12.53 N/um"\nzeta = 0.03\n""").cutting
RPM = np.arange(3000.0, 15000.0 + 1, 10.0)


def noisy(d: str, seed: int) -> np.ndarray:
    h = modal_receptance(F, *(np.asarray(v, float) for v in TRUE[d]))
    rng = np.random.default_rng(seed)
    return h + 0.02 * np.abs(h).max() * (rng.standard_normal(F.size) + 1j * rng.standard_normal(F.size)) / np.sqrt(2)


def write_pair(folder: Path, seed: int) -> tuple[Path, Path]:
    return (write_frf_csv(folder / f"x{seed}.csv", F, noisy("x", 2 * seed)),
            write_frf_csv(folder / f"y{seed}.csv", F, noisy("y", 2 * seed + 1)))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    print(describe())
    true = Structure(**{d: tuple(Mode(*p) for p in zip(*TRUE[d])) for d in TRUE})
    b_true = zoa.envelope(true, CUTTING, RPM).depth.min()
    with tempfile.TemporaryDirectory() as tmp, threadpool_limits(1):
        px, py = write_pair(Path(tmp), 0)
        fit_files(px, py)  # warm-up (imports)
        times = []
        for _ in range(args.repeats):
            t = time.perf_counter()
            fit_files(px, py)
            times.append(time.perf_counter() - t)
        print(f"one fit of x and y, {F.size} lines each, from CSV: best {min(times):.3f} s, median "
              f"{np.median(times):.3f} s of {args.repeats} (target <= 2 s)")
        worst = {"fn": 0.0, "k": 0.0, "zeta": 0.0, "sld": 0.0}
        missed = 0
        for seed in range(args.seeds):
            px, py = write_pair(Path(tmp), seed)
            res = fit_files(px, py)
            for d, fit in res.fits.items():
                if len(fit.modes) != len(TRUE[d][0]):
                    missed += 1
                    continue
                for p, truth in zip(("fn", "k", "zeta"), TRUE[d]):
                    got = np.array([getattr(m, p) for m in fit.modes])
                    worst[p] = max(worst[p], float(np.max(np.abs(got / np.asarray(truth) - 1))))
            b_fit = zoa.envelope(res.structure, CUTTING, RPM).depth.min()
            worst["sld"] = max(worst["sld"], abs(b_fit / b_true - 1))
        print(f"{args.seeds} noise draws (2 % of max|H|): worst error fn {100 * worst['fn']:.3f} % (target 0.2), "
              f"k {100 * worst['k']:.2f} % (5), zeta {100 * worst['zeta']:.2f} % (5), SLD minimum "
              f"{100 * worst['sld']:.2f} % (3); directions with a wrong mode count: {missed}")
    _sdypy(noisy("x", 0))


def _sdypy(h: np.ndarray) -> None:
    try:
        from sdypy import EMA
    except ImportError:
        print("sdypy-EMA not installed: comparison skipped")
        return
    fn, _, zeta = (np.asarray(v, float) for v in TRUE["x"])
    for order in (20, 40):
        with warnings.catch_warnings(), threadpool_limits(1):
            warnings.simplefilter("ignore")
            t = time.perf_counter()
            m = EMA.Model(frf=h, freq=F, lower=100, upper=2000, pol_order_high=order, frf_form="receptance")
            m.get_poles(show_progress=False)
            m.select_closest_poles(list(fn))  # handed the true frequencies: no automatic choice exists
            m.get_constants(whose_poles="own", FRF_ind="all")
            dt = time.perf_counter() - t
        print(f"sdypy-EMA order {order} (x, seed 0, true fn given): worst fn error "
              f"{100 * np.max(np.abs(m.nat_freq / fn - 1)):.3f} %, zeta "
              f"{100 * np.max(np.abs(m.nat_xi / zeta - 1)):.2f} %, {dt:.2f} s")


if __name__ == "__main__":
    main()
