"""Many conditions, one machine (issue 27): train on cuts in two conditions, decide in conditions never cut.

Per virtual machine (seeded):

* the hammer test (the prior's medians) and a truth off it (fn ×1.03/0.97, k ×0.8/1.15, ζ ×1.25: in-process
  dynamics differ from a tap test); the true labels come from the SEMI-DISCRETIZATION boundary of the TRUE
  structure (``sdm`` at its accuracy control, ``--truth-steps``; :mod:`_truth`: 40 fixed steps, the truth before
  2026-11-28, put limits up to 11 % too high), never from the fitted model (zero-order, ``--engine``): the model
  error of zoa at low immersion is part of the test;
* training cuts: ``--cuts`` per training condition (slot and a/D 0.5 down), at random speeds in ``--rpm``,
  depths = the hammer test's own zero-order limit × exp(N(0, 0.5²)) (a shop tests around what it believes);
  labelled by the truth, ``--flip`` of them swapped (an operator's slip);
* held-out cuts: ``--held`` per target condition (a/D 0.25 up, a/D 0.1 down, and a/D 0.5 UP: the direction
  never cut), at random speeds, depths = the TRUE limit × exp(U(−0.6, 0.6)) (the hard band around it);
* scored: the Brier score of P(label chatter) (``millstab predict``'s column) against the true labels
  of the held-out cuts, for the joint posterior (one update over both training conditions), the hammer test
  alone (the prior's draws through the same label model), and one posterior per training condition (the
  same cuts split by condition: the slot posterior and the half-immersion posterior each decide alone);
  in the training conditions too (held-out cuts there), where one posterior per condition has only its
  own condition's cuts; the recommendation at ``--risk`` in each target condition (``recommend
  --radial-immersion ... --milling ...``): truly stable when its depth is below the true (sdm) limit at its
  speed ±0.25 %.

``--design alternate | recommend`` places the training cuts as a shop would run the campaign instead
(:func:`millstab.update.campaign.run_condition_campaign`): 2·``--cuts`` rounds of update → ``recommend`` in
one training condition (alternating) → its next test (with ``recommend``, free to move to the other training
condition where a test carries more information: ``next_test_across``) → labelled by the truth. The
single-condition posteriors then get as many cuts: a campaign of 2·``--cuts`` in each training condition alone
(``--single campaign``, the default) or the joint campaign's cuts split by condition (``--single split``: two
plain updates, cheaper). Each round's recommendation costs what a target's does (with spectral at 300 samples
66–139 s CPU for the prior's, the first round, 62 s for a later one), so a spectral campaign of 10 cuts is ~10–12
CPU-minutes: the command for many cores is in docs/updating.md "Many conditions". Without model error
(measured there): ``nice .venv/bin/python benchmarks/bench_conditions_campaign.py --design recommend
--truth-engine zoa --samples 300 --cuts 10 --held 30 --repeats 3`` (≈ 20 s CPU per campaign).

Machines: ``sym`` (two close modes, x and y alike), ``soft-x`` (x 4× softer than y: up and down milling
differ ×5 at a/D 0.5, the issue's ×4 machine), ``three`` (three teeth, x and y apart).

The cost of an update over several conditions against one: ``benchmarks/bench_conditions.py``.

Run (small): ``nice .venv/bin/python benchmarks/bench_conditions_campaign.py --samples 1000 --cuts 10 --held 30``

``--no-recommend`` scores the Brier only (the updates and the predictions at the held-out cuts): with an
accurate engine the recommendations are most of the cost. ``--diagnose`` prints, per condition on stderr, why
the joint posterior scores what it does: the fitted engine's error at the TRUE structure (model error) and
the joint posterior's and the hammer test's bias and spread of ln(b_lim/b_true) at the held-out cuts (one
more pass over two posteriors' predictions). ``--first-repeat K`` numbers the repeats from K, so several
processes can share the repeats of one run (the same campaigns as ``--repeats``). The accurate fit, Brier
only (measured: docs/updating.md "Many conditions"; ≈ 200–400 s CPU per campaign at 300 samples):
``nice .venv/bin/python benchmarks/bench_conditions_campaign.py --engine spectral --samples 300 --cuts 10
--held 30 --no-recommend --repeats 5 --jobs 15``.

Many cores: ``--jobs N`` runs the campaigns (machines × ``--repeats``) in a pool of N processes, each with one
numba and one BLAS thread; every campaign draws from its own generator (seed + 100·machine + 10 000·repeat,
the update's own seed ``--seed``), so the figures do not depend on N or on the order the campaigns finish.
``--engine sdm`` fits with the semi-discretization engine (delayed acceptance by default, ``--sampler``) instead of
the zero-order model that misses the 3-tooth machine at a/D 0.5; ``--engine-option KEY=VALUE`` fixes its
discretisation (kept in every posterior, so the predictions and recommendations use it too). Accurate and
cheapest: ``--engine-option fn_max_hz=1`` (20 and 40 steps per tooth period, extrapolated: 0.02 % median error,
30 ms per (set, speed); ``benchmarks/bench_sdm_steps.py``, docs/updating.md). The CPU of each phase is reported:
with sdm the three recommendations (≈ 1 000 limits per posterior sample each) dominate, not the updates: about
9 CPU-hours per campaign at 300 samples and ``--held 30`` (1.1 M limits × 30 ms; estimated, not run). For a
many-core machine with that time (each campaign runs in one worker):
``nice .venv/bin/python benchmarks/bench_conditions_campaign.py --engine sdm --engine-option fn_max_hz=1
--sampler surrogate --samples 300 --cuts 10 --held 30 --repeats 5 --jobs 15``.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, os.path.dirname(__file__))
from _machine import describe
from _truth import truth_depth_mm, truth_spec

from millstab.config import Config
from millstab.model import Cutting, Mode, Structure
from millstab.points import PointSet, condition_text
from millstab.stability import get_engine

TRAIN = ((1.0, "down"), (0.5, "down"))
TARGETS = ((0.25, "up"), (0.1, "down"), (0.5, "up"))
KT, KR = 6.0e8, 0.3


def machines() -> dict[str, tuple[Structure, Structure, int]]:
    """{name: (hammer test, truth, teeth)}."""
    def s(fx, kx, zx, fy, ky, zy):
        return Structure(x=(Mode(fx, kx, zx),), y=(Mode(fy, ky, zy),))

    off = np.array([1.03, 0.8, 1.25, 0.97, 1.15, 1.25])
    out = {}
    for name, base, teeth in (("sym", (900.0, 8e6, 0.03, 1000.0, 8e6, 0.03), 2),
                              ("soft-x", (800.0, 6e6, 0.03, 1200.0, 20e6, 0.03), 3),
                              ("three", (700.0, 5e6, 0.035, 1100.0, 30e6, 0.025), 3)):
        b = np.array(base)
        out[name] = (s(*b), s(*(b * off)), teeth)
    return out


def cond(teeth: int, ri: float, milling: str) -> Cutting:
    return Cutting.from_immersion(teeth, KT, KR, ri, milling)


TRUTH_ENGINE = "sdm"


def true_limit(struct: Structure, cutting: Cutting, rpm: np.ndarray, steps: str) -> np.ndarray:
    """The true limiting depth [mm] at each speed: SDM of the true structure to ``--truth-steps`` (``auto``: SDM's
    accuracy control, :mod:`_truth`); with ``--truth-engine zoa`` the fitted model's own engine (a control: no model
    error)."""
    if TRUTH_ENGINE == "sdm":
        return truth_depth_mm(struct, cutting, rpm, steps)
    return get_engine(TRUTH_ENGINE).envelope(struct, cutting, np.asarray(rpm, float)).depth_mm


def cuts_file(rpm, depth, label, conds: list[tuple[float, str]], teeth_idx=None) -> PointSet:
    ri = np.array([c[0] for c in conds], float)
    mill = np.array([c[1] for c in conds], dtype=object)
    return PointSet(np.asarray(rpm, float), np.asarray(depth, float), label,
                    conditions={"radial_immersion": ri, "milling": mill})


def run_machine(name, hammer, truth, teeth, args, rng):
    from millstab.update import Posterior, make_prior, update

    lo, hi = args.rpm
    base = cond(teeth, 1.0, "down")
    cfg = Config(base, hammer, name)
    if args.design != "around":
        return run_designed(name, hammer, truth, teeth, args, rng, cfg)
    zoa = get_engine("zoa")
    # training cuts: around the hammer test's belief
    tr_rpm, tr_depth, tr_cond = [], [], []
    for ri, m in TRAIN:
        r = rng.uniform(lo, hi, args.cuts)
        belief = zoa.envelope(hammer, cond(teeth, ri, m), r).depth_mm
        tr_rpm.append(r)
        tr_depth.append(belief * np.exp(rng.normal(0, 0.5, args.cuts)))
        tr_cond += [(ri, m)] * args.cuts
    tr_rpm, tr_depth = np.concatenate(tr_rpm), np.concatenate(tr_depth)
    lim = np.concatenate([true_limit(truth, cond(teeth, ri, m), tr_rpm[k * args.cuts:(k + 1) * args.cuts],
                                     args.truth_steps) for k, (ri, m) in enumerate(TRAIN)])
    chatter = tr_depth > lim
    flip = rng.random(chatter.size) < args.flip
    label = np.where(chatter ^ flip, "chatter", "stable")
    train = cuts_file(tr_rpm, tr_depth, label, tr_cond)
    held, held_tl = held_out(truth, teeth, args, rng)
    t0 = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = {"samples": args.samples, "seed": args.seed, "engine": args.engine, "sampler": args.sampler,
               "engine_options": args.engine_options}
        joint = update(cfg, train, **fit)
        per = {}
        for k, (ri, m) in enumerate(TRAIN):  # one posterior per condition: its own cuts only
            sl = slice(k * args.cuts, (k + 1) * args.cuts)
            one = cuts_file(tr_rpm[sl], tr_depth[sl], label[sl], [(ri, m)] * args.cuts)
            per[(ri, m)] = update(cfg, one, **fit)
        prior = make_prior(hammer, base)
        hammer_post = Posterior(prior, np.exp(prior.sample(args.samples, np.random.default_rng(args.seed))),
                                args.engine, cuts={"rpm": [lo, hi]}, engine_options=dict(args.engine_options))
    cpu_update = time.process_time() - t0
    say(f"{name}: 3 updates {cpu_update:.0f} s CPU; the joint posterior's label error ε "
        f"{joint.label_error.mean():.3f}, depth-noise factor s {joint.sigma_depth_factor.mean():.2f}")
    rows, cpu = score(name, teeth, truth, joint, per, hammer_post, held, held_tl, args)
    return rows, (cpu_update, *cpu)


def held_out(truth, teeth, args, rng):
    """Held-out cuts in the trained conditions and the targets, around the TRUE limit: ({condition: cuts},
    {condition: true limits})."""
    lo, hi = args.rpm
    held, held_tl = {}, {}
    for ri, m in TRAIN + TARGETS:
        r = rng.uniform(lo, hi, args.held)
        tl = held_tl[(ri, m)] = true_limit(truth, cond(teeth, ri, m), r, args.truth_steps)
        d = tl * np.exp(rng.uniform(-0.6, 0.6, args.held))
        held[(ri, m)] = cuts_file(r, d, np.where(d > tl, "chatter", "stable"), [(ri, m)] * args.held)
    return held, held_tl


def run_designed(name, hammer, truth, teeth, args, rng, cfg):
    """The training cuts placed as a shop would run the campaign (``--design alternate | recommend``,
    :func:`millstab.update.campaign.run_condition_campaign`): 2·``--cuts`` rounds of recommend → next test
    → label by the truth → update, the decision alternating between the two training conditions (with
    ``recommend``, its next test may move to the other one). The single-condition posteriors for the same
    number of cuts: with ``--single campaign`` (the default) a campaign of 2·``--cuts`` cuts in each training
    condition alone; with ``--single split`` the joint campaign's cuts split by condition."""
    from millstab.update import Posterior, make_prior, update
    from millstab.update.campaign import run_condition_campaign

    lo, hi = args.rpm
    conds = [cond(teeth, ri, m) for ri, m in TRAIN]
    prior = make_prior(hammer, conds[0])
    fit = {"samples": args.samples, "engine": args.engine, "sampler": args.sampler,
           "engine_options": args.engine_options}
    play = {**fit, "risk": args.risk, "rpm_range": (lo, hi), "max_depth_mm": args.max_depth,
            "fresh_last": args.final == "fresh"}

    def labeler(cs):
        def label(rpm, depth, i, r):
            chatter = depth > true_limit(truth, cs[i], rpm, args.truth_steps)
            chatter ^= r.random(chatter.size) < args.flip
            return list(np.where(chatter, "chatter", "stable")), [float("nan")] * chatter.size
        return label

    t0 = time.process_time()
    seeds = rng.integers(2**31, size=3)
    def progress(k, c):
        say(f"{name}: cut {k + 1} in {condition_text(conds[c]).split(',')[0]}, {time.process_time() - t0:.0f} s CPU")

    run = run_condition_campaign(cfg, prior, conds, labeler(conds), cuts=2 * args.cuts, seed=int(seeds[0]),
                                 choose=args.design, progress=progress, **play)
    joint = run.posterior
    cc = np.array(run.cut_condition)
    ch = run.cuts.label == "chatter"
    tl = np.array([true_limit(truth, conds[c], run.cuts.rpm[i:i + 1], args.truth_steps)[0] for i, c in enumerate(cc)])
    ratio = run.cuts.depth_mm / tl
    say(f"{name}: the joint campaign's {cc.size} cuts: " + "; ".join(
        f"{condition_text(conds[i]).split(',')[0]} {np.sum(cc == i)} cuts, {np.sum(ch[cc == i])} chatter, depth/true "
        f"limit {np.quantile(ratio[cc == i], [0, 0.5, 1]).round(2).tolist() if np.any(cc == i) else '-'} (min, median, "
        f"max), at {np.unique(np.round(run.cuts.rpm[cc == i], -1)).size} speeds"
        for i in range(len(conds))) + (f"; updates failed after cuts {run.failed}" if run.failed else ""))
    per = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for k, key in enumerate(TRAIN):
            if args.single == "campaign":
                one = run_condition_campaign(cfg, prior, [conds[k]], labeler([conds[k]]), cuts=2 * args.cuts,
                                             seed=int(seeds[1 + k]), choose="alternate", **play)
                per[key] = one.posterior
            else:
                sl = cc == k
                one = cuts_file(run.cuts.rpm[sl], run.cuts.depth_mm[sl], run.cuts.label[sl], [key] * int(sl.sum()))
                per[key] = update(cfg, one, seed=args.seed, **fit)
        hammer_post = Posterior(prior, np.exp(prior.sample(args.samples, np.random.default_rng(args.seed))),
                                args.engine, cuts={"rpm": [lo, hi]}, engine_options=dict(args.engine_options))
    extra = {}
    if args.fresh:  # the joint campaign's cuts in ONE fresh update: is the sequential posterior's spread the data's?
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            extra[f"fresh {args.fresh}"] = update(cfg, run.cuts, seed=args.seed, **{**fit, "samples": args.fresh})
    cpu_update = time.process_time() - t0
    say(f"{name}: the campaigns (joint and single-condition, their decisions included) {cpu_update:.0f} s CPU")
    held, held_tl = held_out(truth, teeth, args, rng)
    rows, cpu = score(name, teeth, truth, joint, per, hammer_post, held, held_tl, args, extra)
    return rows, (cpu_update, *cpu)


def score(name, teeth, truth, joint, per, hammer_post, held, held_tl, args, extra=None):
    """The Brier scores at the held-out cuts of every posterior, and the joint one's recommendation in each target
    condition judged against the truth: (rows, (CPU of the predictions, of the recommendations))."""
    from millstab import api

    lo, hi = args.rpm
    cpu_predict = cpu_rec = 0.0
    rows = []
    for key, pts in held.items():
        target = key in TARGETS

        def brier(post):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                return api.predict(post, pts).scores()["brier"]

        t0 = time.process_time()
        b_joint, b_hammer = brier(joint), brier(hammer_post)
        b_per = {k: brier(p) for k, p in per.items()}
        if extra:  # --fresh: a line on stderr, not a table column
            say(f"{name}: {condition_text(cond(teeth, *key)).split(',')[0]}: Brier joint {b_joint:.3f}, "
                + ", ".join(f"{k} {brier(p):.3f}" for k, p in extra.items()))
        cpu_predict += time.process_time() - t0
        own = b_per.get(key)
        if args.diagnose:
            t0 = time.process_time()
            diagnose(name, teeth, key, joint, hammer_post, truth, pts, held_tl[key], args, extra)
            cpu_predict += time.process_time() - t0
        rec_ok = None
        if target and args.recommend:
            ri, m = key
            t0 = time.process_time()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                rec = api.recommend(api.for_condition(joint, radial_immersion=ri, milling=m), args.risk, (lo, hi),
                                    max_depth_mm=args.max_depth, seed=args.seed)
            tl = true_limit(truth, cond(teeth, ri, m), rec.rpm * np.array([1 - 0.0025, 1.0, 1 + 0.0025]),
                            args.truth_steps)
            rec_ok = bool(rec.depth_mm < tl.min())
            cpu_rec += time.process_time() - t0
            # the zero-order recommendation's own check against interrupted cutting (update.model_check)
            warned = any("checked against interrupted cutting" in w for w in rec.warnings)
            rows.append((key, b_joint, b_hammer, b_per, own, rec_ok, rec.depth_mm, float(tl.min()), warned))
        else:
            rows.append((key, b_joint, b_hammer, b_per, own, None, None, None, None))
        say(f"{name}: {condition_text(cond(teeth, *key)).split(',')[0]} scored; CPU so far: predictions "
            f"{cpu_predict:.0f} s, recommendations {cpu_rec:.0f} s")
    return rows, (cpu_predict, cpu_rec)


def diagnose(name, teeth, key, joint, hammer_post, truth, pts, tl, args, extra=None) -> None:
    """Why the joint posterior scores what it does in condition ``key`` (a line on stderr): the fitted
    engine's model error (its limit at the TRUE structure against the truth's, and the share of the held-out
    labels that error alone flips), and the posterior's (and the hammer test's) limit at the held-out speeds
    against the truth's, as a bias (the median over the cuts of the samples' median ln(b_lim/b_true); and of
    its absolute value: lobes off in speed are off by turns up and down) and a
    spread (the median over the cuts of the samples' sd of ln b_lim): model error, a prior that the cuts did
    not move, or too few cuts to pin it."""
    from millstab import api
    from millstab.update.predict import cut_limits

    ri, m = key
    c = cond(teeth, ri, m)
    model = get_engine(args.engine).envelope(truth, c, pts.rpm, **args.engine_options).depth_mm
    err = np.log(model / tl)
    flipped = np.mean((pts.depth_mm > model) != (pts.depth_mm > tl))
    txt = [(f"model at the truth: median |ln b/b_true| {np.median(np.abs(err)):.3f} (median "
            f"{np.median(err):+.3f}), flips {flipped:.0%} of the held-out labels")]
    for who, post in (("joint", joint), ("hammer", hammer_post), *(extra or {}).items()):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            lb = np.log(cut_limits(api.for_condition(post, radial_immersion=ri, milling=m), pts.rpm) / tl[None, :])
        bias = np.median(lb, axis=0)  # per cut: a lobe off in speed is off by turns up and down
        txt.append(f"{who}: bias {np.median(bias):+.3f} (per cut |bias| {np.median(np.abs(bias)):.3f}), "
                   f"spread {np.median(lb.std(axis=0)):.3f}")
    say(f"{name}: {condition_text(c).split(',')[0]}: " + "; ".join(txt))


def say(text: str) -> None:
    """A progress line on stderr (an sdm-fitted campaign runs for hours on 2 cores: where it is, what it cost)."""
    print(f"[{time.strftime('%H:%M:%S')}] {text}", file=sys.stderr, flush=True)


def campaign(task: tuple[int, str, int, argparse.Namespace]):
    """One campaign (machine ``name``, number ``i`` in :func:`machines`, repeat ``rep``) with its own generator:
    the same numbers in a worker process as in the main one."""
    i, name, rep, args = task
    global TRUTH_ENGINE
    TRUTH_ENGINE = args.truth_engine
    hammer, truth, teeth = machines()[name]
    with threadpool_limits(1):
        rows, cpu = run_machine(name, hammer, truth, teeth, args,
                                np.random.default_rng(args.seed + 100 * i + 10_000 * rep))
    return name, rep, teeth, rows, cpu


def run_all(args) -> list:
    """Every (machine, repeat) campaign, in that order; in a pool of ``args.jobs`` processes (spawned, each
    with one numba thread: N processes on N cores instead of N × threads) when ``--jobs`` > 1."""
    order = list(machines())  # a machine's seed is its place in the full list: --machines three is the same campaign
    reps = range(args.first_repeat, args.first_repeat + args.repeats)
    tasks = [(order.index(name), name, rep, args) for name in args.machines.split(",") for rep in reps]
    if args.jobs <= 1:
        return [campaign(t) for t in tasks]
    os.environ["NUMBA_NUM_THREADS"] = "1"  # read by numba when a spawned worker imports it
    with ProcessPoolExecutor(args.jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
        return list(pool.map(campaign, tasks))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--samples", type=int, default=1000)
    ap.add_argument("--cuts", type=int, default=10, help="training cuts per training condition")
    ap.add_argument("--held", type=int, default=30, help="held-out cuts per condition")
    ap.add_argument("--flip", type=float, default=0.0, help="share of training labels swapped")
    ap.add_argument("--risk", type=float, default=0.05)
    ap.add_argument("--max-depth", type=float, default=30.0)
    ap.add_argument("--rpm", type=float, nargs=2, default=(4000.0, 12000.0))
    ap.add_argument("--truth-steps", default="auto", type=truth_spec,
                    help="the SDM truth's discretisation: auto (SDM's accuracy control, the default since 2026-11-28), "
                         "fnF, or fixed steps per tooth period (40: the runs before; off by up to 11 %%, _truth.py)")
    ap.add_argument("--engine", default="zoa")
    ap.add_argument("--engine-option", action="append", default=[], metavar="KEY=VALUE",
                    help="the fitted engine's discretisation, e.g. fn_max_hz=1 for sdm (as millstab update's); kept in "
                         "the posteriors, so every prediction and recommendation uses it; the hammer test's too")
    ap.add_argument("--sampler", default="auto",
                    help="update's sampler: auto (delayed acceptance for sdm/spectral), delayed, plain or surrogate")
    ap.add_argument("--truth-engine", default="sdm", help="sdm (default) or zoa (a control without model error)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--machines", default="sym,soft-x,three")
    ap.add_argument("--repeats", type=int, default=1, help="campaigns per machine (each its own seeded cuts)")
    ap.add_argument("--first-repeat", type=int, default=0,
                    help="number the repeats from here (another process's share of the same campaigns)")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (the figures do not depend on it)")
    ap.add_argument("--diagnose", action="store_true",
                    help="per condition, on stderr: the fitted engine's error at the true structure, the joint "
                         "posterior's and the hammer test's bias and spread of ln(b_lim / b_true) at the held-out cuts")
    ap.add_argument("--fresh", type=int, default=0, metavar="N",
                    help="with a campaign design: also the joint campaign's cuts in one fresh update of N samples "
                         "(not tempered in one cut a round), its Brier and (--diagnose) bias and spread on stderr")
    ap.add_argument("--design", choices=("around", "alternate", "recommend"), default="around",
                    help="the training cuts: around (depths drawn around the hammer test's belief), alternate "
                         "(a campaign: recommend's next test, the decision alternating between the two training "
                         "conditions) or recommend (the same, the next test free to move to the other condition)")
    ap.add_argument("--single", choices=("campaign", "split"), default="campaign",
                    help="with a campaign design, the single-condition posteriors: a campaign of as many cuts in "
                         "each training condition alone, or the joint campaign's cuts split by condition")
    ap.add_argument("--final", choices=("fresh", "sequential"), default="sequential",
                    help="with a campaign design, the joint campaign's final posterior: the last sequential update "
                         "(each round tempering one cut into the previous posterior; the default) or one fresh update "
                         "over all its cuts (what `millstab update CONFIG CUTS` gives; measured within the seed "
                         "scatter of 300-sample posteriors, docs/updating.md)")
    ap.add_argument("--no-recommend", dest="recommend", action="store_false",
                    help="score the Brier only: no recommendation in the target conditions (with an accurate engine "
                         "the recommendations cost ~1 000 limits per posterior sample each, the rest a few hundred)")
    args = ap.parse_args()
    from millstab.cli.options import engine_option_pairs
    from millstab.errors import InputError
    from millstab.forward import engine_options

    try:
        args.engine_options = dict(engine_options(args.engine, engine_option_pairs(args.engine_option)))
    except InputError as exc:
        ap.error(str(exc))  # one line, exit 2
    global TRUTH_ENGINE
    TRUTH_ENGINE = args.truth_engine
    print(describe())
    print(f"load average: {os.getloadavg()[0]:.1f}")
    with threadpool_limits(1):
        print(f"train: {', '.join(condition_text(cond(2, *c)).split(',')[0] for c in TRAIN)} ({args.cuts} cuts each, "
              f"{'around the hammer test' if args.design == 'around' else args.design + ' campaign'}); "
              f"targets: {', '.join(condition_text(cond(2, *c)).split(',')[0] for c in TARGETS)}; {args.held} held-out "
              f"cuts per condition; labels: {args.truth_engine} truth ({args.truth_steps}), {args.flip:.0%} "
              f"flipped; model {args.engine} {args.engine_options or '(its own discretisation)'}, "
              f"{args.sampler} sampler, {args.samples} samples")
        allrows = []
        t0 = time.perf_counter()
        results = run_all(args)
        for name, rep, teeth, rows, cpu in results:
            print(f"\n{name}{f' #{rep}' if args.repeats > 1 or rep else ''} ({teeth} teeth; CPU: "
                  f"{'3 updates' if args.design == 'around' else 'the campaigns'} {cpu[0]:.1f} s, "
                  f"4 posteriors' predictions {cpu[1]:.1f} s, 3 recommendations {cpu[2]:.1f} s)")
            print("  condition              joint  hammer  slot-only  half-only  own-only  recommendation")
            for key, bj, bh, bp, own, ok, dep, tl, warned in rows:
                txt = condition_text(cond(teeth, *key)).split(",")[0]
                rec = "" if ok is None else (f"{dep:.2f} mm vs true {tl:.2f}: {'stable' if ok else 'CHATTERS'}"
                                             + ("; warned by the check" if warned else ""))
                print(f"  {txt:<22} {bj:6.3f} {bh:7.3f} {bp[TRAIN[0]]:10.3f} {bp[TRAIN[1]]:10.3f} "
                      f"{'' if own is None else f'{own:8.3f}':>9}  {rec}")
            allrows += rows
        tgt = [r for r in allrows if r[0] in TARGETS]
        bj = np.mean([r[1] for r in tgt])
        bh = np.mean([r[2] for r in tgt])
        bsep = np.mean([min(r[3].values()) for r in tgt])
        recs = [r[5] for r in tgt if r[5] is not None]
        trained = [r for r in allrows if r[0] not in TARGETS]
        print()
        for name in args.machines.split(","):  # per machine, over its repeats: where a miss sits
            mt = [r for (n, _, _, rows, _) in results if n == name for r in rows if r[0] in TARGETS]
            mj, mh = np.mean([r[1] for r in mt]), np.mean([r[2] for r in mt])
            print(f"{name}: unseen ({len(mt)}) Brier joint {mj:.3f}, hammer test {mh:.3f} (joint/hammer "
                  f"{mj / mh:.2f}), best single-condition {np.mean([min(r[3].values()) for r in mt]):.3f}")
        stable = (f"recommendations truly stable {sum(recs)}/{len(recs)} (target ≥ 95 %)" if recs
                  else "recommendations not made (--no-recommend)")
        if recs:  # the check against interrupted cutting: chattering ones it warned, stable ones it warned falsely
            w_bad = sum(1 for r in tgt if r[5] is False and r[8])
            w_ok = sum(1 for r in tgt if r[5] is True and r[8])
            stable += (f"; the model check warned {w_bad} of the {len(recs) - sum(recs)} chattering and {w_ok} of the "
                       f"{sum(recs)} stable")
        print(f"unseen conditions ({len(tgt)}): mean Brier joint {bj:.3f} (target ≤ 0.08), hammer test {bh:.3f} "
              f"(joint/hammer {bj / bh:.2f}, target ≤ 0.5), best single-condition posterior {bsep:.3f}; {stable}")
        print(f"{len(results)} campaigns in {time.perf_counter() - t0:.0f} s wall ({args.jobs} job(s)), "
              f"CPU {sum(r[4][0] for r in results):.0f} s in the updates, {sum(r[4][1] for r in results):.0f} s in the "
              f"predictions, {sum(r[4][2] for r in results):.0f} s in the recommendations")
        print(f"trained conditions ({len(trained)}): mean Brier joint {np.mean([r[1] for r in trained]):.3f} vs one "
              f"posterior per condition (its own cuts) {np.mean([r[4] for r in trained]):.3f}")


if __name__ == "__main__":
    main()
