"""Chatter a few Hz from a spindle harmonic, on hand-made recordings (tests/listen_synth.py and
tests/listen_shop.py, independent of the simulator): the share heard right.

Each case: 2-4 teeth, 3 000-18 000 rpm read up to ±1 % off, chatter 1-3 Hz above or below a random
spindle harmonic k f_s (k = 1-11: runout and tooth-passing lines alike) at 0.25-4 × the forced
vibration, 2-5 s of cutting, the two generators alternately (runout 0.3 and 0.1 of the forced RMS).
Right: label chatter and the frequency within max(2 Hz, 0.5 %).

    python benchmarks/bench_listen_near.py [--cases 40] [--seed 1]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from listen_shop import shop_recording
from listen_synth import milling_sound

from millstab.listen import listen


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--cases", type=int, default=40)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args(argv)
    rng = np.random.default_rng(a.seed)
    n = bad = 0
    while n < a.cases:
        teeth, rpm, off = int(rng.integers(2, 5)), float(rng.uniform(3000, 18000)), float(rng.uniform(-0.01, 0.01))
        sec, fs = float(rng.uniform(2, 5)), 48000
        f_s = rpm * (1 + off) / 60
        k, d = int(rng.integers(1, 12)), float(rng.uniform(1.0, 3.0)) * float(rng.choice([-1, 1]))
        fc = k * f_s + d
        if fc < 150:
            continue
        ratio = float(10 ** rng.uniform(np.log10(0.25), np.log10(4)))
        if n % 2:
            x = milling_sound(fs=fs, seconds=sec, rpm=rpm, true_rpm=rpm * (1 + off), teeth=teeth, chatter_hz=fc,
                              ratio=ratio, runout=0.3, hum=float(rng.choice([0, 0.3])), seed=n)
        else:
            x, _ = shop_recording(fs=fs, seconds=sec + 0.6, rpm=rpm, off=off, teeth=teeth, chatter_hz=fc, ratio=ratio,
                                  runout=0.1, seed=n)
        r = listen(x, fs, rpm, teeth)
        n += 1
        if not (r.label == "chatter" and abs(r.chatter_hz - fc) <= max(2.0, 0.005 * fc)):
            bad += 1
            print(f"! case {n} ({'synth' if n % 2 == 0 else 'shop'}): {teeth} teeth, {rpm:.0f} rpm, {sec:.1f} s, "
                  f"chatter {fc:.2f} Hz = {k} f_s {d:+.2f} Hz, {ratio:.2f}x: heard {r.label} {r.chatter_hz:.2f} Hz")
    print(f"{n - bad} of {n} right (chatter 1-3 Hz from a spindle harmonic; seed {a.seed})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
