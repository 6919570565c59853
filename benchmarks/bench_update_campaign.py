"""Virtual test campaigns: recommend → cut → update, against a truth the tool does not know.

Each campaign (seeded):
* prior = the hammer test: the seed paper's Ex.1 structure (2-tooth slotting) with the default spreads;
* truth = the hammer test off by a random factor per parameter, uniform in fn ±3 %, k ±20 %, ζ ±30 %
  (in-process dynamics differ from a tap test);
* labels: a cut at (Ω, b) chatters when b > b_lim,true(Ω) · exp(ε), ε ~ N(0, 3 %) (label noise), with
  b_lim,true from ``--truth-engine`` (default sdm with 40 steps per tooth period, ``--truth-steps``: the labels do NOT come from the zero-order model
  being fitted, so model error is in the loop; ``--truth-engine zoa`` for calibration);
  or, with ``--labels simulate``, from the time-domain simulation (millstab.simulate.label_cuts: its
  stable | marginal | chatter labels and chatter frequencies, ``--flip`` of the stable/chatter labels
  swapped by the "operator"), the truth engine then only judging whether a recommendation is stable;
* the loop: the first cut is the recommendation of the prior alone; then ``--cuts`` − 1 times: update
  (``--samples``, zoa), cut the tool's next test, label it. After each update: the recommendation at
  ``--risk`` in ``--rpm`` with ``--max-depth``, whether it is truly stable (b < b_lim,true), and its
  productivity (b·Ω) over that of the best truly stable cut (b_lim,true capped at max depth, on 181
  speeds); the Brier score of the P(stable) map against the truth (61 × 40 grid) beside the prior's;
  whether each parameter's 90 % interval covers the truth (in the x/y orientation closer to it).
* baselines: the recommendation from the hammer-test SLD alone (the deepest·fastest point of the
  prior-median zero-order SLD, 5 % below the limit): is it truly stable, its productivity; and
  evenly spaced test cuts (same number, at speeds evenly spaced, depth = prior median limit) → update →
  recommend.

Run: ``.venv/bin/python benchmarks/bench_update_campaign.py [--campaigns 5] [--cuts 10] [--samples 1000]``.
Slow (minutes): every round runs a full SMC update.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).parent))
from _machine import describe  # noqa: E402

from millstab.io import load_config  # noqa: E402
from millstab.io.config import PriorTable  # noqa: E402
from millstab.io.points import PointSet  # noqa: E402
from millstab.stability import get_engine  # noqa: E402
from millstab.update import Posterior, make_prior, p_stable_map, recommend, update  # noqa: E402
from millstab.update.posterior import exchange_of  # noqa: E402

OFF = {"fn": 0.03, "k": 0.20, "zeta": 0.30}
#: feed per tooth of the simulated cuts [m]
FEED_M = 0.1e-3


def truth_of(prior, rng) -> np.ndarray:
    f = np.array([rng.uniform(-OFF[prior.par.kind(n)], OFF[prior.par.kind(n)]) for n in prior.par.free])
    return prior.median * (1 + f)


def label(b_true: np.ndarray, depth: np.ndarray, rng, noise: float) -> np.ndarray:
    return np.where(depth > b_true * np.exp(noise * rng.standard_normal(depth.shape)), "chatter", "stable")


def simulated(structure, cutting, rpm, depth_mm, seed: int, flip: float) -> tuple[list[str], list[float]]:
    """Labels and chatter frequencies [Hz] of cuts from the time-domain simulation (operator swaps a
    stable/chatter label with probability ``flip``; marginal kept)."""
    from millstab.simulate import label_cuts

    lab = label_cuts(structure, cutting, np.atleast_1d(rpm), np.atleast_1d(depth_mm) * 1e-3, FEED_M, label_noise=flip,
                     seed=seed)
    return [str(x) for x in lab.label], [float(h) for h in lab.chatter_hz]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--campaigns", type=int, default=5)
    ap.add_argument("--cuts", type=int, default=10)
    ap.add_argument("--samples", type=int, default=1000)
    ap.add_argument("--risk", type=float, default=0.05)
    ap.add_argument("--rpm", default="5000:12000")
    ap.add_argument("--max-depth", type=float, default=8.0)
    ap.add_argument("--noise", type=float, default=0.03, help="label noise: σ of ln(boundary)")
    ap.add_argument("--truth-engine", default="sdm")
    ap.add_argument("--truth-steps", type=int, default=40, help="SDM steps per tooth period of the truth (speed)")
    ap.add_argument("--labels", choices=("engine", "simulate"), default="engine",
                    help="labels from the truth engine with boundary noise, or from the time-domain simulation")
    ap.add_argument("--flip", type=float, default=0.05, help="simulate: probability an operator swaps a label")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sigma-depth-rel", type=float, default=None,
                    help="the likelihood's depth noise relative to the depth (default: the absolute 0.05 mm)")
    args = ap.parse_args()
    print(describe())
    lo, hi = (float(x) for x in args.rpm.split(":"))
    cfg = load_config("example:ex1")
    table = PriorTable({}, sigma_depth_rel=args.sigma_depth_rel) if args.sigma_depth_rel else None
    prior = make_prior(cfg.structure, cfg.cutting, table)
    truth_engine = get_engine(args.truth_engine)
    fine = np.linspace(lo, hi, 181)
    g_rpm, g_depth = fine[::3], np.linspace(0.05, args.max_depth, 40)
    opts = {"steps": args.truth_steps} if args.truth_engine == "sdm" else {}
    rows = []
    with threadpool_limits(1), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for c in range(args.campaigns):
            t0 = time.perf_counter()
            rng = np.random.default_rng([args.seed, c])
            theta = truth_of(prior, rng)
            s_true = prior.par.structure(theta)
            b_fine = truth_engine.envelope(s_true, cfg.cutting, fine, **opts).depth_mm
            b_grid = b_fine[::3]
            best = float((np.minimum(b_fine, args.max_depth) * fine).max())
            stable_grid = g_depth[None, :] < b_grid[:, None]

            def b_true(rpm: float) -> float:
                return float(truth_engine.envelope(s_true, cfg.cutting, [rpm], **opts).depth_mm[0])

            def truly(rpm: float, depth: float) -> tuple[bool, float]:
                return depth < b_true(rpm), rpm * depth / best

            def brier(post) -> float:
                return float(((p_stable_map(post, g_rpm, g_depth) - stable_grid) ** 2).mean())

            prior_post = Posterior(prior, np.exp(prior.sample(args.samples, rng)), cuts={"rpm": [lo, hi]})
            brier0 = brier(prior_post)
            # baseline 1: the hammer-test SLD alone, 5 % below its limit
            b_ham = get_engine("zoa").envelope(cfg.structure, cfg.cutting, fine).depth_mm
            j = int(np.argmax(np.minimum(0.95 * b_ham, args.max_depth) * fine))
            ham_ok, ham_prod = truly(fine[j], min(0.95 * b_ham[j], args.max_depth))
            # the campaign
            rec = recommend(prior_post, args.risk, (lo, hi), max_depth_mm=args.max_depth, seed=c)
            cut_rpm, cut_depth = [rec.rpm], [rec.depth_mm]
            hz: list[float] = [np.nan]
            if args.labels == "simulate":
                labels, hz = simulated(s_true, cfg.cutting, rec.rpm, rec.depth_mm, 1000 * c, args.flip)
            else:
                labels = [str(label(np.array([b_true(rec.rpm)]), np.array([rec.depth_mm]), rng, args.noise)[0])]
            trace = []
            post = prior_post
            for k in range(1, args.cuts + 1):
                cuts = PointSet(cut_rpm, cut_depth, labels, chatter_hz=hz)
                if (cuts.stable.any() or cuts.chatter.any()):
                    post = update(cfg, cuts, prior=prior, samples=args.samples, seed=1000 * (args.seed * 100 + c) + k)
                rec = recommend(post, args.risk, (lo, hi), max_depth_mm=args.max_depth, seed=k)
                ok, prod = truly(rec.rpm, rec.depth_mm)
                trace.append((k, ok, prod))
                if k == args.cuts:
                    break
                nt = rec.next_test
                cut_rpm.append(nt["rpm"])
                cut_depth.append(nt["depth_mm"])
                if args.labels == "simulate":
                    lab1, hz1 = simulated(s_true, cfg.cutting, nt["rpm"], nt["depth_mm"], 1000 * c + k, args.flip)
                    labels += lab1
                    hz += hz1
                else:
                    labels.append(str(label(np.array([b_true(nt["rpm"])]), np.array([nt["depth_mm"]]), rng, args.noise)[0]))
                    hz.append(np.nan)
            brier_end = brier(post)
            # each sample in the x/y orientation closer to the truth (the exact twins are indistinguishable)
            xm = exchange_of(prior, "zoa")
            samp = post.samples
            if xm is not None:
                twin = samp[:, xm[0]] * np.exp(xm[1])
                closer = np.abs(np.log(twin / theta)).max(1) < np.abs(np.log(samp / theta)).max(1)
                samp = np.where(closer[:, None], twin, samp)
            q05, q95 = np.quantile(samp, [0.05, 0.95], axis=0)
            cover = (q05 <= theta) & (theta <= q95)
            # baseline 2: evenly spaced test cuts at the prior-median limit depth
            ev_rpm = np.linspace(lo, hi, args.cuts)
            ev_depth = np.minimum(get_engine("zoa").envelope(cfg.structure, cfg.cutting, ev_rpm).depth_mm, args.max_depth)
            if args.labels == "simulate":
                ev_lab, ev_hz = simulated(s_true, cfg.cutting, ev_rpm, ev_depth, 1000 * c + 999, args.flip)
            else:
                ev_lab = label(truth_engine.envelope(s_true, cfg.cutting, ev_rpm, **opts).depth_mm, ev_depth, rng, args.noise)
                ev_hz = np.full(ev_rpm.size, np.nan)
            ev_cuts = PointSet(ev_rpm, ev_depth, ev_lab, chatter_hz=ev_hz)
            ev_ok, ev_prod = (False, 0.0)
            if ev_cuts.stable.any() or ev_cuts.chatter.any():
                ev_post = update(cfg, ev_cuts, prior=prior, samples=args.samples, seed=c)
                ev_rec = recommend(ev_post, args.risk, (lo, hi), max_depth_mm=args.max_depth, seed=c)
                ev_ok, ev_prod = truly(ev_rec.rpm, ev_rec.depth_mm)
            rows.append({"trace": trace, "ham": (ham_ok, ham_prod), "even": (ev_ok, ev_prod), "brier": (brier0, brier_end),
                         "cover": cover})
            tr = " ".join(f"{'S' if ok else 'C'}{p:.2f}" for _, ok, p in trace)
            print(f"campaign {c}: {time.perf_counter() - t0:.0f} s; after each cut (S stable/C chatter, productivity/best): {tr}")
            print(f"   hammer SLD: {'stable' if ham_ok else 'CHATTER'} {ham_prod:.2f}; even cuts: "
                  f"{'stable' if ev_ok else 'CHATTER'} {ev_prod:.2f}; Brier prior {brier0:.3f} -> {brier_end:.3f}; "
                  f"90 % intervals cover truth: {cover.astype(int).tolist()}")
    n = len(rows)
    fin = [r["trace"][-1] for r in rows]
    src = (f"the time-domain simulation ({args.flip:.0%} swapped; chatter frequencies used)" if args.labels == "simulate"
           else f"{args.truth_engine} with {args.noise:.0%} boundary noise")
    print(f"\n{n} campaigns, risk {args.risk}, labels from {src}, truth {args.truth_engine}, {args.cuts} cuts, "
          f"{args.samples} samples:")
    print(f"  final recommendation truly stable: {sum(ok for _, ok, _ in fin)}/{n}; productivity/best: median "
          f"{np.median([p for _, _, p in fin]):.2f}, min {min(p for _, _, p in fin):.2f}; >= 0.85 and stable: "
          f"{sum(ok and p >= 0.85 for _, ok, p in fin)}/{n}")
    print(f"  every recommendation along the way truly stable: {sum(ok for r in rows for _, ok, _ in r['trace'])}/"
          f"{sum(len(r['trace']) for r in rows)}")
    print(f"  hammer-test SLD alone: stable {sum(r['ham'][0] for r in rows)}/{n}, productivity median "
          f"{np.median([r['ham'][1] for r in rows]):.2f}")
    print(f"  evenly spaced cuts: stable {sum(r['even'][0] for r in rows)}/{n}, productivity median "
          f"{np.median([r['even'][1] for r in rows]):.2f}")
    print(f"  Brier score better than the prior's: {sum(r['brier'][1] < r['brier'][0] for r in rows)}/{n}")
    cov = np.array([r["cover"] for r in rows]).mean(0)
    print(f"  90 % interval coverage per parameter ({', '.join(prior.names)}): {np.round(cov, 2).tolist()}")


if __name__ == "__main__":
    main()
