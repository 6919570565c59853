"""The default solver: multi-start bounded trust-region least squares in log-parameters.

Stages (u = ln θ throughout; every stage evaluates its candidates in ONE batched engine call per step):

1. **Screening.** ``n_candidates`` scrambled-Sobol points (seeded) fill a search box around the start
   (fn ×/÷ 1.5, k ×/÷ 2.5, ζ ×/÷ 2.5 by default, inside the parameterization's bounds), plus the start, all
   evaluated in one call. When every stiffness is free, the common stiffness scale is profiled out
   in closed form (all k × c ⇒ every depth × c), so the box is searched in one dimension less.
2. **Batched Levenberg–Marquardt, successive halving.** The best 32 distinct candidates run 3 LM
   iterations together, the best 8 of them 5 more, the best 2 up to 30 (``schedule``); each iteration
   evaluates every start's trial point and its forward-difference rows in one call. While the RMS
   residual stays above ``good_rms``, up to ``rounds`` re-seeding rounds re-sample one mode at a time
   (the others held at the best so far) plus fresh global candidates and halve again — a wrong basin
   is usually one mode's (fn, k, ζ) caught in a neighbouring valley. Finally ``n_local`` points in the
   linearised 3σ confidence region of the best solution are tried (one call) and halved again.
2a. **Zero-order basins** (engines other than ``zoa``; issue 28; after the first halving, before the
   re-seeding). The accurate engines' objective is rough
   (narrow lobe bands found or not as the parameters move), so which basin their screening ends in turned
   on 0.1 %-level depth differences. The zero-order engine's own global search runs on the same points
   (~1 000× cheaper per evaluation) and its distinct end points, whole and each of their modes put into
   the accurate search's best point and into the start, run batched LM under the accurate engine and
   compete by their accurate residual (:func:`basin_search`; opt-in, ``zoa_basins=8``: it did not yet
   move the issue's failing case out of its wrong basin, docs/identification.md).
2b'. **Merged modes** (``merge``, default on; after the re-seeding, while the RMS residual exceeds
   ``good_rms``). At low immersion two modes of one frequency act much like one, and the search can end
   with one mode carrying the whole boundary and the other parked where the points do not see it, outside
   the search box (issue 28, Example 1 at a/D 0.1). Every mode is put onto every other (fn ×0.95/1/1.05,
   k and ζ ×0.5/1/2; the stiffness profile splits the load) and those starts are halved like a
   re-seeding round (:func:`merge_modes`). It moved that case from its wrong basin to the truth.
3. **Polish.** ``scipy.optimize.least_squares(method="trf")`` from the best refined start, with the
   chosen robust ``loss``; its Jacobian comes from the same batched call as its residuals (the
   residual row plus P forward-difference rows), never scipy's per-column differences.

4. **x = y?** In an x/y-symmetric cut the tied model is fitted as well and reported when an F-test
   does not reject it (:mod:`~millstab.identify.tie`: near x = y a free fit splits the pairs by
   noise alone, with overconfident standard errors); with a robust ``loss`` the test, like the standard
   errors, leaves out the points the fit flags as outliers (:func:`~millstab.identify.quality.kept_points`).

Diagnostics at the solution: cov_u = σ²(JᵀJ)⁻¹ in log-parameters with σ the residual scatter
√(RSS/(n − p)) — or a stated (``noise``) or assumed depth noise where the points leave few or no
degrees of freedom (:func:`~millstab.identify.quality.error_sigma`) — standard errors
θ·√diag(cov_u) (delta method), the correlation matrix, cond(JᵀJ); warnings for an exact x↔y symmetry
(slotting: the estimate is returned in canonical order, fn_x ≤ fn_y) and for the general exact x↔y
mode exchange of the zero-order SLD (any cut with α_xx α_yy > 0: (fn, ζ) of x and y exchanged,
k_x' = (α_xx/α_yy) k_y, k_y' = k_x α_yy/α_xx — :func:`~millstab.identify.symmetry.exchange_map`; the
exchanged estimate, which explains the points equally well, is listed first in the alternatives and the
solver cannot prefer either: with noise-free data it returns whichever basin the start leads to), near-singular JᵀJ,
strongly correlated pairs, and other multi-start solutions inside the 95 % joint confidence region
RSS ≤ RSS_min (1 + p/(n − p) F_{p, n−p}(0.95)) (Beale 1960) that differ from the estimate. Then the
quality checks of :func:`~millstab.identify.quality.diagnose` (degrees of freedom, poor or systematic
residuals, the zero-order model's known weak cuts), each warning with a code in ``Fit.codes``.
"""

from __future__ import annotations

import time
from typing import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize, stats
from scipy.stats import qmc

from millstab.errors import InputError
from millstab.forward import FD_STEP, fd_rows  # noqa: F401 (FD_STEP: the solver's step, re-exported)
from millstab.forward import fd_difference as jacobians
from millstab.identify.objective import Problem
from millstab.identify.quality import check_noise, diagnose, error_sigma, kept_points, residual_scale
from millstab.identify.result import Fit
from millstab.identify.search import SEARCH, options_with, pick_distinct, search_box, sobol
from millstab.identify.symmetry import (canonical, exchange_map, exchange_note, exchanged, swap_permutation,
                                        xy_symmetry_note)
from millstab.identify.tie import prefer_tied
from millstab.progress import SolverProgress

LOSSES = ("linear", "soft_l1", "huber", "cauchy", "arctan")
#: successive halving of the re-seeding rounds' and of the confidence-region candidates
RESEED_SCHEDULE = ((16, 3), (4, 8), (2, 30))
LOCAL_SCHEDULE = ((8, 4), (2, 20))


def screen(problem: Problem, u0: np.ndarray, n_candidates: int, seed: int,
           search=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stage 1: QMC candidates in the search box plus the start, one engine call.

    Returns (u (N, P), predictions (N, n) [mm], rss (N,)), k-profiled when possible.
    """
    blo, bhi = search_box(problem, u0, search)
    sob = sobol(problem.p, n_candidates, seed)
    u = np.vstack([u0[None], blo + sob * (bhi - blo)])
    pred = problem.predict_u(u)
    u, pred = problem.profile_k(u, pred)
    return u, pred, problem.rss(pred)


def batched_lm(problem: Problem, u: np.ndarray, *, max_iter: int = 40, tol: float = 1e-10, central: bool = False,
               record: Callable[[np.ndarray, np.ndarray], None] | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Stage 2: Levenberg–Marquardt on K starts at once in log-parameters, inside the bounds.

    Each iteration is ONE engine call holding every start's trial point and its difference rows.
    Returns (u (K, P), rss (K,), J at u (K, n, P), iterations).
    """
    lo, hi = np.log(problem.par.lower), np.log(problem.par.upper)
    u = np.clip(u, lo, hi)
    rows, steps = fd_rows(u, lo, hi, central=central)
    r, jac = jacobians(problem.residuals(problem.predict_u(rows)), steps, central)
    cost = np.einsum("ki,ki->k", r, r)
    lam = np.full(u.shape[0], 1e-2)
    active = np.ones(u.shape[0], bool)
    it = 0
    for it in range(1, max_iter + 1):
        jtj = np.einsum("kip,kiq->kpq", jac, jac)
        g = np.einsum("kip,ki->kp", jac, r)
        diag = np.einsum("kpp->kp", jtj)
        a = jtj + (lam[:, None] * (diag + 1e-12 * diag.max(axis=1, keepdims=True)))[:, :, None] * np.eye(u.shape[1])
        try:
            delta = -np.linalg.solve(a, g[..., None])[..., 0]
        except np.linalg.LinAlgError:
            delta = -np.linalg.lstsq(a.reshape(-1, u.shape[1]), g.reshape(-1), rcond=None)[0].reshape(u.shape)
        delta = np.clip(delta, -0.5, 0.5)  # never jump more than ×/÷ 1.65 in one step
        u_new = np.clip(u + delta, lo, hi)
        rows, steps = fd_rows(u_new[active], lo, hi, central=central)
        r_new, jac_new = jacobians(problem.residuals(problem.predict_u(rows)), steps, central)
        c_new = np.einsum("ki,ki->k", r_new, r_new)
        idx = np.flatnonzero(active)
        better = c_new < cost[idx]
        acc = idx[better]
        rel_drop = np.zeros(u.shape[0])
        rel_drop[acc] = (cost[acc] - c_new[better]) / np.maximum(cost[acc], 1e-300)
        u[acc], r[acc], jac[acc], cost[acc] = u_new[acc], r_new[better], jac_new[better], c_new[better]
        lam[acc] = np.maximum(lam[acc] / 3.0, 1e-9)
        lam[idx[~better]] *= 4.0
        if record is not None:
            record(u, cost)
        # a start is done when its accepted steps stop paying or its damping has exploded
        done = np.zeros(u.shape[0], bool)
        done[acc] = (rel_drop[acc] < tol) | (np.abs(delta[acc]).max(axis=1) < 1e-9)
        done |= lam > 1e8
        active &= ~done
        if not active.any():
            break
    return u, cost, jac, it


class _Cached:
    """Residuals and Jacobian of one parameter vector from ONE engine call (residual row + P difference rows)."""

    def __init__(self, problem: Problem, central: bool):
        self.problem, self.central = problem, central
        self.lo, self.hi = np.log(problem.par.lower), np.log(problem.par.upper)
        self.key: bytes | None = None
        self.r = self.j = None
        self.n_iter = 0

    def _eval(self, u: np.ndarray) -> None:
        key = u.tobytes()
        if key != self.key:
            rows, steps = fd_rows(u[None], self.lo, self.hi, central=self.central)
            r, j = jacobians(self.problem.residuals(self.problem.predict_u(rows)), steps, self.central)
            self.key, self.r, self.j = key, r[0], j[0]

    def fun(self, u: np.ndarray) -> np.ndarray:
        self._eval(u)
        return self.r

    def jac(self, u: np.ndarray) -> np.ndarray:
        self._eval(u)
        self.n_iter += 1
        return self.j


def covariance(jac: np.ndarray, rss: float, n: int, p: int, sigma2: float | None = None) -> tuple[np.ndarray, float]:
    """cov_u = σ²(JᵀJ)⁻¹ (pseudo-inverse when singular), and cond(JᵀJ); σ² = RSS/(n − p) unless given."""
    jtj = jac.T @ jac
    cond = float(np.linalg.cond(jtj))
    if sigma2 is None:
        sigma2 = rss / max(n - p, 1)
    return sigma2 * np.linalg.pinv(jtj, rcond=1e-15), cond


def mode_blocks(problem: Problem) -> list[list[int]]:
    """Column groups of θ, one per mode (direction, mode index) of the free parameters."""
    blocks: dict[tuple, list[int]] = {}
    for j, name in enumerate(problem.par.free):
        d, i, _ = problem.par._slots(name)[0]
        blocks.setdefault((d, i), []).append(j)
    return list(blocks.values())


def halving(problem: Problem, u: np.ndarray, cost: np.ndarray, schedule, perm, record=None, central: bool = False):
    """Successive halving of LM starts: the best distinct ``schedule[0][0]`` candidates run
    ``schedule[0][1]`` batched LM iterations, the best ``schedule[1][0]`` of them go on, and so on.

    Returns (u (K, P), rss (K,), iterations) of the last stage.
    """
    u = u[pick_distinct(u, cost, schedule[0][0], 0.05, perm)]
    c = cost
    its = 0
    for k, iters in schedule:
        if u.shape[0] > k:
            u = u[np.argsort(c, kind="stable")[:k]]
        u, c, _, it = batched_lm(problem, u.copy(), max_iter=iters, central=central, record=record)
        its += it
    return u, c, its


def fit_lsq(problem: Problem, theta0: np.ndarray | None = None, *, tie_xy: bool = True, **options) -> Fit:
    """Identify the free parameters of ``problem`` by multi-start least squares (see module docstring).

    Args:
        theta0: start [Hz, N/m, -]; default the parameterization's start (the config's structure).
        tie_xy: in an x/y-symmetric cut, also fit x = y and report it when the points do not reject it
            (:mod:`~millstab.identify.tie`).
        options: the search settings of :func:`fit_lsq_free` (``noise``: the stated relative depth noise).
    """
    free = fit_lsq_free(problem, theta0, **options)
    fit = free if not tie_xy else prefer_tied(problem, free, lambda prob, start: fit_lsq_free(prob, start, **options))
    return diagnose(fit, problem, options.get("noise"))


def check_options(loss: str, n_candidates: int, schedule) -> None:
    """InputError for an unknown robust loss or an empty screening/halving schedule."""
    if loss not in LOSSES:
        raise InputError("loss", loss, f"must be one of {', '.join(LOSSES)}")
    if n_candidates < 1 or not schedule or any(k < 1 or i < 1 for k, i in schedule):
        raise InputError("schedule", schedule,
                         "need n_candidates >= 1 and a schedule of (starts >= 1, iterations >= 1)")


class History:
    """The best-so-far path of the search, one entry per recorded step (``Fit.history_*``); called as
    ``record(u (K, P), rss (K,))`` by every stage, it also reports ``progress("lsq", step, best rss)``."""

    def __init__(self, progress: SolverProgress | None = None):
        self.progress = progress
        self.u: list[np.ndarray] = []
        self.rss: list[float] = []

    def __call__(self, u: np.ndarray, cost: np.ndarray) -> None:
        i = int(np.argmin(cost))
        if self.rss and self.rss[-1] <= cost[i]:
            self.u.append(self.u[-1])
            self.rss.append(self.rss[-1])
        else:
            self.u.append(u[i].copy())
            self.rss.append(float(cost[i]))
        if self.progress is not None:
            self.progress("lsq", len(self.rss), self.rss[-1])


@dataclass
class Starts:
    """Where the multi-start stages ended: the best point so far and every stage's final LM starts
    (their u (K, P) and RSS (K,), searched for alternatives at the end)."""

    best_u: np.ndarray
    best_rss: float
    u: list[np.ndarray] = field(default_factory=list)
    rss: list[np.ndarray] = field(default_factory=list)
    lm_iterations: int = 0
    rounds: int = 0

    def add(self, u_end: np.ndarray, c_end: np.ndarray, iterations: int, margin: float = 0.0) -> bool:
        """Keep a stage's final starts; the best of them becomes the best point when it beats the
        current one by the relative ``margin``. Returns whether it did."""
        self.lm_iterations += iterations
        self.u.append(u_end)
        self.rss.append(c_end)
        if c_end.min() < self.best_rss * (1 - margin):
            self.best_u, self.best_rss = u_end[np.argmin(c_end)], float(c_end.min())
            return True
        return False


def multistart(problem: Problem, u0: np.ndarray, *, n_candidates: int, schedule, seed: int, search, perm, record,
               central: bool) -> Starts:
    """Stages 1 and 2: the screening design (one call), then successive halving of batched LM starts."""
    u_c, _, c_c = screen(problem, u0, n_candidates, seed, search)
    record(u_c, c_c)
    u_end, c_end, its = halving(problem, u_c, c_c, schedule, perm, record, central)
    return Starts(u_end[np.argmin(c_end)], float(c_end.min()), [u_end], [c_end], its)


def reseed_candidates(problem: Problem, best_u: np.ndarray, blo: np.ndarray, bhi: np.ndarray, seed: int,
                      round_no: int) -> np.ndarray:
    """Candidates (1 + 128·modes + 256, P) of one re-seeding round: the best point; per mode, 128 Sobol
    re-samples of that mode's columns in the box (others held at the best); 256 fresh global ones.
    Seeded by (seed, round, mode)."""
    parts = [best_u[None]]
    for b, cols in enumerate(mode_blocks(problem)):
        sob = qmc.Sobol(len(cols), scramble=True, seed=np.random.default_rng([seed, round_no, b])).random(128)
        uu = np.tile(best_u, (128, 1))
        uu[:, cols] = blo[cols] + sob * (bhi[cols] - blo[cols])
        parts.append(uu)
    sob = qmc.Sobol(problem.p, scramble=True, seed=np.random.default_rng([seed, round_no, 99])).random(256)
    parts.append(blo + sob * (bhi - blo))
    return np.vstack(parts)


def reseed(problem: Problem, starts: Starts, u0: np.ndarray, *, rounds: int, good_rms: float, seed: int, search,
           perm, record, central: bool) -> None:
    """Stage 2b: while the RMS residual exceeds ``good_rms``, up to ``rounds`` re-seeding rounds
    (:func:`reseed_candidates`, one call, halving again); stops at the first round that finds nothing
    better by 0.1 % (a noise-level fit). Updates ``starts``."""
    blo, bhi = search_box(problem, u0, search)
    for r in range(rounds):
        if np.sqrt(starts.best_rss / problem.n) < good_rms:
            break
        starts.rounds += 1
        uu = reseed_candidates(problem, starts.best_u, blo, bhi, seed, r)
        pred = problem.predict_u(uu)
        uu, pred = problem.profile_k(uu, pred)
        if not starts.add(*halving(problem, uu, problem.rss(pred), RESEED_SCHEDULE, perm, record, central),
                          margin=1e-3):
            break


#: the multiplicative steps of a merged mode against the mode it copies (:func:`merge_candidates`): fn, k, ζ
MERGE_STEPS = ((0.95, 1.0, 1.05), (0.5, 1.0, 2.0), (0.5, 1.0, 2.0))


def merge_candidates(problem: Problem, best_u: np.ndarray) -> np.ndarray:
    """Starts (27·M(M − 1), P) that put one mode onto another: for every ordered pair (a, b) of modes with
    the same free parameters, mode a's (fn, k, ζ) := mode b's × :data:`MERGE_STEPS` (3 × 3 × 3), the other
    modes held at ``best_u``; inside the bounds (not the search box: a parked mode sits outside it).

    Why (issue 28): at low immersion two modes of one frequency act much like one mode, and the search can
    end with one mode carrying the whole boundary and the other parked where the points do not see it
    (Example 1 at a/D 0.1: fn_x 1 767 Hz, 2× the truth's 903 Hz, k_x 3.5×). Re-sampling one mode inside
    the search box around the start does not reach the truth from there; copying the carrying mode onto
    the parked one and letting the stiffness profile split the load does (docs/identification.md)."""
    lo, hi = np.log(problem.par.lower), np.log(problem.par.upper)
    blocks = mode_blocks(problem)
    kinds = [tuple(problem.par.kind(problem.par.free[j]) for j in cols) for cols in blocks]
    steps = np.log(np.array(np.meshgrid(*MERGE_STEPS, indexing="ij")).reshape(3, -1).T)  # (27, 3): fn, k, ζ
    col = {"fn": 0, "k": 1, "zeta": 2}
    parts = [best_u[None]]
    for a, ca in enumerate(blocks):
        for b, cb in enumerate(blocks):
            if a == b or kinds[a] != kinds[b]:
                continue
            uu = np.tile(best_u, (steps.shape[0], 1))
            uu[:, ca] = best_u[cb] + steps[:, [col[k] for k in kinds[a]]]
            parts.append(uu)
    return np.clip(np.vstack(parts), lo, hi)


def merge_modes(problem: Problem, starts: Starts, *, good_rms: float, perm, record, central: bool) -> bool:
    """Stage 2b': while the RMS residual exceeds ``good_rms``, LM from the merged-mode starts of the best
    point (:func:`merge_candidates`, one call, halved by :data:`RESEED_SCHEDULE`); kept if better by 0.1 %.
    Updates ``starts``; returns whether a merged start became the best point."""
    if np.sqrt(starts.best_rss / problem.n) < good_rms or len(mode_blocks(problem)) < 2:
        return False
    uu = merge_candidates(problem, starts.best_u)
    if uu.shape[0] < 2:
        return False
    pred = problem.predict_u(uu)
    uu, pred = problem.profile_k(uu, pred)
    return starts.add(*halving(problem, uu, problem.rss(pred), RESEED_SCHEDULE, perm, record, central), margin=1e-3)


#: halving of the zero-order basins under the accurate engine (:func:`zoa_basins`)
BASIN_SCHEDULE = ((8, 5), (2, 30))


def zoa_basins(problem: Problem, u0: np.ndarray, k: int, *, n_candidates: int, schedule, rounds: int, good_rms: float,
               seed: int, search, perm, central: bool) -> np.ndarray:
    """Up to ``k`` distinct basins (K, P) of the zero-order engine's own global search on the same points
    (screening, halving, re-seeding: :func:`multistart`, :func:`reseed`), best first.

    Why (issue 28): the accurate engines' objective is rough (lobe bands found or not as the parameters
    move), so which basin their screening and halving end in turns on 0.1 %-level depth differences; the
    zero-order boundary is smooth and ~1 000× cheaper, and at low immersion it is wrong only locally (flip
    lobes, damping), so its basins sit near the accurate ones. Its end points then start LM under the
    accurate engine and compete with the accurate search's own by their accurate residual.
    """
    twin = problem.with_engine("zoa")
    quiet = lambda u, c: None  # noqa: E731 (the zero-order path is not the fit's history)
    stage = dict(seed=seed, search=search, perm=perm, record=quiet, central=central)
    starts = multistart(twin, u0, n_candidates=n_candidates, schedule=schedule, **stage)
    reseed(twin, starts, u0, rounds=rounds, good_rms=good_rms, **stage)
    u, c = np.vstack(starts.u), np.concatenate(starts.rss)
    return u[pick_distinct(u, c, k, 0.05, perm)]


def basin_search(problem: Problem, starts: Starts, u0: np.ndarray, *, k: int, n_candidates: int, schedule, rounds: int,
                 good_rms: float, seed: int, search, perm, record, central: bool) -> bool:
    """Stage 1b (accurate engines only): LM under the accurate engine from the zero-order basins
    (:func:`zoa_basins`), halved by :data:`BASIN_SCHEDULE`; the best end point is kept if better.
    Updates ``starts``; returns whether a zero-order basin became the best point."""
    if k <= 0 or problem.engine == "zoa":
        return False
    uz = zoa_basins(problem, u0, k, n_candidates=n_candidates, schedule=schedule, rounds=rounds, good_rms=good_rms,
                    seed=seed, search=search, perm=perm, central=central)
    uu = basin_candidates(problem, uz, np.vstack([starts.best_u, u0]))
    pred = problem.predict_u(uu)
    uu, pred = problem.profile_k(uu, pred)
    return starts.add(*halving(problem, uu, problem.rss(pred), BASIN_SCHEDULE, perm, record, central))


def basin_candidates(problem: Problem, uz: np.ndarray, anchors: np.ndarray) -> np.ndarray:
    """Starts (K (1 + A·modes), P) from the zero-order basins uz (K, P): each basin whole, and each basin's
    mode (fn, k, ζ of one direction) put into each anchor (A, P) (the accurate search's best, the start).

    Why the mixes: at low immersion the zero-order boundary hardly shows the feed-direction mode (its
    fitted damping runs to a bound: tests/test_identify_accurate.py), while the accurate one does; the
    zero-order basin then gives the mode it sees and the anchor the other."""
    parts = [uz]
    for cols in mode_blocks(problem):
        for a in anchors:
            mix = np.tile(a, (uz.shape[0], 1))
            mix[:, cols] = uz[:, cols]
            parts.append(mix)
    return np.vstack(parts)


def confidence_cloud(problem: Problem, best_u: np.ndarray, n_local: int, seed: int, central: bool) -> np.ndarray:
    """The best point and ``n_local`` seeded draws (1 + n_local, P) in its linearised 3σ confidence
    region (σ from the residual scatter; each step capped at 0.15 in ln θ), inside the bounds."""
    lo, hi = np.log(problem.par.lower), np.log(problem.par.upper)
    cache0 = _Cached(problem, central)
    r0, j0 = cache0.fun(best_u), cache0.jac(best_u)
    cov0, _ = covariance(j0, float(r0 @ r0), problem.n, problem.p)
    w_, v_ = np.linalg.eigh((cov0 + cov0.T) / 2)
    sd_dir = v_ * np.sqrt(np.clip(w_, 0, None))  # columns: principal axes scaled by their σ
    z = np.random.default_rng([seed, 7]).standard_normal((n_local, problem.p))
    cloud = np.clip(best_u + 3 * np.clip(z @ sd_dir.T, -0.05, 0.05), lo, hi)
    return np.vstack([best_u[None], cloud])


def local_search(problem: Problem, starts: Starts, *, n_local: int, seed: int, perm, record, central: bool) -> None:
    """Stage 2c: with noise the non-smooth boundary (cusps crossing points) leaves small local minima
    next to the best one; sample the confidence region once (:func:`confidence_cloud`) and halve again."""
    if n_local <= 0:
        return
    uu = confidence_cloud(problem, starts.best_u, n_local, seed, central)
    starts.add(*halving(problem, uu, problem.rss(problem.predict_u(uu)), LOCAL_SCHEDULE, perm, record, central))


def polish(problem: Problem, u_start: np.ndarray, *, loss: str, f_scale: float, max_nfev: int, central: bool):
    """Stage 3: scipy's trust-region reflective least squares from ``u_start`` with the robust ``loss``,
    its Jacobian from the batched rows. Returns (scipy result, residuals (n,), J (n, P)) at the solution."""
    cache = _Cached(problem, central)
    lo, hi = np.log(problem.par.lower), np.log(problem.par.upper)
    sol = optimize.least_squares(cache.fun, u_start, jac=cache.jac, bounds=(lo, hi), method="trf", loss=loss,
                                 f_scale=f_scale, x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=max_nfev)
    return sol, cache.fun(sol.x), cache.jac(sol.x)


def uncertainty(problem: Problem, jac: np.ndarray, rss: float, noise: float | None):
    """Standard errors of ln θ (P,), the correlation matrix (P, P) and cond(JᵀJ) at the solution, with σ
    from the residual scatter, a stated or an assumed noise (:func:`~millstab.identify.quality.error_sigma`).
    ``jac`` (m, P) and ``rss`` are those of the m points the fit stands on (all n, or a robust fit's kept
    points: :func:`~millstab.identify.quality.kept_points`)."""
    n, p = jac.shape[0], problem.p
    sig = error_sigma(rss, n, p, residual_scale(problem.residual, problem.depth_mm), noise)
    cov_u, cond = covariance(jac, rss, n, p, sig["sigma"] ** 2)
    sd_u = np.sqrt(np.clip(np.diag(cov_u), 0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov_u / np.outer(sd_u, sd_u)
    corr = np.where(np.isfinite(corr), corr, 0.0)
    np.fill_diagonal(corr, 1.0)
    return sd_u, corr, cond


def identifiability_warnings(names, corr: np.ndarray, cond: float) -> list[tuple[str, str]]:
    """(code, text) for a near-singular JᵀJ and for strongly correlated parameter pairs."""
    out = []
    if cond > 1e8:  # cond(J) > 1e4: some combination is determined 1e4× worse than the best one
        out.append(("near_singular",
                    f"near-singular JᵀJ (condition number {cond:.2g} in log-parameters): some parameter "
                    "combinations are not identifiable from these points; standard errors are unreliable"))
    p = len(names)
    pairs = [f"{names[i]}/{names[j]} ({corr[i, j]:+.3f})" for i in range(p)
             for j in range(i + 1, p) if abs(corr[i, j]) > 0.99]
    if pairs:
        out.append(("correlated", "strongly correlated (|r| > 0.99), not separately identifiable from these points: "
                                  + ", ".join(pairs)))
    return out


def alternative_solutions(problem: Problem, theta_hat: np.ndarray, rss: float, sd_u: np.ndarray, starts: Starts,
                          perm, xmap, keep: np.ndarray | None = None) -> list[dict]:
    """Parameter sets that explain the points as well as the estimate: the exact x↔y exchange (when
    ``xmap``), then the other multi-start solutions inside the 95 % joint confidence region
    RSS ≤ RSS_min (1 + p/(n − p) F_{p, n−p}(0.95)) (Beale 1960) that differ from the estimate by more than
    max(1 %, 4 σ) in some ln θ and from every listed one by 1 %.

    ``keep`` (n,) bool: the points a robust fit stands on (:func:`~millstab.identify.quality.kept_points`);
    where some are left out, ``rss`` is the estimate's over the kept points, and the multi-start solutions
    (searched with every point) are compared over them too, one engine call: over every point a solution
    pulled towards the outliers looked as good as a robust estimate whose kept residuals were 20× smaller."""
    n, p, par = problem.n, problem.p, problem.par
    c_lm, u_lm = np.concatenate(starts.rss), np.vstack(starts.u)
    c_cmp = c_lm  # what is compared; an alternative's "rss" stays its RSS over every point, as Fit.rss
    if keep is not None and not keep.all():
        n = int(keep.sum())
        r_lm = problem.residuals(problem.predict_u(u_lm))[:, keep]
        c_cmp = np.einsum("ki,ki->k", r_lm, r_lm)
    thresh = rss * (1 + p / (n - p) * stats.f.ppf(0.95, p, n - p)) if n > p else rss
    thresh = max(thresh, rss + 1e-12 * n)
    u_best_c = np.log(canonical(theta_hat, perm))
    alternatives = []
    if xmap is not None:
        theta_x = exchanged(theta_hat, xmap)
        pred_x = problem.predict_mm(theta_x[None])
        alternatives.append({"estimate": par.as_dict(theta_x), "mlae": float(problem.mlae(pred_x)[0]),
                             "rss": float(problem.rss(pred_x)[0]),
                             "why": "the exact x↔y mode exchange of the estimate (same zero-order SLD)"})
    for i in np.argsort(c_cmp, kind="stable"):
        if c_cmp[i] > thresh:
            continue
        u_i = np.log(canonical(np.exp(u_lm[i]), perm))
        d = np.abs(u_i - u_best_c)
        if (d > np.maximum(0.01, 4 * sd_u)).any() and all(
                np.abs(u_i - np.log(list(a["estimate"].values()))).max() > 0.01 for a in alternatives):
            pred_i = problem.predict_u(u_i[None])
            alternatives.append({"estimate": par.as_dict(np.exp(u_i)), "mlae": float(problem.mlae(pred_i)[0]),
                                 "rss": float(c_lm[i]), "why": "another multi-start solution inside the 95 % joint "
                                                                 "confidence region of the estimate"})
    return alternatives


def cut_warning(cuts: dict | None) -> str | None:
    """The warning text when labelled test cuts contradict the fitted limit, else ``None``."""
    if cuts and (cuts["stable_predicted_chatter"] or cuts["chatter_predicted_stable"]):
        return (f"test cuts: {cuts['stable_predicted_chatter']} of {cuts['stable_cuts']} stable cuts lie above the "
                f"fitted limit, {cuts['chatter_predicted_stable']} of {cuts['chatter_cuts']} chatter cuts below it")
    return None


@dataclass(frozen=True)
class LsqOptions:
    """The search settings of :func:`fit_lsq_free` (its docstring explains each), checked when built: an
    unknown loss or an empty schedule is an InputError. ``fit_lsq(problem, options=LsqOptions(rounds=0))``
    and ``fit_lsq(problem, rounds=0)`` are the same call (the keywords replace fields of ``options``)."""

    n_candidates: int = 512
    schedule: tuple = ((32, 3), (8, 5), (2, 30))
    rounds: int = 3
    good_rms: float = 0.01
    n_local: int = 64
    loss: str = "linear"
    f_scale: float | None = None
    central: bool = False
    max_nfev: int = 100
    zoa_basins: int = 0
    merge: bool = True

    def __post_init__(self) -> None:
        check_options(self.loss, self.n_candidates, self.schedule)


def fit_lsq_free(problem: Problem, theta0: np.ndarray | None = None, *, options: LsqOptions | None = None,
                 seed: int = 0, search: dict[str, float] | None = None, progress: SolverProgress | None = None,
                 noise: float | None = None, **tuning) -> Fit:
    """:func:`fit_lsq` without the x = y test: the multi-start search itself (module docstring), run as
    its stages :func:`multistart`, :func:`reseed`, :func:`local_search`, :func:`polish`, then the
    diagnostics :func:`uncertainty`, :func:`identifiability_warnings`, :func:`alternative_solutions`.

    Args:
        theta0: start [Hz, N/m, -]; default the parameterization's start (the config's structure).
        options: the search settings (:class:`LsqOptions`, its fields below); keywords named as its
            fields replace them (``fit_lsq_free(problem, rounds=0)``).
        n_candidates: QMC screening candidates (one engine call).
        zoa_basins: with an engine other than ``zoa``, LM under that engine also starts from up to this
            many distinct basins of the zero-order engine's own global search on the same points
            (:func:`basin_search`; default 0: off — measured without gain so far, +20–30 % evaluations:
            docs/identification.md).
        merge: while the RMS residual exceeds ``good_rms`` after the re-seeding, LM also starts from every
            mode put onto every other mode (:func:`merge_modes`; default on: ~1 000 SLDs when it runs, it
            took Example 1 at a/D 0.1 out of its parked-mode basin, docs/identification.md).
        schedule: successive halving of the LM starts, ((starts, iterations), ...).
        rounds: at most this many re-seeding rounds while the RMS residual exceeds ``good_rms``: each
            re-samples every mode's parameters in the search box (others at the best so far, 128 each)
            plus 256 fresh global candidates, one call, then halving again; kept only if better, and
            the rounds stop at the first that finds nothing better.
        good_rms: RMS residual (log residuals: relative, 0.01 = 1 %) below which no re-seeding is done.
        n_local: points sampled in the linearised 3σ confidence region of the best solution (one call),
            then halved again: with noisy points the non-smooth boundary leaves small local minima there.
        loss: scipy robust loss of the polish (``linear``, ``soft_l1``, ``huber``, ``cauchy``, ``arctan``).
        f_scale: residual scale of a robust loss (default 0.05: 5 % for log residuals, 0.05 mm for mm).
        central: central instead of forward differences (2P + 1 rows per Jacobian).
        seed: seed of the Sobol designs (same seed ⇒ same result).
        search: {kind: factor} overriding :data:`SEARCH`.
        progress: called as progress(stage, iteration, best_rss).
        noise: stated relative standard deviation of a measured depth (0.02 = 2 %), or ``None``: the
            standard errors then use the residual scatter (an assumed noise with few degrees of freedom;
            :func:`~millstab.identify.quality.error_sigma`).
    """
    noise = check_noise(noise)
    o = options_with(options, LsqOptions, tuning, "fit_lsq_free")  # checked when built
    n_candidates, schedule, rounds, good_rms, n_local, loss, f_scale, central, max_nfev = (
        o.n_candidates, o.schedule, o.rounds, o.good_rms, o.n_local, o.loss, o.f_scale, o.central, o.max_nfev)
    t0 = time.perf_counter()
    sets0, calls0 = problem.n_sets, problem.n_calls
    par = problem.par
    lo, hi = np.log(par.lower), np.log(par.upper)
    theta_start = par.theta0 if theta0 is None else np.asarray(theta0, dtype=float)
    u0 = np.clip(np.log(theta_start), lo, hi)
    perm = swap_permutation(par, problem.cutting)
    record = History(progress)
    # 1. screening, 2. successive halving of batched LM starts; 2b. re-seeding; 2c. the confidence region
    stage = dict(seed=seed, perm=perm, record=record, central=central)
    starts = multistart(problem, u0, n_candidates=n_candidates, schedule=schedule, search=search, **stage)
    basin_won = basin_search(problem, starts, u0, k=o.zoa_basins, n_candidates=n_candidates, schedule=schedule,
                             rounds=rounds, good_rms=good_rms, search=search, **stage)
    reseed(problem, starts, u0, rounds=rounds, good_rms=good_rms, search=search, **stage)
    merge_won = o.merge and merge_modes(problem, starts, good_rms=good_rms, perm=perm, record=record,
                                        central=central)
    local_search(problem, starts, n_local=n_local, **stage)
    # 3. polish with scipy trf (the chosen loss), Jacobian from the batched rows
    if f_scale is None:
        f_scale = 0.05
    sol, r_hat, j_hat = polish(problem, starts.best_u, loss=loss, f_scale=f_scale, max_nfev=max_nfev, central=central)
    if problem.refine(np.exp(sol.x)):
        # the engine's discretisation (chosen once, at the start) is not converged at the solution:
        # polish again on the one chosen there
        sol, r_hat, j_hat = polish(problem, sol.x, loss=loss, f_scale=f_scale, max_nfev=max_nfev, central=central)
    rss = float(r_hat @ r_hat)
    record(sol.x[None], np.array([rss]))
    iterations = len(record.rss) - 1  # screening is iteration 0
    theta_hat = np.exp(sol.x)

    # diagnostics: a robust loss gives outliers almost no weight in the estimate, so its standard errors
    # leave them out too (with them, σ̂ grew with their squares: 12× the inliers' scatter for 3 in 30)
    keep = kept_points(loss, r_hat, problem, problem.p)
    sd_u, corr, cond = uncertainty(problem, j_hat[keep], float(r_hat[keep] @ r_hat[keep]), noise)
    warn: list[str] = []
    codes: list[str] = []  # one per warning kind (Fit.codes)
    symmetry = None
    if perm is not None:
        symmetry, text = xy_symmetry_note("(first differing pair has x < y, i.e. fn_x <= fn_y)")
        codes.append("xy_symmetry")
        warn.append(text)
        theta_c = canonical(theta_hat, perm)
        if not np.array_equal(theta_c, theta_hat):
            sd_u, corr = sd_u[perm], corr[np.ix_(perm, perm)]
            theta_hat = theta_c
    xmap = exchange_map(par, problem.cutting, problem.engine) if perm is None else None
    if xmap is not None:
        symmetry, text = exchange_note(problem.cutting)
        codes.append("xy_exchange")
        warn.append(text)
    for code, text in identifiability_warnings(par.free, corr, cond):
        codes.append(code)
        warn.append(text)
    if not sol.success:
        codes.append("not_converged")
        warn.append(f"least squares did not converge: {sol.message}")
    alternatives = alternative_solutions(problem, theta_hat, float(r_hat[keep] @ r_hat[keep]), sd_u, starts, perm,
                                         xmap, keep)
    if alternatives:
        codes.append("alternatives")
        warn.append(f"{len(alternatives)} distinct parameter set(s) explain the points as well as the estimate "
                    "(see alternatives): the data do not determine the parameters uniquely")
    pred_hat = problem.predict_mm(theta_hat[None])
    mlae = float(problem.mlae(pred_hat)[0])
    cuts = problem.cut_report(theta_hat)
    text = cut_warning(cuts)
    if text:
        codes.append("test_cuts")
        warn.append(text)
    hist_theta = np.exp(np.array(record.u))
    hist_mlae = problem.mlae(problem.predict_mm(hist_theta))
    return Fit(method="lsq", par=par, estimate=theta_hat, start=np.exp(u0), mlae=mlae, rss=rss, iterations=iterations,
               evaluations=problem.n_sets - sets0, engine_calls=problem.n_calls - calls0,
               time_s=time.perf_counter() - t0, history_theta=hist_theta, history_mlae=hist_mlae,
               history_rss=np.array(record.rss), std_errors=theta_hat * sd_u, correlation=corr, condition=cond,
               warnings=warn, codes=codes, alternatives=alternatives, symmetry=symmetry, test_cuts=cuts,
               cutting=problem.cutting,
               settings={"n_candidates": n_candidates, "loss": loss, "f_scale": f_scale,
                         "central": central, "seed": seed, "search": {**SEARCH, **(search or {})},
                         "schedule": [list(x) for x in schedule], "rounds_run": starts.rounds, "n_local": n_local,
                         "zoa_basins": o.zoa_basins, "zoa_basin_won": basin_won,
                         "merge": o.merge, "merge_won": merge_won,
                         "good_rms": good_rms, "residual": problem.residual, "engine": problem.engine,
                         "lm_iterations": starts.lm_iterations, "polish_nfev": int(sol.nfev),
                         "polish_status": int(sol.status), "noise": noise})


__all__ = ["BASIN_SCHEDULE", "LOSSES", "SEARCH", "LsqOptions", "Starts", "alternative_solutions", "basin_candidates",
           "basin_search", "check_options", "confidence_cloud", "covariance", "fit_lsq", "fit_lsq_free",
           "identifiability_warnings", "local_search", "merge_candidates", "merge_modes", "multistart", "polish",
           "reseed", "reseed_candidates", "uncertainty", "zoa_basins"]
