"""Throughput of the batched zero-order envelope (the hot path of every parameter study).

B = 10 000 parameter sets of the seed paper's Example 1 drawn uniformly within ±10 %, S = 200
speeds over 2 000–12 000 rpm, at the engine's full accuracy (every depth root-found; tests/test_zoa.py
and tests/test_zoa_dense.py check it against a brute-force reference to 1e-6). Also streams 10^6 sets
in chunks and reports the peak memory. Run: ``.venv/bin/python benchmarks/bench_envelope.py [--million]``.
Last line: ``envelopes_per_s: N``.

``--against FILE`` times another version of the compiled kernel on the same sets, interleaved with
this one (old, new, old, new, ...), and prints the ratio and the largest depth difference: on a shared
machine absolute rates drift with the load, ratios measured in the same moment do not. Make FILE with
e.g. ``git show <rev>:src/millstab/stability/_zoa_kernel.py > /tmp/old_kernel.py``.
"""

from __future__ import annotations

import argparse
import math
import resource
import sys
import time
import types
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).parent))
from _machine import describe  # noqa: E402

from millstab.datasets import load_example  # noqa: E402
from millstab.params import Parameterization  # noqa: E402
from millstab.stability import _zoa_kernel  # noqa: E402
from millstab.stability import zoa  # noqa: E402


def _load_kernel(path: str):
    """Another version of _zoa_kernel.py as a module of its own, compiled afresh (not cached: numba
    could not reload its cached parallel function, whose module is not importable by name)."""
    source = Path(path).read_text().replace("cache=True", "cache=False")
    mod = types.ModuleType("_zoa_kernel_against")
    mod.__file__ = path
    sys.modules[mod.__name__] = mod
    exec(compile(source, path, "exec"), mod.__dict__)
    return mod


def _run_kernel(mod, batch, cutting, rpm: np.ndarray) -> tuple[float, np.ndarray]:
    """Seconds and depths (B, S) of one call of ``mod.envelope_modal_batch`` (either calling convention:
    six mode arrays before packed modes existed, packed modes and work counters after)."""
    n_b, n_s = batch.size, rpm.size
    depth, lobe, wc = np.empty((n_b, n_s)), np.empty((n_b, n_s), dtype=np.int64), np.empty((n_b, n_s))
    two_pi = 2 * math.pi
    modes = (two_pi * batch.fn_x, batch.k_x, batch.zeta_x, two_pi * batch.fn_y, batch.k_y, batch.zeta_y)
    extra = ()
    if hasattr(mod, "pack_modes"):
        modes = (mod.pack_modes(*modes),)
    if hasattr(mod, "N_STATS"):
        extra = (np.zeros((0, mod.N_STATS), dtype=np.int64),)
    a = mod.directional_brackets(cutting.kr, cutting.entry, cutting.exit)
    t = time.perf_counter()
    mod.envelope_modal_batch(*modes, a, cutting.teeth, cutting.kt, rpm, zoa.N_BASE, zoa._OFFSETS, depth, lobe, wc,
                             *extra)
    return time.perf_counter() - t, depth


def paired(path: str, batch, cutting, rpm: np.ndarray, rounds: int = 5) -> None:
    """Time the kernel at ``path`` (old) and the current one (new) alternately on the same sets."""
    old = _load_kernel(path)
    small = batch.__class__(*(getattr(batch, f)[:4] for f in ("fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y")))
    _run_kernel(old, small, cutting, rpm)  # compile / load the caches
    _run_kernel(_zoa_kernel, small, cutting, rpm)
    t_old, t_new = [], []
    for _ in range(rounds):
        t, d_old = _run_kernel(old, batch, cutting, rpm)
        t_old.append(t)
        t, d_new = _run_kernel(_zoa_kernel, batch, cutting, rpm)
        t_new.append(t)
    ratio = np.array(t_old) / np.array(t_new)
    print(f"paired with {path} ({rounds} rounds, interleaved): old {batch.size / min(t_old):.0f} sets/s, "
          f"new {batch.size / min(t_new):.0f} sets/s (best of each)")
    print(f"speed-up new/old: best-to-best {min(t_old) / min(t_new):.3f}, median of the rounds "
          f"{np.median(ratio):.3f} (range {ratio.min():.3f}-{ratio.max():.3f})")
    print(f"largest relative depth difference new vs old: {np.max(np.abs(d_new / d_old - 1)):.2e}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", type=int, default=10_000)
    ap.add_argument("--million", action="store_true", help="also stream 10^6 sets and report peak memory")
    ap.add_argument("--against", metavar="FILE", help="another _zoa_kernel.py to time against, interleaved")
    args = ap.parse_args()
    cfg = load_example("ex1")
    par = Parameterization(cfg.structure)
    rng = np.random.default_rng(0)
    theta = par.theta0 * rng.uniform(0.9, 1.1, (args.sets, par.size))
    rpm = np.linspace(2000, 12000, 200)
    print(describe())
    if args.against:
        with threadpool_limits(1):
            paired(args.against, par.batch(theta), cfg.cutting, rpm)
        return
    with threadpool_limits(1):
        t = time.perf_counter()
        zoa.envelope_batch(par.batch(theta[:8]), cfg.cutting, rpm)  # compile / load the cache
        print(f"first call (compile or cache load): {time.perf_counter() - t:.2f} s")
        best = np.inf
        for _ in range(3):
            t = time.perf_counter()
            depth = zoa.envelope_batch(par.batch(theta), cfg.cutting, rpm)
            best = min(best, time.perf_counter() - t)
        assert np.isfinite(depth).all()
        print(f"B={args.sets} sets x S={rpm.size} speeds: best of 3 {best:.3f} s; "
              f"min depth {depth.min() * 1e3:.4f} mm, max {depth.max() * 1e3:.4f} mm")
        if args.million:
            n = 1_000_000
            t = time.perf_counter()
            lo = np.inf
            for start in range(0, n, 100_000):  # draw and evaluate in pieces: memory stays bounded
                th = par.theta0 * np.random.default_rng(start).uniform(0.9, 1.1, (100_000, par.size))
                for _, d in zoa.iter_envelope_chunks(par.batch(th), cfg.cutting, rpm):
                    lo = min(lo, d.min())
            dt = time.perf_counter() - t
            print(f"10^6 sets streamed: {dt:.1f} s ({n / dt:.0f} sets/s), overall min depth {lo * 1e3:.4f} mm")
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak_rss_mb: {peak_mb:.0f}")
    print(f"envelopes_per_s: {args.sets / best:.0f}")


if __name__ == "__main__":
    main()
