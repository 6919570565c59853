"""Decisions from an accurate posterior (issue 28): the update, the recommendation (with its next test) and the
P(stable) map, with the zero-order engine and with the spectral engine, timed in the same run; and the fast
speed search of :func:`millstab.update.decide.recommend` against the full scan on the same posterior.

Case (as ``bench_update_accurate.py``, the low-immersion shop of docs/updating.md): the seed paper's Ex.1 structure
as the hammer test with the default prior spreads, a/D ``--immersion`` down milling; the truth is the hammer test
off by a random factor per parameter (fn ±3 %, k ±20 %, ζ ±30 %, seed ``--seed``); ``--cuts`` cuts at random speeds
in ``--rpm``, depths uniform in ±30 % around the truth's SDM limit, labels with 3 % relative depth noise.

Timed (wall and CPU; BLAS pinned to one thread, ``OMP_WAIT_POLICY=PASSIVE`` set before numba starts its threads,
engines warmed first): ``update`` (``--samples``), ``recommend`` (risk ``--risk``, the default rule: 90 %
confidence, ±0.25 % speed tolerance, data guard, the next test), ``p_stable_map`` on ``--map-speeds`` ×
60 depths (``--map-samples``, default auto: the zero-order map from every sample, the accurate one from a seeded
subsample of ``decide.MAP_SAMPLES``); for each engine; and for the accurate engine the map and the recommendation
sharing their limits (one ``LimitMemo``, the map first: the app's Map and recommend). ``search="full"`` (every
sample on the 200-speed coarse grid and the refinement) and
``search="auto"`` (the default: the fast search for an engine other than the cheapest) are both timed for the
spectral posterior, and compared: the speed, depth, productivity ratio, the fast recommendation's P(chatter)
under the full posterior at its speed and ±the tolerance (every sample, the spectral engine) against the risk,
and whether both sit in the same pocket (no speed of the full scan's coarse grid between them where the full
posterior's safe depth falls below half of the lesser of the two depths).

``--seeds``, ``--immersions``: the comparison on several posteriors (each a fresh case and update).
``--cache DIR``: keep each case's posteriors (and their update's timing) there and reuse them in a later run.
``--jobs N``: the cases in a process pool (each seeded by its own case, the figures do not depend on N; timings
under a pool share the machine: quote them from ``--jobs 1``).

Run: ``PYTHONPATH=src:benchmarks .venv/bin/python benchmarks/bench_decide_accurate.py [--samples 1000]
[--immersions 0.1] [--seeds 0]``.
"""

from __future__ import annotations

import argparse
import os
import pickle
import sys
import time

if __name__ == "__main__":  # before numba starts its OpenMP threads (bench_update_accurate.py measured why)
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import numpy as np
from threadpoolctl import threadpool_limits

from _machine import describe, pool_of


def timed(f):
    t, c = time.perf_counter(), time.process_time()
    out = f()
    return out, time.perf_counter() - t, time.process_time() - c


def make_case(immersion: float, seed: int, n_cuts: int, rpm: tuple[float, float]):
    """(config, prior, cuts, text, the true structure) of the case in the module docstring."""
    from millstab.io import load_config
    from millstab.io.config import PriorTable
    from millstab.model import Cutting
    from millstab.points import PointSet
    from millstab.stability import sdm
    from millstab.update import make_prior

    cfg = load_config("example:ex1")
    cut = Cutting.from_immersion(cfg.cutting.teeth, cfg.cutting.kt, cfg.cutting.kr, immersion, "down")
    prior = make_prior(cfg.structure, cut, PriorTable({}, sigma_depth_rel=0.05))
    rng = np.random.default_rng(seed)
    names = list(prior.par.free)
    off = {"fn": 0.03, "k": 0.2, "zeta": 0.3}
    fac = np.array([1 + rng.uniform(-off[prior.par.kind(n)], off[prior.par.kind(n)]) for n in names])
    truth = prior.par.structure(prior.median * fac)
    r = np.sort(rng.uniform(*rpm, n_cuts))
    b_true = sdm.envelope(truth, cut, r).depth_mm
    depth = b_true * rng.uniform(0.7, 1.3, r.size)
    chatter = depth > b_true * np.exp(0.03 * rng.standard_normal(r.size))
    cuts = PointSet(r, depth, np.where(chatter, "chatter", "stable"))
    text = f"a/D {immersion} seed {seed}: {n_cuts} cuts, {int(chatter.sum())} chatter, truth = hammer test x " \
           f"{np.round(fac, 3).tolist()}"
    return cfg, prior, cuts, text, truth


def same_pocket(post, rpm_range, a: tuple[float, float], b: tuple[float, float], risk: float, count: int,
                n_speeds: int = 200) -> bool:
    """Whether cuts ``a`` and ``b`` (rpm, mm) lie in one pocket of the full posterior's safe depth: no speed of a
    ``n_speeds`` grid between them where the risk quantile falls below half the lesser depth."""
    from millstab.update.decide import safe_depth
    from millstab.update.likelihood import limits

    lo, hi = sorted((a[0], b[0]))
    grid = np.linspace(*rpm_range, n_speeds)
    between = np.concatenate([[lo], grid[(grid > lo) & (grid < hi)], [hi]])
    blim, _ = limits(post.prior, post.decision_u, between, post.engine, options=post.engine_options)
    return bool(safe_depth(blim, risk, count).min() >= 0.5 * min(a[1], b[1]))


def one_case(args, immersion: float, seed: int) -> list[str]:
    """Every figure of one case, as printed lines."""
    from millstab.update import decide, p_stable_map, update
    from millstab.update.decide import allowed_count, effective_samples, recommend
    from millstab.update.likelihood import limits

    class Lines(list):  # printed as they come when the cases run in this process (progress), else by the caller
        def append(self, line: str) -> None:
            super().append(line)
            if args.jobs <= 1:
                print(line, flush=True)

    lines = Lines()
    lo, hi = (float(x) for x in args.rpm.split(":"))
    cfg, prior, cuts, text, _ = make_case(immersion, seed, args.cuts, (lo, hi))
    lines.append(text)
    map_rpm, map_depth = np.linspace(lo, hi, args.map_speeds), np.linspace(0.01, 3 * float(cuts.depth_mm.max()), 60)
    res = {}
    default_m = decide.SEARCH_SAMPLES
    with threadpool_limits(1):
        for eng in ("zoa", "spectral"):  # compile / load the caches outside the timings
            update(cfg, cuts, samples=20, seed=99, engine=eng, moves=1, prior=prior, sampler="plain")
        for eng in args.engines.split(","):
            path = (os.path.join(args.cache, f"{eng}-{immersion:g}-{seed}-{args.samples}-{args.cuts}.pkl")
                    if args.cache else None)
            if path and os.path.exists(path):  # the posterior and its update's timing from an earlier run
                with open(path, "rb") as fh:
                    post, w_u, c_u = pickle.load(fh)
            else:
                post, w_u, c_u = timed(lambda eng=eng: update(cfg, cuts, samples=args.samples, seed=seed, engine=eng,
                                                              prior=prior))
                if path:
                    with open(path, "wb") as fh:
                        pickle.dump((post, w_u, c_u), fh)
            lines.append(f"  {eng:8s}: update {w_u:7.1f} s wall {c_u:7.1f} s CPU")
            searches = ["auto"] + ([f"fast/{m}" for m in args.search_samples.split(",") if m] if eng != "zoa" else [])
            searches += ["full"] if eng != "zoa" and args.full else []
            for s in searches:
                decide.SEARCH_SAMPLES = int(s.split("/")[1]) if "/" in s else default_m
                kept = f"{path}.{s.replace('/', '-')}-{args.risk:g}-{args.coarse}.pkl" if path else None
                if kept and s == "full" and os.path.exists(kept):  # the full scan of an earlier run (minutes)
                    with open(kept, "rb") as fh:
                        rec, w_r, c_r = pickle.load(fh)
                else:
                    rec, w_r, c_r = timed(lambda s=s: recommend(post, args.risk, (lo, hi), seed=seed,
                                                                search=s.split("/")[0], coarse_points=args.coarse))
                    if kept and s == "full":
                        with open(kept, "wb") as fh:
                            pickle.dump((rec, w_r, c_r), fh)
                decide.SEARCH_SAMPLES = default_m
                res[eng, s] = (post, rec, w_r, c_r)
                lines.append(f"  {eng:8s}: recommend (search {s}) {w_r:7.1f} s wall {c_r:7.1f} s CPU -> {rec.rpm:.1f} "
                             f"rpm {rec.depth_mm:.4f} mm, P(chatter) {rec.p_chatter_speed_error:.4f} (next test "
                             f"{rec.next_test['rpm']:.0f} rpm {rec.next_test['depth_mm']:.3f} mm)")
            m = decide.map_samples(eng, post.u.shape[0], "auto" if eng == "zoa" else args.map_samples)
            pm, w_m, c_m = timed(lambda: p_stable_map(post, map_rpm, map_depth, samples=m, seed=seed))
            res[eng, "update"], res[eng, "map"] = (w_u, c_u), (w_m, c_m)
            lines.append(f"  {eng:8s}: map {args.map_speeds}x60 from {decide.map_samples_text(m, post.u.shape[0])} "
                         f"{w_m:6.1f} s wall {c_m:6.1f} s CPU")
            if eng != "zoa" and args.shared:  # the app's Map and recommend: one memo, the map first
                def both():
                    memo = decide.LimitMemo()
                    return (p_stable_map(post, map_rpm, map_depth, samples=m, seed=seed, memo=memo),
                            recommend(post, args.risk, (lo, hi), seed=seed, coarse_points=args.coarse, memo=memo))
                (pm2, rec2), w_s, c_s = timed(both)
                alone = res[eng, "auto"][1]
                # to the root search's tolerance (a limit computed in another call: 1e-13 relative, LimitColumns)
                same = bool(np.allclose([rec2.rpm, rec2.depth_mm, rec2.next_test["rpm"], rec2.next_test["depth_mm"]],
                                        [alone.rpm, alone.depth_mm, alone.next_test["rpm"],
                                         alone.next_test["depth_mm"]], rtol=1e-9, atol=0))
                res[eng, "shared"] = (w_s, c_s)
                lines.append(f"  {eng:8s}: map + recommend sharing their limits {w_s:6.1f} s wall {c_s:6.1f} s CPU "
                             f"(apart {c_m + res[eng, 'auto'][3]:.1f} s CPU); the same cut and next test (1e-9) "
                             f"{same}"
                             f", map within {np.abs(pm2 - pm).max():.2g}")
        for key in [k for k in res if k[0] == "spectral" and (k[1] == "auto" or k[1].startswith("fast/"))]:
            if ("spectral", "full") not in res:
                break
            post, fast = res[key][:2]
            full = res["spectral", "full"][1]
            offs = np.array([0.0, -0.0025, 0.0025])
            around, _ = limits(post.prior, post.decision_u, fast.rpm * (1 + offs), post.engine,
                               options=post.engine_options)
            p_full = float(np.max(np.mean(around <= fast.depth_mm, axis=0)))
            count = allowed_count(post.u.shape[0], args.risk, effective_samples(post))
            pocket = same_pocket(post, (lo, hi), (fast.rpm, fast.depth_mm), (full.rpm, full.depth_mm), args.risk,
                                 count)
            lines.append(f"  {key[1]} vs full: productivity ratio {fast.productivity / full.productivity:.4f}, speeds "
                         f"{fast.rpm:.1f} / {full.rpm:.1f} rpm, same pocket {pocket}; the fast cut's P(chatter) under "
                         f"the full posterior at its speed and ±0.25 % {p_full:.4f} (risk {args.risk:g}, "
                         f"{'ok' if p_full <= args.risk else 'EXCEEDS'})")
        if ("zoa", "auto") in res and ("spectral", "auto") in res:
            z = [res["zoa", k] for k in ("update", "map")] + [res["zoa", "auto"][2:]]
            s = [res["spectral", k] for k in ("update", "map")] + [res["spectral", "auto"][2:]]
            tz, ts = sum(x[0] for x in z), sum(x[0] for x in s)
            cz, cs = sum(x[1] for x in z), sum(x[1] for x in s)
            dz, ds = z[2][1] + z[1][1], s[2][1] + s[1][1]
            lines.append(f"  ratio spectral/zoa (CPU): update {s[0][1] / z[0][1]:.1f}, recommend "
                         f"{s[2][1] / z[2][1]:.1f}"
                         f", map {s[1][1] / z[1][1]:.1f}"
                         + (f", map + recommend sharing their limits {res['spectral', 'shared'][1] / dz:.1f}, update + "
                            f"both {(s[0][1] + res['spectral', 'shared'][1]) / cz:.1f}" if ("spectral", "shared") in res
                            else ""))
            lines.append(f"  ratio spectral/zoa: update + recommend + map {ts / tz:.1f} wall, {cs / cz:.1f} CPU; "
                         f"recommend + map alone {ds / dz:.1f} CPU; recommend alone {s[2][1] / z[2][1]:.1f} CPU"
                         + (f" (the full search: {res['spectral', 'full'][3] / z[2][1]:.1f} CPU; the fast search saves "
                            f"{res['spectral', 'full'][3] / s[2][1]:.1f}x CPU)" if ("spectral", "full") in res else ""))
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=1000)
    ap.add_argument("--cuts", type=int, default=10)
    ap.add_argument("--immersions", default="0.1", help="comma-separated a/D")
    ap.add_argument("--seeds", default="0", help="comma-separated case seeds")
    ap.add_argument("--rpm", default="5000:12000")
    ap.add_argument("--risk", type=float, default=0.05)
    ap.add_argument("--map-speeds", type=int, default=200)
    ap.add_argument("--coarse", type=int, default=200, help="speeds of the recommendation's coarse grid")
    ap.add_argument("--map-samples", default="auto", help="the accurate engine's map: auto (decide.MAP_SAMPLES), all, "
                    "or a number of samples (the zero-order map reads every sample)")
    ap.add_argument("--no-shared", dest="shared", action="store_false", help="skip the accurate engine's map and "
                    "recommendation sharing their limits (the app's Map and recommend)")
    ap.add_argument("--engines", default="zoa,spectral")
    ap.add_argument("--search-samples", default="", help="also the fast search with these subsample sizes "
                    "(comma-separated; the default search=auto uses decide.SEARCH_SAMPLES)")
    ap.add_argument("--no-full", dest="full", action="store_false", help="skip the full-scan recommendation")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--cache", default=None, help="keep / reuse each case's posteriors (pickles) in this folder")
    args = ap.parse_args()
    print(describe() + f"; OMP_WAIT_POLICY={os.environ.get('OMP_WAIT_POLICY')}; load {os.getloadavg()[0]:.1f}")
    cases = [(float(a), int(s)) for a in args.immersions.split(",") for s in args.seeds.split(",")]
    with pool_of(args.jobs) as pool:
        outs = (pool.map(one_case, [args] * len(cases), *zip(*cases)) if pool is not None
                else (one_case(args, a, s) for a, s in cases))
        for lines in outs:
            if pool is not None:
                print("\n".join(lines), flush=True)


if __name__ == "__main__":
    sys.exit(main())
