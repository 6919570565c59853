"""Tool tip by receptance coupling (``millstab tooltip --stickout``): the issue's speed figure.

A stickout sweep: 50 stickouts (3..10 D of a 12 mm carbide end mill, 26 mm fluted at 0.8 D, ζ 1 %), each the
coupled tip FRF on its grid (~1 500-2 000 lines), its first modes and the zoa SLD at 500 speeds (3-tooth slotting,
5 000..30 000 rpm) with its minimum — for three holders: rigid, face modes (900 Hz 40 N/um ζ 4 % + 2.6 kHz),
and measured face receptances (a synthetic 25 × 70 mm steel holder tabulated every 2 Hz, 20..20 000 Hz).

Prints the wall time of each sweep (best and median of ``--repeats`` after a warm-up that also compiles
zoa), with BLAS pinned to one thread and numba on its default threads. Target: ≤ 5 s on 2 cores.

Then the artifact test's sensitivity to measurement noise: a 16 × 80 mm steel artifact in that steel holder
(second point 20 or 60 mm from its free end),
its three FRFs (50..6000 Hz, 5 Hz steps) from the exact assembly beam (tests/reference_timoshenko.py) with
relative complex Gaussian noise; printed: the median relative error of the recovered H, L, P and the median
and 90th percentile of the error of a 12 mm carbide tool's tip (45 mm) predicted with the recovered holder.

Run:
``PYTHONPATH=src:tests .venv/bin/python benchmarks/bench_tooltip.py [--stickouts 50] [--speeds 500] [--repeats 3]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).parent))
from _machine import describe  # noqa: E402

from millstab.api import stickout_sweep as sweep  # noqa: E402
from millstab.io import parse_config  # noqa: E402
from millstab.tooltip import (MATERIALS, Beam, FaceMode, MeasuredHolder, ModalHolder, RigidHolder,  # noqa: E402
                              Section, Tool)

CFG = parse_config("""[cutting]\nteeth = 3\nkt = "700 MPa"\nkr = 0.3\nradial_immersion = 1
[tool]\ndiameter = "12 mm"\nstickout = "45 mm"\nfluted_length = "26 mm"\nmaterial = "carbide"\nzeta = 0.01
[holder]\nrigid = true\n""")


def holders() -> dict:
    steel = MATERIALS["steel"]
    beam = Beam((Section(0.07, 0.025, steel),), eta=0.02)
    f = np.arange(20.0, 20000.0 + 1, 2.0)
    last = 2 * (beam.mesh()[0].size - 1)
    r = beam.receptance(f, [last, last + 1], clamped=True)
    return {"rigid": RigidHolder(),
            "modes": ModalHolder((FaceMode(900.0, 40e6, 0.04, 20.0), FaceMode(2600.0, 80e6, 0.03, -15.0))),
            "measured": MeasuredHolder(f, r[:, 0, 0], r[:, 0, 1], r[:, 1, 0], r[:, 1, 1])}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--stickouts", type=int, default=50)
    ap.add_argument("--speeds", type=int, default=500)
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    print(describe())
    tool = Tool(0.012, 0.045, MATERIALS["carbide"], 0.026, zeta=0.01)
    sticks = np.linspace(3 * 0.012, 10 * 0.012, a.stickouts)
    rpm = np.linspace(5000.0, 30000.0, a.speeds)
    print(f"{a.stickouts} stickouts {sticks[0] * 1e3:g}..{sticks[-1] * 1e3:g} mm x zoa SLD at {a.speeds} speeds")
    with threadpool_limits(1):
        for name, holder in holders().items():
            sweep(CFG, tool, holder, sticks[:2], rpm)  # warm-up (zoa compile, caches)
            times = []
            for _ in range(a.repeats):
                t0 = time.perf_counter()
                s = sweep(CFG, tool, holder, sticks, rpm)
                times.append(time.perf_counter() - t0)
            b = s.best()
            print(f"  {name:8s} holder: best {min(times):.2f} s, median {np.median(times):.2f} s; "
                  f"min limit {s.min_depth_mm.min():.3g}..{s.min_depth_mm.max():.3g} mm, best stickout "
                  f"{sticks[b] * 1e3:.3g} mm")
    artifact_noise()


def artifact_noise() -> None:
    import reference_timoshenko as rt

    from millstab.tooltip import artifact_beam, from_artifact, tip_receptance

    st, c = MATERIALS["steel"], MATERIALS["carbide"]

    def sec(L, D, m=st, eta=None):
        s = rt.section(L, D, m.E, m.density, m.nu)
        return s if eta is None else s + (eta,)

    f = np.arange(50.0, 6001.0, 5.0)
    known = rt.clamped_tip([sec(0.07, 0.025)], f, 0.02)
    exact_tip = rt.clamped_tip([sec(0.07, 0.025), sec(0.045, 0.012, c)], f, 0.02)[:, 0, 0]
    tool = Tool(0.012, 0.045, c, zeta=0.01)
    print("artifact test with noise: median error of H, L, P | tip of a 12 mm tool at 45 mm: median, 90th percentile")
    for off in (0.02, 0.06):
        before = [sec(0.07, 0.025), sec(0.08 - off, 0.016, eta=0.0)]
        tip = rt.clamped_tip(before + [sec(off, 0.016, eta=0.0)], f, 0.02)[:, 0, 0]
        at_s = rt.clamped_point_force(before, [sec(off, 0.016, eta=0.0)], f, 0.02)
        art = artifact_beam(0.016, 0.08, off, st)
        for noise in (0.0, 0.001, 0.01, 0.03):
            rng = np.random.default_rng(1)

            def noisy(h):
                return h * (1 + noise * (rng.standard_normal(h.size) + 1j * rng.standard_normal(h.size)) / np.sqrt(2))

            rec = from_artifact(f, noisy(tip), noisy(at_s[:, 1]), noisy(at_s[:, 0]), art, off)
            got = rec.receptance(f)
            e = [np.median(np.abs(got[:, i, j] / known[:, i, j] - 1)) for i, j in ((0, 0), (0, 1), (1, 1))]
            t = np.abs(tip_receptance(tool, rec, f) / exact_tip - 1)
            print(f"  offset {off * 1e3:g} mm, noise {100 * noise:4.1f} %: H {100 * e[0]:6.2f} %, L {100 * e[1]:6.2f} "
                  f"%, P {100 * e[2]:6.2f} % | tip {100 * np.median(t):5.2f} %, {100 * np.quantile(t, 0.9):5.1f} %")


if __name__ == "__main__":
    main()
