"""Speed of the semi-discretization engine on the classic benchmark (see tests/test_sdm.py).

Run: .venv/bin/python benchmarks/bench_sdm.py
Prints the machine, the time of a 200-speed limiting-depth curve (slotting and a/D = 0.05) at 40 steps
per tooth period and with the accuracy-controlled default, and of a 200 × 100 speed × depth ρ map at
40 steps per period. Compilation is done (or loaded from cache) before timing. The last line is
``sdm_map_200x100_s: X``.

``--process-damping C`` (N/m; e.g. 2e4) instead times the cost of process damping: the same speeds
(``--speeds`` of them, 1 500 … 25 000 rpm, a 16 mm tool, a/D = 0.5 down milling, 3 teeth, a mode in x
and one in y) with and without the term, CPU time of each and their same-run ratio, and the gain of
the limit at the lowest and highest speeds. The last line is ``sdm_process_damping_cost_ratio: X``.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import time

import numba
import numpy as np
from threadpoolctl import threadpool_limits

from millstab.model import Cutting, Mode, Structure
from millstab.stability import sdm

MASS, FN, ZETA = 0.03993, 922.0, 0.011
BENCH = Structure(x=(Mode(FN, MASS * (2 * math.pi * FN) ** 2, ZETA),))
RPM = np.linspace(5000.0, 25000.0, 200)
DEPTH = np.linspace(0.0, 10e-3, 100)


def timed(f):
    t = time.perf_counter()
    out = f()
    return time.perf_counter() - t, out


def main() -> None:
    print(f"machine: {platform.platform()}, {platform.processor() or platform.machine()}, cpus={os.cpu_count()}, "
          f"numba threads={numba.get_num_threads()}, numba {numba.__version__}, numpy {np.__version__}")
    with threadpool_limits(1):  # many tiny LAPACK calls: BLAS threads only add overhead
        cuts = {"slot": Cutting(2, 6e8, 1 / 3, 0.0, math.pi),
                "aD0.05": Cutting.from_immersion(2, 6e8, 1 / 3, 0.05, "down")}
        t, _ = timed(lambda: (sdm.envelope(BENCH, cuts["slot"], [9000.0], steps=40),
                              sdm.envelope(BENCH, cuts["slot"], [9000.0]),
                              sdm.rho_map(BENCH, cuts["slot"], [9000.0], [1e-3], steps=40)))
        print(f"warm-up (compile or cache load): {t:.2f} s")
        for name, cut in cuts.items():
            t40, e40 = timed(lambda: sdm.envelope(BENCH, cut, RPM, steps=40))
            td, ed = timed(lambda: sdm.envelope(BENCH, cut, RPM))
            print(f"{name}: 200-speed curve, 40 steps/period: {t40:.3f} s; accuracy-controlled default "
                  f"(steps {sdm.default_steps(FN, cut, RPM).min()}..{sdm.default_steps(FN, cut, RPM).max()} + halved, "
                  f"Richardson): {td:.3f} s; min depth {ed.depth_mm.min():.4f} mm "
                  f"(40 steps: {e40.depth_mm.min():.4f} mm)")
        t_map, rho = timed(lambda: sdm.rho_map(BENCH, cuts["slot"], RPM, DEPTH, steps=40))
        print(f"slot: 200 x 100 rho map, 40 steps/period: {t_map:.3f} s ({t_map / rho.size * 1e3:.3f} ms per point); "
              f"unstable share {np.mean(rho > 1):.3f}")
    print(f"sdm_map_200x100_s: {t_map:.3f}")


def process_damping(c: float, n_speeds: int) -> None:
    """CPU time of the limit curve with and without process damping C [N/m], and their ratio."""
    print(f"machine: {platform.platform()}, cpus={os.cpu_count()}, numba threads={numba.get_num_threads()}, "
          f"load {os.getloadavg()[0]:.1f}")
    two = Structure(x=(Mode(FN, MASS * (2 * math.pi * FN) ** 2, ZETA),),
                    y=(Mode(1150.0, 1.3 * MASS * (2 * math.pi * FN) ** 2, 0.015),))
    plain = Cutting.from_immersion(3, 6e8, 0.3, 0.5, "down", diameter=0.016)
    damped = Cutting.from_immersion(3, 6e8, 0.3, 0.5, "down", process_damping=c, diameter=0.016)
    rpm = np.geomspace(1500.0, 25000.0, n_speeds)
    with threadpool_limits(1):
        sdm.envelope(two, damped, rpm[-1:])  # compile or load from cache
        t0 = time.process_time()
        b0 = sdm.envelope(two, plain, rpm).depth
        t_plain = time.process_time() - t0
        t0 = time.process_time()
        b = sdm.envelope(two, damped, rpm).depth
        t_pd = time.process_time() - t0
    gain = b / b0
    print(f"{n_speeds} speeds {rpm[0]:.0f}..{rpm[-1]:.0f} rpm, default steps: CPU {t_plain:.2f} s without, "
          f"{t_pd:.2f} s with C = {c:g} N/m; gain b_pd/b_0 {gain[0]:.3f} at {rpm[0]:.0f} rpm, "
          f"{gain[-1]:.3f} at {rpm[-1]:.0f} rpm (inf: no boundary)")
    print(f"sdm_process_damping_cost_ratio: {t_pd / t_plain:.3f}")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--process-damping", type=float, default=None, metavar="C",
                    help="time the limit curve with and without process damping C [N/m]")
    ap.add_argument("--speeds", type=int, default=40, help="speeds of the --process-damping run (default 40)")
    args = ap.parse_args()
    if args.process_damping is None:
        main()
    else:
        process_damping(args.process_damping, args.speeds)
