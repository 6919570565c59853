"""How far a chattering cut's frequency lies from the boundary's chatter frequency, by how deep the cut is.

The updating's frequency term compares a chatter cut's measured frequency f_m with the model's chatter frequency
f_c at the LIMIT (the boundary's critical multiplier). A cut deeper than the limit chatters at the frequency of its
own fastest-growing vibration, which moves away from f_c as the depth rises (and, with the teeth leaving the cut,
settles into a limit cycle). This benchmark measures that drift on the virtual shop: cuts simulated in the time
domain (:func:`millstab.simulate.label_cuts`, the same labels and frequencies as ``millstab simulate``) at depths
b = b_lim × e^x, x uniform in [0, ``--max-log``] (the true limit b_lim and f_c from the spectral engine, within
0.5 % of converged SDM; the member of ±f_c + m·f_tp nearest f_m, ``likelihood.frequency_distance``), on the
example tools and a three-tooth machine in a slot and at a/D 0.5, 0.25 and 0.1 up and down, at random speeds.
Printed: |f_m − f_c| / f_c by bins of x = ln(b / b_lim) (median, 90 %, share beyond 5 %), and the rms slope γ of
|f_m − f_c| / f_c on x through the origin over the readings within 5 % (the likelihood's ``FREQ_DRIFT``,
:mod:`millstab.update.likelihood`).

``--at-depth``: also the frequency of the fastest-growing vibration at the cut's OWN depth as the prediction (the
dominant Floquet multiplier μ of the spectral monodromy at (speed, depth), f = |arg μ|·f_tp/2π, the same nearest-member
distance), the same table side by side: is the drift the linear growth frequency moving with depth, which a likelihood
could compute per cut, or the saturated limit cycle's?

Run: ``PYTHONPATH=src:benchmarks .venv/bin/python benchmarks/bench_chatter_drift.py`` (~10 s on 2 cores).
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from threadpoolctl import threadpool_limits

from _machine import describe
from millstab.api import config
from millstab.model import Cutting, Mode, Structure
from millstab.params import Parameterization
from millstab.simulate import label_cuts
from millstab.stability import spectral
from millstab.update.likelihood import frequency_distance


def machines() -> dict[str, tuple[Structure, Cutting]]:
    out = {}
    for name in ("ex1", "ex3", "fourflute"):
        cfg = config(f"example:{name}")
        out[name] = (cfg.structure, cfg.cutting)
    three = Structure(x=(Mode(700.0, 8e6, 0.025),), y=(Mode(820.0, 1.2e7, 0.03),))
    out["three"] = (three, Cutting(3, 7e8, 0.3, 0.0, math.pi))
    return out


def conditions(base: Cutting) -> list[Cutting]:
    c = [Cutting(base.teeth, base.kt, base.kr, 0.0, math.pi)]
    c += [Cutting.from_immersion(base.teeth, base.kt, base.kr, a, m) for a in (0.5, 0.25, 0.1) for m in ("up", "down")]
    return c


def growth_hz(st: Structure, c: Cutting, rpm: np.ndarray, depth_m: np.ndarray) -> np.ndarray:
    """The frequency [Hz] of the dominant Floquet multiplier at each (speed, depth): |arg μ|·f_tp/2π (a member of
    the family ±f + m·f_tp, which is all the nearest-member distance reads)."""
    out = np.empty(rpm.size)
    for i, (r, b) in enumerate(zip(rpm, depth_m)):  # a benchmark's census, ~1 000 cuts
        mu = np.linalg.eigvals(spectral.monodromy(st, c, float(r), float(b), nodes=8))
        out[i] = abs(np.angle(mu[np.argmax(np.abs(mu))])) / (2.0 * math.pi) * c.teeth * r / 60.0
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cuts", type=int, default=40, help="cuts per (machine, condition)")
    ap.add_argument("--max-log", type=float, default=2.0, help="largest ln(depth / limit)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--at-depth", action="store_true",
                    help="also the dominant multiplier's frequency at the cut's own depth as the prediction")
    args = ap.parse_args()
    print(describe())
    rng = np.random.default_rng(args.seed)
    rows = []
    t0 = time.perf_counter()
    with threadpool_limits(1):
        for name, (st, base) in machines().items():
            par = Parameterization(st)
            batch = par.batch(par.theta0[None])
            fmax = max(m.fn for m in st.modes)
            for c in conditions(base):
                # speeds where the tooth-passing frequency is 0.1-1 times the highest mode's
                rpm = rng.uniform(0.1, 1.0, args.cuts) * 60.0 * fmax / c.teeth
                lim, fc = spectral.envelope_batch_hz(batch, c, rpm)
                lim, fc = lim[0], fc[0]
                ok = np.isfinite(lim) & np.isfinite(fc)
                x = rng.uniform(0.0, args.max_log, args.cuts)
                lab = label_cuts(st, c, rpm[ok], lim[ok] * np.exp(x[ok]), 1e-4)
                # the distance to the nearest member of ±f_c + m·f_tp: the likelihood's own reading of a frequency
                f_tp = c.teeth * rpm[ok] / 60.0
                dist = frequency_distance(lab.chatter_hz, fc[ok], f_tp)
                at = (frequency_distance(lab.chatter_hz, growth_hz(st, c, rpm[ok], lim[ok] * np.exp(x[ok])), f_tp)
                      if args.at_depth else np.full(dist.shape, np.nan))
                for d, a, f, xi, lb, fm in zip(dist, at, fc[ok], x[ok], lab.true_label, lab.chatter_hz):
                    if lb == "chatter" and np.isfinite(fm):
                        rows.append((name, c.teeth_in_cut, xi, d / f, a / f))
    rel = np.array([r[3] for r in rows])
    x = np.array([r[2] for r in rows])
    print(f"{len(rows)} chattering cuts simulated ({time.perf_counter() - t0:.0f} s); |f_m - f_c| / f_c by "
          "x = ln(depth / limit):")
    print("  x bin       n   median    90 %   share > 5 %")
    edges = np.linspace(0.0, args.max_log, 6)
    for lo, hi in zip(edges[:-1], edges[1:]):
        sel = (x >= lo) & (x < hi)
        if sel.any():
            print(f"  {lo:.1f}-{hi:.1f}  {sel.sum():5d}  {np.median(rel[sel]):7.4f} {np.quantile(rel[sel], 0.9):7.4f} "
                  f"{(rel[sel] > 0.05).mean():8.2f}")
    if args.at_depth:
        at = np.array([r[4] for r in rows])
        print("the same with the dominant multiplier's frequency at the cut's own depth as the prediction:")
        for lo, hi in zip(edges[:-1], edges[1:]):
            sel = (x >= lo) & (x < hi)
            if sel.any():
                print(f"  {lo:.1f}-{hi:.1f}  {sel.sum():5d}  {np.median(at[sel]):7.4f} "
                      f"{np.quantile(at[sel], 0.9):7.4f} {(at[sel] > 0.05).mean():8.2f}")
    core = rel <= 0.05
    gamma = float(np.sqrt(np.sum(rel[core] ** 2) / np.sum(x[core] ** 2)))
    slope = float(np.sum(rel[core] * x[core]) / np.sum(x[core] ** 2))
    print(f"rms slope through the origin (readings within 5 %): gamma = {gamma:.4f} per unit of ln(depth / limit); "
          f"least-squares slope of the mean {slope:.4f}; beyond 5 %: {(~core).mean():.2f} of the readings")
    near_x = x < 0.2
    if near_x.any():
        print(f"within 22 % of the limit (x < 0.2): median {np.median(rel[near_x]):.4f}, n = {near_x.sum()}")


if __name__ == "__main__":
    main()
