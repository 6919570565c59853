"""Accuracy of the zero-order envelope against the independent brute-force reference, on random cases.

Each case: 0–2 modes per direction (at least one mode; fn 300–5000 Hz, k 2–50 N/µm, ζ 0.005–0.08),
1–7 teeth, Kt 500–2500 MPa, Kr 0–0.8, radial immersion 2–100 %, up or down milling, five speeds at
0.05–3 × the speed whose tooth-passing frequency is the highest natural frequency. The reference
(tests/reference_zoa.py) scans a label-free function of ω on a 300 000-point grid at each speed and
root-finds every sign change with Brent's method. Prints the worst relative depth error.
Run: ``.venv/bin/python benchmarks/accuracy_zoa.py [--cases 40] [--seed 1]`` (about 10 s per 10 cases).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from reference_zoa import reference_envelope  # noqa: E402

from millstab.model import Cutting, Mode, Structure  # noqa: E402
from millstab.stability import zoa  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=40)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    worst, bad, n_speeds = 0.0, 0, 0
    for case in range(args.cases):
        nx, ny = int(rng.integers(0, 3)), int(rng.integers(0, 3))
        nx = nx or (1 if ny == 0 else 0)

        def modes(n):
            return tuple(Mode(rng.uniform(300, 5000), rng.uniform(2e6, 50e6), rng.uniform(0.005, 0.08)) for _ in range(n))

        s = Structure(x=modes(nx), y=modes(ny))
        cut = Cutting.from_immersion(int(rng.integers(1, 8)), rng.uniform(5e8, 2.5e9), rng.uniform(0.0, 0.8),
                                     rng.uniform(0.02, 1.0), str(rng.choice(["up", "down"])))
        f_max = max(m.fn for m in s.modes)
        rpm = np.sort(rng.uniform(0.05, 3.0, 5) * 60 * f_max / cut.teeth)
        ref, _ = reference_envelope(s, cut, rpm, n_grid=300_000)
        got = zoa.envelope(s, cut, rpm).depth
        both_inf = np.isinf(ref) & np.isinf(got)
        rel = np.where(both_inf, 0.0, np.abs(got / ref - 1))
        n_speeds += rpm.size
        if rel.max() > 1e-6:
            bad += 1
            j = int(np.argmax(rel))
            print(f"case {case}: {nx}+{ny} modes, {cut.teeth} teeth, {rpm[j]:.0f} rpm: {got[j] * 1e3:.5g} mm vs "
                  f"reference {ref[j] * 1e3:.5g} mm")
        worst = max(worst, float(rel.max()))
    print(f"{args.cases} cases, {n_speeds} speeds: {bad} with an error above 1e-6")
    print(f"worst_relative_error: {worst:.2e}")


if __name__ == "__main__":
    main()
