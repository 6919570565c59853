"""Virtual test campaigns: recommend → cut → update, against a truth the tool does not know.

Each campaign (seeded; the loop is :func:`millstab.update.campaign.run_campaign`):
* prior = the hammer test: the seed paper's Ex.1 structure (2 teeth) with the default spreads, at
  radial immersion ``--immersion`` (1 = slotting, as Ex.1; else down milling);
* truth, two designs:
  - ``--calibrate``: θ_true drawn FROM THE PRIOR and labels from the likelihood's own noise model
    (chatter when b > b_lim,true(Ω) + σ_b ε, ε ~ N(0, 1), σ_b the prior's 0.05 mm), truth = zoa: the
    model that generated the data is the one fitted, so the 90 % intervals must cover ≈ 90 %;
  - default (the issue's shop): θ_true = the hammer test off by a random factor per parameter, uniform
    in fn ±3 %, k ±20 %, ζ ±30 % (in-process dynamics differ from a tap test); labels: chatter when
    b > b_lim,true · exp(ε), ε ~ N(0, ``--noise``), b_lim,true from ``--truth-engine`` (sdm to
    ``--truth-steps``, :mod:`_truth`, or zoa); or, with ``--labels simulate``, from the
    time-domain simulation (its stable | marginal | chatter labels and chatter frequencies, ``--flip``
    of the stable/chatter labels swapped by the "operator"), the truth engine then only judging
    whether a recommendation is stable;
* the loop: the first cut is the recommendation of the prior alone; then ``--cuts`` − 1 times: update
  (``--samples``, ``--engine``; each update starts from the previous posterior unless ``--fresh``), cut
  the tool's next test, label it. After each update: the recommendation at ``--risk`` in ``--rpm``
  with ``--max-depth``, whether it is truly stable (b < b_lim,true), and its productivity (b·Ω) over that
  of the best truly stable cut (b_lim,true capped at max depth, on ``--best-speeds`` 361 speeds); the Brier score of the
  P(stable) map against the truth (``--grid``, 61 × 40) beside the prior's; whether each parameter's 90 %
  interval covers the truth (in the x/y orientation closer to it).
* baselines: the recommendation from the hammer-test SLD alone (the deepest·fastest point of the
  prior-median SLD, 5 % below the limit): is it truly stable, its productivity; and evenly spaced test
  cuts (same number, at speeds evenly spaced, depth = prior-median limit) → one update → recommend.
* ``--engine-check zoa,sdm,spectral``: model error without sampling: how many of the campaign's
  stable/chatter labels the TRUE structure contradicts under each engine (one parameter set, so even
  a slow engine costs only a few envelopes).

* the decision rule (:func:`millstab.update.recommend`): P(chatter) ≤ risk held with ``--confidence``
  (default 0.9) against the Monte Carlo error over the effective sample size, at ±``--speed-tolerance``
  (default 0.25 %) of the speed; ``--confidence none --speed-tolerance 0`` is the plain rule (the risk
  quantile at the speed). After the campaigns, each final recommendation that chatters is printed with
  its diagnosis: P(chatter) epistemic (fraction of samples with b_lim ≤ b, what "truly stable" judges)
  and with the label noise, distinct samples and ESS, and the posterior's 5 % quantile beside the true
  limit at the speed × (1 ± 0.5, 1, 2 %) (a knife-edge shows as a quantile that falls steeply beside it).
* the 90 % interval of the LIMIT at the cut speeds against the truth's limit: the model-error measure
  that needs no "true parameter" (with another engine's labels, a parameter's truth is not the fitted
  model's).

Run: ``.venv/bin/python benchmarks/bench_update_campaign.py --calibrate --campaigns 50 [--samples 1000]``
(``--json FILE`` keeps every campaign's record; ``--first K`` starts at campaign K, to split a study
over processes; 50 calibration campaigns took 6 min on the 2-core machine beside another job; ``--jobs N``
runs them in N processes, one numba thread each, with the same figures; ``--save FILE.npz`` keeps every
round's posterior samples and cuts, for ``score_conflict.py`` to score a conflict rule offline). The
model-error study (issue 17; a/D 0.1, labels from the time-domain simulation, limits there are 25–100 mm,
hence the depth cap and the relative depth noise; docs/updating.md has the measured figures)::

    bench_update_campaign.py --immersion 0.1 --labels simulate --truth-engine sdm --max-depth 60 \
        --sigma-depth-rel 0.05 --cuts 10 --best-speeds 121 --grid 31x20 --engine-check zoa,spectral \
        --campaigns 50 --samples 1000 --engine zoa                      # 13 min (16 s a campaign)
    ... --samples 1000 --no-baselines --engine spectral --first K --campaigns 1   # ~130 s CPU a campaign (--profile)

(``--labels engine --truth-engine sdm --noise 0.03`` takes the labels from SDM's boundary with 3 % noise
instead: cheaper, without the simulation's own model of the cut.)
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
import os
import sys
import time
import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).parent))
from _campaign_profile import Profile, profiled, round_lines, summed, table  # noqa: E402
from _conflict_record import campaign_record, save  # noqa: E402
from _machine import describe, run_campaigns  # noqa: E402
from _truth import sdm_options, truth_spec  # noqa: E402

from millstab.io import load_config  # noqa: E402
from millstab.io.config import PriorTable  # noqa: E402
from millstab.points import PointSet  # noqa: E402
from millstab.model import Cutting  # noqa: E402
from millstab.stability import get_engine  # noqa: E402
from millstab.update import make_prior, recommend, update  # noqa: E402
from millstab.update.campaign import CampaignOptions, coverage, run_campaign  # noqa: E402
from millstab.update.decide import CONFIDENCE, SPEED_TOLERANCE, TEST_RISK  # noqa: E402

OFF = {"fn": 0.03, "k": 0.20, "zeta": 0.30}
#: feed per tooth of the simulated cuts [m]
FEED_M = 0.1e-3


#: relative speed offsets at which the final recommendation's depth is checked (spindle speed error)
OFFSETS = (-0.02, -0.01, -0.005, 0.0, 0.005, 0.01, 0.02)


def final_diagnosis(post, rpm: float, depth: float, truth) -> dict:
    """Why a recommendation chatters: P(chatter) epistemic (fraction of samples with b_lim ≤ b) and
    with the label noise (mean Φ((b − b_lim)/σ_b)); distinct samples and the last stage's ESS; the
    posterior's 5 % quantile and the true limit at the speed ± :data:`OFFSETS` (a knife-edge shows as
    a quantile that falls steeply beside the speed)."""
    from scipy.special import ndtr

    from millstab.update.decide import distinct_limits

    sp = rpm * (1 + np.array(OFFSETS))
    bl = distinct_limits(post.prior, post.u, sp, post.engine)
    sig = post.prior.sigma_depth_mm(np.array([depth]))[0]
    i0 = OFFSETS.index(0.0)
    ess = post.diagnostics.get("ess") or [float("nan")]
    return {"rpm": rpm, "depth": depth, "true_limit": [float(x) for x in truth(sp)],
            "q05": [float(x) for x in np.quantile(bl, 0.05, axis=0)],
            "p_epistemic": float(np.mean(bl[:, i0] <= depth)),
            "p_label": float(np.mean(ndtr((depth - bl[:, i0]) / sig))),
            "distinct": int(np.unique(post.u, axis=0).shape[0]), "ess_last": float(ess[-1]),
            "stages": int(post.diagnostics.get("stages", 0))}


def limit_coverage(post, rpm: np.ndarray, truth, level: float = 0.90) -> list[bool]:
    """Whether the posterior's central ``level`` interval of b_lim covers the truth's limit, per speed [rpm]
    (the model-error check that needs no parameter to be "true": it reads the boundary itself)."""
    from millstab.update.decide import distinct_limits

    bl = distinct_limits(post.prior, post.u, np.asarray(rpm, float), post.engine)
    lo_q, hi_q = np.quantile(bl, [(1 - level) / 2, (1 + level) / 2], axis=0)
    t = truth(np.asarray(rpm, float))
    return [bool(a <= x <= b) for a, x, b in zip(lo_q, t, hi_q)]


def parse() -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--campaigns", type=int, default=5)
    ap.add_argument("--first", type=int, default=0, help="index of the first campaign (to split a study)")
    ap.add_argument("--cuts", type=int, default=10)
    ap.add_argument("--samples", type=int, default=1000)
    ap.add_argument("--risk", type=float, default=0.05)
    ap.add_argument("--rpm", default="5000:12000")
    ap.add_argument("--max-depth", type=float, default=8.0)
    ap.add_argument("--immersion", type=float, default=1.0,
                    help="radial immersion a/D (1: slotting; else down milling)")
    ap.add_argument("--calibrate", action="store_true", help="truth drawn from the prior, labels from the likelihood")
    ap.add_argument("--noise", type=float, default=0.03, help="label noise: σ of ln(boundary)")
    ap.add_argument("--truth-engine", default="sdm")
    ap.add_argument("--truth-steps", default="fn1", type=truth_spec,
                    help="the SDM truth: fn1 (20 and 40 steps extrapolated, the default since 2026-11-28), auto "
                         "(SDM's accuracy control: at a/D 0.1 34 ms a speed, where fn1 misses one thin lobe by 10 %%; "
                         "in a slot 0.1-0.4 s a speed), or fixed steps per tooth period (40: the runs before, 3.7 %% "
                         "high in the median at a/D 0.1; _truth.py)")
    ap.add_argument("--engine", default="zoa", help="engine of the updates and decisions")
    ap.add_argument("--sigma-depth-rel", type=float, default=None,
                    help="the likelihood's depth noise relative to the depth (default: the absolute 0.05 mm)")
    ap.add_argument("--labels", choices=("engine", "simulate"), default="engine",
                    help="labels from the truth engine with boundary noise, or from the time-domain simulation")
    ap.add_argument("--flip", type=float, default=0.05, help="simulate: probability an operator swaps a label")
    ap.add_argument("--fresh", action="store_true", help="a fresh update after each cut (no sequential reuse)")
    ap.add_argument("--sampler", default="auto", help="the updates' sampler (update()'s: auto | delayed | plain | "
                    "surrogate; delayed with zoa: a zoa screen of zoa, the delayed-acceptance settings' calibration)")
    ap.add_argument("--no-baselines", action="store_true")
    ap.add_argument("--engine-check", default="",
                    help="comma-separated engines: how many of the campaign's stable/chatter labels the TRUE structure "
                         "contradicts under each (model error, one parameter set: cheap even for slow engines)")
    ap.add_argument("--confidence", default=str(CONFIDENCE),
                    help="one-sided confidence of P(chatter) <= risk against its Monte Carlo error ('none': plain "
                         "count)")
    ap.add_argument("--speed-tolerance", type=float, default=SPEED_TOLERANCE,
                    help="relative spindle-speed error the recommended depth must tolerate (0: none)")
    ap.add_argument("--coarse", type=int, default=None,
                    help="speeds of the recommendation's coarse grid (default 200; fewer for a slow --engine)")
    ap.add_argument("--label-error", type=float, default=None,
                    help="the likelihood's label-swap probability (default: the prior's); --calibrate swaps labels so")
    ap.add_argument("--test-risk", default=str(TEST_RISK),
                    help="cap on the next test's probability of chatter ('none': no cap, the most informative cut)")
    ap.add_argument("--no-guard", action="store_true", help="recommend without the data guard (the model alone)")
    ap.add_argument("--confirm", default="conflict",
                    help="recommend's confirm rule: conflict (default) | always | never")
    ap.add_argument("--discriminate", default="never",
                    help="recommend's next test while a conflict is named: conflict (the conflict test) | never "
                         "(default)")
    ap.add_argument("--tails", default=None,
                    help="tails of the prior: student | normal | mixture | multivariate_t (default: the "
                         "prior's default, student)")
    ap.add_argument("--chatter-hz-alias", type=float, default=None,
                    help="the prior's chatter_hz_alias (the chance a chatter frequency is another member of its "
                         "family than the one near the mode; default: the prior's, 1)")
    ap.add_argument("--truth-tails", default="normal",
                    help="--calibrate: the family the truths are drawn from (the hammer test's spreads, Gaussian by "
                         "default: the shop's in-process drift; 'same': the prior's own, the self-consistent check)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--best-speeds", type=int, default=361, help="speeds on which the best truly stable cut is sought")
    ap.add_argument("--grid", default="61x40", help="speeds x depths of the Brier-score grid")
    ap.add_argument("--json", type=Path, default=None, help="write every campaign's record here")
    ap.add_argument("--jobs", type=int, default=1, help="campaigns run in parallel processes (the figures do not "
                                                         "depend on it: each campaign is seeded by its index)")
    ap.add_argument("--conflict-test", action="store_true",
                    help="the policy of bench_robust.py --conflict-test: when the update does not name the conflict "
                         "and a 3.5σ-shifted kind fits the cuts as well, the next test is "
                         "millstab.update.discriminate's")
    ap.add_argument("--profile", action="store_true",
                    help="where each campaign's time goes: per round and in all, the update, the recommendation's "
                         "search, data guard and next test, and the bench's truth, labels, Brier map and coverage "
                         "(wall, CPU, CPU/wall, limits asked of the decisions' engine calls)")
    ap.add_argument("--save", type=Path, default=None, help="an .npz of every round's posterior samples and cuts, "
                                                             "to score conflict rules offline (score_conflict.py)")
    args = ap.parse_args()
    if args.calibrate:
        args.truth_engine, args.labels = "zoa", "engine"
    return args


def setup(args: argparse.Namespace) -> SimpleNamespace:
    """The study's fixed parts: config, cutting, prior, truth prior, decision keywords, truth engine, grid."""
    lo, hi = (float(x) for x in args.rpm.split(":"))
    cfg = load_config("example:ex1")
    cut = cfg.cutting
    if args.immersion < 1:
        cut = Cutting.from_immersion(cut.teeth, cut.kt, cut.kr, args.immersion, "down")
    table = PriorTable({}, sigma_depth_rel=args.sigma_depth_rel, label_error=args.label_error, tails=args.tails,
                       chatter_hz_alias=args.chatter_hz_alias)
    prior = make_prior(cfg.structure, cut, table)
    truth_prior = prior if args.truth_tails == "same" else dataclasses.replace(prior, tails=args.truth_tails)
    decision = {"confidence": None if args.confidence.lower() == "none" else float(args.confidence),
                "speed_tolerance": args.speed_tolerance,
                "test_risk": None if args.test_risk.lower() == "none" else float(args.test_risk),
                "guard": not args.no_guard, "confirm": args.confirm,
                "discriminate": args.discriminate}
    if args.coarse:
        decision["coarse_points"] = args.coarse
    truth_engine = get_engine(args.truth_engine)
    opts = sdm_options(args.truth_steps) if args.truth_engine == "sdm" else {}
    gs, gd = (int(x) for x in args.grid.split("x"))
    g_rpm, g_depth = np.linspace(lo, hi, gs), np.linspace(0.05, args.max_depth, gd)
    return SimpleNamespace(lo=lo, hi=hi, cfg=cfg, cut=cut, prior=prior, truth_prior=truth_prior, decision=decision,
                           truth_engine=truth_engine, opts=opts, g_rpm=g_rpm, g_depth=g_depth)


def with_conflict_test(rec_fn):
    """``recommend`` whose next test is the conflict test (:func:`millstab.update.discriminate.conflict_test`) when
    the posterior does not name the conflict and the rival fits the cuts at least as well (the experimental
    policy of ``--conflict-test``; the product's ``recommend`` does not do this yet)."""
    from millstab.update.discriminate import conflict_test

    def rec_ct(post, risk, rpm_range, **kw):
        rec = rec_fn(post, risk, rpm_range, **kw)
        if any(str(w).startswith("the cuts contradict the hammer test") for w in post.warnings):
            return rec
        ct = conflict_test(post, rpm_range, kw.get("max_depth_mm") or float("inf"), seed=int(kw.get("seed", 0)))
        return dataclasses.replace(rec, next_test=ct) if ct and ct["rival_log_likelihood_ratio"] >= 0 else rec
    return rec_ct


def baselines(args: argparse.Namespace, st: SimpleNamespace, truth, labeler, rng, best: float, c: int, say) -> dict:
    """The two baselines of a campaign: the hammer-test SLD alone (5 % below its limit) and evenly spaced test
    cuts followed by one update; {"hammer": [stable, productivity / best], "even": [...]}."""
    lo, hi, cfg, cut, prior, decision = st.lo, st.hi, st.cfg, st.cut, st.prior, st.decision
    row = {}
    # baseline 1: the hammer-test SLD alone, 5 % below its limit
    fine = np.linspace(lo, hi, args.best_speeds)
    b_ham = get_engine(args.engine).envelope(cfg.structure, cut, fine).depth_mm
    j = int(np.argmax(np.minimum(0.95 * b_ham, args.max_depth) * fine))
    d_ham = min(0.95 * b_ham[j], args.max_depth)
    row["hammer"] = [bool(d_ham < truth([fine[j]])[0]), float(fine[j] * d_ham / best)]
    # baseline 2: evenly spaced test cuts at the prior-median limit depth, one update
    ev_rpm = np.linspace(lo, hi, args.cuts)
    ev_depth = np.minimum(get_engine(args.engine).envelope(cfg.structure, cut, ev_rpm).depth_mm, args.max_depth)
    ev_lab, ev_hz = labeler(ev_rpm, ev_depth, rng)
    ev = PointSet(ev_rpm, ev_depth, ev_lab, chatter_hz=ev_hz)
    row["even"] = [False, 0.0]
    if ev.stable.any() or ev.chatter.any():
        try:
            ev_post = update(cfg, ev, prior=prior, engine=args.engine, samples=args.samples, seed=c)
        except RuntimeError:  # stalled tempering: no posterior, no recommendation (counted as a miss)
            say("   even cuts: UPDATE FAILED (tempering stalled)")
        else:
            r = recommend(ev_post, args.risk, (lo, hi), max_depth_mm=args.max_depth, seed=c, **decision)
            row["even"] = [bool(r.depth_mm < truth([r.rpm])[0]), float(r.rpm * r.depth_mm / best)]
    return row


def run_one(args: argparse.Namespace, c: int) -> tuple[dict, list[str], dict]:
    """Campaign c: (its row, its printed lines, its record for --save)."""
    if args.conflict_test:  # the campaign loop's recommend, in this (worker) process
        import millstab.update.campaign as campaign_module

        campaign_module.recommend = with_conflict_test(recommend)
    st = setup(args)
    lo, hi, cfg, cut, prior, truth_prior = st.lo, st.hi, st.cfg, st.cut, st.prior, st.truth_prior
    decision, truth_engine, opts, g_rpm, g_depth = st.decision, st.truth_engine, st.opts, st.g_rpm, st.g_depth
    lines: list[str] = []
    say = lines.append
    with threadpool_limits(1), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        c0 = time.process_time()
        t0 = time.perf_counter()
        rng = np.random.default_rng([args.seed, c])
        if args.calibrate:
            theta = np.exp(truth_prior.sample(1, rng)[0])
        else:
            f = np.array([rng.uniform(-OFF[prior.par.kind(n)], OFF[prior.par.kind(n)]) for n in prior.par.free])
            theta = prior.median * (1 + f)
        s_true = prior.par.structure(theta)

        def truth(rpm, s_true=s_true):
            return truth_engine.envelope(s_true, cut, np.asarray(rpm, float), **opts).depth_mm

        def labeler(rpm, depth, r, s_true=s_true, truth=truth):
            if args.labels == "simulate":
                from millstab.simulate import label_cuts

                lab = label_cuts(s_true, cut, rpm, depth * 1e-3, FEED_M, label_noise=args.flip,
                                 seed=int(r.integers(2**31)))
                # an operator who swapped chatter to stable wrote no frequency down
                return ([str(x) for x in lab.label],
                        [float("nan") if str(x) == "stable" else float(h) for x, h in zip(lab.label, lab.chatter_hz)])
            b = truth(rpm)
            if args.calibrate:  # the likelihood's own model: probit noise, then a swap with probability ε
                edge = b + prior.sigma_depth_mm(depth) * r.standard_normal(b.shape)
                chat = (depth > edge) ^ (r.random(b.shape) < prior.label_error)
            else:
                chat = depth > b * np.exp(args.noise * r.standard_normal(b.shape))
            return list(np.where(chat, "chatter", "stable")), [float("nan")] * b.size

        prof = Profile() if args.profile else None
        if prof is not None:
            truth, labeler = prof.wrap("truth: limits", truth), prof.wrap("labels", labeler)
        grid = (g_rpm, g_depth, g_depth[None, :] < truth(g_rpm)[:, None])
        settings = CampaignOptions(cuts=args.cuts, samples=args.samples, risk=args.risk, rpm_range=(lo, hi),
                               max_depth_mm=args.max_depth, seed=int(rng.integers(2**31)), engine=args.engine,
                               reuse=not args.fresh, best_speeds=args.best_speeds, decision=decision,
                               keep=tuple(range(1, args.cuts + 1)) if args.save else (), sampler=args.sampler)
        with profiled(prof) if prof is not None else contextlib.nullcontext():
            camp = run_campaign(cfg, prior, truth, labeler, settings, truth_grid=grid,
                                progress=None if prof is None else prof.next_round)
        part = prof.part if prof is not None else lambda name: contextlib.nullcontext()
        with part("coverage and diagnosis"):
            cover = coverage(camp.posteriors[args.cuts], theta)
            cover50 = coverage(camp.posteriors[args.cuts], theta, 0.5)
        row = {"campaign": c, "theta": theta.tolist(), "cuts": [camp.cut_rpm, camp.cut_depth_mm, camp.labels],
               "rec_stable": camp.rec_stable, "rec_productivity": camp.rec_productivity,
               "rec": [camp.rec_rpm, camp.rec_depth_mm], "brier": camp.brier, "cover": cover.tolist(),
               "cover50": cover50.tolist(), "stages": camp.stages, "best": camp.best, "failed": camp.failed,
               "tests": {k: camp.test_chatter_share(k) for k in ("chatter", "marginal", "true")},
               "conflict": any(str(w).startswith("the cuts contradict the hammer test")
                               for w in camp.posteriors[args.cuts].warnings)}
        if not args.no_baselines:
            with part("baselines"):
                row.update(baselines(args, st, truth, labeler, rng, camp.best, c, say))
        with part("coverage and diagnosis"):
            row["final"] = final_diagnosis(camp.posteriors[args.cuts], camp.rec_rpm[-1], camp.rec_depth_mm[-1], truth)
            row["limit_cover"] = limit_coverage(camp.posteriors[args.cuts], np.unique(camp.cut_rpm), truth)
            if args.engine_check:
                lab = np.array(camp.labels)
                sel = lab != "marginal"
                r_c, d_c = np.array(camp.cut_rpm)[sel], np.array(camp.cut_depth_mm)[sel]
                row["contradicted"] = {}
                for e in args.engine_check.split(","):
                    try:
                        # sorted unique speeds: the spectral engine fails on some unsorted lists with repeats
                        r_u, inv = np.unique(r_c, return_inverse=True)
                        b_e = get_engine(e).envelope(s_true, cut, r_u).depth_mm[inv]
                    except Exception as exc:  # noqa: BLE001 - an engine's failure is a finding, not the end
                        say(f"   {e} failed ({type(exc).__name__}: {exc}) on theta={theta.tolist()} rpm={r_c.tolist()}")
                        row["contradicted"][e] = None
                        continue
                    row["contradicted"][e] = int(((d_c > b_e) != (lab[sel] == "chatter")).sum())
                row["labelled"] = int(sel.sum())
                say(f"   labels the true structure contradicts: {row['contradicted']} of {row['labelled']}")
        tr = " ".join(f"{'S' if ok else 'C'}{p:.2f}" for ok, p in zip(camp.rec_stable, camp.rec_productivity))
        fail = f" UPDATE FAILED after cuts {camp.failed};" if camp.failed else ""
        say(f"campaign {c}: {time.perf_counter() - t0:.0f} s, stages {camp.stages};{fail} after 0..{args.cuts} cuts "
              f"(S stable/C chatter, productivity/best): {tr}")
        extra = "" if args.no_baselines else (
            f"hammer SLD: {'stable' if row['hammer'][0] else 'CHATTER'} {row['hammer'][1]:.2f}; even cuts: "
            f"{'stable' if row['even'][0] else 'CHATTER'} {row['even'][1]:.2f}; ")
        say(f"   {extra}Brier prior {camp.brier[0]:.4f} -> {camp.brier[-1]:.4f}; 90 % intervals cover truth: "
              f"{cover.astype(int).tolist()}")
        row["cpu_s"] = time.process_time() - c0
        if prof is not None:
            prof.stop()
            row["profile"] = prof.record()
            lines.extend(table(row["profile"]["totals"], prof.wall, prof.cpu, f"   campaign {c}, where the time went "
                               "(exclusive of the parts inside each; per round: wall/CPU s):"))
            lines.extend(round_lines(row["profile"]))
        rec = campaign_record(c, [camp.posteriors[k] for k in range(1, args.cuts + 1) if k in camp.posteriors],
                              {"theta": theta.tolist()}) if args.save else {}
    return row, lines, rec


def main() -> None:
    args = parse()
    print(describe())
    st = setup(args)
    prior, decision = st.prior, st.decision
    t_all, c_all = time.perf_counter(), time.process_time()
    rows, records = run_campaigns(run_one, args, range(args.first, args.first + args.campaigns))
    if args.save:
        save(args.save, prior, records)
    n = len(rows)
    for r in rows:
        if not r["rec_stable"][-1]:  # the failures, one by one
            f = r["final"]
            print(f"  campaign {r['campaign']} CHATTERS: {f['rpm']:.0f} rpm, {f['depth']:.3f} mm; true limit "
                  f"{f['true_limit'][OFFSETS.index(0.0)]:.3f} mm; P(chatter) epistemic {f['p_epistemic']:.3f}, "
                  f"with label noise {f['p_label']:.3f}; distinct samples {f['distinct']}, last ESS "
                  f"{f['ess_last']:.0f}; at speed x(1{'/'.join(f'{o:+g}' for o in OFFSETS)}): 5 % quantile "
                  f"{' '.join(f'{x:.2f}' for x in f['q05'])}, truth {' '.join(f'{x:.2f}' for x in f['true_limit'])}")
    if args.json:
        args.json.write_text(json.dumps({"args": {k: str(v) for k, v in vars(args).items()}, "names": list(prior.names),
                                         "campaigns": rows}))
    fin_ok = [r["rec_stable"][-1] for r in rows]
    fin_p = [r["rec_productivity"][-1] for r in rows]
    if args.calibrate:
        design = "CALIBRATION: truth drawn from the prior, labels from the likelihood's noise model (σ_b 0.05 mm), zoa"
    else:
        src = (f"the time-domain simulation ({args.flip:.0%} swapped; chatter frequencies used)"
               if args.labels == "simulate"
               else f"{args.truth_engine} with {args.noise:.0%} boundary noise")
        design = f"truth = hammer test off by fn±3 %, k±20 %, ζ±30 %; labels from {src}; truth {args.truth_engine}"
    print(f"\n{n} campaigns ({time.perf_counter() - t_all:.0f} s wall, "
          f"{time.process_time() - c_all + sum(r['cpu_s'] for r in rows) * (args.jobs > 1):.0f} s CPU, load "
          f"{os.getloadavg()[0]:.1f}), a/D {args.immersion}, risk {args.risk}, {design}; "
          f"{args.cuts} cuts, {args.samples} samples, engine {args.engine}, "
          f"{'fresh updates' if args.fresh else 'sequential reuse'}, sampler {args.sampler}, likelihood depth noise "
          f"{prior.sigma_depth_m * 1e3 if prior.sigma_depth_m else 0:g} mm abs / {prior.sigma_depth_rel or 0:g} rel, "
          f"label error {prior.label_error:g}; decision: confidence {decision['confidence']}, speed tolerance "
          f"±{decision['speed_tolerance']:g}:")
    print(f"  final posterior: distinct samples median {np.median([r['final']['distinct'] for r in rows]):.0f}, "
          f"last-stage ESS median {np.median([r['final']['ess_last'] for r in rows]):.0f}; P(chatter) at the final "
          f"recommendation, epistemic: median {np.median([r['final']['p_epistemic'] for r in rows]):.3f}, with label "
          f"noise {np.median([r['final']['p_label'] for r in rows]):.3f}")
    print(f"  final recommendation truly stable: {sum(fin_ok)}/{n}; productivity/best: median {np.median(fin_p):.2f}, "
          f"min {min(fin_p):.2f}; >= 0.85 and stable: {sum(ok and p >= 0.85 for ok, p in zip(fin_ok, fin_p))}/{n}")
    print(f"  every recommendation along the way truly stable: {sum(sum(r['rec_stable']) for r in rows)}/"
          f"{sum(len(r['rec_stable']) for r in rows)}")
    if not args.no_baselines:
        print(f"  hammer-test SLD alone: stable {sum(r['hammer'][0] for r in rows)}/{n}, productivity median "
              f"{np.median([r['hammer'][1] for r in rows]):.2f}")
        print(f"  evenly spaced cuts: stable {sum(r['even'][0] for r in rows)}/{n}, productivity median "
              f"{np.median([r['even'][1] for r in rows]):.2f}; >= 0.85 and stable: "
              f"{sum(r['even'][0] and r['even'][1] >= 0.85 for r in rows)}/{n}")
    print(f"  Brier score better than the prior's: {sum(r['brier'][-1] < r['brier'][0] for r in rows)}/{n} "
          f"(median {np.median([r['brier'][0] for r in rows]):.4f} -> {np.median([r['brier'][-1] for r in rows]):.4f})")
    cov = np.array([r["cover"] for r in rows]).mean(0)
    print(f"  90 % interval coverage per parameter ({', '.join(prior.names)}): {np.round(cov, 2).tolist()} "
          f"(all: {cov.mean():.2f}); 50 % intervals: {np.array([r['cover50'] for r in rows]).mean():.2f} over all")
    if args.engine_check:
        print("  labels contradicted by the TRUE structure under each engine: " + ", ".join(
            f"{e} {sum(r['contradicted'][e] for r in rows if r['contradicted'][e] is not None)}/"
            f"{sum(r['labelled'] for r in rows if r['contradicted'][e] is not None)}"
            for e in args.engine_check.split(",")))
    lc = [x for r in rows for x in r["limit_cover"]]
    print(f"  90 % interval of the limit covers the truth's limit at the cut speeds: {sum(lc)}/{len(lc)} = "
          f"{np.mean(lc):.2f} (per campaign median {np.median([np.mean(r['limit_cover']) for r in rows]):.2f})")
    print(f"  campaigns with a failed (stalled) update: {sum(bool(r['failed']) for r in rows)}/{n}")
    print(f"  tests (cuts 2..{args.cuts}) labelled chatter: {np.mean([r['tests']['chatter'] for r in rows]):.0%}, "
          f"marginal: {np.mean([r['tests']['marginal'] for r in rows]):.0%}, truly chattering: "
          f"{np.mean([r['tests']['true'] for r in rows]):.0%} (test risk {decision['test_risk']}, data guard "
          f"{'on' if decision['guard'] else 'off'})")
    if args.profile:
        tot, wall, cpu = summed([r["profile"] for r in rows])
        print("\n".join(table(tot, wall, cpu, f"  where the time went, {n} campaigns together:")))
        walls, cpus = [r["profile"]["wall"] for r in rows], [r["profile"]["cpu"] for r in rows]
        print(f"  per campaign: wall median {np.median(walls):.1f} s (max {max(walls):.1f}), CPU median "
              f"{np.median(cpus):.1f} s")
    print(f"  final posterior names a prior-data conflict: {sum(r['conflict'] for r in rows)}/{n}")
    k_best = [next((k for k, (ok, p) in enumerate(zip(r["rec_stable"], r["rec_productivity"])) if ok and p >= 0.85),
                   None)
              for r in rows]
    reached = [k for k in k_best if k is not None]
    print(f"  cuts until a truly stable recommendation at >= 0.85 of the best: median "
          f"{np.median(reached) if reached else float('nan'):.0f} ({len(reached)}/{n} reached it at some point)")


if __name__ == "__main__":
    main()
