"""Accuracy and speed of the spectral-element engine (issue 16), against semi-discretization.

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_spectral.py [--n 81] [--repeat 5]

1. Accuracy on the classic benchmark (Insperger & Stépán: 922 Hz, ζ 0.011, 2 teeth, Kt 6e8, Kn 2e8 N/m²,
   m 0.03993 kg, down milling) at a/D = 0.05, 0.1, 0.5 and 1 on ``--n`` speeds 5 000–25 000 rpm: the
   relative difference to SDM's accuracy-controlled default (itself within 0.1–0.2 % of a Richardson
   extrapolation of 120/240 steps per period, tests/test_sdm.py), worst case with its speed and lobe
   type, and the count of flip speeds each engine reports. Grid independence (issue 25): on a coarse grid
   (21 speeds) and a random set (20, seed 0), the worst deviation of a speed's depth from that speed
   computed alone (same nodes: the search alone) and from SDM.
2. Speed: 200 speeds, one mode per direction (x and y), a/D = 0.05: envelopes per second of the spectral
   engine (best of ``--repeat``), of SDM (once) and of the zero-order engine, measured in the same run
   (the machine is shared, so the ratio is the robust figure), and the ρ / characteristic-function
   evaluations per speed, and the best wall and CPU time (process_time) per envelope on 1 and on all
   numba threads. The last line is ``spectral_envelopes_per_s: X``.
"""

from __future__ import annotations

import argparse
import math
import time

import numba
import numpy as np
from threadpoolctl import threadpool_limits

from _machine import describe
from millstab.frf import ModalBatch
from millstab.model import Cutting, Mode, Structure
from millstab.stability import sdm, spectral, zoa

MASS, FN, ZETA = 0.03993, 922.0, 0.011
K = MASS * (2 * math.pi * FN) ** 2
BENCH = Structure(x=(Mode(FN, K, ZETA),))
XY = Structure(x=(Mode(FN, K, ZETA),), y=(Mode(FN, K, ZETA),))
KT, KR = 6e8, 1.0 / 3.0


def cut(immersion: float) -> Cutting:
    return Cutting.from_immersion(2, KT, KR, immersion, "down")


def timed(f):
    t = time.perf_counter()
    out = f()
    return time.perf_counter() - t, out


def worst(rel: np.ndarray, rpm: np.ndarray) -> str:
    i = int(np.argmax(np.abs(rel)))
    return f"{100 * rel[i]:+.3f} % at {rpm[i]:.0f} rpm"


def grid_independence(c: Cutting, nodes: int) -> str:
    """The worst deviation of a speed's depth on a coarse grid (21 speeds) and on a random set (20 speeds,
    seed 0) from the same speed alone (same nodes), and from SDM (issue 25: a coarse grid once gave
    +11.65 % at 10 000 rpm, a/D = 0.5)."""
    parts = []
    for label, rpm in (("coarse 21", np.linspace(5000.0, 25000.0, 21)),
                       ("random 20", np.sort(np.random.default_rng(0).uniform(5000.0, 25000.0, 20)))):
        grid = spectral.envelope(BENCH, c, rpm, nodes=nodes).depth
        alone = np.array([spectral.envelope(BENCH, c, [r], nodes=nodes).depth[0] for r in rpm])
        ref = sdm.envelope(BENCH, c, rpm).depth
        parts.append(f"{label}: vs alone {worst(grid / alone - 1, rpm)}, vs SDM {worst(grid / ref - 1, rpm)}")
    return "; ".join(parts)


def accuracy(n: int, independence: bool) -> None:
    rpm = np.linspace(5000.0, 25000.0, n)
    print(f"accuracy, 1-DOF benchmark, {n} speeds 5000-25000 rpm, against SDM's default (Richardson):")
    for imm in (0.05, 0.1, 0.5, 1.0):
        c = cut(imm)
        t_s, e = timed(lambda: spectral.envelope(BENCH, c, rpm))
        t_d, ref = timed(lambda: sdm.envelope(BENCH, c, rpm))
        mu_sdm = sdm.critical_multipliers(BENCH, c, rpm)
        flip_sdm = np.abs(np.angle(mu_sdm)) > math.pi - spectral.FLIP_ARG
        rel = e.depth / ref.depth - 1
        i = int(np.argmax(np.abs(rel)))
        rel_z = zoa.envelope(BENCH, c, rpm).depth / ref.depth - 1
        print(f"  a/D {imm:4}: max |spectral/SDM - 1| {100 * abs(rel[i]):.3f} % at {rpm[i]:.0f} rpm ({e.kind[i]}, "
              f"{e.depth_mm[i]:.4f} mm); mean {100 * np.mean(np.abs(rel)):.3f} %; flip speeds "
              f"{int(np.sum(e.kind == 'flip'))} (SDM {int(flip_sdm.sum())}, same type at "
              f"{int(np.sum((e.kind == 'flip') == flip_sdm))}/{n}); nodes {e.nodes}; zero-order max error "
              f"{100 * np.max(np.abs(rel_z)):.0f} %, min-depth error "
              f"{100 * (np.min(zoa.envelope(BENCH, c, rpm).depth) / np.min(ref.depth) - 1):+.0f} %; time spectral "
              f"{t_s:.2f} s, SDM {t_d:.2f} s")
        if independence:
            print(f"    grid independence: {grid_independence(c, e.nodes)}")


def cpu_per_envelope(rpm, c, threads: int, repeat: int) -> tuple[float, float]:
    """(best wall, best CPU) seconds of one envelope with ``threads`` numba threads."""
    saved = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        walls, cpus = [], []
        for _ in range(repeat):
            w, c0 = time.perf_counter(), time.process_time()
            spectral.envelope(XY, c, rpm)
            walls.append(time.perf_counter() - w)
            cpus.append(time.process_time() - c0)
    finally:
        numba.set_num_threads(saved)
    return min(walls), min(cpus)


def speed(repeat: int) -> float:
    rpm = np.linspace(5000.0, 25000.0, 200)
    c = cut(0.05)
    spectral.envelope(XY, c, rpm[:3])  # compile / cache load
    times = [timed(lambda: spectral.envelope(XY, c, rpm))[0] for _ in range(repeat)]
    t_spec = min(times)
    for threads in sorted({1, numba.get_num_threads()}):
        w, cpu = cpu_per_envelope(rpm, c, threads, repeat)
        print(f"  {threads} thread(s): best wall {w * 1e3:.1f} ms, best CPU {cpu * 1e3:.1f} ms per envelope")
    t_zoa = min(timed(lambda: zoa.envelope(XY, c, rpm))[0] for _ in range(repeat))
    t_sdm, _ = timed(lambda: sdm.envelope(XY, c, rpm))
    batch = ModalBatch.from_structures([XY])
    rs = rpm
    _, _, n_eval = spectral._solve(batch, c, rs, spectral._b_ref(batch, c, rs), spectral.P_NODES)
    print(f"speed, 200 speeds, one mode per direction, a/D = 0.05: spectral {t_spec * 1e3:.1f} ms "
          f"({1 / t_spec:.1f} envelopes/s; all runs {', '.join(f'{t * 1e3:.0f}' for t in times)} ms), "
          f"SDM {t_sdm:.2f} s ({t_sdm / t_spec:.0f}x slower), zero-order {t_zoa * 1e3:.1f} ms; "
          f"evaluations per speed {n_eval.mean():.1f} (ρ and characteristic function)")
    return 1 / t_spec


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=81, help="speeds of the accuracy grid")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--skip-accuracy", action="store_true")
    ap.add_argument("--skip-independence", action="store_true", help="skip the coarse / random grid checks")
    a = ap.parse_args()
    print(describe())
    with threadpool_limits(1):
        if not a.skip_accuracy:
            accuracy(a.n, not a.skip_independence)
        eps = speed(a.repeat)
    print(f"spectral_envelopes_per_s: {eps:.1f}")


if __name__ == "__main__":
    main()
