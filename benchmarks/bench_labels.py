"""A virtual shop with the label pathologies of real data, and millstab's held-out predictions against
simple baselines (issue 24): "can I trust it on my machine?".

Each shop (seeded):
* the hammer test is the seed paper's Ex.1 (2 teeth, slotting) — the config, i.e. the prior; the TRUE
  in-process structure is off by a random factor per parameter (uniform: fn ±3 %, k ±20 %, ζ ±30 %);
* the truth is the semi-discretization boundary (``sdm`` to ``--steps``: ``fn1``, 20 and 40 steps extrapolated, the
  default since 2026-11-28; 40 fixed steps before, limits up to ~10 % high, :mod:`_truth`) of that structure — not
  the zero-order model millstab fits;
* ``--days`` test days; each day every natural frequency drifts by one common factor, uniform ±3 %
  (spindle warm-up, a re-clamped tool); depth is confounded with the day: day d (0-based) cuts at depths
  b_ref · U(0.8, 1.8) · (0.7 + 0.15 d), b_ref the lower quartile of the true limit over the speed range (the
  shop starts careful and grows bolder: with Ex.1 about 17, 30, 45, 61 % of the cuts truly chatter on days
  1-4), at ``--speeds`` random speeds a day, ``--depths`` depths per speed;
* graded labels 0/1/2 (stable / marginal / chatter) by two operators: operator 1 sees the relative
  distance r = b / b_lim,day − 1 with noise N(0, 0.04) and writes 2 for r > 0.08, 0 for r < −0.08, else 1;
  operator 2 writes the same code, moved by one step (towards the other side where clipped) on
  exactly ``--disagree`` (12 %) of the cuts, chosen at random;
* the file is written as a shop would (``label_op1,label_op2`` codes, ``date``, ``feed``, ``notes``) and
  read by millstab's reader with ``--labels 0=stable,1=marginal,2=chatter``.

Then :func:`millstab.update.validate.cross_validate` (random folds, leave-one-speed-out, leave-one-day-out):
millstab's P(label chatter) from a zero-order update on the training cuts against the majority rate,
logistic regression and kNN on the same folds. Target: millstab's held-out Brier ≤ the best baseline, and
≤ the majority rate in every fold scheme.

Run (the sizes in docs/updating.md; about a minute a shop on the idle 2-core machine)::

    .venv/bin/python benchmarks/bench_labels.py --shops 10 --samples 500 [--json out.json]
    .venv/bin/python benchmarks/bench_labels.py --shops 5 --samples 500 --immersion 0.1 --sigma-depth-rel 0.05
    .venv/bin/python benchmarks/bench_labels.py --shops 10 --samples 500 --batch-effect 0.03   # the test-day effect

(``--batch-effect`` τ: each test day's shift of ln fn is sampled with the parameters; held-out cuts of a
day the training cuts include are predicted at that day's shift, leave-one-day-out at a new day's.)
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).parent))
from _machine import describe  # noqa: E402
from _truth import truth_depth_mm, truth_spec  # noqa: E402

from millstab.io import load_config  # noqa: E402
from millstab.io.config import PriorTable  # noqa: E402
from millstab.io.points import parse_points  # noqa: E402
from millstab.model import Cutting  # noqa: E402
from millstab.update import make_prior  # noqa: E402
from millstab.update.validate import METHODS, cross_validate  # noqa: E402

OFF = {"fn": 0.03, "k": 0.20, "zeta": 0.30}
CODES = "0=stable,1=marginal,2=chatter"


def shop_file(seed: int, args, cut, prior) -> tuple[str, dict]:
    """The CSV text a shop would write, and facts about it (disagreement, chatter share, true limits)."""
    rng = np.random.default_rng([seed, 24])
    kinds = np.array([prior.par.kind(n) for n in prior.par.free])
    theta = prior.median * (1 + np.array([rng.uniform(-OFF[k], OFF[k]) for k in kinds]))
    lo, hi = args.rpm
    b_ref = float(np.percentile(truth_depth_mm(prior.par.structure(theta), cut, np.linspace(lo, hi, 60), args.steps),
                                25))
    rec = []  # (day, rpm, depth, true limit, operator 1's code)
    for d in range(args.days):
        drift = 1 + rng.uniform(-0.03, 0.03)
        th = theta * np.where(kinds == "fn", drift, 1.0)
        speeds = np.round(rng.uniform(lo, hi, args.speeds), -1)
        limit = truth_depth_mm(prior.par.structure(th), cut, speeds, args.steps)
        for s, bl in zip(speeds, limit):
            for b in np.round(b_ref * rng.uniform(0.8, 1.8, args.depths) * (0.7 + 0.15 * d), 3):
                r = b / bl - 1 + rng.normal(0, 0.04)
                rec.append((d, s, b, bl, 2 if r > 0.08 else 0 if r < -0.08 else 1))
    n = len(rec)
    differ = set(rng.choice(n, int(round(args.disagree * n)), replace=False).tolist())
    lines = ["rpm,depth_mm,label_op1,label_op2,date,feed,notes"]
    for i, (d, s, b, bl, c1) in enumerate(rec):
        c2 = c1
        if i in differ:  # one step, towards the other side where the first step would leave 0..2
            step = int(rng.choice([-1, 1]))
            c2 = c1 + step if 0 <= c1 + step <= 2 else c1 - step
        lines.append(f"{s:g},{b:g},{c1},{c2},2024-05-{d + 1:02d},0.1,{'' if c1 == c2 else 'operators disagree'}")
    facts = {"disagree": len(differ) / n, "truly_chatter": float(np.mean([b >= bl for _, _, b, bl, _ in rec])),
             "cuts": n, "b_ref_mm": b_ref,
             "truly_chatter_per_day": [float(np.mean([b >= bl for d2, _, b, bl, _ in rec if d2 == d]))
                                       for d in range(args.days)]}
    return "\n".join(lines) + "\n", facts


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--shops", type=int, default=3)
    ap.add_argument("--first", type=int, default=0)
    ap.add_argument("--days", type=int, default=4)
    ap.add_argument("--speeds", type=int, default=4, help="speeds a day")
    ap.add_argument("--depths", type=int, default=3, help="depths per speed")
    ap.add_argument("--disagree", type=float, default=0.12, help="share of cuts where operator 2 differs by one step")
    ap.add_argument("--rpm", type=lambda t: tuple(float(x) for x in t.split(":")), default=(5000.0, 12000.0))
    ap.add_argument("--steps", default="fn1", type=truth_spec,
                    help="the SDM truth: fn1 (20 and 40 steps extrapolated, the default), auto, or fixed steps per "
                         "tooth period (40: the runs before 2026-11-28)")
    ap.add_argument("--samples", type=int, default=500)
    ap.add_argument("--folds", type=int, default=5)
    ap.add_argument("--engine", default="zoa")
    ap.add_argument("--immersion", type=float, default=1.0,
                    help="radial immersion a/D (1: slotting; else down milling)")
    ap.add_argument("--sigma-depth-rel", type=float, default=None,
                    help="relative depth noise of the likelihood (at a/D 0.1 the limits are 25-100 mm: use 0.05)")
    ap.add_argument("--batch-effect", type=float, default=0.0,
                    help="σ of the test-day shift of ln fn in the updates ([prior] batch_effect; 0: off, the default)")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--keep-files", type=Path, default=None, help="folder to keep each shop's cuts CSV in")
    args = ap.parse_args()
    print(describe())
    cfg = load_config("example:ex1")
    cut = cfg.cutting
    if args.immersion < 1:
        cut = Cutting.from_immersion(cut.teeth, cut.kt, cut.kr, args.immersion, "down")
    # the shop's prior: its cutting conditions and depth noise
    prior = make_prior(cfg.structure, cut, PriorTable({}, sigma_depth_rel=args.sigma_depth_rel,
                                                      batch_effect=args.batch_effect or None))
    rows = []
    t_all = time.perf_counter()
    with threadpool_limits(1):
        for shop in range(args.first, args.first + args.shops):
            t0 = time.perf_counter()
            text, facts = shop_file(shop, args, cut, prior)
            if args.keep_files:
                args.keep_files.mkdir(parents=True, exist_ok=True)
                (args.keep_files / f"shop{shop}.csv").write_text(text)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # the note on the ignored feed/notes columns
                cuts = parse_points(text, f"shop{shop}.csv", CODES)
            res = cross_validate(cfg, cuts, n_folds=args.folds, seed=shop, samples=args.samples, engine=args.engine,
                                 prior=prior)
            print(f"shop {shop}: {facts['cuts']} cuts, operators disagree on {facts['disagree']:.0%}, truly chattering "
                  f"{facts['truly_chatter']:.0%} (per day "
                  f"{', '.join(f'{x:.0%}' for x in facts['truly_chatter_per_day'])}), labelled chatter (grade > 1/2) "
                  f"{np.mean(cuts.grade > 0.5):.0%}; {time.perf_counter() - t0:.0f} s")
            for s, d in res.summary.items():
                best = min(d[m]["brier"] for m in METHODS[1:])
                flag = ("OK" if d["millstab"]["brier"] <= best and d["millstab"]["brier"] <= d["majority"]["brier"]
                        else "LOSES")
                print(f"   {s:7s} Brier " + "  ".join(f"{m} {d[m]['brier']:.4f}" for m in METHODS)
                      + f"   AUC " + " ".join(f"{d[m]['auc']:.2f}" for m in METHODS) + f"   {flag}")
            for note in res.notes:
                print(f"   note: {note}")
            rows.append({"shop": shop, "facts": facts, "summary": res.summary})
    print(f"\n{len(rows)} shops ({time.perf_counter() - t_all:.0f} s), a/D {args.immersion}, {args.days} days x "
          f"{args.speeds} speeds x {args.depths} depths, truth SDM ({args.steps}), updates {args.engine} with "
          f"{args.samples} samples, test-day effect τ = {args.batch_effect:g}, "
          f"{args.folds} random folds:")
    for s in ("random", "speed", "batch"):
        have = [r for r in rows if s in r["summary"]]
        if not have:
            continue
        mean = {m: np.mean([r["summary"][s][m]["brier"] for r in have]) for m in METHODS}
        auc = {m: np.nanmean([r["summary"][s][m]["auc"] for r in have]) for m in METHODS}
        wins = sum(r["summary"][s]["millstab"]["brier"] <= min(r["summary"][s][m]["brier"] for m in METHODS[1:])
                   for r in have)
        print(f"  {s:7s} mean Brier " + "  ".join(f"{m} {mean[m]:.4f}" for m in METHODS) + "; mean AUC "
              + " ".join(f"{m} {auc[m]:.2f}" for m in METHODS)
              + f"; millstab <= best baseline in {wins}/{len(have)} shops")
    if args.json:
        args.json.write_text(json.dumps({"args": {k: str(v) for k, v in vars(args).items()}, "shops": rows}, indent=1))


if __name__ == "__main__":
    main()
