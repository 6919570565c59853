"""Virtual test campaigns: recommend → cut → label → update, against a truth the tool does not know.

One campaign (:func:`run_campaign`) starts from the prior (the hammer test): its first cut is the
recommendation of the prior alone; then, ``cuts`` − 1 times, the posterior is updated with every
labelled cut so far and the tool's next test is cut and labelled. After each update the
recommendation at ``risk`` is judged against the truth: is it truly stable (b < b_lim,true), and its
productivity b·Ω over that of the best truly stable cut (b_lim,true capped at the depth limit, on a
fine speed grid). Each update starts from the previous posterior (sequential reuse, see
:func:`millstab.update.update`'s ``start``), which tempers in only the new cut.

The truth and the labels come from callables, so the same loop serves calibration (truth drawn from
the prior, labels from the likelihood's own noise model), model-error studies (labels from SDM or
the time-domain simulation) and the report. Units: rpm and mm.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Callable

import dataclasses

import numpy as np

from millstab.points import PointSet
from millstab.update import update
from millstab.update.decide import SPEED_TOLERANCE, LimitMemo, p_stable_map, recommend
from millstab.update.posterior import Posterior, exchange_of, split_modes
from millstab.update.prior import Prior
from millstab.warnlog import quiet

#: labels of cuts: (rpm (K,), depth_mm (K,), rng) -> (labels, chatter frequencies [Hz] or NaN)
Labeler = Callable[[np.ndarray, np.ndarray, np.random.Generator], tuple[list[str], list[float]]]
#: the true limiting depth [mm] at speeds [rpm]
Truth = Callable[[np.ndarray], np.ndarray]
#: labels of cuts in one of a campaign's conditions: (rpm (K,), depth_mm (K,), condition index, rng) -> as Labeler
ConditionLabeler = Callable[[np.ndarray, np.ndarray, int, np.random.Generator], tuple[list[str], list[float]]]


@dataclass(frozen=True)
class Campaign:
    """The record of one campaign.

    Attributes:
        cut_rpm, cut_depth_mm, labels, chatter_hz: the cuts in the order they were made.
        rec_rpm, rec_depth_mm, rec_stable, rec_productivity: the recommendation after 0, 1, … cuts
            (index k = after k cuts; 0 = the prior's), whether it is truly stable, and its productivity
            relative to the best truly stable cut under the same constraints (speed range, depth cap, and the
            decision's spindle-speed tolerance: :func:`best_productivity`).
        best: productivity (mm·rpm) of that best cut; best_exact: of the exact best (no speed tolerance, it
            may sit on a pocket's cusp), for reporting both.
        brier: Brier score of the P(stable) map against the truth after 0, 1, … cuts (when asked).
        posteriors: the posterior after k cuts for the k in ``keep`` (index 0 = prior draws).
        stages: tempering stages of each update.
        failed: after which cuts the update failed (tempering stalled: the model cannot explain the labels).
        cut_true_chatter: whether each cut truly chattered (its depth at or above the true limit).

    Frozen (issue 26): the sequences are tuples and ``posteriors`` a read-only mapping; :func:`run_campaign`
    collects the record as it plays and builds the campaign once, at the end.
    """

    cut_rpm: tuple[float, ...] = ()
    cut_depth_mm: tuple[float, ...] = ()
    labels: tuple[str, ...] = ()
    chatter_hz: tuple[float, ...] = ()
    rec_rpm: tuple[float, ...] = ()
    rec_depth_mm: tuple[float, ...] = ()
    rec_stable: tuple[bool, ...] = ()
    rec_productivity: tuple[float, ...] = ()
    best: float = 0.0
    best_exact: float = 0.0
    brier: tuple[float, ...] = ()
    posteriors: MappingProxyType = field(default_factory=dict)
    stages: tuple[int, ...] = ()
    failed: tuple[int, ...] = ()
    cut_true_chatter: tuple[bool, ...] = ()

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if isinstance(v, list):  # a record built from lists (the loop's, a test's) is stored as tuples
                object.__setattr__(self, f.name, tuple(v))
        object.__setattr__(self, "posteriors", MappingProxyType(dict(self.posteriors)))

    def __reduce__(self):  # a read-only mapping does not pickle (a campaign returned by a process pool)
        kw = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        kw["posteriors"] = dict(self.posteriors)
        return _campaign, (kw,)

    def test_chatter_share(self, label: str = "chatter") -> float:
        """The share of the tool's tests (every cut after the first, which is the prior's recommendation) whose
        label is ``label`` (``"true"``: that truly chattered); NaN without tests."""
        tests = self.labels[1:] if label != "true" else self.cut_true_chatter[1:]
        if not tests:
            return float("nan")
        return float(np.mean([bool(x) if label == "true" else x == label for x in tests]))


def _campaign(kw: dict) -> Campaign:
    """A pickled :class:`Campaign` rebuilt."""
    return Campaign(**kw)


def best_productivity(truth: Truth, rpm_range: tuple[float, float], max_depth_mm: float, n: int = 361,
                      speed_tolerance: float = 0.0) -> float:
    """The best truly stable cut under the recommendation's constraints: max over speeds Ω (``n`` evenly spaced, refined
    around the best three) of min(b_lim,true, max depth)·Ω [mm·rpm], b_lim,true taken as its smallest at Ω and
    Ω·(1 ± speed_tolerance) (the speeds at which :func:`millstab.update.recommend` holds its risk; 0: the exact best,
    which may sit on a pocket's cusp that no cut tolerating a speed error can use)."""
    off = np.array([0.0, -speed_tolerance, speed_tolerance]) if speed_tolerance > 0 else np.zeros(1)

    def rate(speeds: np.ndarray) -> np.ndarray:
        lim = truth((speeds[None, :] * (1 + off[:, None])).ravel()).reshape(off.size, speeds.size).min(axis=0)
        return np.minimum(lim, max_depth_mm) * speeds

    fine = np.linspace(*rpm_range, n)
    r = rate(fine)
    # the best sits on a pocket's cusp (with a tolerance, on a narrower peak): refine around the three best
    # grid speeds, ±1 grid step on 41 speeds each
    step = fine[1] - fine[0]
    top = fine[np.argsort(r)[-3:]]
    near = np.clip((top[:, None] + np.linspace(-step, step, 41)[None, :]).ravel(), *rpm_range)
    return float(max(r.max(), rate(near).max()))


def brier_score(post: Posterior, truth_grid: tuple[np.ndarray, np.ndarray, np.ndarray],
                memo: LimitMemo | None = None) -> float:
    """Mean squared difference between P(stable) and the true 0/1 stability on a grid (rpm, depth, stable);
    ``memo``: limits remembered from earlier rounds (:class:`millstab.update.decide.LimitMemo`)."""
    rpm, depth, stable = truth_grid
    return float(((p_stable_map(post, rpm, depth, memo=memo) - stable) ** 2).mean())


@dataclass(frozen=True)
class CampaignOptions:
    """The settings of one virtual campaign (:func:`run_campaign`), checked when built: a setting out of
    range is an InputError naming it. ``run_campaign(..., options=CampaignOptions(cuts=5))`` and
    ``run_campaign(..., cuts=5)`` are the same call (the keywords replace fields of ``options``).

    Attributes:
        cuts: test cuts (≥ 1); samples: posterior samples per update (≥ 2); risk: tolerated P(chatter), in (0, 1).
        rpm_range, max_depth_mm: the constraints of the recommendation [rpm] (0 < low < high), [mm] (> 0).
        seed: seed of everything random in the campaign.
        engine: the engine of the updates and decisions.
        reuse: start each update from the previous posterior (else a fresh update each time).
        fresh_last: with ``reuse``, the last cut's update starts fresh from the prior over every cut (the campaign's
            final posterior is the one ``millstab update CONFIG CUTS`` gives). Measured (issue 27, 20-cut accurate
            campaigns of 300 samples, ``bench_conditions_campaign.py --final fresh``): held-out Brier in unseen
            conditions 0.079 against the sequential posterior's 0.085 on the same cuts, but two fresh updates of one
            machine's cuts with other seeds scored 0.070 and 0.103 (the sequential 0.097): within the seed scatter
            of 300-sample posteriors (docs/updating-measured.md, "The truth, converged").
        keep: after which numbers of cuts to keep the posterior (for maps).
        best_speeds: speeds of the grid on which the best truly stable cut is sought (≥ 2; a slow truth: fewer).
        decision: more keywords of :func:`recommend` (``confidence``, ``speed_tolerance``, ``test_risk``,
            ``guard``), or ``None``.
        sampler: the updates' sampler (:func:`update`'s).
        engine_options: the engine's discretisation (:func:`update`'s; kept in the posteriors, so the decisions use
            them too; :func:`run_condition_campaign` only).
    """

    cuts: int = 10
    samples: int = 1000
    risk: float = 0.05
    rpm_range: tuple[float, float] = (5000.0, 12000.0)
    max_depth_mm: float = 8.0
    seed: int = 0
    engine: str = "zoa"
    reuse: bool = True
    fresh_last: bool = False
    keep: tuple[int, ...] = ()
    best_speeds: int = 361
    decision: dict | None = None
    sampler: str = "auto"
    engine_options: dict | None = None

    def __post_init__(self) -> None:
        from millstab.bounds import seed as check_seed
        from millstab.errors import InputError

        for name, low in (("cuts", 1), ("samples", 2), ("best_speeds", 2)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
                raise InputError(name, v, f"a whole number ≥ {low}")
        if not 0 < self.risk < 1:
            raise InputError("risk", self.risk, "a probability of chatter in (0, 1)")
        lo, hi = self.rpm_range
        if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo < hi):
            raise InputError("rpm_range", self.rpm_range, "(low, high) speeds in rev/min with 0 < low < high")
        if not (np.isfinite(self.max_depth_mm) and self.max_depth_mm > 0):
            raise InputError("max_depth_mm", self.max_depth_mm, "a depth limit > 0 mm")
        check_seed(self.seed, "seed")
        object.__setattr__(self, "keep", tuple(int(k) for k in self.keep))

    def start(self, last, final: bool):
        """The posterior an update starts from (``update``'s ``start``): ``last`` with ``reuse``, except the campaign's
        ``final`` update under ``fresh_last``; ``None`` (from the prior) otherwise."""
        return last if self.reuse and not (self.fresh_last and final) else None


def run_campaign(config, prior: Prior, truth: Truth, labeler: Labeler, options: CampaignOptions | None = None, *,
                 truth_grid: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
                 progress: Callable[[int], None] | None = None, **settings) -> Campaign:
    """Play one virtual campaign of ``options.cuts`` test cuts (see the module docstring).

    Args:
        config: the config whose structure is the prior (passed to :func:`update`).
        prior: the prior (usually ``make_prior`` of the config).
        truth: the true limit [mm] at speeds [rpm] (judges the recommendations).
        labeler: labels of the cuts made (may differ from ``truth``: label noise, another model).
        options: the campaign's settings (:class:`CampaignOptions`); keywords named as its fields
            (``cuts=``, ``samples=``, …) replace them.
        truth_grid: (rpm (S,), depth (D,), stable (S, D) bool) to score maps on after each cut, or ``None``.
        progress: called with k after the recommendation that follows k cuts.
    Raises:
        InputError: a setting out of range (named); TypeError: a keyword that is no setting.
    """
    from millstab.identify.search import options_with

    o = options_with(options, CampaignOptions, settings, "run_campaign")
    cuts, samples, risk, rpm_range, max_depth_mm = o.cuts, o.samples, o.risk, o.rpm_range, o.max_depth_mm
    seed, engine, keep, best_speeds, decision = o.seed, o.engine, o.keep, o.best_speeds, o.decision
    rng = np.random.default_rng(seed)
    lo, hi = rpm_range
    tol = (decision or {}).get("speed_tolerance", SPEED_TOLERANCE)
    # the record, collected as the campaign plays (the Campaign is built once, at the end, frozen)
    out = {k: [] for k in ("cut_rpm", "cut_depth_mm", "labels", "chatter_hz", "rec_rpm", "rec_depth_mm", "rec_stable",
                           "rec_productivity", "brier", "stages", "failed", "cut_true_chatter")}
    out["posteriors"] = {}
    best = best_productivity(truth, rpm_range, max_depth_mm, best_speeds, tol)
    post = Posterior(prior, np.exp(prior.sample(samples, rng)), engine, cuts={"rpm": [lo, hi]})
    last: Posterior | None = None  # the last posterior of an update (the start of the next one)
    # the limits of the samples each update keeps (most of them) at the speeds every round reads (the coarse scan,
    # the range's ends, the map's grid) are remembered from round to round: the same numbers, computed once
    memo = LimitMemo()
    with quiet():  # one-sided early data and ranges beyond the cuts are expected here
        for k in range(cuts + 1):
            if k:
                ps = PointSet(out["cut_rpm"], out["cut_depth_mm"], out["labels"], chatter_hz=out["chatter_hz"])
                if ps.stable.any() or ps.chatter.any():
                    try:
                        post = update(config, ps, prior=prior, engine=engine, samples=samples,
                                      seed=int(rng.integers(2**31)), start=o.start(last, k == cuts),
                                      sampler=o.sampler)
                    except RuntimeError:  # the tempering stalled (labels the model cannot explain): say so, go on
                        out["failed"].append(k)  # with the last posterior (the next update tries these cuts again)
                    else:
                        last = post
                        out["stages"].append(int(post.diagnostics["stages"]))
            if k in keep:
                out["posteriors"][k] = post
            if truth_grid is not None:
                out["brier"].append(brier_score(post, truth_grid, memo))
            rec = recommend(post, risk, rpm_range, max_depth_mm=max_depth_mm, seed=int(rng.integers(2**31)),
                            memo=memo, **(decision or {}))
            out["rec_rpm"].append(rec.rpm)
            out["rec_depth_mm"].append(rec.depth_mm)
            out["rec_stable"].append(bool(rec.depth_mm < truth(np.array([rec.rpm]))[0]))
            out["rec_productivity"].append(rec.rpm * rec.depth_mm / best)
            if progress is not None:
                progress(k)
            if k == cuts:
                break
            # the first cut is the prior's recommendation itself; later ones the tool's next test
            nxt = (rec.rpm, rec.depth_mm) if k == 0 else (rec.next_test["rpm"], rec.next_test["depth_mm"])
            lab, hz = labeler(np.array([nxt[0]]), np.array([nxt[1]]), rng)
            out["cut_rpm"].append(float(nxt[0]))
            out["cut_depth_mm"].append(float(nxt[1]))
            out["cut_true_chatter"].append(bool(nxt[1] >= truth(np.array([nxt[0]]))[0]))
            out["labels"] += list(lab)
            out["chatter_hz"] += list(hz)
    out["posteriors"].setdefault(cuts, post)
    return Campaign(**out, best=best, best_exact=best_productivity(truth, rpm_range, max_depth_mm, best_speeds))


#: how :func:`run_condition_campaign` picks the condition of each test: ``alternate`` (the decision and its next
#: test cycle through the conditions) or ``recommend`` (the decision cycles, and :func:`recommend`'s next test
#: may move to another of the campaign's conditions where a test there carries more information)
CHOOSE = ("alternate", "recommend")


@dataclass(frozen=True)
class ConditionCampaign:
    """The record of one campaign over several cutting conditions (:func:`run_condition_campaign`).

    Attributes:
        conditions: the campaign's conditions (:class:`~millstab.model.Cutting`).
        cuts: the labelled cuts in the order made, with the condition columns ``teeth``, ``entry_deg`` and
            ``exit_deg`` (ready for :func:`update` and ``millstab update``).
        cut_condition: the index in ``conditions`` of each cut; decided_in: of the condition each round decided in.
        why: why each cut was chosen (the next test's ``why``; the first: the prior's recommendation).
        posteriors: the posterior after k cuts for the k in ``keep`` and the last (0 = prior draws).
        failed: after which cuts the update failed (tempering stalled); the campaign went on with the last one.
    """

    conditions: tuple = ()
    cuts: PointSet | None = None
    cut_condition: tuple[int, ...] = ()
    decided_in: tuple[int, ...] = ()
    why: tuple[str, ...] = ()
    posteriors: MappingProxyType = field(default_factory=dict)
    failed: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        for name in ("conditions", "cut_condition", "decided_in", "why", "failed"):
            object.__setattr__(self, name, tuple(getattr(self, name)))
        object.__setattr__(self, "posteriors", MappingProxyType(dict(self.posteriors)))

    def __reduce__(self):  # as Campaign's: the read-only mapping does not pickle
        kw = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        kw["posteriors"] = dict(self.posteriors)
        return _condition_campaign, (kw,)

    @property
    def posterior(self) -> Posterior:
        """The last posterior (after every cut)."""
        return self.posteriors[max(self.posteriors)]


def _condition_campaign(kw: dict) -> ConditionCampaign:
    """A pickled :class:`ConditionCampaign` rebuilt."""
    return ConditionCampaign(**kw)


def condition_cuts(rpm, depth_mm, labels, conditions, cut_condition, chatter_hz=None) -> PointSet:
    """Labelled cuts whose row i is in ``conditions[cut_condition[i]]``: the condition columns ``teeth``,
    ``entry_deg`` and ``exit_deg`` [deg] (exact for any engagement, an a/D and a direction or not)."""
    c = [conditions[i] for i in cut_condition]
    cols = {"teeth": np.array([x.teeth for x in c], float),
            "entry_deg": np.degrees([x.entry for x in c]), "exit_deg": np.degrees([x.exit for x in c])}
    hz = None if chatter_hz is None else np.asarray(chatter_hz, float)
    return PointSet(np.asarray(rpm, float), np.asarray(depth_mm, float), np.asarray(labels, dtype=str),
                    chatter_hz=hz, conditions=cols)


def run_condition_campaign(config, prior: Prior, conditions, labeler: ConditionLabeler,
                           options: CampaignOptions | None = None, *, choose: str = "alternate",
                           progress: Callable[[int, int], None] | None = None, **settings) -> ConditionCampaign:
    """A virtual campaign whose test cuts are in several conditions, placed as a shop would run it (issue 27).

    Round k (0 … ``cuts`` − 1) decides in ``conditions[k % len(conditions)]`` from the posterior of the cuts
    so far (:meth:`Posterior.for_condition`): :func:`recommend` at ``risk``; the cut is its recommendation in
    round 0 (the prior's belief, a safe first cut) and its next test after that (the most informative cut more
    productive than the recommendation, at most ``test_risk`` likely to chatter). With ``choose="recommend"``
    the next test may move to another of ``conditions`` where :func:`next_test_across` finds a test carrying
    more information (its candidates: the trained conditions and the slot; a slot outside ``conditions`` is
    not cut: the round then cuts its recommendation). The cut is labelled by ``labeler`` in its condition,
    then one update over every cut so far (from the last posterior with ``reuse``: only the new cut is
    tempered in; the last one fresh with ``fresh_last``). Why not depths drawn around the prior's belief: a low
    belief puts most cuts of a stiff condition above the limit, and chatter cuts bound it from one side only
    (measured, docs/updating.md "Many conditions").

    Args:
        config: the config whose structure is the prior; its cutting is the posterior's base condition.
        prior: the prior (usually ``make_prior`` of the config).
        conditions: the conditions of the test cuts (:class:`~millstab.model.Cutting`, the config's tool family).
        labeler: (rpm (K,), depth (K,), index in ``conditions``, rng) -> (labels, chatter frequencies [Hz]).
        options: :class:`CampaignOptions` (``cuts``, ``samples``, ``risk``, ``rpm_range``, ``max_depth_mm``,
            ``seed``, ``engine``, ``reuse``, ``fresh_last``, ``keep``, ``decision``, ``sampler``,
            ``engine_options``), replaced by keywords named as its fields.
        choose: :data:`CHOOSE`.
        progress: called with (k, index of the cut's condition) after the k-th cut (from 0) is labelled.
    Raises:
        InputError: a setting out of range, no condition or an unknown ``choose``.
    """
    from millstab.errors import InputError
    from millstab.identify.search import options_with
    from millstab.points import same_condition

    o = options_with(options, CampaignOptions, settings, "run_condition_campaign")
    conditions = tuple(conditions)
    if not conditions:
        raise InputError("conditions", conditions, "at least one cutting condition")
    if choose not in CHOOSE:
        raise InputError("choose", choose, " | ".join(CHOOSE))
    rng = np.random.default_rng(o.seed)
    opts = dict(o.engine_options or {})
    post = Posterior(prior, np.exp(prior.sample(o.samples, rng)), o.engine, cuts={"rpm": list(o.rpm_range)},
                     engine_options=opts)
    last: Posterior | None = None
    memos = [LimitMemo() for _ in conditions]  # a memo serves one cutting
    rec = {k: [] for k in ("rpm", "depth", "labels", "hz", "cond", "decided", "why", "failed")}
    kept = {0: post} if 0 in o.keep else {}
    with quiet():
        for k in range(o.cuts):
            d = k % len(conditions)
            r = recommend(post.for_condition(conditions[d]), o.risk, o.rpm_range, max_depth_mm=o.max_depth_mm,
                          seed=int(rng.integers(2**31)), memo=memos[d], across=choose == "recommend",
                          **(o.decision or {}))
            nt, c = r.next_test, d
            if k == 0:
                cut, why = (r.rpm, r.depth_mm), "the prior's recommendation (the first cut)"
            else:
                cut, why = (nt["rpm"], nt["depth_mm"]), nt["why"]
                where = _cutting_of(conditions[d], nt["condition"])
                if not same_condition(where, conditions[d]):  # next_test_across moved it to another condition
                    moved = [i for i, x in enumerate(conditions) if same_condition(x, where)]
                    if moved:
                        c = moved[0]
                    else:
                        cut, why = (r.rpm, r.depth_mm), "the recommendation (the next test was outside the campaign)"
            lab, hz = labeler(np.array([cut[0]]), np.array([cut[1]]), c, rng)
            for key, v in (("rpm", float(cut[0])), ("depth", float(cut[1])), ("cond", c), ("decided", d),
                           ("why", why)):
                rec[key].append(v)
            rec["labels"] += list(lab)
            rec["hz"] += list(hz)
            if progress is not None:
                progress(k, c)
            ps = condition_cuts(rec["rpm"], rec["depth"], rec["labels"], conditions, rec["cond"], rec["hz"])
            try:
                post = update(config, ps, prior=prior, engine=o.engine, samples=o.samples,
                              seed=int(rng.integers(2**31)), start=o.start(last, k == o.cuts - 1),
                              sampler=o.sampler, engine_options=opts or None)
            except RuntimeError:  # the tempering stalled: say so, go on with the last posterior
                rec["failed"].append(k + 1)
            else:
                last = post
            if k + 1 in o.keep:
                kept[k + 1] = post
    kept[o.cuts] = post
    cuts = condition_cuts(rec["rpm"], rec["depth"], rec["labels"], conditions, rec["cond"], rec["hz"])
    return ConditionCampaign(conditions, cuts, rec["cond"], rec["decided"], rec["why"], kept, rec["failed"])


def _cutting_of(like, c: dict):
    """The cutting of a condition record (:func:`millstab.points.describe_condition`: teeth, angles [deg]) on
    ``like``'s coefficients."""
    from dataclasses import replace

    return replace(like, teeth=int(c["teeth"]), entry=float(np.radians(c["entry_deg"])),
                   exit=float(np.radians(c["exit_deg"])))


def coverage(post: Posterior, theta: np.ndarray, level: float = 0.90) -> np.ndarray:
    """Whether each parameter's central ``level`` interval covers the truth θ (P,), bool (P,).

    With the zero-order engine a structure and its x↔y exchange give the same boundaries, so the
    parameters are identifiable only up to the exchange. Samples AND truth are therefore put in one
    canonical orientation by a rule that does not look at the truth (:func:`split_modes`: the
    orientation of higher prior density; for an x/y-symmetric prior, fn_x ≤ fn_y), and the intervals
    are read there. (Choosing per sample the orientation closer to the truth pulls samples towards it
    and inflates the coverage; with prior-wide samples of Example 1 by 1–3 points.)
    """
    samp = post.samples
    xm = exchange_of(post.prior, post.engine)
    truth = np.asarray(theta, float)
    if xm is not None:
        def canonical(t: np.ndarray) -> np.ndarray:
            swap = split_modes(post.prior, t, post.engine)
            return np.where(swap[:, None], t[:, xm[0]] * np.exp(xm[1]), t)

        samp = canonical(samp)
        truth = canonical(truth[None])[0]
    a = (1 - level) / 2
    q_lo, q_hi = np.quantile(samp, [a, 1 - a], axis=0)
    return (q_lo <= truth) & (truth <= q_hi)


__all__ = ["CHOOSE", "Campaign", "CampaignOptions", "ConditionCampaign", "ConditionLabeler", "Labeler", "Truth",
           "best_productivity", "brier_score", "condition_cuts", "coverage", "run_campaign", "run_condition_campaign"]
