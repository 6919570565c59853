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
  between the best point's neighbours, each round one engine call, the bracket shrinking each time.
* :func:`next_test`: the cut with the largest expected information about the parameters per unit of
  productivity, among cuts more productive than the recommendation (criterion: the mutual information
  between the cut's label and θ, I = H(E_θ π) − E_θ H(π), π = Φ((b − b_lim(θ))/σ_b) the label
  probability of the likelihood (ε + (1 − 2ε)·Φ with a label error ε) — "BALD" — times the cut's productivity relative to the
  recommendation). It is the test most likely both to shrink the uncertainty and to move the
  recommendation to a more productive cut; evaluated on a subsample of the posterior.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from millstab.errors import InputError
from millstab.update._bald import label_information
from millstab.update.likelihood import limits
from millstab.update.posterior import Posterior
from millstab.warnlog import warn

#: speeds of the coarse grid of :func:`recommend`
COARSE_POINTS = 200
#: speeds per refinement round, and rounds
REFINE_POINTS = 24
REFINE_ROUNDS = 3
#: posterior samples used for the next-test criterion (its cost is quadratic-free but per sample)
NEXT_TEST_SAMPLES = 1000
#: one-sided confidence with which the recommendation's P(chatter) ≤ risk must hold against the
#: Monte Carlo error of its estimate (None in :func:`recommend`: the plain count ⌊risk·N⌋)
CONFIDENCE = 0.9
#: relative spindle-speed error (±) the recommended depth must tolerate
SPEED_TOLERANCE = 0.0025


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
    below = np.searchsorted(flat, (d[None, :] + off).ravel(), side="right").reshape(s, d.size) - n * np.arange(s)[:, None]
    return 1.0 - below / n


def p_stable_map(post: Posterior, rpm, depth_mm, client=None) -> np.ndarray:
    """P(stable) on the grid rpm (S,) × depth_mm (D,), shape (S, D); one engine call (``client``: on its
    Dask cluster where that pays, same numbers)."""
    blim, _ = limits(post.prior, post.u, np.asarray(rpm, float), post.engine, client=client)
    return p_stable_from_limits(blim, np.asarray(depth_mm, float))


def warn_outside(post: Posterior, lo: float, hi: float, what: str = "the answer", stacklevel: int = 2) -> None:
    """Warn when the speeds ``lo``..``hi`` [rpm] reach more than 10 % beyond the tested speeds: there
    ``what`` leans on the prior."""
    data_rpm = np.asarray(post.cuts.get("rpm") or [], float)
    if data_rpm.size and (lo < 0.9 * data_rpm.min() or hi > 1.1 * data_rpm.max()):
        warn(f"the speed range {lo:g}-{hi:g} rpm reaches beyond the tested speeds ({data_rpm.min():g}-"
             f"{data_rpm.max():g} rpm): there {what} leans on the prior", UserWarning, stacklevel=stacklevel + 1)


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

    def to_json(self) -> dict:
        out = {"schema": "millstab.recommendation/1", "rpm": self.rpm, "depth_mm": self.depth_mm,
               "p_chatter": self.p_chatter, "risk": self.risk, "limited_by": self.limited_by,
               "relative_productivity_mm_rpm": self.productivity, "next_test": self.next_test,
               "p_chatter_speed_error": self.p_chatter_speed_error, "p_chatter_bound": self.p_chatter_bound,
               "effective_samples": self.effective_samples, "confidence": self.confidence,
               "speed_tolerance": self.speed_tolerance}
        if self.mrr_cm3_per_min is not None:
            out["mrr_cm3_per_min"] = self.mrr_cm3_per_min
        return out


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
    if width_mm is None or feed_mm is None:
        raise InputError("--radial-width" if width_mm is None else "--feed-per-tooth", None,
                         "give both the radial width and the feed per tooth for a removal rate in cm^3/min")
    for name, v in (("--radial-width", width_mm), ("--feed-per-tooth", feed_mm)):
        if not (math.isfinite(v) and v > 0):
            raise InputError(name, v, "must be a finite number > 0 mm")
    return width_mm * feed_mm * teeth / 1000.0  # mm·mm·mm/min per (mm·rpm) → cm³/min


def recommend(post: Posterior, risk: float, rpm_range: tuple[float, float], *, max_depth_mm: float | None = None,
              width_mm: float | None = None, feed_mm: float | None = None, seed: int = 0,
              confidence: float | None = CONFIDENCE, speed_tolerance: float = SPEED_TOLERANCE,
              coarse_points: int = COARSE_POINTS) -> Recommendation:
    """The cut with the highest removal rate whose P(chatter) ≤ ``risk`` in ``rpm_range``, and the next test.

    Args:
        post: the posterior.
        risk: tolerated probability of chatter, in (0, 1).
        rpm_range: (low, high) spindle speeds [rpm].
        max_depth_mm: the deepest cut allowed [mm] (tool, machine), or ``None``.
        width_mm, feed_mm: radial width of cut and feed per tooth [mm] for a rate in cm³/min.
        seed: seed of the subsample of the next-test criterion.
        confidence: P(chatter) ≤ risk must hold with this one-sided confidence against the Monte Carlo
            error of the estimate (see the module docstring); ``None``: the plain count ⌊risk·N⌋.
        speed_tolerance: the depth must keep P(chatter) ≤ risk at every speed within ±this fraction.
        coarse_points: speeds of the coarse grid before the refinement (fewer for a slow engine).
    Raises:
        InputError: risk outside (0, 1), a bad speed range or depth limit, a bad confidence or tolerance.
    Warns:
        UserWarning: the speed range reaches beyond the speeds of the data (the answer leans on the prior
            there); too few effective samples to bound the risk at ``confidence``.
    """
    if not (isinstance(risk, (int, float)) and 0 < risk < 1):
        raise InputError("--risk", risk, "the tolerated probability of chatter must be in (0, 1), e.g. 0.05")
    lo, hi = (float(x) for x in rpm_range)
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
        raise InputError("--rpm", f"{lo:g}:{hi:g}", "need 0 < LOW < HIGH rev/min")
    if max_depth_mm is not None and not (math.isfinite(max_depth_mm) and max_depth_mm > 0):
        raise InputError("--max-depth", max_depth_mm, "must be a finite depth > 0 mm")
    if confidence is not None and not (isinstance(confidence, (int, float)) and 0.5 <= confidence < 1):
        raise InputError("confidence", confidence, "must be in [0.5, 1), e.g. 0.9 (or None for the plain count)")
    if not (isinstance(speed_tolerance, (int, float)) and 0 <= speed_tolerance < 0.1):
        raise InputError("speed_tolerance", speed_tolerance, "a relative spindle-speed error in [0, 0.1), e.g. 0.0025")
    factor = _mrr_factor(post.prior.cutting.teeth, width_mm, feed_mm)
    warn_outside(post, lo, hi, "the recommendation", stacklevel=3)
    cap = math.inf if max_depth_mm is None else max_depth_mm
    u = post.u
    n = u.shape[0]
    n_eff = effective_samples(post)
    count = allowed_count(n, risk, n_eff, confidence)
    if count < 0:
        warn(f"{n_eff:.0f} effective samples cannot bound P(chatter) ≤ {risk:g} at {confidence:.0%} "
             "confidence: the recommendation is the least limit of all samples; update with more --samples",
             UserWarning, stacklevel=2)
    offsets = np.array([0.0, -speed_tolerance, speed_tolerance]) if speed_tolerance > 0 else np.zeros(1)

    def best_of(speeds: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
        # one engine call for the speeds and their ±tolerance neighbours; the nominal block first
        both, _ = limits(post.prior, u, (speeds[None, :] * (1 + offsets[:, None])).ravel(), post.engine)
        blim = both[:, :speeds.size]
        d_all = safe_depth(both, risk, count).reshape(offsets.size, speeds.size)
        depth = np.minimum(d_all.min(axis=0), cap)
        depth = np.where(np.isfinite(depth), depth, 0.0)
        return int(np.argmax(depth * speeds)), depth, blim

    if not (isinstance(coarse_points, (int, np.integer)) and coarse_points >= 3):
        raise InputError("coarse_points", coarse_points, "need an integer ≥ 3 speeds")
    speeds = np.linspace(lo, hi, int(coarse_points))
    i, depth, blim = best_of(speeds)
    best = (speeds[i], depth[i], blim[:, i])
    step = speeds[1] - speeds[0]
    for _ in range(REFINE_ROUNDS):  # bounded 1-D search around the best speed, one engine call per round
        a, b = max(lo, best[0] - step), min(hi, best[0] + step)
        cand = np.linspace(a, b, REFINE_POINTS)
        j, d2, bl2 = best_of(cand)
        if d2[j] * cand[j] > best[1] * best[0]:
            best = (cand[j], d2[j], bl2[:, j])
        step = cand[1] - cand[0]
    rpm_best, depth_best, col = best
    p_ch = float(np.mean(col <= depth_best))
    around, _ = limits(post.prior, u, rpm_best * (1 + offsets), post.engine)  # the cut's own ±tolerance check
    p_worst = float(np.max(np.mean(around <= depth_best, axis=0)))
    bound = None
    if confidence is not None:
        from scipy.stats import beta

        k = p_worst * n_eff
        bound = float(beta.ppf(confidence, k + 1, max(n_eff - k, 1e-12)))
    prod = float(rpm_best * depth_best)
    limited = "max_depth" if depth_best >= cap * (1 - 1e-12) else "chatter risk"
    # the next test reads the coarse grid's limits (every other speed) instead of a second engine call
    nt = next_test(post, (lo, hi), rpm_best, depth_best, cap, seed=seed, grid=(speeds[::2], blim[:, ::2]))
    return Recommendation(float(rpm_best), float(depth_best), p_ch, prod,
                          None if factor is None else prod * factor, float(risk), nt, limited, p_worst, bound,
                          n_eff, confidence, float(speed_tolerance))


def next_test(post: Posterior, rpm_range: tuple[float, float], rpm_rec: float, depth_rec: float, cap: float = math.inf,
              *, n_rpm: int = 120, n_depth: int = 60, seed: int = 0,
              grid: tuple[np.ndarray, np.ndarray] | None = None) -> dict:
    """The next test cut: the largest productivity-weighted label information (see the module docstring).

    ``grid`` = (speeds (S,) [rpm], limits (N, S) [mm] of all the posterior's samples) reuses limits the
    caller has computed already (then ``n_rpm`` is unused); else ``n_rpm`` speeds span ``rpm_range``.
    """
    rng = np.random.default_rng(seed)
    n = post.u.shape[0]
    rows = rng.choice(n, NEXT_TEST_SAMPLES, replace=False) if n > NEXT_TEST_SAMPLES else np.arange(n)
    if grid is None:
        speeds = np.linspace(*rpm_range, n_rpm)
        blim, _ = limits(post.prior, post.u[rows], speeds, post.engine)  # (M, S)
    else:
        speeds, blim = np.asarray(grid[0], float), np.asarray(grid[1], float)[rows]
    finite = np.where(np.isfinite(blim), blim, np.nan)
    top = float(np.nanquantile(finite, 0.95)) if np.isfinite(finite).any() else 2 * max(depth_rec, 1e-3)
    d_hi = min(cap, 1.2 * top) if math.isfinite(cap) else 1.2 * top
    depths = np.linspace(d_hi / n_depth, d_hi, n_depth)
    sig = post.prior.sigma_depth_mm(depths)  # (D,)
    pbar, info = label_information(blim, depths, sig, post.prior.label_error)  # (S, D): P(chatter label), mutual information [nats]
    prod = speeds[:, None] * depths[None, :]
    ref = max(rpm_rec * depth_rec, 1e-300)
    score = info * prod / ref
    better = prod > ref
    if better.any():
        score = np.where(better, score, -np.inf)
    i, j = np.unravel_index(int(np.argmax(score)), score.shape)
    return {"rpm": float(speeds[i]), "depth_mm": float(depths[j]), "p_chatter": float(pbar[i, j]),
            "information_nats": float(info[i, j]), "relative_productivity": float(prod[i, j] / ref),
            "why": "largest expected information about the parameters (mutual information between the cut's label "
                   "and θ) times its productivity relative to the recommendation, among cuts more productive than "
                   "the recommendation" if better.any() else
                   "largest expected information about the parameters (no cut in range is more productive than the "
                   "recommendation)"}


__all__ = ["CONFIDENCE", "SPEED_TOLERANCE", "Recommendation", "allowed_count", "effective_samples", "next_test", "p_stable_from_limits", "p_stable_map", "recommend", "safe_depth"]
