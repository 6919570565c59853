"""Where the time of the batched zero-order envelope goes, and how far it is from the flop limit.

On the throughput benchmark's problem (benchmarks/bench_envelope.py: Example 1 sets drawn within
±10 %, S = 200 speeds over 2 000–12 000 rpm) this prints

1. the work counts per envelope from the kernel's own counters (``stats`` of
   ``_zoa_kernel.envelope_on_grid``): grid nodes, root evaluations of each kind, segments and
   (segment, lobe) pairs visited, candidates found and refined;
2. the time per envelope of each stage, one thread, measured cumulatively (grid and receptances;
   + both eigenvalue branches; + Re ν = 0 edges and the candidate scan; the whole envelope), so the
   differences are the stages' costs;
3. a flop estimate per envelope from those counts and hand counts of each evaluation (below), and
   the time it would take at the scalar rate the same machine reaches on a dense loop of the same
   operations (measured here as well, not assumed).

Run: ``.venv/bin/python benchmarks/profile_zoa.py [--sets 2000]``. Single thread (NUMBA_NUM_THREADS
is not changed; the stage timings run serially). Its own stage function is compiled on every run (about a
minute; not cached, as numba's cache does not notice edits to the kernel module it calls).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numba as nb
import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).parent))
from _machine import describe  # noqa: E402

from millstab.datasets import load_example  # noqa: E402
from millstab.params import Parameterization  # noqa: E402
from millstab.stability import _zoa_kernel as K  # noqa: E402
from millstab.stability import zoa  # noqa: E402

#: hand counts of floating-point operations (a division, square root or atan2 counted as one, and the
#: complex ones as their real operations) of the kernel's evaluations, per call:
#: a modal receptance 1/(k(1 − r² + 2iζr)) per mode: r, 1 − r², 2ζr, |.|², k·, 1/, two products, two sums
FLOPS_RECEPTANCE_PER_MODE = 12
#: one root ν of [α][G] from the two receptances (one mode each): tr, det, tr² − 4det, complex sqrt,
#: both roots, the distance of each to the interpolated guess, the phase ε (atan2)
FLOPS_ROOT = 2 * FLOPS_RECEPTANCE_PER_MODE + 60
#: a root with dε/dω and d²ε/dω² (_phase_at: receptance derivatives and the chain of quotients)
FLOPS_ROOT_SLOPES = FLOPS_ROOT + 160
#: ε', ε'' at a node whose root is known (_node_slopes)
FLOPS_NODE_SLOPES = 130
#: one (segment, lobe) pair of the candidate scan: two bracket speeds (two divisions), their range
FLOPS_PAIR = 12
#: one candidate: the two H values at its bracket ends and the interpolated estimate
FLOPS_CANDIDATE = 12


@nb.njit  # not cached: numba's cache would not see edits to the kernel module it calls
def _stages(upto, md, a, n_teeth, kt, rpm, n_base, offsets, depth, lobe, wc):
    """Run the per-set pipeline serially up to stage ``upto`` (0 grid and receptances, 1 + branches,
    2 + Re ν = 0 edges and the candidate scan, 3 the whole envelope); returns a checksum."""
    n_b = md.shape[0]
    w_top = K.TWO_PI * n_teeth * rpm[rpm.size - 1] / 60.0
    acc = 0.0
    none = np.zeros(0, dtype=np.int64)
    for b in range(n_b):
        w, G = K.modal_grid(md[b], w_top, n_base, offsets)
        acc += G[0, 0].real
        if upto == 0:
            continue
        if upto == 3:
            K.envelope_on_grid(w, G, a, n_teeth, kt, rpm, md[b], False, depth[b], lobe[b], wc[b], none)
            continue
        if upto == 1:
            nu = K._branches(a, G[0], G[1], G[2], G[3])
            acc += nu[0, 0].real
            continue
        acc += K._scan(w, G, a, n_teeth, rpm, md[b], False, none)[4].size
    return acc


@nb.njit  # not cached: numba's cache would not see edits to the kernel module it calls
def _dense_rate(n, md, a):
    """The same operations as one root evaluation (two receptances, tr/det, sqrt, atan2) in a dense
    loop with no branches or memory traffic: root evaluations per second at the scalar rate."""
    acc = 0.0
    for i in range(n):
        w = md[0, 0, 0] * (0.5 + i * (1.0 / n))
        gxx = K._modal_receptance(w, md, 0)
        gyy = K._modal_receptance(w, md, 1)
        tr, det = K._tr_det(a, gxx, 0.0j, 0.0j, gyy)
        s = np.sqrt(tr * tr - 4.0 * det)
        v = 0.5 * (tr + s)
        acc += K._eps(v) + v.real
    return acc


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", type=int, default=2000)
    args = ap.parse_args()
    cfg = load_example("ex1")
    par = Parameterization(cfg.structure)
    theta = par.theta0 * np.random.default_rng(0).uniform(0.9, 1.1, (args.sets, par.size))
    rpm = np.linspace(2000, 12000, 200)
    batch = par.batch(theta)
    n_b, n_s = args.sets, rpm.size
    print(describe())
    print(f"B={n_b} Example 1 sets (±10 %) x S={n_s} speeds")

    stats = np.zeros((n_b, K.N_STATS), dtype=np.int64)
    with threadpool_limits(1):
        zoa._run_modal(batch, cfg.cutting, rpm, stats)
    mean = stats.mean(axis=0)
    print("\nwork per envelope (mean over the sets; per speed in brackets):")
    for name, m in zip(K.STAT_NAMES, mean):
        print(f"  {name:28s} {m:10.1f}   ({m / n_s:.2f})")
    ev = dict(zip(K.STAT_NAMES, mean))
    roots = ev["edge evaluations"] + ev["refinement evaluations"]
    print(f"  root evaluations in all       {roots + ev['split-point evaluations'] + ev['grid nodes']:10.1f}"
          f"   (grid nodes {ev['grid nodes']:.0f}, edges {ev['edge evaluations']:.1f}, split points "
          f"{ev['split-point evaluations']:.1f}, refinement {ev['refinement evaluations']:.1f}; "
          f"{ev['refinement evaluations'] / max(ev['candidates refined'], 1):.2f} per refined candidate)")

    # stage timings, one thread, serial
    two_pi = 2 * math.pi
    a = K.directional_brackets(cfg.cutting.kr, cfg.cutting.entry, cfg.cutting.exit)
    arrays = (K.pack_modes(two_pi * batch.fn_x, batch.k_x, batch.zeta_x, two_pi * batch.fn_y, batch.k_y, batch.zeta_y),)
    out = (np.empty((n_b, n_s)), np.empty((n_b, n_s), dtype=np.int64), np.empty((n_b, n_s)))
    t0 = time.perf_counter()
    small = tuple(x[:2] for x in arrays)
    for upto in range(4):
        _stages(upto, *small, a, cfg.cutting.teeth, cfg.cutting.kt, rpm, zoa.N_BASE, zoa._OFFSETS,
                *(o[:2] for o in out))
    print(f"\n(stage function compiled in {time.perf_counter() - t0:.1f} s)")
    names = ("grid + receptances", "+ eigenvalue branches", "+ edges and candidate scan", "whole envelope")
    times = []
    for upto in range(4):
        best = np.inf
        for _ in range(3):
            t = time.perf_counter()
            _stages(upto, *arrays, a, cfg.cutting.teeth, cfg.cutting.kt, rpm, zoa.N_BASE, zoa._OFFSETS, *out)
            best = min(best, time.perf_counter() - t)
        times.append(best / n_b * 1e6)
    print("time per envelope, one thread (cumulative; best of 3):")
    prev = 0.0
    for name, t in zip(names, times):
        print(f"  {name:28s} {t:8.1f} µs   (stage {t - prev:6.1f} µs)")
        prev = t
    total = times[-1]

    # flop estimate and the scalar rate of the same operations
    flops = (ev["grid nodes"] * (2 * FLOPS_RECEPTANCE_PER_MODE + 60)
             + ev["edge evaluations"] * FLOPS_ROOT + ev["split-point evaluations"] * FLOPS_ROOT_SLOPES
             + ev["node slope evaluations"] * FLOPS_NODE_SLOPES + ev["(segment, lobe) pairs"] * FLOPS_PAIR
             + ev["candidates"] * FLOPS_CANDIDATE + ev["refinement evaluations"] * (FLOPS_ROOT + 20))
    n = 2_000_000
    md = K.pack_modes(*([v] for v in (two_pi * 903.0, 1.253e7, 0.03, two_pi * 910.0, 1.253e7, 0.03)))
    _dense_rate(10, md, a)
    t = time.perf_counter()
    _dense_rate(n, md, a)
    per_root = (time.perf_counter() - t) / n
    rate = FLOPS_ROOT / per_root
    print(f"\nflops per envelope (hand counts x work counts): {flops / 1e3:.0f} k")
    print(f"scalar rate on a dense loop of root evaluations: {per_root * 1e9:.1f} ns per root = "
          f"{rate / 1e9:.2f} Gflop/s (one core)")
    print(f"flop limit at that rate: {flops / rate * 1e6:.1f} µs per envelope = {rate / flops:.0f} sets/s per core; "
          f"measured {total:.1f} µs = {1e6 / total:.0f} sets/s per core "
          f"({flops / rate * 1e6 / total:.0%} of the limit)")


if __name__ == "__main__":
    main()
