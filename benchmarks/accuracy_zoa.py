"""Accuracy of the zero-order envelope against the independent brute-force reference, on random cases.

Two studies, each printing the worst relative depth error and where it occurred:

1. scattered speeds (as before): 0–2 modes per direction (at least one mode; fn 300–5000 Hz,
   k 2–50 N/µm, ζ 0.005–0.08), 1–7 teeth, Kt 500–2500 MPa, Kr 0–0.8, radial immersion 2–100 %, up or
   down milling, five speeds at 0.05–3 × the speed whose tooth-passing frequency is the highest
   natural frequency; reference: tests/reference_zoa.py ``reference_envelope`` (a label-free
   function of ω scanned on a 300 000-point grid per speed, Brent's method on every sign change).
2. dense speed grids (``--dense``, the study behind issue 10): 1–3 modes per direction (fn 300–3000
   Hz, k 2–50 N/µm, ζ 0.01–0.06), 2–6 teeth, slotting or a/D 0.05–0.5 up or down, a band of
   ``--band`` rpm at 2 rpm spacing placed at random between 0.3 and 1.5 × the speed whose
   tooth-passing frequency is the lowest natural frequency, plus 1 rpm grids ±15 rpm around the
   three lowest lobe tips in the band (where a lobe turns back; those were skipped before the fix);
   reference: ``reference_envelope_dense`` (50 points per damping width, bisection, eigvals).

Run: ``.venv/bin/python benchmarks/accuracy_zoa.py [--cases 40] [--seed 1] [--dense 40] [--band 2000]``
(study 1: about 10 s per 10 cases; study 2: about 1–5 s per case, depending on the band).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from reference_zoa import lobe_tips, reference_envelope, reference_envelope_dense  # noqa: E402

from millstab.model import Cutting, Mode, Structure  # noqa: E402
from millstab.stability import zoa  # noqa: E402


def relative_error(got: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """|got/ref − 1|, 0 where both are inf (no boundary), inf where only one is."""
    both_inf = np.isinf(ref) & np.isinf(got)
    with np.errstate(invalid="ignore"):
        rel = np.abs(got / ref - 1)
    return np.where(both_inf, 0.0, np.where(np.isinf(ref) | np.isinf(got), np.inf, rel))


def scattered(cases: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    worst, bad, n_speeds, where = 0.0, 0, 0, ""
    for case in range(cases):
        nx, ny = int(rng.integers(0, 3)), int(rng.integers(0, 3))
        nx = nx or (1 if ny == 0 else 0)

        def modes(n):
            return tuple(Mode(rng.uniform(300, 5000), rng.uniform(2e6, 50e6), rng.uniform(0.005, 0.08))
                         for _ in range(n))

        s = Structure(x=modes(nx), y=modes(ny))
        cut = Cutting.from_immersion(int(rng.integers(1, 8)), rng.uniform(5e8, 2.5e9), rng.uniform(0.0, 0.8),
                                     rng.uniform(0.02, 1.0), str(rng.choice(["up", "down"])))
        f_max = max(m.fn for m in s.modes)
        rpm = np.sort(rng.uniform(0.05, 3.0, 5) * 60 * f_max / cut.teeth)
        ref, _ = reference_envelope(s, cut, rpm, n_grid=300_000)
        got = zoa.envelope(s, cut, rpm).depth
        rel = relative_error(got, ref)
        n_speeds += rpm.size
        j = int(np.argmax(rel))
        if rel[j] > 1e-6:
            bad += 1
            print(f"case {case}: {nx}+{ny} modes, {cut.teeth} teeth, {rpm[j]:.0f} rpm: {got[j] * 1e3:.5g} mm vs "
                  f"reference {ref[j] * 1e3:.5g} mm")
        if rel[j] > worst:
            worst, where = float(rel[j]), f"case {case}, {rpm[j]:.1f} rpm"
    print(f"scattered speeds: {cases} cases, {n_speeds} speeds: {bad} with an error above 1e-6")
    print(f"worst_relative_error: {worst:.2e} ({where})")


def dense(cases: int, seed: int, band: float) -> None:
    rng = np.random.default_rng(seed)
    worst, bad, n_speeds, n_tips, where = 0.0, 0, 0, 0, ""
    for case in range(cases):
        def modes(n):
            return tuple(Mode(rng.uniform(300, 3000), rng.uniform(2e6, 50e6), rng.uniform(0.01, 0.06))
                         for _ in range(n))

        s = Structure(x=modes(int(rng.integers(1, 4))), y=modes(int(rng.integers(1, 4))))
        teeth = int(rng.integers(2, 7))
        kind = int(rng.integers(0, 3))
        if kind == 0:
            cut = Cutting(teeth, rng.uniform(5e8, 2.5e9), rng.uniform(0.1, 0.8))
        else:
            cut = Cutting.from_immersion(teeth, rng.uniform(5e8, 2.5e9), rng.uniform(0.1, 0.8), rng.uniform(0.05, 0.5),
                                         "up" if kind == 1 else "down")
        f_min = min(m.fn for m in s.modes)
        lo = max(rng.uniform(0.3, 1.5) * 60 * f_min / teeth - band / 2, 100.0)
        tips, tip_depth = lobe_tips(s, cut, lo, lo + band)
        n_tips += tips.size
        grids = [np.arange(lo, lo + band, 2.0)]
        grids += [np.arange(x - 15, x + 15, 1.0) + rng.uniform(0, 1) for x in tips[np.argsort(tip_depth)[:3]]]
        rpm = np.unique(np.concatenate(grids))
        got = zoa.envelope(s, cut, rpm).depth
        finite = got[np.isfinite(got)]
        ref, _ = reference_envelope_dense(s, cut, rpm, depth_cap=1.01 * finite.max() if finite.size else None)
        rel = relative_error(got, ref)
        n_speeds += rpm.size
        j = int(np.argmax(rel))
        if rel[j] > 1e-6:
            bad += 1
            print(f"case {case}: {len(s.x)}+{len(s.y)} modes, {teeth} teeth, {rpm[j]:.1f} rpm: {got[j] * 1e3:.6g} mm "
                  f"vs reference {ref[j] * 1e3:.6g} mm ({int((rel > 1e-6).sum())} speeds above 1e-6)")
        if rel[j] > worst:
            worst, where = float(rel[j]), f"case {case}, {rpm[j]:.1f} rpm"
    print(f"dense grids: {cases} cases, {n_speeds} speeds, {n_tips} lobe tips in the bands: "
          f"{bad} cases with an error above 1e-6")
    print(f"worst_relative_error_dense: {worst:.2e} ({where})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=40, help="scattered-speed cases (0: skip)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--dense", type=int, default=0, help="dense-grid cases (0: skip)")
    ap.add_argument("--band", type=float, default=2000.0, help="width of each dense band [rpm]")
    args = ap.parse_args()
    if args.cases:
        scattered(args.cases, args.seed)
    if args.dense:
        dense(args.dense, args.seed, args.band)


if __name__ == "__main__":
    main()
