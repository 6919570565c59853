"""Speed of the semi-discretization engine on the classic benchmark (see tests/test_sdm.py).

Run: .venv/bin/python benchmarks/bench_sdm.py
Prints the machine, the time of a 200-speed limiting-depth curve (slotting and a/D = 0.05) at 40 steps
per tooth period and with the accuracy-controlled default, and of a 200 × 100 speed × depth ρ map at
40 steps per period. Compilation is done (or loaded from cache) before timing. The last line is
``sdm_map_200x100_s: X``.
"""

from __future__ import annotations

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
        cuts = {"slot": Cutting(2, 6e8, 1 / 3, 0.0, math.pi), "aD0.05": Cutting.from_immersion(2, 6e8, 1 / 3, 0.05, "down")}
        t, _ = timed(lambda: (sdm.envelope(BENCH, cuts["slot"], [9000.0], steps=40), sdm.envelope(BENCH, cuts["slot"], [9000.0]),
                              sdm.rho_map(BENCH, cuts["slot"], [9000.0], [1e-3], steps=40)))
        print(f"warm-up (compile or cache load): {t:.2f} s")
        for name, cut in cuts.items():
            t40, e40 = timed(lambda: sdm.envelope(BENCH, cut, RPM, steps=40))
            td, ed = timed(lambda: sdm.envelope(BENCH, cut, RPM))
            print(f"{name}: 200-speed curve, 40 steps/period: {t40:.3f} s; accuracy-controlled default "
                  f"(steps {sdm.default_steps(FN, cut, RPM).min()}..{sdm.default_steps(FN, cut, RPM).max()} + halved, "
                  f"Richardson): {td:.3f} s; min depth {ed.depth_mm.min():.4f} mm (40 steps: {e40.depth_mm.min():.4f} mm)")
        t_map, rho = timed(lambda: sdm.rho_map(BENCH, cuts["slot"], RPM, DEPTH, steps=40))
        print(f"slot: 200 x 100 rho map, 40 steps/period: {t_map:.3f} s ({t_map / rho.size * 1e3:.3f} ms per point); "
              f"unstable share {np.mean(rho > 1):.3f}")
    print(f"sdm_map_200x100_s: {t_map:.3f}")


if __name__ == "__main__":
    main()
