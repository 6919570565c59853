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

``--conditions`` prints instead what one cutting condition costs on top of a set's shared grid (issue 27: an
update over cuts in 4 conditions against one in 1): per set, one thread, the stages of one condition (eigenvalues
on the grid, Re ν = 0 edges, merging them into the grid, the candidate scan, the refinement) for the
bench_conditions.py conditions and prior draws with 1, 10 and 40 speeds, and the engine ratio 4 × 10 speeds
against 1 × 40 that these per-condition costs give, with the fixed cost per condition the issue's 1.5× would need.

Run: ``.venv/bin/python benchmarks/profile_zoa.py [--sets 2000] [--conditions]``. Single thread (NUMBA_NUM_THREADS
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
    no_cap = np.zeros(0)  # no ceiling (a censored search: _zoa_kernel.envelope_on_grid)
    for b in range(n_b):
        w, G = K.modal_grid(md[b], w_top, n_base, offsets)
        acc += G[0, 0].real
        if upto == 0:
            continue
        if upto == 3:
            K.envelope_on_grid(w, G, a, n_teeth, kt, rpm, md[b], False, depth[b], lobe[b], wc[b], none, no_cap)
            continue
        if upto == 1:
            nu = K._branches(a, G[0], G[1], G[2], G[3])
            acc += nu[0, 0].real
            continue
        acc += K._scan(w, G, a, n_teeth, rpm, md[b], False, no_cap, none)[4].size
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


@nb.njit  # not cached, as _stages
def _condition_stages(upto, md, a, n_teeth, kt, rpm, n_base, offsets, depth, lobe, wc):
    """One condition's pipeline on each set's shared grid, serially, up to stage ``upto``: 0 the grid and
    receptances (shared by the conditions), 1 + the eigenvalue branches, 2 + the Re ν = 0 edges, 3 + merging
    them into the grid, 4 + the candidate scan (the whole of :func:`_zoa_kernel._scan`), 5 the whole envelope
    (+ the refinement). Returns a checksum."""
    none = np.zeros(0, dtype=np.int64)
    no_cap = np.zeros(0)  # no ceiling (a censored search: _zoa_kernel.envelope_on_grid)
    w_top = K.TWO_PI * n_teeth * rpm[rpm.size - 1] / 60.0
    acc = 0.0
    for b in range(md.shape[0]):
        w, G = K.modal_grid(md[b], w_top, n_base, offsets)
        acc += w[0]
        if upto == 0:
            continue
        if upto == 5:
            K.envelope_on_grid(w, G, a, n_teeth, kt, rpm, md[b], False, depth[b], lobe[b], wc[b], none, no_cap)
            continue
        if upto == 4:
            acc += K._scan(w, G, a, n_teeth, rpm, md[b], False, no_cap, none)[4].size
            continue
        nu = K._branches_diag(a, G[0], G[3])
        acc += nu[0, 0].real
        if upto == 1:
            continue
        extra = K._distinct_new(w, K._validity_edges(w, nu, a, md[b], False, G, none))
        acc += extra.size
        if upto == 3 and extra.size:
            acc += K._with_nodes(w, G, nu, extra, a, False, md[b])[0].size
    return acc


def conditions_profile(n_sets: int) -> None:
    """What one cutting condition costs per set on the shared grid (``--conditions``; module docstring)."""
    from millstab.io import load_config
    from millstab.model import Cutting
    from millstab.update import make_prior

    sys.path.insert(0, str(Path(__file__).parent))
    from bench_conditions import IMMERSIONS

    cfg = load_config("example:ex1")
    c = cfg.cutting
    prior = make_prior(cfg.structure, c)
    batch = prior.par.batch(prior.split(prior.sample_full(n_sets, np.random.default_rng(3)))[0])
    two_pi = 2 * math.pi
    md = K.pack_modes(two_pi * batch.fn_x, batch.k_x, batch.zeta_x, two_pi * batch.fn_y, batch.k_y, batch.zeta_y)
    rng = np.random.default_rng(2)
    speeds = np.sort(rng.permutation(np.unique(rng.uniform(4000, 12000, 160).round(-1)))[:40])
    names = ("grid (shared)", "eigenvalues", "Re ν = 0 edges", "merge", "candidate scan", "refinement")
    print(f"B={n_sets} prior draws of Example 1 (bench_conditions.py's); µs per set, one thread, best of 3")
    print(f"{'condition':16s} {'S':>3s} " + " ".join(f"{n:>15s}" for n in names) + f" {'condition':>10s}")
    per_cond = {}
    for ri, mill in IMMERSIONS:
        cut = Cutting.from_immersion(c.teeth, c.kt, c.kr, ri, mill)
        a = K.directional_brackets(cut.kr, cut.entry, cut.exit)
        for rpm in (speeds[:1].copy(), speeds[::4].copy(), speeds):
            n_s = rpm.size
            out = (np.empty((n_sets, n_s)), np.empty((n_sets, n_s), dtype=np.int64), np.empty((n_sets, n_s)))
            _condition_stages(5, md[:2], a, cut.teeth, cut.kt, rpm, zoa.N_BASE, zoa._OFFSETS, *(o[:2] for o in out))
            cum = []
            for upto in range(6):
                best = np.inf
                for _ in range(3):
                    t = time.process_time()
                    _condition_stages(upto, md, a, cut.teeth, cut.kt, rpm, zoa.N_BASE, zoa._OFFSETS, *out)
                    best = min(best, time.process_time() - t)
                cum.append(best / n_sets * 1e6)
            # the scan stage (4) includes eigenvalues, edges and merge again: its own cost is stage 4 − stage 3
            parts = [cum[0], cum[1] - cum[0], cum[2] - cum[1], cum[3] - cum[2], cum[4] - cum[3], cum[5] - cum[4]]
            per_cond.setdefault(n_s, []).append((cum[0], cum[5] - cum[0]))
            print(f"{ri:4.2f} {mill:4s}        {n_s:3d} " + " ".join(f"{p:15.1f}" for p in parts)
                  + f" {cum[5] - cum[0]:10.1f}")
    grid = np.mean([g for g, _ in per_cond[40]])
    f1, f10, f40 = (np.mean([x for _, x in per_cond[n]]) for n in (1, 10, 40))
    one, four = grid + f40, grid + 4 * f10
    print(f"a condition with 1 speed costs {f1:.1f} µs, with 10 {f10:.1f}, with 40 {f40:.1f} (mean over the four "
          f"conditions); the shared grid {grid:.1f} µs")
    print(f"engine per set: 1 condition x 40 speeds {one:.1f} µs, 4 conditions x 10 speeds {four:.1f} µs: "
          f"ratio {four / one:.2f}")
    # the engine ratio r_e the 1.5x needs: 1.5 = calls ratio (20/16, the stages: data-driven) x r_e x 0.9
    # (bench_conditions.py: the numpy part grows less than the engine part); at a fixed per-speed cost the fixed
    # per-condition cost F then must satisfy grid + 4F + 40r <= r_e (grid + F + 40r)
    r_e = 1.5 / (20 / 16) / 0.9
    per_speed = (f40 - f1) / 39
    need = (r_e * (grid + 40 * per_speed) - grid - 40 * per_speed) / (4 - r_e)
    print(f"the issue's 1.5x per update needs about {r_e:.2f}x per set (20 against 16 engine calls, x0.9 for the "
          f"numpy part): at {per_speed:.2f} µs per speed a fixed cost per condition of at most {need:.1f} µs "
          f"(now {f1:.1f} µs)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", type=int, default=2000)
    ap.add_argument("--conditions", action="store_true",
                    help="what one cutting condition costs on the shared grid (issue 27), instead")
    args = ap.parse_args()
    if args.conditions:
        print(describe())
        with threadpool_limits(1):
            nb.set_num_threads(1)
            conditions_profile(args.sets)
        return
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
