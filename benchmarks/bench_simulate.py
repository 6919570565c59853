"""Validity and speed of the time-domain simulation (millstab.simulate).

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_simulate.py [--quick]
     (``--figure cut.png`` instead draws a stable and a chattering cut side by side, for the report)

1. Boundary: at 10 speeds 5 000-25 000 rpm the simulated stability boundary (bisection on the
   depth where the fitted once-per-tooth multiplier |μ| crosses 1, small vibration) against the
   semi-discretization engine (accuracy-controlled default), for the 1-DOF benchmark (922 Hz,
   ζ 0.011, 2 teeth, Kt 6e8, Kr 1/3) in slotting and at a/D = 0.05 down milling, and for a two-mode
   structure (one mode in x, one in y, 3 teeth, a/D = 0.5). Also the multiplier's angle (chatter
   frequency modulo the tooth-passing frequency), the lobe type and the detector's frequency.
2. Time-step convergence of the boundary (steps per tooth period 20 … 640) and of a stable cut's
   forced vibration against the frequency-domain steady state.
3. Speed: one cut of 100 tooth periods (one mode per direction), and 1 000 cuts labelled.
Prints the machine first. The last lines are ``max_boundary_err_pct: X`` and ``label_1000_s: Y``.
"""

from __future__ import annotations

import math
import sys
import time

import numba
import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from _machine import describe  # noqa: E402

from millstab.model import Cutting, Mode, Structure  # noqa: E402
from millstab.simulate import _kernel, detect, label_cuts, simulate_cut  # noqa: E402
from millstab.simulate.boundary import simulated_limit  # noqa: E402
from millstab.stability import sdm  # noqa: E402

FN, ZETA, MASS = 922.0, 0.011, 0.03993
K = MASS * (2 * math.pi * FN) ** 2
BENCH = Structure(x=(Mode(FN, K, ZETA),))
TWO = Structure(x=(Mode(FN, K, ZETA),), y=(Mode(1150.0, 1.3 * K, 0.015),))
CASES = {
    "slotting": (BENCH, Cutting(2, 6e8, 1 / 3, 0.0, math.pi)),
    "a/D=0.05": (BENCH, Cutting.from_immersion(2, 6e8, 1 / 3, 0.05, "down")),
    "two-mode": (TWO, Cutting.from_immersion(3, 6e8, 0.3, 0.5, "down")),
}
RPM = np.linspace(5000.0, 25000.0, 10)


def mod_tooth(f_hz: float, f_tooth: float) -> float:
    """Frequency folded into [0, f_T/2]: a multiplier and its conjugate give the same value."""
    r = f_hz % f_tooth
    return min(r, f_tooth - r)


def boundary(quick: bool) -> float:
    worst = 0.0
    for name, (structure, cutting) in CASES.items():
        env = sdm.envelope(structure, cutting, RPM)
        mus = sdm.critical_multipliers(structure, cutting, RPM)
        print(f"\n{name}: rpm, b_sdm [mm], b_sim [mm], error %, |mu| angle: sim vs sdm [deg], lobe, detector chatter "
              "Hz (folded sim / sdm)")
        errs = []
        for i, rpm in enumerate(RPM[::3] if quick else RPM):
            j = int(np.where(RPM == rpm)[0][0])
            b0 = env.depth[j]
            b_sim, mu = simulated_limit(structure, cutting, rpm, 0.9 * b0, 1.1 * b0, rtol=5e-4)
            err = 100 * (b_sim / b0 - 1)
            errs.append(abs(err))
            f_t = cutting.teeth * rpm / 60
            res = simulate_cut(structure, cutting, rpm, 1.05 * b_sim, 1e-4, revs=300 / cutting.teeth)
            det = detect(res)
            lobe_sdm = "flip" if abs(mus[j].imag) < 1e-6 and mus[j].real < 0 else "hopf"
            print(f"  {rpm:7.0f} {b0 * 1e3:8.4f} {b_sim * 1e3:8.4f} {err:+7.3f}   "
                  f"{math.degrees(abs(np.angle(mu))):7.2f} / {math.degrees(abs(np.angle(mus[j]))):7.2f}   "
                  f"{det.lobe:4s}/{lobe_sdm:4s} {det.label:8s} {det.chatter_hz:7.1f} Hz "
                  f"({mod_tooth(det.chatter_hz, f_t):6.1f} / {mod_tooth(env.chatter_hz[j], f_t):6.1f})")
        print(f"  {name}: max |error| {max(errs):.3f} %")
        worst = max(worst, max(errs))
    return worst


def convergence() -> None:
    structure, cutting = CASES["a/D=0.05"]
    rpm = 12000.0
    b0 = sdm.envelope(structure, cutting, [rpm]).depth[0]
    print(f"\ntime-step convergence, a/D = 0.05 at {rpm:g} rpm (sdm {b0 * 1e3:.5f} mm): steps per tooth, b_sim [mm], "
          f"change from the previous")
    prev = None
    for m in (20, 40, 80, 160, 320, 640):
        b, _ = simulated_limit(structure, cutting, rpm, 0.8 * b0, 1.2 * b0, rtol=2e-5, steps_per_tooth=m)
        print(f"  {m:4d} {b * 1e3:.5f} {'' if prev is None else f'{(b - prev) * 1e3:+.2e}'}  error vs sdm "
              f"{100 * (b / b0 - 1):+.3f} %")
        prev = b
    # forced vibration of a stable cut (started at rest) against the Fourier series x receptance
    structure, cutting = TWO, CASES["two-mode"][1]
    rpm, depth = 9000.0, 0.3 * sdm.envelope(structure, cutting, [9000.0]).depth[0]
    print(f"\nforced vibration, two-mode structure, {rpm:g} rpm, depth {depth * 1e3:.3f} mm, from rest, 400 tooth "
          "periods: steps per tooth, max |u_sim - u_fourier| over the last period / max |u|")
    for m in (20, 40, 80, 160, 320):
        res = simulate_cut(structure, cutting, rpm, depth, 1e-4, revs=400 / 3, steps_per_tooth=m, start="rest")
        ref = fourier_steady(structure, cutting, rpm, depth, 1e-4, res.t[-m - 1:])
        sim = np.stack([res.x[-m - 1:], res.y[-m - 1:]])
        print(f"  {m:4d} {np.abs(sim - ref).max() / np.abs(ref).max():.2e}")


def fourier_steady(structure, cutting, rpm, depth, ft, t, n_harm: int = 4000) -> np.ndarray:
    """(x, y) at times t of the forced periodic motion: Σ_n G(n ωT) c_n e^{i n ωT t} (benchmark copy)."""
    wT = 2 * math.pi * cutting.teeth * rpm / 60
    out = np.zeros((2, t.size))
    for n in range(n_harm + 1):
        cx, cy = _kernel.force_harmonic(n, cutting.teeth, cutting.kt, cutting.kr, cutting.entry, cutting.exit, depth,
                                        ft)
        w = n * wT
        for d, modes, c in ((0, structure.x, cx), (1, structure.y, cy)):
            G = sum(1 / (m.mass * (m.omega ** 2 - w * w + 2j * m.zeta * m.omega * w)) for m in modes)
            out[d] += (1 if n == 0 else 2) * (G * c * np.exp(1j * w * t)).real
    return out


def speed() -> float:
    sym = Structure.symmetric(FN, K, ZETA)
    cut = Cutting(2, 6e8, 1 / 3, 0.0, math.pi)
    simulate_cut(sym, cut, 10000.0, 5e-4, 1e-4, revs=50)
    for rpm in (5000.0, 10000.0, 20000.0):
        ts = []
        for _ in range(20):
            t0 = time.perf_counter()
            res = simulate_cut(sym, cut, rpm, 5e-4, 1e-4, revs=50)
            ts.append(time.perf_counter() - t0)
        print(f"one cut, 100 tooth periods, one mode per direction, {rpm:g} rpm ({res.steps_per_tooth} steps per "
              f"period): median {1e3 * np.median(ts):.2f} ms, best {1e3 * min(ts):.2f} ms")
    rng = np.random.default_rng(1)
    rpm = rng.uniform(5000.0, 25000.0, 1000)
    depth = rng.uniform(0.1e-3, 3e-3, 1000)
    label_cuts(sym, cut, rpm[:4], depth[:4], 1e-4)
    t0 = time.perf_counter()
    lab = label_cuts(sym, cut, rpm, depth, 1e-4)
    dt = time.perf_counter() - t0
    counts = {k: int(np.sum(lab.label == k)) for k in ("stable", "marginal", "chatter")}
    print("1000 cuts (100 revolutions = 200 tooth periods each, 5 000-25 000 rpm, 0.1-3 mm), "
          f"{numba.get_num_threads()} threads: {dt:.2f} s; labels {counts}")
    return dt


def figure(path: str) -> None:
    """A stable and a chattering cut of the benchmark side by side (slotting, 18 333 rpm)."""
    from millstab.io.figures import save_figure
    from millstab.plot.simulate import plot_cuts

    structure, cutting = CASES["slotting"]
    b0 = sdm.envelope(structure, cutting, [18333.0]).depth[0]
    pairs = []
    for f in (0.8, 1.3):
        res = simulate_cut(structure, cutting, 18333.0, f * b0, 1e-4, revs=150)
        pairs.append((res, detect(res)))
    save_figure(plot_cuts(pairs, title=f"1-DOF benchmark, slotting, 18 333 rpm: 0.8 and 1.3 x the SDM limit "
                                       f"{b0 * 1e3:.3f} mm"), path)
    print(f"wrote {path}")


def main() -> None:
    quick = "--quick" in sys.argv
    if "--figure" in sys.argv:
        figure(sys.argv[sys.argv.index("--figure") + 1])
        return
    print(describe())
    with threadpool_limits(1):
        t_label = speed()
        worst = boundary(quick)
        if not quick:
            convergence()
    print(f"max_boundary_err_pct: {worst:.3f}")
    print(f"label_1000_s: {t_label:.2f}")


if __name__ == "__main__":
    main()
