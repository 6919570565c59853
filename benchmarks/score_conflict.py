"""Score the prior–data conflict rule offline on saved campaigns (no engine call, seconds).

``bench_robust.py --save FILE.npz`` (wrong hammer tests: every campaign should name the conflict) and
``bench_update_campaign.py --calibrate --save FILE.npz`` (the hammer test right: none should) keep every
round's posterior samples; this script runs :func:`millstab.update.conflict.check` (the rule as it is in
the tree, on the same samples the update gives it: the larger exchange mode's) on each and prints, per
file, the campaigns that name a conflict after the first update / in some round / in the last, and the
distribution of the check's figures (the log Bayes factor and the tail share), so a threshold can be
judged against the measured rates. The rounds of a campaign are scored in order, each knowing whether the
one before named the conflict (the hysteresis of :func:`check`, as a sequential update does); the
margin line counts the updates whose ratio reached each of 2, 3, 4, 5 (the false-alarm tail of a
calibration run). The learned label error's second check needs an engine call and is
not rescored here (it fires where the cuts contradict each other, not in these designs).

Run: ``.venv/bin/python benchmarks/score_conflict.py robust.npz calibration.npz [--show] [--bayes-factor 10]
[--keep-factor 2]`` (``--keep-factor 5``: no hysteresis, the rule before).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _conflict_record import load  # noqa: E402

from millstab.update import conflict  # noqa: E402
from millstab.update.conflict import check  # noqa: E402
from millstab.update.posterior import split_modes  # noqa: E402


def main_mode(prior, u: np.ndarray, engine: str = "zoa") -> np.ndarray:
    """The samples :func:`millstab.update.update` checks: the larger exchange mode's (all when unimodal)."""
    twin = split_modes(prior, np.exp(u), engine)
    return u if twin is None else u[twin if twin.mean() > 0.5 else ~twin]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", type=Path, nargs="+")
    ap.add_argument("--show", action="store_true", help="print every campaign's figures per round")
    ap.add_argument("--bayes-factor", type=float, default=None,
                    help=f"score with this threshold instead of the tree's ({conflict.BAYES_FACTOR:g})")
    ap.add_argument("--keep-factor", type=float, default=None,
                    help="keep a named conflict while the ratio is ≥ this (the tree's: "
                         f"{conflict.BAYES_FACTOR_KEEP:g}); equal to --bayes-factor: no hysteresis")
    args = ap.parse_args()
    if args.bayes_factor is not None:
        conflict.BAYES_FACTOR = args.bayes_factor
    if args.keep_factor is not None:
        conflict.BAYES_FACTOR_KEEP = args.keep_factor
    print(f"rule: the evidence ratio robust/tight above {conflict.BAYES_FACTOR:g}, kept while ≥ "
          f"{conflict.BAYES_FACTOR_KEEP:g} (millstab.update.conflict)")
    for path in args.files:
        prior, camps = load(path)
        named, lbf, tail = {}, [], []
        for c, d in camps.items():
            res, before = [], False
            for r in d["rounds"]:  # in order: each round knows whether the one before named it (hysteresis)
                res.append(check(prior, main_mode(prior, r["u"].astype(float)), named_before=before)[1])
                before = res[-1]["conflict"]
            named[c] = [x["conflict"] for x in res]
            lbf.append([x["log_bayes_factor"] or 0.0 for x in res])
            tail.append([x.get("tail_share", 0.0) for x in res])
            if args.show:
                print(f"  campaign {c}: " + " ".join(f"{b:.1f}/{t:.2f}{'!' if n else ''}"
                                                     for b, t, n in zip(lbf[-1], tail[-1], named[c])))
        n = len(named)
        some = [c for c, v in named.items() if any(v)]
        print(f"{path.name}: {n} campaigns, {sum(len(v) for v in named.values())} updates; conflict named after the "
              f"first update {sum(v[0] for v in named.values())} / {n}, in some round {len(some)} / {n}, in the last "
              f"{sum(v[-1] for v in named.values())} / {n}; in {sum(sum(v) for v in named.values())} updates"
              + (f"; campaigns naming it: {some}" if 0 < len(some) <= 10 else "")
              + (f"; never: {[c for c in named if c not in some]}" if 0 < n - len(some) <= 10 else ""))
        allb = np.concatenate([np.asarray(v, float) for v in lbf])
        print("   updates whose ratio reached " + ", ".join(
            f"{t:g}: {int((allb >= np.log(t)).sum())} ({int(sum(max(v) >= np.log(t) for v in lbf))} campaigns)"
            for t in (2, 3, 4, 5)) + f" of {allb.size} ({n} campaigns); largest ratio {np.exp(allb.max()):.3g}")
        for name, x in (("log Bayes factor", lbf), ("tail share", tail)):
            mx = np.array([max(v) for v in x])
            last = np.array([v[-1] for v in x])
            print(f"   {name}: per campaign, max over rounds: median {np.median(mx):.2f}, range {mx.min():.2f}-"
                  f"{mx.max():.2f}; last round: median {np.median(last):.2f}, range {last.min():.2f}-{last.max():.2f}")


if __name__ == "__main__":
    main()
