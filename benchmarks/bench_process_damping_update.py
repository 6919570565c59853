"""Process damping learned from low-speed cuts (issue 27: "one coefficient and a prior").

Case: a two-mode tool tip (x 922 Hz, y 1 150 Hz; the tests' ``TWO``), 3 teeth, a/D 0.5 down milling, a 16 mm tool;
the hammer test is right, the process-damping coefficient is not: the tool's C is ``--c-true`` (3·10⁴ N/m), the
config's (a handbook value, the prior median) ``--c-config`` (10⁴ N/m). ``--cuts`` cuts at random speeds in
``--rpm`` (low speed, where the term lifts the limit), depths uniform in ±``--spread`` around the true limit (SDM at its
default accuracy with the true C), and ``--held`` held-out cuts the same way (another seed); every label comes from
the time-domain simulation (:func:`millstab.simulate.label_cuts`, the true structure and C): a model independent
of the fitted one, whose marginal cuts count as chatter.

Two updates of the same cuts with the sdm engine, its steps per tooth period chosen for modes up to ``--fn-max-hz``
(``engine_options``, Richardson extrapolation kept: 300 Hz is ~1 % from the converged limit here at 0.1 s a limit;
the default, for the 1 150 Hz mode, costs ~2 s a limit at 1 500 rpm, the tooth period spanning ~15 vibration
periods; a fixed ``--steps`` count drops the extrapolation: 200 steps 2.4 % off at 1 500 rpm, 80 steps far more, and a
model that far off teaches a wrong C), ``--samples`` samples, seed ``--seed``: C held at the config's value, and C free
with a log-normal prior of spread ``--c-spread`` around it. The modal parameters named by ``--free`` are free with
their default spreads, the others held at the hammer test. Printed: each update's wall and CPU time, the posterior
of C (median, 90 % interval), and the held-out Brier score of P(stable) (:func:`millstab.update.predict.predict_cuts`)
beside the prior's and the hammer test's own boundary (0/1 from the SDM limit at the config's C).

    PYTHONPATH=src:benchmarks .venv/bin/python benchmarks/bench_process_damping_update.py
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time

import numpy as np
from _machine import describe
from threadpoolctl import threadpool_limits

from millstab.config import Config, PriorTable
from millstab.model import Cutting, Mode, Structure
from millstab.points import PointSet
from millstab.simulate import label_cuts
from millstab.stability import sdm
from millstab.update import make_prior, update
from millstab.update.posterior import Posterior
from millstab.update.predict import predict_cuts

FN, ZETA, MASS = 922.0, 0.011, 0.03993
K = MASS * (2 * math.pi * FN) ** 2
TWO = Structure(x=(Mode(FN, K, ZETA),), y=(Mode(1150.0, 1.3 * K, 0.015),))
KT, KR, D = 6e8, 0.3, 0.016
ALL = ("fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y")


def cuts_of(cut_true: Cutting, n: int, lo: float, hi: float, spread: float, seed: int):
    """(rpm (n,), depth [mm] (n,), simulated labels (n,), the true SDM limits [mm] (n,))."""
    rng = np.random.default_rng(seed)
    rpm = np.sort(rng.uniform(lo, hi, n))
    b_true = sdm.envelope(TWO, cut_true, rpm).depth_mm
    depth = b_true * rng.uniform(1 - spread, 1 + spread, n)
    lab = label_cuts(TWO, cut_true, rpm, depth * 1e-3, 1e-4, revs=60)
    labels = np.where(np.asarray(lab.true_label) == "stable", "stable", "chatter")
    return rpm, depth, labels, b_true


def timed(fn):
    w, c = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - w, time.process_time() - c


def brier(p_stable: np.ndarray, labels: np.ndarray) -> float:
    return float(np.mean((p_stable - (labels == "stable")) ** 2))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--c-true", type=float, default=3e4, help="the tool's process-damping coefficient [N/m]")
    ap.add_argument("--c-config", type=float, default=1e4, help="the config's C, the prior median [N/m]")
    ap.add_argument("--c-spread", type=float, default=1.0, help="σ of ln C in the prior")
    ap.add_argument("--cuts", type=int, default=12)
    ap.add_argument("--held", type=int, default=16)
    ap.add_argument("--rpm", default="1500:3000")
    ap.add_argument("--spread", type=float, default=0.2)
    ap.add_argument("--samples", type=int, default=100)
    ap.add_argument("--fn-max-hz", type=float, default=300.0, help="sdm's steps for modes up to this [Hz]")
    ap.add_argument("--steps", type=int, default=None, help="a fixed step count instead (no extrapolation)")
    ap.add_argument("--free", default="zeta_x", help="the free modal parameters, comma-separated, or 'all'")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    print(describe())
    lo, hi = (float(x) for x in args.rpm.split(":"))
    cut_true = Cutting.from_immersion(3, KT, KR, 0.5, "down", process_damping=args.c_true, diameter=D)
    cut_cfg = dataclasses.replace(cut_true, process_damping=args.c_config)
    free = ALL if args.free == "all" else tuple(n.strip() for n in args.free.split(","))
    held_names = tuple(n for n in ALL if n not in free)
    with threadpool_limits(1):
        rpm, depth, labels, b_true = cuts_of(cut_true, args.cuts, lo, hi, args.spread, args.seed)
        h_rpm, h_depth, h_labels, h_true = cuts_of(cut_true, args.held, lo, hi, args.spread, args.seed + 1000)
        b_cfg = sdm.envelope(TWO, cut_cfg, h_rpm).depth_mm
        opts = {"steps": args.steps} if args.steps else {"fn_max_hz": args.fn_max_hz}
        print(f"case: C true {args.c_true:g} N/m, config {args.c_config:g} N/m (prior spread {args.c_spread:g}); "
              f"{args.cuts} cuts at {lo:g}-{hi:g} rpm ({int((labels == 'chatter').sum())} chatter, labels from the "
              f"time-domain simulation), {args.held} held out ({int((h_labels == 'chatter').sum())} chatter); the "
              f"true limits {np.round(b_true, 2).tolist()} mm; with the config's C the limits are "
              f"{np.mean(b_cfg / h_true):.2f}x the true ones (held-out mean); free {list(free)}, "
              f"sdm {opts}")
        cuts = PointSet(rpm, depth, labels)
        hammer, true_c = brier((h_depth < b_cfg) * 1.0, h_labels), brier((h_depth < h_true) * 1.0, h_labels)
        majority = brier(np.full(args.held, np.mean(labels == "stable")), h_labels)
        print(f"held-out Brier: the hammer test's boundary with the config's C {hammer:.3f}, with the true C (SDM) "
              f"{true_c:.3f}, majority rate {majority:.3f}")
        for name, spreads in (("C held", {}), ("C free", {"process_damping": args.c_spread})):
            table = PriorTable(spreads, fixed=held_names)
            prior = make_prior(TWO, cut_cfg, table)
            cfg = Config(cut_cfg, TWO, "process-damping case", prior=table)
            post, wall, cpu = timed(lambda p=prior, c=cfg: update(c, cuts, engine="sdm", samples=args.samples,
                                                                 seed=args.seed, prior=p, engine_options=opts))
            p_prior = Posterior(prior, np.exp(prior.sample(args.samples, np.random.default_rng(args.seed))), "sdm",
                                engine_options=opts)
            (ps, _), pw, _ = timed(lambda q=post: predict_cuts(q, h_rpm, h_depth))
            ps0, _ = predict_cuts(p_prior, h_rpm, h_depth)
            line = (f"{name}: update {wall:.0f} s wall, {cpu:.0f} s CPU ({post.samples.shape[0]} samples); held-out "
                    f"Brier {brier(ps, h_labels):.3f} (prior {brier(ps0, h_labels):.3f}; prediction {pw:.0f} s)")
            if prior.pd_free:
                c = post.samples[:, list(post.names).index("process_damping")]
                q = np.quantile(c, [0.05, 0.5, 0.95])
                line += f"; C median {q[1]:.3g} N/m, 90 % {q[0]:.3g}-{q[2]:.3g} (truth {args.c_true:g})"
            print(line, flush=True)


if __name__ == "__main__":
    main()
