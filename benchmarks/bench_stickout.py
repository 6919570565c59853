"""Cuts at 45 mm, decisions at 60 mm: one posterior over the holder against the hammer test alone.

The shop (each campaign seeded): the config's holder modes are the hammer test of the spindle–holder
(tests/test_update_stickout.py's CONFIG: a 12 mm carbide end mill, 2 holder modes); the TRUE holder differs
by a random factor per parameter (fn ±5 %, k ×/÷ 1.6, ζ ±30 %). Truth = the SDM engine (interrupted
cutting, 40 steps per tooth period) on the true holder's tip at each stickout (the tip modes of
millstab.tooltip.param at the true holder; within 1 % of the RCSA tip FRF, tests/test_tooltip_param.py);
the model updated is the zero-order engine. ``--cuts`` test cuts at 45 mm, speeds evenly spaced in
``--rpm``, depths the hammer test's limit × U(0.5, 1.5), labelled by the truth with 5 % log-normal depth
noise. Compared at 60 mm:

* holder posterior: update over the holder (``--samples``) at 45 mm, decide at 60 mm (:func:`at_stickout`);
* hammer test: the config's prior over the holder at 60 mm, no cuts (RCSA transfer, no learning);
* tip posterior at 45 mm: the old way, the 45 mm tip modes of the hammer test updated from the same cuts and
  used as they are at 60 mm (nothing transfers the learning to another stickout).

Figures: Brier of P(stable) on a 41 × 30 grid at 60 mm against the truth; the recommendation at 60 mm
(risk 10 %) truly stable?, and its depth over the truth's limit there. Prints CPU seconds.

    nice python benchmarks/bench_stickout.py --campaigns 3 --samples 600
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parents[1] / "tests"))

from _machine import describe  # noqa: E402

from millstab.io.config import parse_config  # noqa: E402
from millstab.points import PointSet  # noqa: E402
from millstab.stability import sdm, zoa  # noqa: E402
from millstab.update import recommend, update  # noqa: E402
from millstab.update.decide import p_stable_map  # noqa: E402
from millstab.update.prior import make_prior  # noqa: E402
from millstab.update.stickout import at_stickout, config_prior  # noqa: E402
from millstab.warnlog import quiet  # noqa: E402
from test_update_stickout import CONFIG  # noqa: E402


def brier(pm: np.ndarray, truth_stable: np.ndarray) -> float:
    return float(np.mean((pm - truth_stable) ** 2))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--campaigns", type=int, default=3)
    ap.add_argument("--samples", type=int, default=600)
    ap.add_argument("--cuts", type=int, default=12)
    ap.add_argument("--rpm", type=float, nargs=2, default=(8000.0, 16000.0))
    args = ap.parse_args()
    print(describe())
    cfg = parse_config(CONFIG)
    prior = config_prior(cfg)
    rpm_grid = np.linspace(*args.rpm, 41)
    rows = []
    t0 = time.process_time()
    for c in range(args.campaigns):
        rng = np.random.default_rng(100 + c)
        truth = prior.median.copy()
        for j, n in enumerate(prior.names):
            kind = prior.par.kind(n)
            truth[j] *= {"fn": rng.uniform(0.95, 1.05), "k": np.exp(rng.uniform(-0.47, 0.47)),
                         "zeta": rng.uniform(0.7, 1.3)}[kind]
        tip = {s: prior.par.at(s).tip_structure(truth) for s in (0.045, 0.06)}
        rpm = np.linspace(*args.rpm, args.cuts)
        nominal = zoa.envelope(prior.par.tip_structure(prior.median), prior.cutting, rpm).depth * 1e3
        depth = nominal * rng.uniform(0.5, 1.5, rpm.size)
        b45 = sdm.envelope(tip[0.045], prior.cutting, rpm, steps=40).depth * 1e3
        label = np.where(depth > b45 * np.exp(0.05 * rng.standard_normal(rpm.size)), "chatter", "stable")
        cuts = PointSet(rpm, depth, label, np.ones(rpm.size))
        b60 = sdm.envelope(tip[0.06], prior.cutting, rpm_grid, steps=40).depth * 1e3
        d_grid = np.linspace(0.05, 1.5 * float(np.max(b60)), 30)
        truth_map = (d_grid[:, None] < b60[None, :]).astype(float)
        with quiet():
            post = update(cfg, cuts, samples=args.samples, seed=c, stickout=np.full(rpm.size, 0.045))
            far = at_stickout(post, 0.06)
            prior60 = at_stickout(prior, 0.06)
            from millstab.update import Posterior

            hammer = Posterior(prior60, np.exp(prior60.sample(args.samples, rng)), "zoa")  # prior draws
            # the old way: the 45 mm tip's modes as the structure, updated, used unchanged at 60 mm
            old_cfg = type(cfg)(cfg.cutting, prior.par.tip_structure(prior.median), "tip 45 mm")
            old = update(old_cfg, cuts, samples=args.samples, seed=c, prior=make_prior(old_cfg.structure, cfg.cutting))
        res = {}
        for name, p in (("holder posterior", far), ("hammer test (prior)", hammer), ("tip posterior 45 mm", old)):
            pm = p_stable_map(p, rpm_grid, d_grid)
            pm = pm if pm.shape == truth_map.shape else pm.T
            rec = recommend(p, 0.1, tuple(args.rpm))
            true_lim = sdm.envelope(tip[0.06], prior.cutting, np.array([rec.rpm]), steps=40).depth[0] * 1e3
            res[name] = (brier(pm, truth_map), rec.depth_mm < true_lim, rec.depth_mm / true_lim)
        rows.append(res)
        print(f"campaign {c}: " + "; ".join(f"{k}: Brier {v[0]:.4f}, rec stable {v[1]}, depth/limit {v[2]:.2f}"
                                             for k, v in res.items()), flush=True)
    print(f"CPU {time.process_time() - t0:.0f} s for {args.campaigns} campaigns, {args.samples} samples, {args.cuts} "
          "cuts")
    for name in rows[0]:
        b = [r[name][0] for r in rows]
        ok = sum(r[name][1] for r in rows)
        q = [r[name][2] for r in rows]
        print(f"{name:22s} Brier mean {np.mean(b):.4f}  recommendation truly stable {ok}/{len(rows)}  "
              f"depth/true limit median {np.median(q):.2f}")


if __name__ == "__main__":
    main()
