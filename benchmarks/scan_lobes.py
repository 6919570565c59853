"""Is the likelihood of a campaign's cuts multimodal in fn (a lobe shift)? A brute-force scan.

Reads a ``bench_robust.py --save`` file and, for one campaign and round, evaluates the log-likelihood of
that round's cuts (zero-order engine, one batched call) and the log prior on a grid of a common shift t
of every ln fn (all natural frequencies × e^t), the other coordinates (stiffnesses, dampings, the learned
noise levels) at that round's posterior medians. Prints the local maxima of the log posterior, the mass
of the grid posterior around each (in t), where the posterior samples' ln fn lie, and the truth's t.

Run: ``.venv/bin/python benchmarks/scan_lobes.py s.npz --campaign 41 --round 9 [--lo -0.15 --hi 0.35]``
(seconds: one engine call of a few hundred sets).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _conflict_record import load  # noqa: E402

from millstab.points import PointSet  # noqa: E402
from millstab.update.likelihood import Evidence, Likelihood  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("npz", type=Path)
    ap.add_argument("--campaign", type=int, default=41)
    ap.add_argument("--round", type=int, default=-1)
    ap.add_argument("--lo", type=float, default=-0.15)
    ap.add_argument("--hi", type=float, default=0.35)
    ap.add_argument("--points", type=int, default=501)
    args = ap.parse_args()
    prior, camps = load(args.npz)
    rd = camps[args.campaign]["rounds"][args.round]
    cuts = rd["cuts"]
    ps = PointSet(cuts[:, 0].tolist(), cuts[:, 1].tolist(), ["chatter" if c else "stable" for c in cuts[:, 2]])
    lik = Likelihood(prior, Evidence.from_points(ps, base_cutting=prior.cutting), "zoa")
    med = np.median(rd["u"].astype(float), axis=0)
    if "noise" in rd:
        nz = np.median(rd["noise"].astype(float), axis=0)
        eps = nz[prior.noise_names.index("label_error")] if "label_error" in prior.noise_names else None
        fac = nz[prior.noise_names.index("sigma_depth")] if "sigma_depth" in prior.noise_names else None
        med = np.r_[med, prior.noise_coordinates(np.atleast_1d(eps), np.atleast_1d(fac)).ravel()]
    fn = [i for i, n in enumerate(prior.names[:prior.n_modal]) if prior.par.kind(n) == "fn"]
    t = np.linspace(args.lo, args.hi, args.points)
    v = np.repeat(med[None, :], t.size, axis=0)
    v[:, fn] = med[fn] + t[:, None]
    ll, lp = lik(v), prior.logpdf_full(v)
    post = ll + lp
    t0 = float(np.mean(np.log(prior.median[fn])))
    shift = t + float(np.mean(med[fn])) - t0  # the common shift of ln fn from the tap test's
    w = np.exp(post - post[np.isfinite(post)].max())
    w /= w.sum()
    peaks = [i for i in range(1, t.size - 1)
             if post[i] >= post[i - 1] and post[i] > post[i + 1] and np.isfinite(post[i])]
    print(f"campaign {args.campaign}, round {args.round}: {len(cuts)} cuts ({int(cuts[:, 2].sum())} chatter); the "
          f"posterior's fn medians {np.exp(med[fn]).round(1).tolist()} Hz (tap test "
          f"{prior.median[fn].round(1).tolist()})")
    meta = camps[args.campaign]["meta"]
    z_true = np.asarray(meta.get("z_off", [np.nan] * prior.size), float)
    if np.isfinite(z_true).all():
        print(f"  the truth's shift of ln fn: {float(np.mean(z_true[fn] * prior.spread[fn])):+.3f}")
    s = rd["u"][:, fn].astype(float).mean(axis=1) - t0
    print(f"  posterior samples' mean ln fn shift: median {np.median(s):+.3f}, 5-95 % {np.percentile(s, 5):+.3f} … "
          f"{np.percentile(s, 95):+.3f}")
    edges = [shift[0]] + [0.5 * (shift[a] + shift[b]) for a, b in zip(peaks[:-1], peaks[1:])] + [shift[-1] + 1e-9]
    print("  local maxima of the log posterior along the shift (log L, log prior, log post; grid mass of its basin):")
    for k, i in enumerate(peaks):
        mass = w[(shift >= edges[k]) & (shift < edges[k + 1])].sum()
        if mass > 1e-4 or ll[i] >= ll[peaks].max() - 5:
            print(f"   shift {shift[i]:+.3f}: {ll[i]:8.2f} {lp[i]:8.2f} {post[i]:8.2f}  mass {mass:.4f}")


if __name__ == "__main__":
    main()
