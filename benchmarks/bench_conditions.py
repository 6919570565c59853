"""Cost of updating from cuts in several cutting conditions (issue 27: ≤ 1.5× one condition): one update
(tempered SMC, zoa) with 4 000 samples over 40 cuts in ONE condition against 40 cuts in FOUR conditions.

Data: the seed paper's Ex.1 config as the prior; a truth drawn from that prior (seed 1); the conditions are the
config's tool in slotting, 50 % down, 50 % up and 25 % down milling; 40 cuts at distinct speeds (uniform
4 000–12 000 rpm, rounded to 10 rpm) and depths uniform in ±50 % of the true limit, labelled by the
semi-discretization engine (sdm: the time-domain model, not the fitted zero-order one). One condition: all 40
cuts in slotting; four: 10 cuts in each. The update is the sampler driven as ``millstab.update.update`` drives
it (prior draws, then tempering stages of 3 MH moves), with the engine calls timed inside the likelihood.

Printed: wall and CPU time (all threads) of each update, the engine-call share, stages and engine sets, the
engine alone on the same prior draws (interleaved, best of 3), the ratio of the two updates, and the ratio per
engine set (the stage count is data-dependent; the per-set ratio
is the engine's own cost of the conditions). On a shared machine quote CPU time and same-run ratios.

Measured (2026-11-27, shared 2-core AMD EPYC, numba 2 threads, default size). Before the modal roots in real
arithmetic (load 16–18): one condition 3.13 s CPU (11.4 s wall), 5 stages, 64 000 engine sets at 41 µs CPU
each; four conditions 9.30 s CPU (28.0 s wall), 7 stages, 88 000 sets at 98 µs; ratio 2.97 CPU (2.45 wall);
engine alone 2.28. After (the roots in real arithmetic and the block-copy merge, bit for bit the same depths;
load 17–20): one condition 2.99 s CPU (15.7 s wall), 5 stages, 39 µs per set; four conditions 8.62 s CPU
(49.5 s wall), 7 stages, 91 µs per set; ratio 2.88 CPU (3.16 wall: the wall time follows the neighbours),
engine per set 2.30, engine alone on the same 4 000 prior draws 2.35 (an earlier run at load 21–30: 2.87
CPU, 2.29 per set). Both sides got faster by about as much (the engine per set 4–9 %, interleaved runs of
the old and new kernel: 43 → 40–42 µs in one condition, 106 → 96 µs in four), so the ratio hardly moves.
The issue's 1.5× is NOT reached; its two factors:

* the engine, ~2.3× per set. Where the zero-order engine's time goes (per set, one thread, these structures
  and speeds, timed by stage, load ~15): the shared grid and receptances 5 µs; per condition the eigenvalues
  on the grid 6 µs (~3.5 µs since the real-arithmetic roots), the Re ν = 0 edges 2.2 µs, merging them 1.8 µs,
  the candidate scan 11.5 µs with 10 speeds (14 µs with 40), refinement ~0.25 µs per speed. The scan is
  not wasted work: per condition it visits 37–42 of ~240 valid segments, and 35–40 of them are needed
  (their best 1/b within REFINE_MARGIN of the worst speed's estimate; a scan with finer levels would skip
  at most 2), each with its ~7 lobes; with 10 speeds instead of 40 it visits ~10 % fewer. A condition
  therefore costs ~20 µs whatever its number of speeds, against ~39 µs for a whole 40-speed envelope.
  Sharing more between conditions without moving the depths is limited: every node value (ν, ε, ε′) seeds
  the refinement's first iterate, so any change of its rounding moves the converged roots by up to the
  refinement tolerance (~1e-7 relative), not by 1e-12;
* the stages, 22 against 16 engine calls (1.375×): the ESS rule (ESS ½ per stage) takes stages in
  proportion to the information the data carry, and the four-condition data carry more: KL(posterior ‖
  prior) 5.9–6.2 nats in one condition against 9.1–11.0 in four (1 000-sample runs, sampler seeds 0–2:
  5, 5, 5 against 7, 6, 6 stages; the posterior sd of ln fn is 2–3× smaller, of ln k 1.3–3×). The extra stages are
  needed, not an artefact (4 000 samples: KL 5.9 against 10.6 nats). The last stage of the four-condition
  runs is often a sliver (β 0.95 → 1 at 4 000 samples, 0.979 → 1 at 1 000, seed 0): three MH moves, 14 % of
  the update, which only accepting an ESS below the target at the last stage would save (not done: the
  sampler's calibration was set with the rule as it is).

Round 3 (2026-11-27, same machine, load 14–16, ``--samples 4000 --fixed-moves``: the four updates in one
run). Where the 2.83× of the sampler as it was goes (CPU, the engine timed inside the likelihood):

* one condition 3.01 s = 16 engine calls × 4 000 sets × 40 µs (2.54 s, 84 %) + 0.47 s numpy (likelihood,
  prior, resampling); four conditions 8.54 s = 22 calls × 4 000 × 90 µs (7.90 s, 92 %) + 0.64 s. So
  2.83 ≈ 1.375 (calls: 7 stages × 3 moves + 1 against 5 × 3 + 1) × 2.28 (engine per set) × 0.90 (the
  numpy part grows less). The engine alone on the same 4 000 prior draws: 2.34.
* what the conditions share: each set's frequency grid and its receptances G(ω) (computed once per set
  for all conditions since round 2). What they cannot share: the eigenvalues ν are those of [α_c][G(ω)],
  and the directional matrix α_c is the condition's, so ν, the Re ν = 0 edges, ε, the lobes' brackets and
  the scan are all per condition (only for a symmetric structure, G_xx = G_yy, would ν = g·eig(α_c)
  factor). The receptance derivatives of the scan's node slopes are condition-free, but they are ~1 µs of a
  condition's ~20.
* acceptance per stage 0.18–0.28 (one condition 0.21–0.25): every regular stage's moves work at the target.
  The moves spent where they were not needed: the last stage of four conditions, β 0.95 → 1, kept
  ESS 0.99 N, so resampling duplicated ~1 % of the particles, and three moves followed (3 of 22 calls).
  The sampler now takes ⌈3·(1 − ESS/N)/0.5⌉ moves after such a step (at least one): 20 calls, **7.81 s
  against 8.54 s (0.91×)**, one condition unchanged (3.01 s, its last step kept ESS 0.67 N: 3 moves).
  **Ratio 2.60 CPU** (2.46 wall) against 2.83 in the same run.
* tried and dropped, early rejection (Solonen et al. 2012): draw the MH uniform first, evaluate the
  conditions one engine call at a time and stop a proposal once its log L so far (the later cuts add ≤ 0)
  is below the acceptance floor. Exact (the same particles, bit for bit, as the full likelihood), but it
  evaluated 73 % of the (set, condition) pairs (survival after the first condition 0.57 in the first stage,
  0.96–0.99 from the fourth: a proposal is rejected by the sum of four conditions' small deficits, not by
  one), and every call recomputes the set's grid (5 µs) and costs Python per stage: 8.54 s CPU against
  8.53 s without (survival traced per stage on a 1 000-sample run). With each set's grid kept between the
  calls (computed once, then read back by the later conditions' calls): 8.63 s against 7.55 s without, the
  same particles; evaluating one condition of 4 000 sets on kept grids took 0.10 s CPU, as much as a quarter
  of the whole four-condition call (0.39 s): reading 11 KB of grid and receptances per set back from a 45 MB
  array costs what computing them in cache costs, and keeping them cost 16 µs per set.

Round 4 (2026-11-27, load 16–23, ``--samples 4000``): one condition 2.98 s CPU (5 stages, 16 calls, 40 µs per
set), four 7.80 s (7 stages, 20 calls, 91 µs per set): **2.62× CPU**, engine 2.30× per set, 2.45 alone; KL 5.9
against 10.6 nats (the stages stay: information). Per condition and set (``profile_zoa.py --conditions``): 14.6 µs
with 1 speed, 22.0 with 10, 33.3 with 40, on a shared grid of 4.8 µs; the 1.5× needs ≤ ~3 µs fixed per condition
(docs/updating.md). A speed-major candidate scan was bit-identical and 0.98–1.02× the time: dropped.

Round 5 (2026-11-27, load 8–12, ``--samples 4000``; the eigenvalues without a branch per node and the grid
without zero-division checks, the same bits): one condition 2.76 s CPU (5 stages, 36 µs per set), four 7.24 s
(7 stages, 83 µs per set): **2.63× CPU**, engine 2.31× per set, 2.30 alone. Both ~8 % faster; the floor of an
exact engine path (~1.8× per set) and what is left are in docs/updating.md. ``--censor`` (also both updates
with the likelihood's ceilings forced on and zoa's censored search, in the same run, load ~11): plain 2.87 and
7.60 s CPU (2.65×), censored 2.81 and 6.64 s (**2.37×**; 0.98× and 0.87× of plain), the same stages, β and
acceptance.

Round 6 (2026-11-27, ``--samples 4000 --census``, load 5–6): the censoring is on (zoa's ``likelihood_ceiling``,
under several conditions too); every run times both updates plain (the likelihood's censoring off) and censored and
checks that their particles are the same bit for bit (True; it was False at 300 samples until zoa's ceilings
saturated every term to the last bit and its censored search refined by the best estimate, not the ceiling: see
docs/updating.md). Plain 2.51 s CPU in one condition, 6.49 in four (**2.59×**); censored 2.53 and 6.28 (**2.48×**;
0.97× of plain in four conditions, 0.93× in another run); 5 against 6 stages (14 against 18 engine calls, KL 4.8
against 8.1 nats). ``--census`` on each censored posterior (4 000 sets, one thread, interleaved best of 5): one
condition 30.5 µs per set plain, 30.6 censored; four 73.3 plain, 70.4 censored (segments visited 134 → 116,
refinement evaluations 70 → 68); 30 % and 47 % of the (set, column) pairs censored, 15 % and 26 % floorable. A
floor (:func:`floors`) was not built: with the search before the refinement fix, which also skipped the floored
pairs' refinement, their tiny ceilings saved at most 4.5 % (one condition) and 3.1 % (four) of the censored
engine's CPU: a floored speed's limit is low, so it never sets how far the scan certifies.

Run: ``.venv/bin/python benchmarks/bench_conditions.py [--samples 4000] [--cuts 40] [--conditions 4]
[--fixed-moves] [--census]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numba as nb
import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).parent))
from _machine import describe  # noqa: E402

from millstab.io import load_config  # noqa: E402
from millstab.model import Cutting  # noqa: E402
from millstab.stability import sdm  # noqa: E402
from millstab.update import make_prior  # noqa: E402
from millstab.stability import _zoa_kernel as K  # noqa: E402
from millstab.stability import zoa  # noqa: E402
from millstab.update.likelihood import Evidence, Likelihood  # noqa: E402
from millstab.update.sampler import tempered_smc  # noqa: E402

IMMERSIONS = ((1.0, "down"), (0.5, "down"), (0.5, "up"), (0.25, "down"))


class TimedLikelihood(Likelihood):
    """The likelihood with its engine calls timed (wall and CPU)."""

    engine_wall = engine_cpu = 0.0

    def _limits(self, v, **kw):
        t, c = time.perf_counter(), time.process_time()
        try:
            return super()._limits(v, **kw)
        finally:
            self.engine_wall += time.perf_counter() - t
            self.engine_cpu += time.process_time() - c


def campaign(cfg, prior, truth, n_cuts: int, n_cond: int, rng) -> Evidence:
    """``n_cuts`` cuts spread over the first ``n_cond`` conditions, labelled by sdm at the true structure."""
    c = cfg.cutting
    conds = tuple(Cutting.from_immersion(c.teeth, c.kt, c.kr, ri, m) for ri, m in IMMERSIONS[:n_cond])
    rpm = np.unique(rng.uniform(4000, 12000, 4 * n_cuts).round(-1))
    rpm = rng.permutation(rpm)[:n_cuts]
    cond = np.arange(n_cuts) % n_cond
    blim = np.empty(n_cuts)
    for i, cut in enumerate(conds):
        blim[cond == i] = sdm.envelope(truth, cut, rpm[cond == i]).depth_mm
    depth = blim * rng.uniform(0.5, 1.5, n_cuts)
    kind = (depth > blim).astype(np.int64)
    return Evidence(rpm, depth, kind, np.ones(n_cuts), np.full(n_cuts, np.nan), np.zeros(0), np.zeros(0),
                    np.zeros(0), cut_cond=cond, conditions=conds)


def floors(lik: Likelihood, u: np.ndarray, noise: np.ndarray | None) -> np.ndarray:
    """The FLOOR per (set, column) [mm] (``--census``; the mirror of :meth:`Likelihood.ceilings`): the depth below
    which no cut's term at that column moves by more than CENSOR_TOL × |w|. A limit b_lim far below a cut, z = (b −
    b_lim)/(s σ_b) ≫ 0: a chatter term log(1 − ε − (1 − 2ε)Φ(−z)) moves from log(1 − ε) by ≤ 2Φ(−z), a stable term
    log(ε + (1 − 2ε)Φ(−z)) from log ε by ≤ Φ(−z)/ε, a graded g by ≤ |w| Φ(−z) ((1 − g)/ε + 2g); the column's floor
    is the lowest of its cuts' b − k s σ_b (:meth:`Likelihood.saturation_depths`; −inf with a boundary point, or a
    stable cut at ε = 0)."""
    low = lik.saturation_depths(u, noise, above=False)
    out = np.full((u.shape[0], lik.speeds.size), np.inf)
    np.minimum.at(out.T, lik._ic, low.T)
    out[:, lik._exact_column] = -np.inf
    return out


def census(lik: Likelihood, v: np.ndarray, label: str, reps: int = 5) -> None:
    """How many (set, column) pairs of the sets ``v`` a floor would skip, and what the scan's certification of them
    costs (``--census``): the engine alone (one thread, best of ``reps`` interleaved) plain, censored, and censored
    with the floored pairs given a tiny ceiling (their speeds then no longer set how far the scan certifies; their
    candidates are still refined, as the censored search decides that by the estimates, not the ceiling, since
    round 6: before, this variant refined none of them either, an upper bound of what a floor could save)."""
    p, q = lik.prior.size, lik.prior.dim
    u, w = v[:, :p], (v[:, p:q] if q > p else None)
    theta, factor = lik.prior.split(u)
    batch, kr = lik.prior.par.batch(theta), lik.prior.kr_of(u)
    cond = lik.prior.cutting if lik._group_conditions[0] is None else lik._group_conditions[0]
    rpm = zoa.check_rpm(lik.speeds)
    lik = Likelihood(lik.prior, lik.evidence)  # censoring on (the caller's may have it off)
    cap = lik.ceilings(u, w) / (1e3 * factor[:, None])  # [m], the engine's own depths
    plain = zoa.envelope_batch(batch, cond, rpm, kr=kr)
    fl = floors(lik, u, w) / (1e3 * factor[:, None])
    floored = plain < fl
    censored = plain > cap
    removed = np.where(floored, 1e-12, cap)
    visited, evals = K.STAT_NAMES.index("segments visited"), K.STAT_NAMES.index("refinement evaluations")
    variants = (("plain", None), ("censored", cap), ("censored, floored removed", removed))
    cost = dict.fromkeys((n for n, _ in variants), np.inf)
    for _ in range(reps):  # interleaved (plain, censored, removed, plain, ...): robust to the load drifting
        for name, c in variants:
            t = time.process_time()
            zoa._run_modal(batch, cond, rpm, None, kr, c)
            cost[name] = min(cost[name], time.process_time() - t)
    for name, c in variants:
        st = np.zeros((batch.size, K.N_STATS), dtype=np.int64)
        zoa._run_modal(batch, cond, rpm, st, kr, c)
        print(f"  {label}, {name}: {1e6 * cost[name] / batch.size:.1f} µs CPU per set; per set "
              f"{st[:, visited].mean():.1f} segments visited, {st[:, evals].mean():.1f} refinement evaluations")
    print(f"  {label}: of {plain.size} (set, column) pairs {censored.mean():.0%} censored, {floored.mean():.0%} "
          f"would be floored (limit below every cut's saturation depth); their tiny ceilings save "
          f"{1 - cost['censored, floored removed'] / cost['censored']:.1%} of the censored engine's CPU")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=4000)
    ap.add_argument("--cuts", type=int, default=40)
    ap.add_argument("--conditions", type=int, default=4)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--census", action="store_true",
                    help="also count, on each censored update's posterior, the (set, column) pairs a floor would "
                         "skip and the engine CPU that would save at most")
    ap.add_argument("--fixed-moves", action="store_true",
                    help="also run both updates with 3 moves at every stage (the sampler before the adaptive "
                         "moves), interleaved in the same run")
    args = ap.parse_args()
    print(describe())
    cfg = load_config("example:ex1")
    prior = make_prior(cfg.structure, cfg.cutting)
    rng = np.random.default_rng(1)
    truth = prior.par.structure(prior.split(prior.sample(1, rng))[0][0])
    runs, liks, fixed, censored, posts = {}, {}, {}, {}, {}
    with threadpool_limits(1):
        evs = {n_cond: campaign(cfg, prior, truth, args.cuts, n_cond, np.random.default_rng(2))
               for n_cond in (1, args.conditions)}
        # plain: every limit searched to its root (the likelihood's censoring off); censored: the default since
        # zoa takes a ceiling (issue 27), exact, so the same particles bit for bit (checked below)
        variants = [("adaptive, plain", True, False), ("adaptive, censored", True, True)]
        if args.fixed_moves:
            variants.append(("fixed 3, plain", False, False))
        for label, adaptive, censor in variants:
            for n_cond, ev in evs.items():
                lik = TimedLikelihood(prior, ev)
                lik._censor = censor and lik._censor
                lik(prior.sample_full(64, rng))  # warm-up: compilation or cache load
                lik.engine_wall = lik.engine_cpu = 0.0
                lik.n_sets = lik.n_calls = lik.n_censored = 0
                t, c = time.perf_counter(), time.process_time()
                res = tempered_smc(prior.sample_full, prior.logpdf_full, lik, args.samples, seed=args.seed,
                                   adaptive_moves=adaptive)
                wall, cpu = time.perf_counter() - t, time.process_time() - c
                d = res.diagnostics()
                (censored if censor else runs if adaptive else fixed)[n_cond] = (wall, cpu, lik.engine_cpu, lik.n_sets)
                if adaptive:
                    posts[(n_cond, censor)] = res.u
                if adaptive and not censor:
                    liks[n_cond] = lik
                print(f"{args.cuts} cuts in {n_cond} condition(s), {label} moves, "
                      f"{lik.speeds.size} engine columns: {wall:.2f} s wall, {cpu:.2f} s CPU (all threads; "
                      f"{nb.get_num_threads()}); engine calls {lik.engine_wall:.2f} s wall = "
                      f"{lik.engine_wall / wall:.0%}, {lik.engine_cpu:.2f} s CPU = {lik.engine_cpu / cpu:.0%}; "
                      f"{d['stages']} stages, {lik.n_calls} "
                      f"engine calls, {lik.n_sets} sets ({1e6 * lik.engine_cpu / lik.n_sets:.0f} µs CPU per set)"
                      + (f", {lik.n_censored / (lik.n_sets * lik.speeds.size):.0%} of the entries censored"
                         if censor else ""))
                # the information the data carry (nats): the ESS rule's stage count grows with it
                ess = ', '.join(f'{e / args.samples:.2f}' for e in res.ess)
                print(f"  KL(posterior || prior) {np.mean(res.loglik) - res.log_evidence:.1f} nats; betas "
                      f"{', '.join(f'{b:.3g}' for b in res.betas)}; ESS/N {ess}; moves {res.moves}; acceptance "
                      f"{', '.join(f'{a:.2f}' for a in res.acceptance)}")
        for n_cond in evs:
            same = np.array_equal(posts[(n_cond, False)], posts[(n_cond, True)])
            print(f"{n_cond} condition(s): the censored update's particles are the plain one's bit for bit: {same}")
        # the engine alone on the same prior draws, interleaved (1, n, 1, n, ...): the per-set cost of the
        # conditions without the data-dependent stage count, robust to the load drifting between the updates
        u = prior.sample_full(args.samples, np.random.default_rng(3))
        best = {}
        for _ in range(3):
            for n_cond, lik in liks.items():
                c = time.process_time()
                lik._limits(u)
                best[n_cond] = min(best.get(n_cond, np.inf), time.process_time() - c)
        print(f"engine alone on {args.samples} prior draws (best of 3, interleaved): {best[1]:.2f} s CPU (1 "
              f"condition), {best[args.conditions]:.2f} s CPU ({args.conditions}): ratio "
              f"{best[args.conditions] / best[1]:.2f}")
        if args.census:
            prev = nb.get_num_threads()
            nb.set_num_threads(1)
            try:
                for n_cond, lik in liks.items():
                    census(lik, posts[(n_cond, True)], f"{n_cond} condition(s), posterior")
            finally:
                nb.set_num_threads(prev)
    (w1, c1, e1, s1), (w4, c4, e4, s4) = runs[1], runs[args.conditions]
    print(f"plain: ratio {args.conditions} conditions / 1 (target <= 1.5): {w4 / w1:.2f} wall, {c4 / c1:.2f} CPU; "
          f"engine CPU per set {(e4 / s4) / (e1 / s1):.2f}")
    (_, k1, g1, n1), (_, k4, g4, n4) = censored[1], censored[args.conditions]
    print(f"censored (the same run): ratio {k4 / k1:.2f} CPU, engine CPU per set {(g4 / n4) / (g1 / n1):.2f}; "
          f"censored / plain: {k1 / c1:.2f} CPU (1 condition), {k4 / c4:.2f} ({args.conditions})")
    if fixed:
        (_, f1, _, _), (_, f4, _, _) = fixed[1], fixed[args.conditions]
        print(f"fixed 3 moves, plain: ratio {f4 / f1:.2f} CPU; adaptive / fixed CPU: {c1 / f1:.2f} (1 condition), "
              f"{c4 / f4:.2f} ({args.conditions})")


if __name__ == "__main__":
    main()
