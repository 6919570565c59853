"""Decisions from posterior samples: the P(stable) map, the recommended cut, and the next test.

A cut at (Ω, b) is truly stable for a sample θ when b < b_lim(Ω; θ), so with equally weighted
samples P(stable | Ω, b) = fraction of samples with b_lim(Ω) > b: a property of the posterior of the
boundary, free of the label noise σ_b of the likelihood (which describes how labels are observed, not
whether the process chatters).

* :func:`p_stable_map`: ONE engine call for all samples × speeds, then a sort per speed and a single
  vectorised ``searchsorted`` for all (speed, depth) pairs.
* :func:`recommend`: the largest depth with P(chatter) ≤ risk at a speed is a low quantile of
  b_lim over the samples (capped by ``max_depth``), made safe against two errors of the estimate
  that the calibration campaigns exposed (every failure sat on P(chatter) = risk exactly, at the
  cusp of a stability pocket, the true limit 0.3–0.9 % below the depth):

  - Monte Carlo error: P(chatter) is a count over ~10³ correlated samples, and the speed search
    picks the speed where that count happens to be most optimistic (the winner's curse). The
    depth is therefore the order statistic a_m with the largest count m whose one-sided
    Clopper–Pearson upper bound (confidence :data:`CONFIDENCE`, over the posterior's effective sample
    size :func:`effective_samples`) is ≤ risk, instead of m = ⌊risk·N⌋;
  - a knife-edge: the best speed is the cusp of a pocket, where the limit falls linearly on both
    sides (6 % within ±0.5 % of the speed in those campaigns); a spindle that runs slightly off
    (or dynamics that drift with speed) chatters there. The depth at Ω is the least of the safe
    depths at Ω(1 − δ), Ω, Ω(1 + δ), δ = :data:`SPEED_TOLERANCE` (between cusps each lobe is convex
    and the envelope's minimum over a window lies at its ends, so three speeds suffice).

  The speed maximises the material removal rate
  depth × speed (× width × feed per tooth × teeth → cm³/min). The best of a coarse grid is refined by a
  bounded 1-D search on the continuous speed axis: rounds of ``REFINE_POINTS`` speeds in the bracket
  between the best point's neighbours, each round one engine call, the bracket shrinking each time. For an
  engine other than the cheapest (``search="auto"``, :func:`fast_search_for`) a seeded subsample of
  :data:`SEARCH_SAMPLES` rows does the scan and refines its :data:`SEARCH_POCKETS` best pockets, and every
  sample then chooses among them and sets the depth: the speed search is approximate, the risk is exact.
  Where a stage needs a limit only as above or below a depth, an engine with a censored search stops there
  (:class:`LimitColumns` ``ceiling``, :func:`censor_ceilings`, :func:`map_ceiling`; the same answers).
  Each (distinct sample, speed) limit is computed once per recommendation (:class:`LimitColumns`: a resampled
  posterior repeats its rows, and the cut's own check reads the columns that chose it), or once per campaign
  (:class:`LimitMemo`), under one discretisation (:func:`decision_options`); the same answers.
* :func:`data_guard`: a backstop from the data where the model does not explain them: no recommended depth
  at or above (1 − :data:`GUARD_MARGIN`) × the depth of a cut labelled chatter (grade > ½) that the posterior
  calls chatter with probability < :data:`GUARD_EXPLAINED` (the fraction of samples whose limit lies at or
  below the cut), within its speed neighbourhood, ±:data:`GUARD_LOBE_FRACTION` of the local lobe spacing
  (Ω·f_tp/f_c, f_tp = N·Ω/60, f_c the cut's measured chatter frequency or else the most flexible mode's
  natural frequency), unless the stable cuts (grade < ½) at least as deep in that neighbourhood outweigh
  the chatter cuts at most as deep there (each cut weighs |2·grade − 1|: 1 for a plain label, 0 for
  marginal; strictly more stable weight). Why: a posterior that cannot explain a chatter label (a
  label-error model absorbs it, a model error hides it) would otherwise recommend the very cut the shop saw
  chatter. A cut the posterior does explain needs no guard: its boundary already puts the limit at or below
  the cut (the calibration campaigns measured the cost of guarding those too: productivity median 0.91 →
  0.79, docs/updating.md).
* :func:`next_test`: the cut with the largest expected information about the parameters per unit of
  productivity, among cuts more productive than the recommendation (criterion: the mutual information
  between the cut's label and θ, I = H(E_θ π) − E_θ H(π), π = ε + (1 − 2ε)·Φ((b − b_lim(θ))/(s·σ_b)) the label
  probability of the likelihood with each sample's learned label error ε and depth-noise factor s — "BALD" — times the
  cut's productivity relative to the recommendation). It is the test most likely both to shrink the uncertainty and to
  move the recommendation to a more productive cut; evaluated on a subsample of the posterior. Its probability of
  chattering (the process's, E_θ Φ((b − b_lim)/(s·σ_b)), without the label error) is capped at ``test_risk``
  (a chattering test costs a part or a tool), and a cut the data guard forbids is never proposed. When no
  such cut is more productive than the recommendation (or none is informative), the next test is the
  recommendation itself. **Blind spot:** tests more productive than the recommendation that chatter bound
  the boundary only from above *at their own cuts*; nothing bounds the recommendation itself, and a
  campaign with a tool truly 3× softer than its hammer test recommended a chattering cut in every round
  that way (every test deeper, every test chattered). So when the last :data:`BLIND_SPOT_CHATTERS` cuts
  were all labelled chatter (grade > ½) and all more productive than the recommendation, and no cut
  within ±:data:`BLIND_SPOT_WIDTH` of its speed at least (1 − :data:`GUARD_MARGIN`)× its depth was
  labelled stable, the next test is the recommendation itself (:func:`blind_spot`). With ``discriminate="conflict"``
  (opt-in, :data:`DISCRIMINATE`), while the posterior names a prior–data conflict, the next test is the conflict test
  instead (:func:`next_test_discriminating`).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from millstab.errors import InputError
from millstab.parsing import check_risk
from millstab.update._bald import label_information
from millstab.update.likelihood import limits
from millstab.update.posterior import Posterior
from millstab.warnlog import collect, emit, warn

#: speeds of the coarse grid of :func:`recommend`
COARSE_POINTS = 200
#: speeds per refinement round, and rounds
REFINE_POINTS = 24
REFINE_ROUNDS = 3
#: the speed search of :func:`recommend`: ``"full"`` (every sample at every speed), ``"fast"`` (a subsample finds
#: the pockets, every sample decides the depth: :func:`recommend`), ``"auto"``: fast for an engine other than the
#: cheapest registered one (:func:`fast_search_for`)
SEARCH_CHOICES = ("auto", "fast", "full")
#: the fast search: posterior samples of its scan (seeded subsample), and the pockets (local maxima of the
#: subsample's productivity) handed to every sample
SEARCH_SAMPLES = 200
SEARCH_POCKETS = 4
#: the fast search's refinement of each pocket on the subsample: rounds, and speeds per round (the bracket
#: shrinks (points − 1)/2-fold a round: from the coarse step to ~1/30 of it, finer than the subsample resolves)
SEARCH_REFINE_ROUNDS = 2
SEARCH_REFINE_POINTS = 12
#: the fast search's last round, with every sample: this many speeds within ±:data:`SEARCH_POLISH_STEPS` coarse
#: steps of the chosen pocket's speed (the subsample placed it 107 rpm, 3 coarse steps, from the full scan's in the
#: a/D 0.1 case of docs/updating.md: 1.9 % less productive)
SEARCH_POLISH_POINTS = 12
SEARCH_POLISH_STEPS = 4
#: whether the fast search's subsample stages (the coarse scan and the pockets' refinement) read the ±speed-tolerance
#: neighbours too (3 speeds per candidate); the every-sample stages, which choose the pocket and set the depth, always
#: do. Off: ~2x less CPU and the same or a more productive cut on the two a/D 0.1 posteriors of docs/updating.md
#: ("Decisions from an accurate posterior": 42.0 -> 21.7 s and 34.9 -> 16.8 s CPU; 0.994 -> 1.003 and 0.990 ->
#: 0.998 of the full scan's productivity), the risk unchanged (the every-sample stages set it)
SEARCH_SUBSAMPLE_TOLERANCE = False
#: the fast search's every-sample stages read a candidate's ±speed-tolerance neighbours only while its depth at the
#: nominal speed (an upper bound of the depth it holds) can still beat the best held so far (:func:`recommend`):
#: the same cut as reading them all, from 21 every-sample speeds instead of 49 (mean of 8 recommendations from 1 000
#: prior draws at a/D 0.1 in the campaigns' 5 000-12 000 rpm, ±0.25 %; tests/test_decide_columns.py)
SEARCH_BOUND = True
#: the ceiling [mm] of an entry a censored engine call computes but no one asked for (:class:`LimitColumns`: a row
#: searched again at some speeds of a call): its search stops at the first depth
CHEAPEST_CEILING = 1e-9
#: the fast search's every-sample stages censor each limit (:class:`LimitColumns`) at a ceiling above the depth the
#: speed may hold (:func:`censor_ceilings`), for an engine with a censored search (spectral); the same cut and risk
SEARCH_CENSOR = True
#: the ceiling: the subsample's order statistic at the :data:`SEARCH_CEILING_LEVEL` binomial quantile of the full
#: count's rank, × (1 + :data:`SEARCH_CEILING_MARGIN`), the largest over the subsample's speeds within a coarse step
SEARCH_CEILING_LEVEL = 0.999
SEARCH_CEILING_MARGIN = 0.05
#: a suggested subsample of a map from an engine other than the cheapest (``millstab map --samples``): its
#: Monte Carlo standard error is at most ½/√M = 0.022
MAP_SAMPLES = 500
#: posterior samples used for the next-test criterion (its cost is quadratic-free but per sample)
NEXT_TEST_SAMPLES = 1000
#: one-sided confidence with which the recommendation's P(chatter) ≤ risk must hold against the
#: Monte Carlo error of its estimate (None in :func:`recommend`: the plain count ⌊risk·N⌋)
CONFIDENCE = 0.9
#: relative spindle-speed error (±) the recommended depth must tolerate
SPEED_TOLERANCE = 0.0025
#: the default cap on the proposed next test's probability of chatter (``--test-risk``; campaign trade-off in
#: docs/updating.md)
TEST_RISK = 0.5
#: data guard: the neighbourhood of a chatter-labelled cut is ±this fraction of the local lobe spacing (½: the
#: width of one lobe, centred on the cut)
#: (relative lobe spacing ≈ f_tp/f_c), clipped to :data:`GUARD_WIDTH_LIMITS` of the speed
GUARD_LOBE_FRACTION = 0.5
GUARD_WIDTH_LIMITS = (0.005, 0.25)
#: data guard: a recommended depth stays below (1 − this)·depth of a guarding chatter cut
GUARD_MARGIN = 0.05
#: data guard: a chatter cut guards when the posterior calls it chatter with less than this probability
#: (the fraction of samples whose limit lies at or below the cut): the model does not explain it
GUARD_EXPLAINED = 0.5
#: blind spot of the next test: when this many of the most recent cuts were all labelled chatter and all more
#: productive than the recommendation, and no cut within ±:data:`BLIND_SPOT_WIDTH` of its speed as deep as it
#: (× (1 − :data:`GUARD_MARGIN`)) was labelled stable, the next test is the recommendation itself
BLIND_SPOT_CHATTERS = 2
BLIND_SPOT_WIDTH = 0.02
#: when the recommendation must be vouched for by a cut labelled stable (:func:`confirmed_cuts`): ``"conflict"``
#: (while the posterior names a prior–data conflict or the data guard holds a chatter cut the posterior does not
#: explain), ``"auto"`` (the default: as ``"conflict"``, unless the cuts' chatter frequencies place the modes,
#: :func:`frequencies_place_modes`), ``"always"``, ``"never"``. Why ``"auto"`` (issue 24, docs/updating.md "The
#: default prior"): the rule is for a posterior that explains its cuts with the wrong structure, so that its lobes
#: between the cuts cannot be trusted; where chatter frequencies read near the mode place the natural frequencies,
#: it only held the softer tool's last recommendation low (8 softer campaigns with frequencies, `multivariate_t`:
#: 5 / 8 at ≥ 0.60 of the best with it, 8 / 8 without, and no chattering recommendation from round 3 on either way)
CONFIRM_CHOICES = ("auto", "conflict", "always", "never")
CONFIRM = "auto"
#: chatter-labelled cuts with a measured frequency needed before the frequencies count as placing the modes
#: (``confirm="auto"``): two, so that one reading of another family member (the prior's alias chance) is not enough
PLACE_MODES_CUTS = 2
#: when the next test is the conflict test (:func:`millstab.update.discriminate.conflict_test`: the cut that best tells
#: the posterior from the hammer test off by 3.5σ in one kind of parameter) instead of the most informative cut:
#: ``"conflict"`` while the posterior names a prior–data conflict, ``"never"`` (the default). Not the default,
#: measured (softer campaigns 60/62/64/70, multivariate-t tails, docs/updating.md "The conflict test while a conflict
#: is named"): the last recommendation fell from 0.40 to 0.14 of the best cut's productivity (equally safe): the
#: conflict tests moved the structure towards the truth (campaign 62: fn from 1.2× to 1.02× the truth's) but went to
#: the low lobes, so the pocket the recommendation needs stayed unexplored
DISCRIMINATE_CHOICES = ("conflict", "gain", "never")
DISCRIMINATE = "never"
#: the conflict test replaces the next test only when its rival fits the cuts so far at least this well: ln of the
#: mean likelihood ratio of the rival over the posterior (0: at least as well; a rival the cuts already reject is not
#: worth a test). In softer campaigns 60-70 it never bound: the rival fitted as well in every round it was asked
DISCRIMINATE_RIVAL_LR = 0.0
#: a confirmed stable cut lets a recommendation as deep as it within ±this fraction of its speed: 0, at its own
#: speed only (±2 % let a softer campaign's recommendation slide from a stable cut at 11 965 rpm, 0.461 mm, to
#: 12 000 rpm, where the true limit is 0.445 mm; ±0.25 % to 11 995 rpm, where it is 0.448 mm)
CONFIRM_WIDTH = 0.0
#: a stable cut vouches only when the posterior gives it at most this P(chatter) (at its speed and ±the speed
#: tolerance): a swapped label (stable at 5× the true limit) that the posterior does not believe does not vouch
CONFIRM_P_CHATTER = 0.25


def p_stable_from_limits(blim_mm: np.ndarray, depth_mm: np.ndarray) -> np.ndarray:
    """P(stable) (S, D): the fraction of rows of ``blim_mm`` (N, S) [mm] above each depth (D,) [mm]."""
    n, s = blim_mm.shape
    d = np.maximum(np.asarray(depth_mm, dtype=float), 0.0)  # every limit is > 0: P(stable) = 1 at b ≤ 0
    top = max(float(np.nanmax(np.where(np.isfinite(blim_mm), blim_mm, 0.0))), float(d.max(initial=0.0)), 1.0)
    width = 4.0 * top  # every column's values (inf → 2 top) fit in [0, width): offsets keep columns apart
    a = np.sort(np.where(np.isfinite(blim_mm), blim_mm, 2.0 * top), axis=0).T  # (S, N)
    off = width * np.arange(s)[:, None]
    flat = (a + off).ravel()
    # samples with b_lim ≤ b chatter at b: count them for every (speed, depth) in one search
    below = (np.searchsorted(flat, (d[None, :] + off).ravel(), side="right").reshape(s, d.size)
             - n * np.arange(s)[:, None])
    return 1.0 - below / n


def map_rows(n: int, samples: int | None, seed: int = 0) -> np.ndarray | None:
    """The posterior rows a map of ``samples`` samples reads: a seeded subsample of ``samples`` of the ``n`` rows
    (sorted), or ``None`` (every row) when ``samples`` is ``None`` or ≥ n. Nested: with the same seed, a subsample of
    more than :data:`SEARCH_SAMPLES` rows holds the fast search's (that many rows' draw, then the others from the
    remaining rows), so that a map and a recommendation from one posterior share those rows' limits at the speeds they
    share (a :class:`LimitMemo`: ``api.p_stable(..., memo=)``, the app's Map and recommend).

    Raises:
        InputError: ``samples`` < 1."""
    if samples is None:
        return None
    if not (isinstance(samples, (int, np.integer)) and samples >= 1):
        raise InputError("--samples", samples, "a whole number ≥ 1 of posterior samples for the map (e.g. "
                                               f"{MAP_SAMPLES}), or leave it out for all of them")
    if samples >= n:
        return None
    rng = np.random.default_rng(seed)
    first = rng.choice(n, int(min(samples, SEARCH_SAMPLES)), replace=False)
    if samples <= SEARCH_SAMPLES:
        return np.sort(first)
    rest = np.setdiff1d(np.arange(n), first)
    return np.sort(np.concatenate([first, rng.choice(rest, int(samples) - first.size, replace=False)]))


def distinct_limits(prior, u: np.ndarray, rpm, engine: str = "zoa", options: dict | None = None,
                    client=None, ceiling_mm: float | None = None) -> np.ndarray:
    """:func:`millstab.update.likelihood.limits` (N, S) [mm] of the rows u = ln θ (N, P) at speeds rpm (S,) [rpm], each
    DISTINCT row evaluated once and its limits copied to its repeats. Why: a posterior is resampled every tempering
    stage and a move keeps a particle where its proposal is rejected, so its rows repeat (the spectral posteriors of
    the a/D 0.1 campaigns, docs/updating-measured.md "A spectral campaign now": ~30 % repeats), and a decision
    that counts samples needs every row's limit but not every row's engine call. The same numbers: a row's limit
    does not depend on the other rows of a call (each row is its own search; spectral without warm starts under the
    sampling discretisation; sdm's steps follow the highest natural frequency of the rows, the same over the distinct
    ones).
    ``ceiling_mm``: one ceiling [mm] for every entry, a censored search where the engine has one (``takes_ceiling``,
    no ``client``): an entry at or above it is a lower bound of its limit, one below it the limit."""
    u = np.asarray(u, float)
    uniq, inv = np.unique(u, axis=0, return_inverse=True)
    rpm = np.asarray(rpm, float)
    ceiling = None
    if ceiling_mm is not None and client is None:
        from millstab.stability import get_engine

        if getattr(get_engine(engine), "takes_ceiling", False):
            ceiling = np.full((uniq.shape[0], rpm.size), float(ceiling_mm))
    if uniq.shape[0] == u.shape[0] and ceiling is None:
        return limits(prior, u, rpm, engine, client=client, options=options)[0]
    return limits(prior, uniq, rpm, engine, client=client, options=options, ceiling_mm=ceiling)[0][inv.ravel()]


def decision_options(post: Posterior, rpm_range: tuple[float, float]) -> dict:
    """The engine's discretisation for every engine call of one decision in ``rpm_range`` [rpm]: the posterior's
    own (:attr:`Posterior.engine_options`) where it has one, else, for an engine that chooses its discretisation per
    call (spectral: the node count of a convergence check at the prior median at the call's lowest, middle and
    highest speed), that choice made once, at the range's ends and middle. Why: a call's choice depends on its
    speed list, so without it a speed's limit could depend on the other speeds of its call (a different node
    count); with it each (sample, speed) is one number however the calls are split (to the root search's
    tolerance), which lets the decision reuse
    a limit it has computed (:class:`LimitColumns`) and skips a check per call (~33 ms CPU at a/D 0.1). The same
    numbers where every call chose alike (the a/D 0.1 campaigns: 6 nodes on 40 random speed lists of 3-200 speeds
    in 5 000-12 000 rpm, as at the range's three)."""
    if post.engine_options:
        return dict(post.engine_options)
    from millstab.forward import forward, option_keywords
    from millstab.update.likelihood import SAMPLING

    fwd = forward(post.prior.par, post.prior.cutting, post.engine, SAMPLING)
    if getattr(fwd._engine_mod, "settings", None) is None:
        return {}
    lo, hi = (float(x) for x in rpm_range)
    chosen = fwd.pinned(np.array([lo, 0.5 * (lo + hi), hi])).settings
    allowed = option_keywords(post.engine)[0]
    return {k: v for k, v in chosen.items() if k in allowed}


class LimitMemo:
    """Limits [mm] of (sample, speed) pairs remembered from one decision to the next, for the posteriors of one
    prior, engine and discretisation (a campaign's: :func:`millstab.update.campaign.run_campaign`). Why: each update
    starts from the last posterior and moves only some particles (a rejected move keeps its particle; resampling
    copies it), so most of a round's samples are the last round's, and the speeds of the coarse scan, the range's
    ends and a map's grid repeat every round. The same numbers as computing them anew: a row's limit does not depend
    on the other rows of a call. Bound to the first (engine, discretisation, cutting, prior parameterization) it
    serves; another one clears it."""

    def __init__(self) -> None:
        self._key = None
        self._clear()

    def _clear(self) -> None:
        # a row's id (its key: the row's bytes), and per speed a column of limits by id (NaN: not remembered), so
        # a lookup is one dict access per row and one gather per speed, not a dict access per (row, speed)
        self._ids: dict[bytes, int] = {}
        self._by_speed: dict[float, np.ndarray] = {}

    def bind(self, post: Posterior, options: dict) -> None:
        """Serve ``post``'s decisions under ``options``: cleared when they are not those it served so far."""
        key = (post.engine, tuple(sorted(dict(options).items())), repr(post.prior.cutting), repr(post.prior.par),
               tuple(post.prior.names))
        if key != self._key:
            self._key = key
            self._clear()

    def known(self, keys: list[bytes], speeds: list[float]) -> tuple[np.ndarray, np.ndarray]:
        """(values (R, S), whether each is remembered (R, S)) of rows named by ``keys`` at ``speeds``."""
        ids = np.array([self._ids.get(k, -1) for k in keys], dtype=np.int64)
        vals = np.full((len(keys), len(speeds)), np.nan)
        seen = ids >= 0
        for j, x in enumerate(speeds):  # a gather per speed
            col = self._by_speed.get(x)
            if col is not None:
                inside = seen & (ids < col.size)
                vals[inside, j] = col[ids[inside]]
        have = ~np.isnan(vals)
        return np.where(have, vals, 0.0), have

    def remember(self, keys: list[bytes], speeds: list[float], values: np.ndarray) -> None:
        """Keep the limits ``values`` (R, S) [mm] of the rows named by ``keys`` at ``speeds``; a NaN entry is not
        kept (the caller marks so what is not a limit: a censored bound, an entry not asked for)."""
        ids = np.array([self._ids.setdefault(k, len(self._ids)) for k in keys], dtype=np.int64)
        for j, x in enumerate(speeds):  # a scatter per speed, into a column grown to the ids known
            keep = ~np.isnan(values[:, j])
            if not keep.any():
                continue
            col = self._by_speed.get(x)
            if col is None or col.size < len(self._ids):
                grown = np.full(len(self._ids), np.nan)
                if col is not None:
                    grown[:col.size] = col
                col = self._by_speed[x] = grown
            col[ids[keep]] = values[keep, j]


class LimitColumns:
    """The limits (N, S) [mm] of fixed posterior rows u (N, P) at any speeds [rpm], each (distinct row, speed)
    computed once (:func:`distinct_limits`): a request calls the engine only for the speeds not seen before (in the
    order asked), and repeats come from memory. A decision asks the same speeds more than once (the chosen cut's
    own ±tolerance check reads the columns of the stage that chose it; a confirmed recommendation searches again).
    ``memo``: a :class:`LimitMemo` of earlier decisions (a campaign's), whose rows it reads and then only the rows
    it lacks go to the engine. The same numbers: under one pinned discretisation (:func:`decision_options`) a
    (row, speed)'s limit depends on neither the other rows of a call nor, beyond the root search's tolerance, its
    other speeds (the continuation from speed to speed starts each search elsewhere: 3e-13 relative measured at
    a/D 0.1, tests/test_decide_columns.py).

    A request may name a ``ceiling`` per speed: the caller needs each limit only where it lies below the ceiling
    (a count of limits at or below a depth under it; an order statistic that turns out below it). For an engine
    with a censored search (``takes_ceiling``: spectral) the engine then stops each search from below once every
    depth up to the ceiling is stable; such an entry is a certified lower bound (≥ the ceiling) of its limit, and
    a later request with a higher ceiling (or none) searches those entries again, alone. Entries below a ceiling
    are the limits themselves (to the root search's tolerance), so every count and order statistic below it is
    the uncensored one. Why: in a decision a limit far above the depth in question costs its whole search (the
    ladder to the root, then the refinement near ρ = 1 and Newton, about half an entry's cost), and tells only
    "above" (docs/updating.md, "Decisions from an accurate posterior"). The memo keeps limits only."""

    def __init__(self, post: Posterior, u: np.ndarray, options: dict | None = None,
                 memo: LimitMemo | None = None) -> None:
        from millstab.stability import get_engine

        self.post, self.options, self.memo = post, dict(options or {}), memo
        self.rows, inv = np.unique(np.asarray(u, float), axis=0, return_inverse=True)
        self.inv = inv.ravel()
        self.n = self.inv.size
        self.censors = bool(getattr(get_engine(post.engine), "takes_ceiling", False))
        self._cols: dict[float, np.ndarray] = {}
        self._ceil: dict[float, np.ndarray] = {}  # per distinct row, the ceiling its entry was searched under
        #: (distinct rows, speeds) the engine was asked for, censored ones among them: what the decision cost
        self.asked = self.censored = 0
        if memo is not None:
            memo.bind(post, self.options)
            self._keys = [r.tobytes() for r in self.rows]

    def seen(self) -> list[float]:
        """The speeds [rpm] whose limits it holds."""
        return list(self._cols)

    def held(self, rpm) -> np.ndarray:
        """The entries (N, S) it holds at speeds it has seen, as they are (a censored one a lower bound of its
        limit), without a search."""
        return np.stack([self._cols[float(x)] for x in np.ravel(rpm)], axis=1)[self.inv]

    def _engine(self, rows: np.ndarray, speeds: list[float], ceiling: np.ndarray | None = None) -> np.ndarray:
        return limits(self.post.prior, rows, np.array(speeds), self.post.engine, options=self.options,
                      ceiling_mm=ceiling)[0]

    def __call__(self, rpm, ceiling=None) -> np.ndarray:
        """The limits (N, S) [mm] at ``rpm`` (S,); ``ceiling`` (a depth [mm], one or per speed; None: none): below
        it each entry is the limit, at or above it a lower bound of the limit (the class docstring)."""
        r = [float(x) for x in np.ravel(np.asarray(rpm, float))]
        if not r:
            return np.zeros((self.n, 0))
        c = np.broadcast_to(np.inf if ceiling is None or not self.censors else np.asarray(ceiling, float), (len(r),))
        need: dict[float, float] = {}
        for x, cx in zip(r, c.tolist()):  # a speed asked twice: the higher ceiling
            need[x] = max(need.get(x, 0.0), cx)
        todo: dict[float, np.ndarray] = {}  # the distinct rows each speed must (re)search
        for x, cx in need.items():
            if x not in self._cols:
                todo[x] = np.ones(self.rows.shape[0], dtype=bool)
            else:
                low = self._ceil[x] < cx  # censored entries below what is needed now
                if low.any():
                    todo[x] = low
        if todo:
            self._fill(todo, need)
        return np.stack([self._cols[x] for x in r], axis=1)[self.inv]

    def _fill(self, todo: dict[float, np.ndarray], need: dict[float, float]) -> None:
        speeds = list(todo)
        mask = np.stack([todo[x] for x in speeds], axis=1)  # (R, S): the entries to (re)search
        cap = np.broadcast_to(np.array([need[x] for x in speeds]), mask.shape)
        vals = np.zeros(mask.shape)
        ceil = np.full(mask.shape, np.inf)  # the ceiling each new entry holds (inf: the limit itself)
        if self.memo is not None:  # the memo's limits first; only the rows it lacks go to the engine
            known, have = self.memo.known(self._keys, speeds)
            vals = np.where(have, known, vals)
            mask = mask & ~have
        miss = np.flatnonzero(mask.any(axis=1))
        if miss.size:
            m, c = mask[miss], cap[miss]
            # an entry of a row that goes to the engine but not asked for: the cheapest search (its value unread)
            asked = np.where(m, c, CHEAPEST_CEILING) if self.censors and np.isfinite(c[m]).any() else None
            b = self._engine(self.rows[miss], speeds, asked)
            censored = m & (b >= c * (1 - 1e-12))  # (the engine's ceiling went through the Kt factor)
            b = np.where(censored, np.maximum(b, c), b)  # so that a censored entry is ≥ its ceiling exactly
            vals[miss] = np.where(m, b, vals[miss])
            ceil[miss] = np.where(censored, c, np.inf)
            self.asked += int(m.sum())
            self.censored += int(censored.sum())
            if self.memo is not None:  # the memo keeps limits only: not a censored bound, nor an entry not asked
                self.memo.remember([self._keys[i] for i in miss], speeds, np.where(m & ~censored, b, np.nan))
        for j, x in enumerate(speeds):
            t = todo[x]
            if x not in self._cols:
                self._cols[x], self._ceil[x] = vals[:, j].copy(), ceil[:, j].copy()
            else:
                self._cols[x][t], self._ceil[x][t] = vals[t, j], ceil[t, j]


def p_stable_map(post: Posterior, rpm, depth_mm, client=None, *, samples: int | None = None,
                 seed: int = 0, memo: LimitMemo | None = None) -> np.ndarray:
    """P(stable) on the grid rpm (S,) × depth_mm (D,), shape (S, D); one engine call (``client``: on its
    Dask cluster where that pays, same numbers). ``samples``: from a seeded subsample (``seed``) of that many
    posterior samples (:func:`map_rows`): each cell's P is then a fraction of M = ``samples`` draws, its Monte
    Carlo standard error √(P(1 − P)/M) ≤ ½/√M (0.022 at M = 500, :func:`map_error`) beside the full posterior's.
    ``memo``: limits remembered from earlier decisions (:class:`LimitMemo`; a campaign's maps and recommendations),
    read under the discretisation of a decision over the map's speed range (:func:`decision_options`); not with
    ``client``.

    Censored at the map's top depth (:func:`map_ceiling`) for an engine with a censored search (spectral; not on a
    cluster): a cell needs only whether each limit lies above its depth, so a limit above the deepest depth is
    searched only up to it. The same map: every entry below the ceiling is the limit, every one at or above it a
    lower bound above every depth of the map (tests/test_decide_censored.py)."""
    warn_time_averaged(post, stacklevel=2, rpm=rpm)
    rows = map_rows(post.u.shape[0], samples, seed)
    u = post.decision_u if rows is None else post.decision_u[rows]
    r = np.asarray(rpm, float)
    d = np.asarray(depth_mm, float)
    top = map_ceiling(d)
    if memo is not None and client is None and r.size:
        blim = LimitColumns(post, u, decision_options(post, (float(r.min()), float(r.max()))), memo)(r, top)
    else:
        blim = distinct_limits(post.prior, u, r, post.engine, post.engine_options, client, ceiling_mm=top)
    return p_stable_from_limits(blim, d)


def map_ceiling(depth_mm: np.ndarray) -> float | None:
    """The censoring ceiling [mm] of a map over ``depth_mm``: just above its deepest depth (a censored entry is ≥
    the ceiling, so above every depth of the map; 1e-9 relative above it, far beyond the engine's rounding of a
    ceiling through the Kt factor), ``None`` where no depth is > 0."""
    top = float(np.max(depth_mm, initial=0.0))
    return top * (1 + 1e-9) if top > 0 and math.isfinite(top) else None


def map_samples(engine: str, n: int, samples: int | str | None = "auto") -> int | None:
    """The posterior samples a map of a posterior of ``engine`` with ``n`` samples reads (``None``: every one):
    ``samples`` = ``"auto"`` (the doors' default): every sample for the cheapest engine (zoa: a 200 × 60 map of 1 000
    samples in ~0.1 s CPU), a seeded subsample of :data:`MAP_SAMPLES` for the others (each cell within ½/√M = 0.022
    standard error of the full posterior's; the a/D 0.1 spectral map of docs/updating.md "Decisions from an accurate
    posterior": 14.2 s CPU from every sample, 7.6 s from 500); ``"all"`` or ``None``: every sample; a whole number
    ≥ 1: that many (every one when ≥ ``n``).

    Raises:
        InputError: anything else (field ``--samples``)."""
    if samples is None or samples == "all":
        return None
    if samples == "auto":
        return MAP_SAMPLES if fast_search_for(engine) and n > MAP_SAMPLES else None
    text = str(samples).strip()
    m = int(text) if isinstance(samples, (int, np.integer)) or text.isdigit() else 0
    if m < 1:
        raise InputError("--samples", samples, "auto (every sample for the cheapest engine, "
                                               f"{MAP_SAMPLES} for the others), all, or a whole number ≥ 1")
    return None if m >= n else m


def map_samples_text(m: int | None, n: int) -> str:
    """What a map says of the samples it read: "1000 samples", or "500 of 1000 samples (Monte Carlo standard error ≤
    0.022 per cell)"."""
    if m is None or m >= n:
        return f"{n} samples"
    return f"{m} of {n} samples (Monte Carlo standard error ≤ {map_error(m):.3f} per cell)"


def map_error(samples: int) -> float:
    """The largest Monte Carlo standard error of a map cell from ``samples`` independent draws: ½/√M (at P = ½)."""
    return 0.5 / math.sqrt(samples)


def warn_outside(post: Posterior, lo: float, hi: float, stacklevel: int = 2) -> None:
    """Warn when the speeds ``lo``..``hi`` [rpm] reach more than 10 % beyond the tested speeds: decisions there lean
    on the prior. One text for every decision (map, recommendation, prediction), so a page that shows a map and a
    recommendation together shows it once."""
    data_rpm = np.asarray(post.cuts.get("rpm") or [], float)
    if data_rpm.size and (lo < 0.9 * data_rpm.min() or hi > 1.1 * data_rpm.max()):
        warn(f"the speed range {lo:g}-{hi:g} rpm reaches beyond the tested speeds ({data_rpm.min():g}-"
             f"{data_rpm.max():g} rpm): decisions there lean on the prior", UserWarning, stacklevel=stacklevel + 1)


def warn_time_averaged(post: Posterior, stacklevel: int = 2, rpm=None) -> None:
    """Warn when ``post``'s engine averages the cutting force over the tooth period (the zero-order model) and the
    decision's condition cuts with less than one tooth on average (:func:`millstab.stability.time_averaged_note`,
    with the measurements): a cut it calls stable can chatter. One text for every decision (map, recommendation,
    prediction), so a page or log that shows a map and a recommendation together shows it once. Where that rule is
    silent and the decision's speeds ``rpm`` [rev/min] are given, the posterior median's limits there are checked
    against the spectral engine (:func:`millstab.update.model_check.median_check`: a shop's 4-tooth tool at a/D 0.5
    down, one tooth in the cut, was 4.9× off), and a large difference is warned with its figures."""
    from millstab.points import condition_text
    from millstab.stability import time_averaged_note

    where = f"this condition ({condition_text(post.condition)})"
    note = time_averaged_note(post.engine, post.condition, where)
    if note:
        warn(f"{note}, so a cut it calls stable can chatter; decide here from an update with an engine of interrupted "
             "cutting (--engine spectral or sdm)", UserWarning, stacklevel=stacklevel + 1)
    elif rpm is not None:
        from millstab.update.model_check import median_check, median_message

        check = median_check(post, rpm)
        if check is not None and check["warn"]:
            warn(median_message(check, post.engine, where), UserWarning, stacklevel=stacklevel + 1)


def warn_averaged_error(post: Posterior, rpm: float, depth_mm: float, risk: float, seed: int = 0) -> None:
    """Warn when the recommended cut of a time-averaged (zero-order) posterior chatters clearly more often under the
    interrupted-cutting engine on the same samples (:mod:`millstab.update.model_check`: the tooth-count rule of
    :func:`warn_time_averaged` missed a 4.9× error at one tooth in the cut)."""
    from millstab.update.model_check import accurate_check, check_message

    check = accurate_check(post, rpm, depth_mm, risk, seed=seed)
    if check is not None and check["warn"]:
        warn(check_message(check, rpm, depth_mm, post.engine), UserWarning, stacklevel=3)


@dataclass(frozen=True)
class Recommendation:
    """The recommended cut and the next test (rpm, mm, cm³/min)."""

    rpm: float
    depth_mm: float
    p_chatter: float
    productivity: float
    mrr_cm3_per_min: float | None
    risk: float
    next_test: dict
    limited_by: str
    #: the largest P(chatter) (fraction of samples) within ±speed_tolerance of the speed
    p_chatter_speed_error: float | None = None
    #: the one-sided upper confidence bound of that probability (its Monte Carlo error)
    p_chatter_bound: float | None = None
    effective_samples: float | None = None
    confidence: float | None = None
    speed_tolerance: float = 0.0
    #: the data guard's chatter cuts near the recommendation's speed range (see :func:`data_guard`)
    guard: tuple[dict, ...] = ()
    test_risk: float | None = None
    #: the cutting condition it is computed for (:func:`millstab.points.describe_condition`)
    computed_for: dict | None = None
    #: every warning that comes with it, one line each: the update's (``post.warnings``: a prior–data conflict, ...)
    #: and the decision's own (speeds beyond the tested ones, a zero-order model below one tooth in the cut, ...)
    warnings: tuple[str, ...] = ()

    #: the ``"schema"`` of :meth:`to_json`
    SCHEMA = "millstab.recommendation/1"

    def figure(self, ax=None, *, title: str = ""):
        """The recommended cut, the next test and the data guard's caps on speed and depth
        (:func:`millstab.plot.update.plot_recommendation`; the P(stable) map behind them is a new computation,
        ``api.update.map_figure``), into ``ax`` or a new figure, which it returns."""
        from millstab.plot.update import plot_recommendation

        return plot_recommendation(self, title=title, ax=ax)

    def table(self) -> tuple[list[str], list]:
        """(header, columns): the recommended cut and the next test, one row each: rpm, depth_mm, p_chatter, and
        why (what limits the cut; why that test); NaN and empty where a read-back next test lacks them."""
        nt = self.next_test
        return (["cut", "rpm", "depth_mm", "p_chatter", "why"],
                [["recommended", "next test"], [self.rpm, float(nt["rpm"])], [self.depth_mm, float(nt["depth_mm"])],
                 [self.p_chatter, float(nt.get("p_chatter", math.nan))],
                 [f"limited by {self.limited_by}", str(nt.get("why", ""))]])

    def summary(self) -> str:
        """What ``millstab recommend`` prints: the cut (rpm, mm, P(chatter) against the risk, what limits it, the
        removal rate), how it is held against a speed error and the sampling error, a binding data guard, and
        the next test."""
        mrr = f", {self.mrr_cm3_per_min:.4g} cm³/min" if self.mrr_cm3_per_min is not None else ""
        lines = [f"recommended: {self.rpm:.0f} rpm, {self.depth_mm:.3f} mm (P(chatter) {self.p_chatter:.3f} ≤ "
                 f"{self.risk:g}, limited by {self.limited_by}{mrr})"]
        if self.p_chatter_bound is not None:
            lines.append(f"  held at ±{100 * self.speed_tolerance:g} % speed error (P(chatter) ≤ "
                         f"{self.p_chatter_speed_error:.3f}) and against the sampling error: "
                         f"{self.confidence:.0%} upper bound {self.p_chatter_bound:.3f} from "
                         f"{self.effective_samples:.0f} effective samples")
        lines += [f"  data guard: held below {g['cap_mm']:.3g} mm within ±{g['half_width_rpm']:.0f} rpm of a cut "
                  f"labelled chatter at {g['rpm']:.0f} rpm, {g['depth_mm']:.3g} mm" for g in self.guard if g["binding"]]
        nt = self.next_test
        lines.append(f"next test: {nt['rpm']:.0f} rpm, {nt['depth_mm']:.3f} mm (P(chatter) {nt['p_chatter']:.2f}; "
                     f"{nt['why']})")
        return "\n".join(lines)

    def to_json(self) -> dict:
        """The JSON of ``millstab recommend --out`` (rpm, mm, cm³/min)."""
        out = {"schema": self.SCHEMA, "rpm": self.rpm, "depth_mm": self.depth_mm,
               "p_chatter": self.p_chatter, "risk": self.risk, "limited_by": self.limited_by,
               "relative_productivity_mm_rpm": self.productivity, "next_test": self.next_test,
               "p_chatter_speed_error": self.p_chatter_speed_error, "p_chatter_bound": self.p_chatter_bound,
               "effective_samples": self.effective_samples, "confidence": self.confidence,
               "speed_tolerance": self.speed_tolerance, "test_risk": self.test_risk, "data_guard": list(self.guard),
               "computed_for": self.computed_for, "warnings": list(self.warnings)}
        if self.mrr_cm3_per_min is not None:
            out["mrr_cm3_per_min"] = self.mrr_cm3_per_min
        return out

    @classmethod
    def from_json(cls, doc: Any, source: str = "recommendation") -> Recommendation:
        """The recommendation of :meth:`to_json` (``millstab recommend --out``); InputError naming ``source``
        and the field for another schema, a missing field or one of the wrong kind."""
        from millstab.jsondoc import check_schema, need

        check_schema(doc, cls.SCHEMA, source)
        num, opt = (int, float), (int, float, type(None))
        return cls(rpm=float(need(doc, "rpm", source, num)), depth_mm=float(need(doc, "depth_mm", source, num)),
                   p_chatter=float(need(doc, "p_chatter", source, num)),
                   productivity=float(need(doc, "relative_productivity_mm_rpm", source, num)),
                   mrr_cm3_per_min=need(doc, "mrr_cm3_per_min", source, num) if "mrr_cm3_per_min" in doc else None,
                   risk=float(need(doc, "risk", source, num)), next_test=need(doc, "next_test", source, dict),
                   limited_by=need(doc, "limited_by", source, str),
                   p_chatter_speed_error=need(doc, "p_chatter_speed_error", source, opt),
                   p_chatter_bound=need(doc, "p_chatter_bound", source, opt),
                   effective_samples=need(doc, "effective_samples", source, opt),
                   confidence=need(doc, "confidence", source, opt),
                   speed_tolerance=float(need(doc, "speed_tolerance", source, num)),
                   guard=tuple(need(doc, "data_guard", source, list)), test_risk=need(doc, "test_risk", source, opt),
                   computed_for=(need(doc, "computed_for", source, (dict, type(None))) if "computed_for" in doc
                                 else None),
                   warnings=tuple(str(w) for w in need(doc, "warnings", source, list)) if "warnings" in doc else ())


def effective_samples(post: Posterior) -> float:
    """The effective number of independent samples of a posterior: the number of distinct samples
    (resampling duplicates them) and at most the ESS of its last tempering stage; N for prior draws.

    A proxy (moved samples stay correlated with their parents), used only to size the Monte Carlo
    error of a probability estimated by counting samples."""
    n = post.u.shape[0]
    distinct = np.unique(post.u, axis=0).shape[0]
    ess = (post.diagnostics or {}).get("ess") or [n]
    return float(min(distinct, ess[-1], n))


def allowed_count(n: int, risk: float, n_eff: float | None = None, confidence: float | None = CONFIDENCE) -> int:
    """The largest count m of N = ``n`` samples with b_lim ≤ b such that P(chatter) ≤ ``risk`` holds
    with one-sided ``confidence``: the Clopper–Pearson upper bound of m/N, with the count scaled to
    the effective sample size (k = m·n_eff/N of n_eff trials), is ≤ risk. ``confidence`` None: ⌊risk·N⌋.
    −1 when even m = 0 is not enough (too few effective samples to bound the risk)."""
    m_max = min(int(math.floor(risk * n)), n - 1)
    if confidence is None:
        return m_max
    from scipy.stats import beta

    ne = float(n if n_eff is None else min(max(n_eff, 1.0), n))
    k = np.arange(m_max + 1) * ne / n
    upper = beta.ppf(confidence, k + 1, np.maximum(ne - k, 1e-12))
    ok = np.flatnonzero(upper <= risk)
    return int(ok[-1]) if ok.size else -1


def safe_depth(blim_mm: np.ndarray, risk: float, count: int | None = None) -> np.ndarray:
    """Per speed (S,), the largest depth [mm] whose P(chatter) = P(b_lim ≤ b) is at most ``risk``
    (at most ``count`` of the N samples below it, when given: see :func:`allowed_count`).

    With the sorted limits a₀ ≤ a₁ ≤ …, any b < a_m (m = ⌊risk·N⌋) has at most m samples below it:
    the answer is a_m less a relative 1e-9 (so that the count is strict).
    """
    n = blim_mm.shape[0]
    m = min(int(math.floor(risk * n)), n - 1) if count is None else min(max(int(count), 0), n - 1)
    a = np.partition(blim_mm, m, axis=0)[m]
    return a * (1 - 1e-9)


def _mrr_factor(teeth: int, width_mm: float | None, feed_mm: float | None) -> float | None:
    if width_mm is None and feed_mm is None:
        return None
    if width_mm is None or feed_mm is None:  # name the option that WAS given (not "= None"), and the missing one
        given, value, missing = (("--feed-per-tooth", feed_mm, "--radial-width") if width_mm is None
                                 else ("--radial-width", width_mm, "--feed-per-tooth"))
        hint = " (or the tool's diameter in the config: the width is then the condition's)" if width_mm is None else ""
        raise InputError(given, value, f"also give {missing} [mm]{hint}: the removal rate in cm^3/min needs the radial "
                                       "width and the feed per tooth (or give neither: depth × speed)")
    for name, v in (("--radial-width", width_mm), ("--feed-per-tooth", feed_mm)):
        if not (math.isfinite(v) and v > 0):
            raise InputError(name, v, "must be a finite number > 0 mm")
    return width_mm * feed_mm * teeth / 1000.0  # mm·mm·mm/min per (mm·rpm) → cm³/min


def _rate_width(post: Posterior, width_mm: float | None, feed_mm: float | None) -> tuple[float | None, float | None]:
    """(width, feed) [mm] of the removal rate. With the tool diameter a width is the decision's condition's (the
    doors set the condition from it: ``millstab.api.for_condition``), so it must be that condition's width, a
    width without a feed only named the condition (no rate in cm³/min, no error), and a feed without a width takes
    the condition's; without a diameter the width is the rate's alone, as given.

    Raises:
        InputError: ``--radial-width`` more than :data:`millstab.points.WIDTH_TOL` · D off the decision's width.
    """
    if post.diameter_mm is None:
        return width_mm, feed_mm
    from millstab.points import WIDTH_TOL, condition_text, radial_width

    d = float(post.diameter_mm)
    w = radial_width(post.condition.entry, post.condition.exit, d)
    if width_mm is None:  # a feed with the tool's diameter: the condition's own width (the feed alone was refused)
        return (w if feed_mm is not None else None), feed_mm
    if not (isinstance(width_mm, (int, float)) and abs(width_mm - w) <= WIDTH_TOL * d):
        raise InputError("--radial-width", width_mm,
                         f"the decision is for {condition_text(post.condition)}, a width of {w:.4g} mm on the {d:g} mm "
                         "tool of the config: give that width, or decide for this one (the width alone, or with an "
                         "a/D or angles that agree with it)")
    return (width_mm if feed_mm is not None else None), feed_mm


def _cut_grades(cuts: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(rpm, depth [mm], grade, chatter_hz) of a posterior's labelled cuts (its ``cuts`` record; ``grade``
    when it was kept, else from the label words)."""
    from millstab.points import GRADE

    lab = [str(x or "") for x in (cuts.get("label") or [])]
    n = len(lab)
    rpm = np.asarray((cuts.get("rpm") or [])[:n], float)
    depth = np.asarray((cuts.get("depth_mm") or [])[:n], float)
    if n == 0 or rpm.size != n or depth.size != n:  # prior draws carry only a speed range
        return np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0)
    g = cuts.get("grade")
    grade = (np.array([np.nan if x is None else float(x) for x in g[:n]]) if g is not None and len(g) >= n
             else np.array([GRADE.get(x, np.nan) for x in lab]))
    hz = np.array([np.nan if x is None else float(x) for x in (cuts.get("chatter_hz") or [None] * n)[:n]], float)
    keep = np.array([bool(x) for x in lab], dtype=bool) & np.isfinite(grade)
    return rpm[keep], depth[keep], grade[keep], hz[keep]


def chatter_cuts(post: Posterior, columns: LimitColumns | None = None) -> list[dict]:
    """Every chatter-labelled cut (grade > ½) of the posterior's condition, as the data guard weighs it (the rule is
    in the module docstring): {rpm, depth_mm, grade, p_model_chatter, half_width_rpm, cap_mm, stable_weight,
    chatter_weight}. ``columns``: the limits of ``post.decision_u`` (:class:`LimitColumns`) a decision shares;
    default a call of its own."""
    rpm, depth, grade, hz = _cut_grades(post.cuts_in_condition())  # per condition: a slot's chatter cut does not
    ch = np.flatnonzero(grade > 0.5)  # bound a finishing pass (the model carries what it teaches)
    if ch.size == 0:
        return []
    # does the posterior explain each chatter cut? the fraction of samples whose limit lies at or below it
    blim = (columns(rpm[ch], depth[ch] * (1 + 1e-6)) if columns is not None
            else distinct_limits(post.prior, post.decision_u, rpm[ch], post.engine, post.engine_options))
    p_model = np.mean(blim <= depth[ch][None, :], axis=0)
    tip = post.prior.par.structure(post.prior.par.theta0)  # the prior median's TIP (a prior over a holder too)
    modes = [m for m in (*tip.x, *tip.y)]
    fc_struct = min(modes, key=lambda m: m.k).fn  # the most flexible mode: where chatter grows
    fc = np.where(np.isfinite(hz) & (hz > 0), hz, fc_struct)
    ftp = post.prior.cutting.teeth * rpm / 60.0
    rel = np.clip(GUARD_LOBE_FRACTION * ftp / fc, *GUARD_WIDTH_LIMITS)
    strength = np.abs(2 * grade - 1)
    out = []
    for i, p in zip(ch, p_model):
        near = np.abs(rpm - rpm[i]) <= rel[i] * rpm[i]
        out.append({"rpm": float(rpm[i]), "depth_mm": float(depth[i]), "grade": float(grade[i]),
                    "p_model_chatter": float(p), "half_width_rpm": float(rel[i] * rpm[i]),
                    "cap_mm": float((1 - GUARD_MARGIN) * depth[i]),
                    "stable_weight": float(strength[near & (grade < 0.5) & (depth >= depth[i])].sum()),
                    "chatter_weight": float(strength[near & (grade > 0.5) & (depth <= depth[i])].sum())})
    return out


def guarding(cuts: list[dict]) -> list[dict]:
    """The cuts of :func:`chatter_cuts` that guard: those the posterior does not explain (it calls them chatter with
    probability below :data:`GUARD_EXPLAINED`: its own boundary does not respect them) and that the stable cuts
    as deep nearby do not outweigh."""
    return [c for c in cuts if c["p_model_chatter"] < GUARD_EXPLAINED and c["stable_weight"] <= c["chatter_weight"]]


def data_guard(post: Posterior, columns: LimitColumns | None = None) -> list[dict]:
    """The chatter-labelled cuts that bound the recommendation (the rule is in the module docstring):
    a list of {rpm, depth_mm, grade, p_model_chatter, half_width_rpm, cap_mm, stable_weight, chatter_weight},
    one per guarding cut (cuts the posterior explains, and outweighed ones, are left out: :func:`guarding` of
    :func:`chatter_cuts`). ``columns``: as :func:`chatter_cuts`."""
    return guarding(chatter_cuts(post, columns))


def explained_below(cuts: list[dict], rpm: float, depth_mm: float) -> list[dict]:
    """The chatter cuts of :func:`chatter_cuts` that the posterior explains, at most ``depth_mm`` deep, whose
    neighbourhood holds ``rpm``: a recommendation there lies above a cut that chattered within a lobe's width of
    it, which the data guard allows (the model puts its limit below that cut and higher here): said in a line."""
    return [c for c in cuts if c["p_model_chatter"] >= GUARD_EXPLAINED and abs(rpm - c["rpm"]) <= c["half_width_rpm"]
            and depth_mm >= c["depth_mm"]]


def guard_cap(guard: list[dict], rpm) -> np.ndarray:
    """The deepest depth [mm] the data guard allows at each speed (inf where no guarding cut is near)."""
    r = np.asarray(rpm, float)
    cap = np.full(r.shape, np.inf)
    for g in guard:
        cap = np.where(np.abs(r - g["rpm"]) <= g["half_width_rpm"], np.minimum(cap, g["cap_mm"]), cap)
    return cap


def conflict_named(post: Posterior) -> bool:
    """Whether the posterior names a prior–data conflict (its ``prior-data-conflict`` warning)."""
    from millstab.update.posterior import warning_code

    return any(warning_code(w) == "prior-data-conflict" for w in post.warnings)


def frequencies_place_modes(post: Posterior) -> bool:
    """Whether the posterior's cuts carry chatter frequencies that place its natural frequencies: at least
    :data:`PLACE_MODES_CUTS` cuts labelled chatter (or marginal) with a measured frequency, read as the member near
    the mode (``prior.chatter_hz_alias`` < 1; read modulo the tooth-passing frequency alone, a frequency cannot tell
    neighbouring lobes apart, docs/updating-measured.md "Chatter frequencies on the softer campaigns")."""
    if not post.prior.chatter_hz_alias < 1:
        return False
    hz = np.asarray(post.cuts.get("chatter_hz", []) or [], dtype=float)
    labels = post.cuts.get("label", []) or []
    chatter = np.array([str(lab) in ("chatter", "marginal") for lab in labels], dtype=bool)
    if hz.size != chatter.size:
        return False
    return int(np.sum(np.isfinite(hz) & (hz > 0) & chatter)) >= PLACE_MODES_CUTS


def confirmed_cuts(post: Posterior, rpm_range: tuple[float, float], offsets: np.ndarray, cap: float = math.inf,
                   guard: list[dict] = (), columns: LimitColumns | None = None) -> list[dict]:
    """The cuts labelled stable (grade < ½, in the decision's condition and speed range, within the depth cap and
    the data guard) whose label the posterior believes: at most :data:`CONFIRM_P_CHATTER` of its samples have a
    limit at or below the cut's depth at its speed × (1 + each of ``offsets``). A list of {rpm, depth_mm,
    p_chatter}; each lets a recommendation as deep as it at its speed (:func:`support_cap`; the recommendation's
    own risk still holds, so the depth there is the lesser of the two).

    Why (issue 24, softer campaigns): a posterior that contradicts its hammer test explains the chatter labels
    with a structure the data cannot check between the cuts (one mode's stiffness 3-4× below the truth's, the
    natural frequencies left at the hammer test's, 20 % off), and its recommendations went 4-8 % above a stable
    cut at the same speed, or into a pocket it predicts between chatter cuts, where the truth has none. A
    stable cut that the posterior also holds safe is what the data vouch for; a single swapped label (a cut
    labelled stable 5× above the true limit) does not vouch, since the posterior does not hold it safe. ``columns``:
    as :func:`data_guard`."""
    rpm, depth, grade, _ = _cut_grades(post.cuts_in_condition())
    lo, hi = rpm_range
    ok = (grade < 0.5) & (rpm >= lo) & (rpm <= hi) & (depth <= cap) & (depth < guard_cap(list(guard), rpm))
    if not ok.any():
        return []
    r, d = rpm[ok], depth[ok]
    at = (r[None, :] * (1 + offsets[:, None])).ravel()
    both = (columns(at, np.tile(d, offsets.size) * (1 + 1e-6)) if columns is not None
            else distinct_limits(post.prior, post.decision_u, at, post.engine, post.engine_options))
    p = (both <= np.tile(d, offsets.size)[None, :]).mean(axis=0).reshape(offsets.size, r.size).max(axis=0)
    return [{"rpm": float(a), "depth_mm": float(b), "p_chatter": float(q)} for a, b, q in zip(r, d, p)
            if q <= CONFIRM_P_CHATTER]


def support_cap(support: list[dict], rpm) -> np.ndarray:
    """The deepest depth [mm] the confirmed cuts ``support`` allow at each speed: the deepest of those within
    ±:data:`CONFIRM_WIDTH` of the speed (0: at the cut's own speed; 0 mm where none is)."""
    r = np.asarray(rpm, float)
    out = np.zeros(r.shape)
    for c in support:
        out = np.where(np.abs(r - c["rpm"]) <= CONFIRM_WIDTH * c["rpm"], np.maximum(out, c["depth_mm"]), out)
    return out


def censor_ceilings(sub: LimitColumns, count: int, n: int, step: float):
    """The censoring ceilings [mm] of the fast search's every-sample stages (with ``count`` and ``n`` the
    subsample's own: of its coarse speeds between those searched to the root, and of the pockets' refinement), as a
    function of speeds (S,) [rpm]: at
    each, the largest over the speeds ``sub`` (the subsample's limits) has searched within ±``step`` [rpm] (a
    coarse step: the nearest coarse speeds and a pocket's refinement) of the subsample's order statistic of rank k,
    k the :data:`SEARCH_CEILING_LEVEL` quantile of a binomial count of its M rows at the full posterior's rate
    (``count`` + 1)/``n``, × (1 + :data:`SEARCH_CEILING_MARGIN`); ``inf`` (no ceiling) where ``sub`` has no speed
    within the step. Why: the depth a speed holds is the full posterior's order statistic of rank ``count``, which
    lies below this ceiling unless the subsample is far off there (the rank's upper binomial bound and a margin
    for the speeds between); where it does not, the stage searches those limits to the root
    (:func:`recommend`), so the ceiling sets the cost, never the answer."""
    from scipy.stats import binom

    known = np.array(sorted(sub.seen()))
    m = sub.n
    k = int(min(binom.ppf(SEARCH_CEILING_LEVEL, m, min((max(count, 0) + 1) / n, 1.0)), m - 1))
    q = np.partition(sub.held(known), k, axis=0)[k] * (1 + SEARCH_CEILING_MARGIN)  # (a censored one: lower)
    q = np.where(np.isfinite(q), q, np.inf)

    def at(speeds) -> np.ndarray:
        x = np.asarray(speeds, float)
        near = np.abs(known[:, None] - x[None, :]) <= step * (1 + 1e-9)
        c = np.where(near, q[:, None], -np.inf).max(axis=0)
        return np.where(near.any(axis=0), c, np.inf)

    return at


def fast_search_for(engine: str) -> bool:
    """Whether ``search="auto"`` of :func:`recommend` takes the fast speed search for a posterior of ``engine``: for
    every engine but the cheapest registered one (:func:`millstab.stability.engine_with` ``cheap=True``: ``zoa``,
    whose full scan costs less than a second per 1 000 samples; its answers stay those of the full scan, bit for
    bit). Why by the registry and not a cost estimate: the cost per limit differs 20-100× between the cheapest
    engine and the others (docs/updating.md, "Decisions from an accurate posterior"), far beyond what an estimate
    would need to tell apart."""
    from millstab.stability import engine_with

    return engine != engine_with(cheap=True).name


def pockets(productivity: np.ndarray, k: int) -> np.ndarray:
    """The indices of the ``k`` largest local maxima (≥ both neighbours; an end counts against its one
    neighbour) of ``productivity`` (S,) with a positive value, the largest first; a plateau counts once (its
    first point)."""
    p = np.asarray(productivity, float)
    left = np.concatenate([[-np.inf], p[:-1]])
    right = np.concatenate([p[1:], [-np.inf]])
    peak = np.flatnonzero((p > left) & (p >= right) & (p > 0))
    if peak.size == 0:  # flat or all zero: the plain argmax
        return np.array([int(np.argmax(p))])
    return peak[np.argsort(-p[peak], kind="stable")][:k]


def keeps_warnings(decide):
    """``decide`` (a decision from a posterior returning a dataclass with a ``warnings`` field: a
    :class:`Recommendation`, a prediction) with every warning it issues passed on as before and kept in its result,
    after the posterior's own: a recommendation or prediction file read alone, or by a program, says what the
    terminal said."""
    @functools.wraps(decide)
    def kept(post: Posterior, *args, **kwargs):
        with collect() as caught:
            rec = decide(post, *args, **kwargs)
        for w in caught:
            emit(w)
        said = [*post.warnings, *(str(w.message) for w in caught)]
        return replace(rec, warnings=tuple(dict.fromkeys(said)))
    return kept


@keeps_warnings
def recommend(post: Posterior, risk: float, rpm_range: tuple[float, float], *, max_depth_mm: float | None = None,
              width_mm: float | None = None, feed_mm: float | None = None, seed: int = 0,
              confidence: float | None = CONFIDENCE, speed_tolerance: float = SPEED_TOLERANCE,
              coarse_points: int = COARSE_POINTS, test_risk: float | None = TEST_RISK,
              guard: bool = True, across: bool | None = None, confirm: str = CONFIRM,
              discriminate: str = DISCRIMINATE, discriminate_rival_lr: float = DISCRIMINATE_RIVAL_LR,
              search: str = "auto", memo: LimitMemo | None = None) -> Recommendation:
    """The cut with the highest removal rate whose P(chatter) ≤ ``risk`` in ``rpm_range``, and the next test.

    Args:
        post: the posterior.
        risk: tolerated probability of chatter, in (0, 1).
        rpm_range: (low, high) spindle speeds [rpm].
        max_depth_mm: the deepest cut allowed [mm] (tool, machine), or ``None``.
        width_mm, feed_mm: radial width of cut and feed per tooth [mm] for a rate in cm³/min; with the posterior's
            tool diameter the width must be its condition's (a width alone then names no rate: :func:`_rate_width`).
        seed: seed of the subsample of the next-test criterion.
        confidence: P(chatter) ≤ risk must hold with this one-sided confidence against the Monte Carlo
            error of the estimate (see the module docstring); ``None``: the plain count ⌊risk·N⌋.
        speed_tolerance: the depth must keep P(chatter) ≤ risk at every speed within ±this fraction.
        coarse_points: speeds of the coarse grid before the refinement (fewer for a slow engine).
        test_risk: the next test's probability of chattering is at most this, in (0, 1]; ``None`` or 1: no cap.
        guard: apply the data guard (:func:`data_guard`; ``False`` only for studies of the model alone).
        across: let the next test be in another condition (the trained ones and the slot) where a test there
            carries more information (:func:`next_test_across`); ``None``: when the posterior knows several
            conditions or decides for one it was not trained in.
        confirm: when the recommendation must be vouched for by a cut labelled stable (no deeper than one whose
            label the posterior believes, at its speed: :func:`confirmed_cuts`; the next
            test is still sought above the model's own cut): ``"conflict"`` while the posterior names a
            prior–data conflict or the data guard holds a chatter cut it does not explain; ``"auto"`` (the default)
            as ``"conflict"`` unless the cuts' chatter frequencies place the modes (:func:`frequencies_place_modes`);
            ``"always"``; ``"never"`` (:data:`CONFIRM`).
        discriminate: ``"conflict"``: while the posterior names a prior–data conflict, the next test is the cut
            that best tells it from the far-off alternative the cuts fit best (:func:`next_test_discriminating`);
            ``"gain"``: while a conflict is named, the cut whose label is expected to raise the recommendation's
            productivity most (:func:`next_test_gain`); ``"never"`` (the default, measured: :data:`DISCRIMINATE`):
            always the most informative cut about θ.
        discriminate_rival_lr: ... only when the rival fits the cuts at least this well (ln likelihood ratio over
            the posterior; ``-inf``: whenever a cut tells the two apart).
        search: the speed search: ``"full"``, every sample on the coarse grid and in the refinement;
            ``"fast"``, a seeded subsample of :data:`SEARCH_SAMPLES` rows (the coarse grid at the same quantile of
            the limits, and the refinement of its :data:`SEARCH_POCKETS` most productive pockets; at the nominal
            speeds only, :data:`SEARCH_SUBSAMPLE_TOLERANCE`) finds where to
            look, then every sample at each pocket's refined speed (and the range's ends) and ±``speed_tolerance``
            chooses among them, refines the chosen pocket once (:data:`SEARCH_POLISH_POINTS`) and sets the depth,
            so its P(chatter) is the full posterior's (the next test reads the subsample's coarse limits); for an
            engine with a censored search the limits it needs only as above or below a depth are censored
            (:data:`SEARCH_CENSOR`, :func:`censor_ceilings`: the same answer);
            ``"auto"`` (the default): fast for an engine other than the cheapest (:func:`fast_search_for`). With
            at most :data:`SEARCH_SAMPLES` samples both are the full search.
        memo: limits remembered from earlier decisions from posteriors of the same prior and engine (a
            :class:`LimitMemo`; a campaign's: most samples and the coarse speeds repeat from round to round), read
            instead of computed again, and the new ones added; the same answer.
    Raises:
        InputError: risk outside (0, 1), a bad speed range or depth limit, a bad confidence, tolerance, test risk
            or confirm, an unknown search.
    Warns:
        UserWarning: the speed range reaches beyond the speeds of the data (the answer leans on the prior
            there); too few effective samples to bound the risk at ``confidence``.
    """
    # a numpy scalar (np.float32(0.05), a value read from an array) is a number: "--risk = 0.05000000074505806 is
    # invalid: must be in (0, 1)" before
    confidence, speed_tolerance, test_risk, max_depth_mm, width_mm, feed_mm = (
        float(x) if isinstance(x, np.number) else x
        for x in (confidence, speed_tolerance, test_risk, max_depth_mm, width_mm, feed_mm))
    risk = check_risk(risk)
    lo, hi = (float(x) for x in rpm_range)
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
        raise InputError("--rpm", f"{lo:g}:{hi:g}", "need 0 < LOW < HIGH rev/min")
    if max_depth_mm is not None and not (math.isfinite(max_depth_mm) and max_depth_mm > 0):
        raise InputError("--max-depth", max_depth_mm, "must be a finite depth > 0 mm")
    if confidence is not None and not (isinstance(confidence, (int, float)) and 0.5 <= confidence < 1):
        raise InputError("confidence", confidence, "must be in [0.5, 1), e.g. 0.9 (or None for the plain count)")
    if not (isinstance(speed_tolerance, (int, float)) and 0 <= speed_tolerance < 0.1):
        raise InputError("speed_tolerance", speed_tolerance, "a relative spindle-speed error in [0, 0.1), e.g. 0.0025")
    if test_risk is not None and not (isinstance(test_risk, (int, float)) and 0 < test_risk <= 1):
        raise InputError("--test-risk", test_risk, "the next test's tolerated probability of chatter, in (0, 1], "
                                                   f"e.g. {TEST_RISK:g} (1: no cap)")
    if confirm not in CONFIRM_CHOICES:
        raise InputError("--confirm", confirm, "one of " + ", ".join(CONFIRM_CHOICES))
    if discriminate not in DISCRIMINATE_CHOICES:
        raise InputError("--discriminate", discriminate, "one of " + ", ".join(DISCRIMINATE_CHOICES))
    factor = _mrr_factor(post.prior.cutting.teeth, *_rate_width(post, width_mm, feed_mm))
    warn_outside(post, lo, hi, stacklevel=3)
    warn_time_averaged(post, stacklevel=3)
    u = post.decision_u  # a new day: with a test-day effect, its shift marginalised
    # every engine call of this decision under one discretisation, each (distinct sample, speed) computed once
    opts = decision_options(post, (lo, hi))
    every = LimitColumns(post, u, opts, memo)
    chatter = chatter_cuts(post, every) if guard else []
    guards = guarding(chatter)
    cap = math.inf if max_depth_mm is None else max_depth_mm
    n = u.shape[0]
    n_eff = effective_samples(post)
    count = allowed_count(n, risk, n_eff, confidence)
    if count < 0:
        warn(f"{n_eff:.0f} effective samples cannot bound P(chatter) ≤ {risk:g} at {confidence:.0%} "
             "confidence: the recommendation is the least limit of all samples; update with more --samples",
             UserWarning, stacklevel=2)
    offsets = np.array([0.0, -speed_tolerance, speed_tolerance]) if speed_tolerance > 0 else np.zeros(1)

    def depths_at(speeds: np.ndarray, support: list[dict] | None, cols: LimitColumns | None = None,
                  cnt: int = count, offsets: np.ndarray = offsets, censor=None) -> tuple[np.ndarray, np.ndarray]:
        # the speeds and their ±tolerance neighbours, the nominal block first (one engine call for those not
        # computed before, on ``cols``' rows: default every sample, censored at ``censor(speeds)`` [mm], by
        # default the fast search's every-sample ceilings)
        at = (speeds[None, :] * (1 + offsets[:, None])).ravel()
        g_all = guard_cap(guards, (speeds[None, :] * (1 + offsets[:, None])))  # the guard holds at the speed error too
        held = np.minimum(g_all.min(axis=0), cap)  # what bounds the depth besides the limits
        if support is not None:  # only as deep as a confirmed stable cut near the speed
            held = np.minimum(held, support_cap(support, speeds))
        censor = censor_at if censor is None and cols is None else censor
        ceil = None
        if censor is not None:  # censored at the depth the speed may hold (at most ``held``)
            ceil = np.maximum(np.minimum(censor(speeds), held * (1 + 1e-9)), CHEAPEST_CEILING)
        cols = every if cols is None else cols
        both = cols(at, None if ceil is None else np.tile(ceil, offsets.size))
        depth = np.minimum(safe_depth(both, risk, cnt).reshape(offsets.size, speeds.size).min(axis=0), held)
        if ceil is not None:
            # a censored entry is a lower bound ≥ its ceiling: the depth is exact where it lies below the ceiling,
            # else the limits there are searched to the root (rare: the ceiling is well above the safe depth)
            short = depth >= ceil * (1 - 2e-9)  # (a safe depth is its order statistic less 1e-9 relative)
            if short.any():  # the short speeds searched to the root, the others read from memory
                both = cols(at, np.tile(np.where(short, np.inf, ceil), offsets.size))
                depth = np.minimum(safe_depth(both, risk, cnt).reshape(offsets.size, speeds.size).min(axis=0), held)
        return np.where(np.isfinite(depth), depth, 0.0), both[:, :speeds.size]

    def best_of(speeds: np.ndarray, support: list[dict] | None) -> tuple[int, np.ndarray, np.ndarray]:
        depth, blim = depths_at(speeds, support)
        return int(np.argmax(depth * speeds)), depth, blim

    def best_bounded(speeds: np.ndarray, support: list[dict] | None, floor: float = -np.inf) -> tuple | None:
        """(speed, depth, every sample's limits at it (N,)) of the most productive of ``speeds`` by every sample
        (its depth held at ±tolerance, :func:`depths_at`), the first of equals as ``np.argmax``; ``None`` when none
        is more productive than ``floor`` [mm·rpm]. The depth at the nominal speed alone bounds the held depth from
        above, so the ±tolerance neighbours are read only for the speeds whose bound can still win (most productive
        bound first): the answer of reading them all (at the a/D 0.1 campaigns' pockets and polish ~2/3 of them)."""
        nominal, blim = depths_at(speeds, support, offsets=np.zeros(1))
        if offsets.size == 1:  # no speed tolerance: the nominal depth is the held one
            depth = nominal
        elif not SEARCH_BOUND:
            depth = depths_at(speeds, support)[0]
        else:
            ub = nominal * speeds
            depth = np.full(speeds.size, -np.inf)
            for i in np.argsort(-ub, kind="stable"):
                if ub[i] <= floor or ub[i] < np.max(depth * speeds):  # neither this one nor any after it can win
                    break
                depth[i] = depths_at(speeds[i:i + 1], support)[0][0]
        j = int(np.argmax(depth * speeds))
        if not depth[j] * speeds[j] > floor:
            return None
        return speeds[j], depth[j], blim[:, j]

    if not (isinstance(coarse_points, (int, np.integer)) and coarse_points >= 3):
        raise InputError("coarse_points", coarse_points, "need an integer ≥ 3 speeds")
    if search not in SEARCH_CHOICES:
        raise InputError("search", search, "one of " + ", ".join(SEARCH_CHOICES))
    fast = n > SEARCH_SAMPLES and (search == "fast" or (search == "auto" and fast_search_for(post.engine)))

    def coarse_grid(support: list[dict] | None) -> np.ndarray:
        speeds = np.linspace(lo, hi, int(coarse_points))
        if support:  # the confirmed cuts' own speeds are candidates too
            speeds = np.union1d(speeds, [c["rpm"] for c in support])
        return speeds

    def search(support: list[dict] | None) -> tuple[np.ndarray, np.ndarray, tuple, np.ndarray | None]:
        """(coarse speeds, their limits (N, S), the best (rpm, depth, limits at it (N,)), None: every row)"""
        if fast:
            return search_fast(support)
        speeds = coarse_grid(support)
        step = speeds[1] - speeds[0]
        i, depth, blim = best_of(speeds, support)
        best = (speeds[i], depth[i], blim[:, i])
        for _ in range(REFINE_ROUNDS):  # bounded 1-D search around the best speed, one engine call per round
            a, b = max(lo, best[0] - step), min(hi, best[0] + step)
            cand = np.linspace(a, b, REFINE_POINTS)
            j, d2, bl2 = best_of(cand, support)
            if d2[j] * cand[j] > best[1] * best[0]:
                best = (cand[j], d2[j], bl2[:, j])
            step = cand[1] - cand[0]
        return speeds, blim, best, None

    def search_fast(support: list[dict] | None) -> tuple[np.ndarray, np.ndarray, tuple, np.ndarray]:
        """The fast search: the coarse scan and the refinement of the best :data:`SEARCH_POCKETS` pockets on a
        seeded subsample of :data:`SEARCH_SAMPLES` rows (at the same quantile of the limits as the full count; the
        nominal speeds only unless :data:`SEARCH_SUBSAMPLE_TOLERANCE`), then every sample at each pocket's speed and
        ±tolerance: the depth, and the choice among the pockets,
        are the full posterior's, which refines the chosen pocket once more. Returns the subsample's coarse limits
        and its rows (for the next test)."""
        cnt = int(round(max(count, 0) * SEARCH_SAMPLES / n))
        speeds = coarse_grid(support)
        step = np.full(SEARCH_POCKETS, speeds[1] - speeds[0])
        sub = offsets if SEARCH_SUBSAMPLE_TOLERANCE else np.zeros(1)
        m_sub, sub_censor = rows.size, None
        if SEARCH_CENSOR and sub_cols.censors and speeds.size >= 5:
            # every other coarse speed to the root (the next test reads those), the ones between censored at a
            # ceiling from their neighbours (they set only the pockets' depth); so is the pockets' refinement
            depth, blim = np.zeros(speeds.size), np.zeros((m_sub, speeds.size))
            depth[::2], blim[:, ::2] = depths_at(speeds[::2], support, sub_cols, cnt, sub)
            sub_censor = censor_ceilings(sub_cols, cnt, m_sub, speeds[1] - speeds[0])
            depth[1::2], blim[:, 1::2] = depths_at(speeds[1::2], support, sub_cols, cnt, sub, censor=sub_censor)
        else:
            depth, blim = depths_at(speeds, support, sub_cols, cnt, sub)
        top = pockets(depth * speeds, SEARCH_POCKETS)
        best_r, best_d = speeds[top], depth[top]
        for _ in range(SEARCH_REFINE_ROUNDS):  # every pocket's bracket in one engine call per round
            a, b = np.maximum(lo, best_r - step[:top.size]), np.minimum(hi, best_r + step[:top.size])
            cand = a[:, None] + (b - a)[:, None] * np.linspace(0.0, 1.0, SEARCH_REFINE_POINTS)[None, :]  # (K, P)
            d2 = depths_at(cand.ravel(), support, sub_cols, cnt, sub, censor=sub_censor)[0].reshape(cand.shape)
            j = np.argmax(d2 * cand, axis=1)
            k = np.arange(top.size)
            better = d2[k, j] * cand[k, j] > best_d * best_r
            best_r, best_d = np.where(better, cand[k, j], best_r), np.where(better, d2[k, j], best_d)
            step = cand[:, 1] - cand[:, 0]
        if SEARCH_CENSOR:  # the every-sample stages' ceilings, from the subsample's limits
            nonlocal censor_at
            censor_at = censor_ceilings(sub_cols, count, n, speeds[1] - speeds[0])
        # every sample decides among the pockets and the range's ends (where the productivity often peaks, and
        # a subsample's noise hides a rise to the end) and sets the depth
        best = best_bounded(np.concatenate([best_r, [lo, hi]]), support)
        w = SEARCH_POLISH_STEPS * (speeds[1] - speeds[0])  # every sample refines the chosen pocket once
        cand = np.linspace(max(lo, best[0] - w), min(hi, best[0] + w), SEARCH_POLISH_POINTS)
        best = best_bounded(cand, support, best[0] * best[1]) or best  # only a more productive cut replaces it
        return speeds, blim, best, rows

    # the fast search's subsample (the rows a map of that many reads), its limits shared by both searches
    censor_at = None  # the every-sample stages' censoring ceilings [mm] at given speeds (the fast search's)
    rows = map_rows(n, SEARCH_SAMPLES, seed) if fast else None
    sub_cols = LimitColumns(post, u[rows], opts, memo) if fast else None
    speeds, blim, best, grid_rows = search(None)
    rpm_best, depth_best, col = best
    model_cut = (float(rpm_best), float(depth_best))  # the model's own cut (the next test is sought above it)
    confirmed = False
    if confirm == "auto":
        confirm = "never" if frequencies_place_modes(post) else "conflict"
    if confirm == "always" or (confirm == "conflict" and (conflict_named(post) or guards)):
        support = confirmed_cuts(post, (lo, hi), offsets, cap, guards, every)
        if support:
            rb, db, cb = search(support)[2]
            if db > 0 and rb * db < rpm_best * depth_best * (1 - 1e-9):
                rpm_best, depth_best, col, confirmed = rb, db, cb, True
    p_ch = float(np.mean(col <= depth_best))
    # the cut's own ±tolerance check (read when it was chosen), known up to the guarding cuts near it (the warning)
    near = [g["depth_mm"] for g in guards if abs(rpm_best - g["rpm"]) <= g["half_width_rpm"]]
    around = every(rpm_best * (1 + offsets), max(max([depth_best, *near]) * (1 + 1e-6), CHEAPEST_CEILING))
    p_worst = float(np.max(np.mean(around <= depth_best, axis=0)))
    bound = None
    if confidence is not None:
        from scipy.stats import beta

        k = p_worst * n_eff
        bound = float(beta.ppf(confidence, k + 1, max(n_eff - k, 1e-12)))
    prod = float(rpm_best * depth_best)
    g_best = float(guard_cap(guards, rpm_best * (1 + offsets)).min())
    limited = ("a cut labelled stable (the cuts contradict the model: no deeper than a stable cut whose "
               "label the posterior believes, at its speed)" if confirmed else
               "max_depth" if depth_best >= cap * (1 - 1e-12) else
               "data guard (a chatter-labelled cut)" if depth_best >= g_best * (1 - 1e-12) else "chatter risk")
    binding = [dict(g, binding=bool(np.any(np.abs(rpm_best * (1 + offsets) - g["rpm"]) <= g["half_width_rpm"])
                                    and depth_best >= g["cap_mm"] * (1 - 1e-12))) for g in guards]
    # where the model alone would go at or above a cut that chattered, the data and the model disagree: say so
    model_depth = float(min(safe_depth(around, risk, count).min(), cap))
    conflict = [g for g in guards if abs(rpm_best - g["rpm"]) <= g["half_width_rpm"] and model_depth >= g["depth_mm"]]
    if conflict and every.censors:  # the depth the warning prints: the limits there to the root
        model_depth = float(min(safe_depth(every(rpm_best * (1 + offsets)), risk, count).min(), cap))
    if conflict:
        g = min(conflict, key=lambda c: (c["cap_mm"], abs(rpm_best - c["rpm"])))
        warn(f"the posterior allows {model_depth:.3g} mm at {rpm_best:.0f} rpm, but a cut chattered at {g['rpm']:.0f} "
             f"rpm, {g['depth_mm']:.3g} mm: the data guard holds the recommendation below {g['cap_mm']:.3g} mm "
             "(the model does not explain that cut; check the label, or update with an engine that models the cut)",
             UserWarning, stacklevel=2)
    beside = explained_below(chatter, rpm_best, depth_best)
    if beside:  # allowed by the rule, but a shop sees a cut deeper than one that chattered nearby: say why
        c = max(beside, key=lambda c: c["depth_mm"])
        warn(f"the recommended {depth_best:.3g} mm at {rpm_best:.0f} rpm is deeper than a cut labelled chatter at "
             f"{c['rpm']:.0f} rpm, {c['depth_mm']:.3g} mm ({abs(rpm_best - c['rpm']):.0f} rpm away, within a lobe's "
             f"width): the posterior explains that cut (P(chatter) there {c['p_model_chatter']:.2f}) and puts the "
             f"limit higher at this speed, so the data guard does not hold it; if that cut's label is doubtful or the "
             f"boundary is not trusted this close to it, cut below {c['depth_mm']:.3g} mm first"
             + (f" ({len(beside)} such cuts)" if len(beside) > 1 else ""), UserWarning, stacklevel=2)
    # the next test reads the coarse grid's limits (every other speed) instead of a second engine call
    # the next test is sought above the MODEL's cut (with a confirmed recommendation too): the tests that teach
    # the model where it may go, and its own cut when nothing above it is allowed and informative
    nt = next_test(post, (lo, hi), *model_cut, cap, seed=seed, grid=(speeds[::2], blim[:, ::2]),
                   test_risk=test_risk, guard=guards, p_chatter_rec=None if confirmed else p_worst, grid_rows=grid_rows)
    if confirmed:
        nt["relative_productivity"] = float(nt["rpm"] * nt["depth_mm"] / max(prod, 1e-300))
        nt["why"] = nt["why"].replace("the recommendation itself", "the model's cut, to be tested before it is "
                                      "recommended (the recommendation is held to a cut labelled stable)", 1)
    from millstab.points import describe_condition, same_condition

    nt["condition"] = describe_condition(post.condition)
    warn_averaged_error(post, float(rpm_best), float(depth_best), risk, seed)
    if across is None:
        trained = post.trained_conditions
        across = len(trained) > 1 or not same_condition(trained[0], post.condition)
    if across:
        nt = next_test_across(post, nt, (lo, hi), cap, seed=seed, test_risk=test_risk, rows=grid_rows)
    elif discriminate == "conflict" and conflict_named(post):
        nt = next_test_discriminating(post, nt, model_cut, (lo, hi), cap, seed=seed, test_risk=test_risk,
                                      guard=guards, reference=prod, min_log_ratio=discriminate_rival_lr)
    elif discriminate == "gain" and conflict_named(post):
        nt = next_test_gain(post, nt, model_cut, risk, (speeds[::2], blim[:, ::2]), cap, seed=seed,
                            test_risk=test_risk, guard=guards, grid_rows=grid_rows, reference=prod)

    return Recommendation(float(rpm_best), float(depth_best), p_ch, prod,
                          None if factor is None else prod * factor, float(risk), nt, limited, p_worst, bound,
                          n_eff, confidence, float(speed_tolerance), tuple(binding), test_risk,
                          _computed_for(post))


def _computed_for(post: Posterior) -> dict:
    """The condition a recommendation is for (:func:`millstab.points.describe_condition`) and, for a posterior over
    the holder, the stickout [mm] it decided at (``stickout_mm``)."""
    from millstab.points import describe_condition
    from millstab.update.stickout import stickout_mm_of

    so = stickout_mm_of(post)
    return describe_condition(post.condition) | ({} if so is None else {"stickout_mm": so})


def next_test_discriminating(post: Posterior, nt: dict, model_cut: tuple[float, float],
                             rpm_range: tuple[float, float], cap: float = math.inf, *, seed: int = 0,
                             test_risk: float | None = TEST_RISK, guard: list[dict] = (),
                             reference: float | None = None, min_log_ratio: float = DISCRIMINATE_RIVAL_LR) -> dict:
    """The next test while the posterior names a prior–data conflict: the conflict test
    (:func:`millstab.update.discriminate.conflict_test`) instead of ``nt``, the most informative cut about θ.

    Why: a posterior that contradicts its hammer test has moved into the prior's tails along the cheapest path
    the cuts allow, not necessarily towards the truth (the softer campaigns: one stiffness far off, the natural
    frequencies left at the tap test's; docs/updating-measured.md, "Why the softer campaigns stop low"). A cut chosen
    for its information about θ under that posterior tests where the posterior is unsure and never asks whether a
    structure it gives no mass to explains the cuts better; the conflict test asks exactly that. ``nt`` stands
    when it tests the recommendation itself (the blind spot, :func:`blind_spot`: a safety rule), when no cut
    tells the two apart (the conflict test returns ``None``) and when the rival fits the cuts so far worse than
    the posterior by more than ``min_log_ratio`` (ln of the mean likelihood ratio; a rival the cuts already
    reject is not worth a test). ``reference``: the recommendation's productivity [mm·rpm], for
    ``relative_productivity``."""
    from millstab.update.discriminate import conflict_test

    if blind_spot(post, *model_cut) is not None:
        return nt
    ct = conflict_test(post, rpm_range, cap, test_risk=1.0 if test_risk is None else test_risk, seed=seed,
                       guard=list(guard))
    if ct is None or ct["rival_log_likelihood_ratio"] < min_log_ratio:
        return nt
    ref = max(reference if reference is not None else model_cut[0] * model_cut[1], 1e-300)
    ct["relative_productivity"] = float(ct["rpm"] * ct["depth_mm"] / ref)
    ct["information_nats"] = ct["divergence_nats"]
    ct["why"] = ("the conflict test: the cuts contradict the hammer test, so " + ct["why"])
    return ct


def next_test_gain(post: Posterior, nt: dict, model_cut: tuple[float, float], risk: float,
                   grid: tuple[np.ndarray, np.ndarray], cap: float = math.inf, *, seed: int = 0,
                   test_risk: float | None = TEST_RISK, guard: list[dict] = (), grid_rows: np.ndarray | None = None,
                   reference: float | None = None, n_depth: int = 40) -> dict:
    """The next test while the posterior names a prior–data conflict: the cut whose label is expected to raise the
    recommendation's productivity most (a one-step look-ahead, "knowledge gradient"), instead of ``nt``, the most
    informative cut about θ.

    For each cut of the grid's speeds × ``n_depth`` depths (at most ``test_risk`` likely to chatter, clear of the data
    guard) the posterior samples are reweighted by each label's likelihood, and the recommendation of each reweighted
    posterior (the weighted ``risk``-quantile of the limits at each speed, capped, the most productive speed) is
    averaged over the two labels (:func:`millstab.update._gain.expected_best`). The gain is that average minus the
    productivity now; the cut with the largest gain is the test. Why (docs/updating-measured.md, "The default prior"): a
    posterior that contradicts its hammer test is often split between lobe numbers, and the recommendation is held
    by the minority of samples whose limit is low in the productive pocket; the most informative cut tests where
    the samples disagree most, often a pocket the truth does not have, while this test asks where a label would
    lift the recommendation. ``nt`` stands when it tests the recommendation itself (the blind spot, a safety rule)
    and when no cut has a positive gain. ``grid`` = (speeds (S,), limits (N, S) of ``grid_rows`` or every sample):
    the limits recommend computed already (no engine call). ``reference``: the recommendation's productivity
    [mm·rpm], for ``relative_productivity``. The speed tolerance and the confidence bound of :func:`recommend` are
    left out of the look-ahead (both labels' answers alike)."""
    from millstab.update._gain import expected_best

    if blind_spot(post, *model_cut) is not None:
        return nt
    speeds, blim = np.asarray(grid[0], float), np.asarray(grid[1], float)
    rows = np.arange(post.u.shape[0]) if grid_rows is None else np.asarray(grid_rows)
    finite = np.where(np.isfinite(blim), blim, np.nan)
    if not np.isfinite(finite).any():
        return nt
    top = float(np.nanquantile(finite, 0.95))
    d_hi = min(cap, 1.2 * top) if math.isfinite(cap) else 1.2 * top
    depths = np.linspace(d_hi / n_depth, d_hi, n_depth)
    sig = post.prior.sigma_depth_mm(depths)
    eps, fac = post.label_error[rows], post.sigma_depth_factor[rows]
    g_cap = guard_cap(list(guard), speeds)
    e, now = expected_best(blim, speeds, np.minimum(g_cap, cap), np.arange(speeds.size), depths, sig, risk, eps, fac)
    _, _, p_process = label_information(blim, depths, sig, eps, fac)
    ok = depths[None, :] < g_cap[:, None]
    if test_risk is not None:
        ok &= p_process <= test_risk
    gain = np.where(ok, e - now, -np.inf)
    i, j = np.unravel_index(int(np.argmax(gain)), gain.shape)
    if not gain[i, j] > 1e-9 * max(now, 1e-300):
        return nt
    ref = max(reference if reference is not None else model_cut[0] * model_cut[1], 1e-300)
    return {"rpm": float(speeds[i]), "depth_mm": float(depths[j]), "p_chatter": float(p_process[i, j]),
            "information_nats": float(nt.get("information_nats", 0.0)), "expected_gain": float(gain[i, j] / ref),
            "relative_productivity": float(speeds[i] * depths[j] / ref),
            "why": "the gain test: the cuts contradict the hammer test, so the cut whose label is expected to raise "
                   f"the recommendation's productivity most (by {gain[i, j] / ref:.1%} of it, averaged over both "
                   "labels)"
                   + ("" if test_risk is None else f", at most {test_risk:g} likely to chatter")}


def blind_spot(post: Posterior, rpm_rec: float, depth_rec: float) -> str | None:
    """Why the next test must be the recommendation itself (the rule in the module docstring), or ``None``.

    Reads the posterior's labelled cuts in their order (the order they were cut)."""
    rpm, depth, grade, _ = _cut_grades(post.cuts_in_condition())
    k = BLIND_SPOT_CHATTERS
    if rpm.size < k:
        return None
    ref = rpm_rec * depth_rec
    last = slice(rpm.size - k, rpm.size)
    if not (np.all(grade[last] > 0.5) and np.all(rpm[last] * depth[last] > ref * (1 + 1e-9))):
        return None
    near = np.abs(rpm - rpm_rec) <= BLIND_SPOT_WIDTH * rpm_rec
    if np.any(near & (grade < 0.5) & (depth >= (1 - GUARD_MARGIN) * depth_rec)):
        return None  # a stable cut near the recommendation, as deep as it: the recommendation is tested
    return (f"the recommendation itself: the last {k} tests, all more productive than it, chattered, and no "
            f"stable cut within ±{BLIND_SPOT_WIDTH:.0%} of its speed is as deep, so no test bounds the "
            "recommendation itself (a chattering test above it says only that the limit is below that test)")


def next_test(post: Posterior, rpm_range: tuple[float, float], rpm_rec: float, depth_rec: float, cap: float = math.inf,
              *, n_rpm: int = 120, n_depth: int = 60, seed: int = 0,
              grid: tuple[np.ndarray, np.ndarray] | None = None, test_risk: float | None = TEST_RISK,
              guard: list[dict] = (), p_chatter_rec: float | None = None,
              grid_rows: np.ndarray | None = None) -> dict:
    """The next test cut: the largest productivity-weighted label information (see the module docstring)
    among cuts more productive than the recommendation whose probability of chattering is at most
    ``test_risk`` and that the data ``guard`` allows; the recommendation itself when there is none.

    ``grid`` = (speeds (S,) [rpm], limits (N, S) [mm] of all the posterior's samples) reuses limits the
    caller has computed already (then ``n_rpm`` is unused); else ``n_rpm`` speeds span ``rpm_range``.
    ``p_chatter_rec``: the recommendation's own P(chatter), reported when it is the next test. ``grid_rows``: the
    posterior rows of ``grid``'s limits (the fast speed search's subsample), which the criterion then reads
    instead of its own subsample.
    """
    rng = np.random.default_rng(seed)
    n = post.u.shape[0]
    rows = rng.choice(n, NEXT_TEST_SAMPLES, replace=False) if n > NEXT_TEST_SAMPLES else np.arange(n)
    if grid is not None and grid_rows is not None:
        rows = np.asarray(grid_rows)

    def the_recommendation(why: str) -> dict:
        p_rec = float(np.mean(distinct_limits(post.prior, post.decision_u[rows], [rpm_rec], post.engine,
                                              post.engine_options)[:, 0] <= depth_rec)) \
            if p_chatter_rec is None else float(p_chatter_rec)
        return {"rpm": float(rpm_rec), "depth_mm": float(depth_rec), "p_chatter": p_rec, "information_nats": 0.0,
                "relative_productivity": 1.0, "why": why}

    blind = blind_spot(post, rpm_rec, depth_rec)
    if blind is not None:
        return the_recommendation(blind)
    if grid is None:
        speeds = np.linspace(*rpm_range, n_rpm)
        blim = distinct_limits(post.prior, post.decision_u[rows], speeds, post.engine, post.engine_options)  # (M, S)
    else:
        speeds, blim = np.asarray(grid[0], float), np.asarray(grid[1], float)
        blim = blim if grid_rows is not None else blim[rows]
    finite = np.where(np.isfinite(blim), blim, np.nan)
    top = float(np.nanquantile(finite, 0.95)) if np.isfinite(finite).any() else 2 * max(depth_rec, 1e-3)
    d_hi = min(cap, 1.2 * top) if math.isfinite(cap) else 1.2 * top
    depths = np.linspace(d_hi / n_depth, d_hi, n_depth)
    sig = post.prior.sigma_depth_mm(depths)  # (D,)
    # the posterior's own label model: each sample's learned label error ε and depth-noise factor s
    # (S, D): P(chatter label), mutual information [nats], the cut's own chance to chatter (no label error)
    pbar, info, p_process = label_information(blim, depths, sig, post.label_error[rows], post.sigma_depth_factor[rows])
    prod = speeds[:, None] * depths[None, :]
    ref = max(rpm_rec * depth_rec, 1e-300)
    score = info * prod / ref
    ok = (prod > ref * (1 + 1e-9)) & (depths[None, :] < guard_cap(list(guard), speeds)[:, None])
    if test_risk is not None:
        ok &= p_process <= test_risk
    # an exactly certain outcome has information ~1e-15 of round-off: not worth a cut
    ok &= info > 1e-6
    if not ok.any():
        return the_recommendation("the recommendation itself: no cut within the limits that is more productive is "
                                  "also informative" + ("" if test_risk is None else f", at most {test_risk:g} likely "
                                                        "to chatter") + (" and clear of the chatter-labelled cuts"
                                                                         if len(guard) else ""))
    score = np.where(ok, score, -np.inf)
    i, j = np.unravel_index(int(np.argmax(score)), score.shape)
    return {"rpm": float(speeds[i]), "depth_mm": float(depths[j]), "p_chatter": float(p_process[i, j]),
            "p_label_chatter": float(pbar[i, j]),
            "information_nats": float(info[i, j]), "relative_productivity": float(prod[i, j] / ref),
            "why": "largest expected information about the parameters (mutual information between the cut's label "
                   "and θ) times its productivity relative to the recommendation, among cuts more productive than "
                   "the recommendation" + ("" if test_risk is None else f" at most {test_risk:g} likely to chatter")}


#: the next test moves to another condition only where its label carries this many times the information of the best
#: test in the decision's own: a binary label carries at most ln 2 = 0.69 nats, and the best tests of every condition
#: sit near that cap once the posterior is uncertain (a user's test: 0.560 against 0.558 nats moved the test to
#: another condition); a test in the decision's own condition also checks the model where the decision is made, which
#: matters where the model is off between conditions (docs/updating-measured.md, the `sym` machine's extrapolation)
ACROSS_MARGIN = 1.1


def next_test_across(post: Posterior, nt: dict, rpm_range: tuple[float, float], cap: float = math.inf, *,
                     seed: int = 0, test_risk: float | None = TEST_RISK, n_rpm: int = 60, n_depth: int = 40,
                     rows: np.ndarray | None = None) -> dict:
    """The next test ``nt`` of the decision's condition, or a test in another condition that carries more
    information per test.

    Candidates: the conditions the posterior was trained in and the slot of the decision's tool (a slot
    teaches the structure cheaply: both directions load, and its limits are the lowest, so shallow cuts
    decide), the decision's own excluded. In each, the cut with the largest mutual information between its
    label and θ (the measure of :func:`next_test`, per test: no productivity weight, since a test's cost is
    one cut whichever the condition) among cuts at most ``test_risk`` likely to chatter and clear of that
    condition's data guard. It replaces ``nt`` when its information exceeds :data:`ACROSS_MARGIN` times ``nt``'s
    (which is 0 when ``nt`` is the recommendation itself); ``why`` then says which condition and why. Why per test and
    not per productivity: the information is about the shared parameters, which every condition's decision reads;
    the productivity weight of :func:`next_test` ranks cuts of one condition by what they may unlock there.
    One engine call per candidate condition: ``n_rpm`` speeds, the posterior rows ``rows`` (the fast speed search's
    subsample, whose information ``nt`` was measured on; default a seeded draw of :data:`NEXT_TEST_SAMPLES`), each
    distinct row once (:func:`distinct_limits`), for a new day (:attr:`Posterior.decision_u`, as ``nt``'s).

    Why the subsample (measured, 2026-11-28): a spectral posterior of 500 samples trained in a slot, a/D 0.5 down and
    a/D 0.25 up, deciding for a/D 0.1 down, spent 82 of its recommendation's 87 s CPU here, on 500 rows × 60 speeds in
    each other condition (1.7 ms a limit in the slot), against 5 s for the decision itself.
    """
    from dataclasses import replace

    from millstab.points import condition_text, describe_condition, same_condition

    here = post.condition
    slot = replace(here, entry=0.0, exit=math.pi)
    cands = [c for c in (*post.trained_conditions, slot) if not same_condition(c, here)]
    cands = [c for i, c in enumerate(cands) if not any(same_condition(c, d) for d in cands[:i])]
    if rows is None:
        rng = np.random.default_rng(seed)
        n = post.u.shape[0]
        rows = rng.choice(n, NEXT_TEST_SAMPLES, replace=False) if n > NEXT_TEST_SAMPLES else np.arange(n)
    rows = np.asarray(rows)
    speeds = np.linspace(*rpm_range, n_rpm)
    best = None
    for c in cands:
        q = post.for_condition(c)
        blim = distinct_limits(q.prior, q.decision_u[rows], speeds, q.engine, q.engine_options)
        finite = np.where(np.isfinite(blim), blim, np.nan)
        if not np.isfinite(finite).any():
            continue
        top = float(np.nanquantile(finite, 0.95))
        d_hi = min(cap, 1.2 * top) if math.isfinite(cap) else 1.2 * top
        depths = np.linspace(d_hi / n_depth, d_hi, n_depth)
        pbar, info, p_process = label_information(blim, depths, q.prior.sigma_depth_mm(depths), q.label_error[rows],
                                                  q.sigma_depth_factor[rows])
        ok = (depths[None, :] < guard_cap(data_guard(q), speeds)[:, None]) & (info > 1e-6)
        if test_risk is not None:
            ok &= p_process <= test_risk
        if not ok.any():
            continue
        score = np.where(ok, info, -np.inf)
        i, j = np.unravel_index(int(np.argmax(score)), score.shape)
        if best is None or info[i, j] > best[0]:
            best = (float(info[i, j]), c, float(speeds[i]), float(depths[j]), float(p_process[i, j]), float(pbar[i, j]))
    own = float(nt.get("information_nats", 0.0))
    if best is None or best[0] <= ACROSS_MARGIN * own:
        return nt
    info, c, rpm, depth, p_ch, p_lab = best
    return {"rpm": rpm, "depth_mm": depth, "p_chatter": p_ch, "p_label_chatter": p_lab, "information_nats": info,
            "relative_productivity": None, "condition": describe_condition(c),
            "why": f"a test in another condition ({condition_text(c)}) carries more information about the shared "
                   f"parameters: {info:.3f} nats per test against {own:.3f} for the best test in the decision's "
                   f"condition ({condition_text(here)}); the structure and coefficients it teaches are those of "
                   "every condition" + ("" if test_risk is None else f"; at most {test_risk:g} likely to chatter")}


__all__ = ["MAP_SAMPLES", "map_samples", "map_samples_text", "SEARCH_BOUND", "SEARCH_CENSOR", "censor_ceilings",
           "map_ceiling", "SEARCH_CHOICES", "SEARCH_POCKETS", "SEARCH_SAMPLES", "LimitColumns",
           "LimitMemo", "decision_options", "distinct_limits", "fast_search_for", "map_error",
           "map_rows", "pockets",
           "ACROSS_MARGIN", "next_test_across", "next_test_discriminating", "next_test_gain", "DISCRIMINATE",
           "DISCRIMINATE_CHOICES",
           "DISCRIMINATE_RIVAL_LR", "CONFIRM",
           "CONFIRM_CHOICES", "CONFIDENCE", "CONFIRM_P_CHATTER", "CONFIRM_WIDTH",
           "confirmed_cuts", "conflict_named", "frequencies_place_modes", "PLACE_MODES_CUTS", "support_cap",
           "keeps_warnings", "warn_averaged_error", "warn_time_averaged",
           "GUARD_EXPLAINED", "GUARD_LOBE_FRACTION", "GUARD_MARGIN",
           "SPEED_TOLERANCE", "TEST_RISK", "Recommendation",
           "allowed_count", "blind_spot", "chatter_cuts", "data_guard", "explained_below", "guarding",
           "effective_samples", "guard_cap", "next_test",
           "p_stable_from_limits", "p_stable_map", "recommend", "safe_depth"]
