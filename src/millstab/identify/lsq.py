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
3. **Polish.** ``scipy.optimize.least_squares(method="trf")`` from the best refined start, with the
   chosen robust ``loss``; its Jacobian comes from the same batched call as its residuals (the
   residual row plus P forward-difference rows), never scipy's per-column differences.

4. **x = y?** In an x/y-symmetric cut the tied model is fitted as well and reported when an F-test
   does not reject it (:mod:`~millstab.identify.tie`: near x = y a free fit splits the pairs by
   noise alone, with overconfident standard errors).

Diagnostics at the solution: cov_u = σ²(JᵀJ)⁻¹ in log-parameters with σ the residual scatter
√(RSS/(n − p)) — or a stated (``noise``) or assumed depth noise where the points leave few or no
degrees of freedom (:func:`~millstab.identify.quality.error_sigma`) — standard errors
θ·√diag(cov_u) (delta method), the correlation matrix, cond(JᵀJ); warnings for an exact x↔y symmetry
(slotting: the estimate is returned in canonical order, fn_x ≤ fn_y) and for the general exact x↔y
mode exchange of the zero-order SLD (any cut with α_xx α_yy > 0: (fn, ζ) of x and y exchanged,
k_x' = (α_xx/α_yy) k_y, k_y' = k_x α_yy/α_xx — :func:`~millstab.identify.objective.exchange_map`; the
exchanged estimate, which explains the points equally well, is listed first in the alternatives and the
solver cannot prefer either: with noise-free data it returns whichever basin the start leads to), near-singular JᵀJ, strongly
correlated pairs, and other multi-start solutions inside the 95 % joint confidence region
RSS ≤ RSS_min (1 + p/(n − p) F_{p, n−p}(0.95)) (Beale 1960) that differ from the estimate. Then the
quality checks of :func:`~millstab.identify.quality.diagnose` (degrees of freedom, poor or systematic
residuals, the zero-order model's known weak cuts), each warning with a code in ``Fit.codes``.
"""

from __future__ import annotations

import time
from typing import Callable

import numpy as np
from scipy import optimize, stats
from scipy.stats import qmc

from millstab.errors import InputError
from millstab.forward import FD_STEP, fd_rows  # noqa: F401 (FD_STEP: the solver's step, re-exported)
from millstab.forward import fd_difference as jacobians
from millstab.identify.objective import Problem, canonical, exchange_map, exchanged, swap_permutation
from millstab.identify.quality import check_noise, diagnose, error_sigma, residual_scale
from millstab.identify.result import Fit
from millstab.identify.tie import prefer_tied
from millstab.stability import zoa

LOSSES = ("linear", "soft_l1", "huber", "cauchy", "arctan")
#: default search box half-widths (multiplicative) around the start, per parameter kind
SEARCH = {"fn": 1.5, "k": 2.5, "zeta": 2.5}

Progress = Callable[[str, int, float], None]


def search_box(problem: Problem, u0: np.ndarray, search: dict[str, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The screening box in log-parameters: start ×/÷ SEARCH[kind], inside the bounds."""
    s = {**SEARCH, **(search or {})}
    half = np.log([s[problem.par.kind(n)] for n in problem.par.free])
    lo, hi = np.log(problem.par.lower), np.log(problem.par.upper)
    return np.maximum(lo, u0 - half), np.minimum(hi, u0 + half)


def screen(problem: Problem, u0: np.ndarray, n_candidates: int, seed: int, search=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stage 1: QMC candidates in the search box plus the start, one engine call.

    Returns (u (N, P), predictions (N, n) [mm], rss (N,)), k-profiled when possible.
    """
    blo, bhi = search_box(problem, u0, search)
    m = max(1, int(np.ceil(np.log2(max(n_candidates, 1)))))
    sob = qmc.Sobol(problem.p, scramble=True, seed=seed).random_base2(m)[:n_candidates]
    u = np.vstack([u0[None], blo + sob * (bhi - blo)])
    pred = problem.predict_u(u)
    u, pred = problem.profile_k(u, pred)
    return u, pred, problem.rss(pred)


def pick_distinct(u: np.ndarray, cost: np.ndarray, k: int, min_dist: float, perm=None) -> np.ndarray:
    """Indices of the k lowest-cost rows whose log-distance (max-norm, up to x↔y swap) to every already
    picked row exceeds ``min_dist``."""
    order = np.argsort(cost, kind="stable")
    picked: list[int] = []
    for i in order:
        if not np.isfinite(cost[i]):
            break
        d_ok = True
        for j in picked:
            d = np.abs(u[i] - u[j]).max()
            if perm is not None:
                d = min(d, np.abs(u[i][perm] - u[j]).max())
            if d < min_dist:
                d_ok = False
                break
        if d_ok:
            picked.append(int(i))
            if len(picked) == k:
                break
    return np.array(picked, dtype=int)


def batched_lm(problem: Problem, u: np.ndarray, *, max_iter: int = 40, tol: float = 1e-10, central: bool = False,
               record: Callable[[np.ndarray, np.ndarray], None] | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
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


def fit_lsq_free(problem: Problem, theta0: np.ndarray | None = None, *, n_candidates: int = 512,
                 schedule=((32, 3), (8, 5), (2, 30)), rounds: int = 3, good_rms: float = 0.01, n_local: int = 64,
                 loss: str = "linear", f_scale: float | None = None, central: bool = False, seed: int = 0,
                 search: dict[str, float] | None = None, max_nfev: int = 100, progress: Progress | None = None,
                 noise: float | None = None) -> Fit:
    """:func:`fit_lsq` without the x = y test: the multi-start search itself (module docstring).

    Args:
        theta0: start [Hz, N/m, -]; default the parameterization's start (the config's structure).
        n_candidates: QMC screening candidates (one engine call).
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
    if loss not in LOSSES:
        raise InputError("loss", loss, f"must be one of {', '.join(LOSSES)}")
    if n_candidates < 1 or not schedule or any(k < 1 or i < 1 for k, i in schedule):
        raise InputError("schedule", schedule, "need n_candidates >= 1 and a schedule of (starts >= 1, iterations >= 1)")
    t0 = time.perf_counter()
    sets0, calls0 = problem.n_sets, problem.n_calls
    par = problem.par
    lo, hi = np.log(par.lower), np.log(par.upper)
    theta_start = par.theta0 if theta0 is None else np.asarray(theta0, dtype=float)
    u0 = np.clip(np.log(theta_start), lo, hi)
    perm = swap_permutation(par, problem.cutting)
    hist_u: list[np.ndarray] = []
    hist_rss: list[float] = []

    def record(u: np.ndarray, cost: np.ndarray) -> None:
        i = int(np.argmin(cost))
        if hist_rss and hist_rss[-1] <= cost[i]:
            hist_u.append(hist_u[-1])
            hist_rss.append(hist_rss[-1])
        else:
            hist_u.append(u[i].copy())
            hist_rss.append(float(cost[i]))
        if progress is not None:
            progress("lsq", len(hist_rss), hist_rss[-1])

    # 1. screening, 2. successive halving of batched LM starts
    u_c, _, c_c = screen(problem, u0, n_candidates, seed, search)
    record(u_c, c_c)
    u_end, c_end, it_lm = halving(problem, u_c, c_c, schedule, perm, record, central)
    finals_u, finals_c = [u_end], [c_end]
    best_u, best_c = u_end[np.argmin(c_end)], float(c_end.min())
    # 2b. re-seeding rounds while the fit is poor: one mode at a time, plus fresh global candidates
    blo, bhi = search_box(problem, u0, search)
    n_rounds = 0
    for r in range(rounds):
        if np.sqrt(best_c / problem.n) < good_rms:
            break
        n_rounds += 1
        parts = [best_u[None]]
        for b, cols in enumerate(mode_blocks(problem)):
            sob = qmc.Sobol(len(cols), scramble=True, seed=np.random.default_rng([seed, r, b])).random(128)
            uu = np.tile(best_u, (128, 1))
            uu[:, cols] = blo[cols] + sob * (bhi[cols] - blo[cols])
            parts.append(uu)
        sob = qmc.Sobol(problem.p, scramble=True, seed=np.random.default_rng([seed, r, 99])).random(256)
        parts.append(blo + sob * (bhi - blo))
        uu = np.vstack(parts)
        pred = problem.predict_u(uu)
        uu, pred = problem.profile_k(uu, pred)
        u_end, c_end, it = halving(problem, uu, problem.rss(pred), ((16, 3), (4, 8), (2, 30)), perm, record, central)
        it_lm += it
        finals_u.append(u_end)
        finals_c.append(c_end)
        if c_end.min() < best_c * (1 - 1e-3):
            best_u, best_c = u_end[np.argmin(c_end)], float(c_end.min())
        else:  # the round found nothing better: more rounds would not either (a noise-level fit)
            break
    # 2c. the confidence region: with noise the non-smooth boundary (cusps crossing points) leaves small
    # local minima next to the best one; sample the linearised 3σ region once and halve again
    if n_local > 0:
        cache0 = _Cached(problem, central)
        r0, j0 = cache0.fun(best_u), cache0.jac(best_u)
        cov0, _ = covariance(j0, float(r0 @ r0), problem.n, problem.p)
        w_, v_ = np.linalg.eigh((cov0 + cov0.T) / 2)
        sd_dir = v_ * np.sqrt(np.clip(w_, 0, None))  # columns: principal axes scaled by their σ
        z = np.random.default_rng([seed, 7]).standard_normal((n_local, problem.p))
        cloud = np.clip(best_u + 3 * np.clip(z @ sd_dir.T, -0.05, 0.05), lo, hi)
        uu = np.vstack([best_u[None], cloud])
        c_cloud = problem.rss(problem.predict_u(uu))
        u_end, c_end, it = halving(problem, uu, c_cloud, ((8, 4), (2, 20)), perm, record, central)
        it_lm += it
        finals_u.append(u_end)
        finals_c.append(c_end)
        if c_end.min() < best_c:
            best_u, best_c = u_end[np.argmin(c_end)], float(c_end.min())
    c_lm = np.concatenate(finals_c)
    u_lm = np.vstack(finals_u)
    # 3. polish with scipy trf (the chosen loss), Jacobian from the batched rows
    cache = _Cached(problem, central)
    if f_scale is None:
        f_scale = 0.05
    sol = optimize.least_squares(cache.fun, best_u, jac=cache.jac, bounds=(lo, hi), method="trf", loss=loss,
                                 f_scale=f_scale, x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=max_nfev)
    u_hat = sol.x
    r_hat = cache.fun(u_hat)
    j_hat = cache.jac(u_hat)
    rss = float(r_hat @ r_hat)
    record(u_hat[None], np.array([rss]))
    iterations = len(hist_rss) - 1  # screening is iteration 0
    theta_hat = np.exp(u_hat)

    # diagnostics
    n, p = problem.n, problem.p
    sig = error_sigma(rss, n, p, residual_scale(problem.residual, problem.depth_mm), noise)
    cov_u, cond = covariance(j_hat, rss, n, p, sig["sigma"] ** 2)
    sd_u = np.sqrt(np.clip(np.diag(cov_u), 0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov_u / np.outer(sd_u, sd_u)
    corr = np.where(np.isfinite(corr), corr, 0.0)
    np.fill_diagonal(corr, 1.0)
    warn: list[str] = []
    codes: list[str] = []  # one per warning kind (Fit.codes)
    symmetry = None
    if perm is not None:
        symmetry = ("x and y are interchangeable: swapping the x and y parameters leaves this cut's SLD unchanged "
                    "exactly (α_xx = α_yy, e.g. slotting); the estimate is given in canonical order "
                    "(first differing pair has x < y, i.e. fn_x <= fn_y)")
        codes.append("xy_symmetry")
        warn.append("x/y symmetry: " + symmetry.split(":", 1)[1].strip())
        theta_c = canonical(theta_hat, perm)
        if not np.array_equal(theta_c, theta_hat):
            q = perm
            sd_u, corr = sd_u[q], corr[np.ix_(q, q)]
            theta_hat = theta_c
    xmap = exchange_map(par, problem.cutting, problem.engine) if perm is None else None
    if xmap is not None:
        a_dir = zoa.directional_matrix(problem.cutting)
        symmetry = (f"x and y modes are exchangeable: with α_xx/α_yy = {a_dir[0, 0] / a_dir[1, 1]:.4g} for this cut, exchanging "
                    "(fn, ζ) of x and y and scaling k_x' = (α_xx/α_yy) k_y, k_y' = k_x (α_yy/α_xx) leaves the "
                    "zero-order SLD unchanged exactly; the points cannot tell the two structures apart "
                    "(the exchanged estimate is listed in alternatives)")
        codes.append("xy_exchange")
        warn.append("x/y exchange: " + symmetry.split(":", 1)[1].strip())
    if cond > 1e8:  # cond(J) > 1e4: some combination is determined 1e4× worse than the best one
        codes.append("near_singular")
        warn.append(f"near-singular JᵀJ (condition number {cond:.2g} in log-parameters): some parameter "
                    "combinations are not identifiable from these points; standard errors are unreliable")
    names = par.free
    pairs = [f"{names[i]}/{names[j]} ({corr[i, j]:+.3f})" for i in range(p) for j in range(i + 1, p) if abs(corr[i, j]) > 0.99]
    if pairs:
        codes.append("correlated")
        warn.append("strongly correlated (|r| > 0.99), not separately identifiable from these points: " + ", ".join(pairs))
    if not sol.success:
        codes.append("not_converged")
        warn.append(f"least squares did not converge: {sol.message}")
    # other multi-start solutions inside the 95 % joint confidence region
    alternatives = []
    if n > p:
        thresh = rss * (1 + p / (n - p) * stats.f.ppf(0.95, p, n - p))
    else:
        thresh = rss
    thresh = max(thresh, rss + 1e-12 * n)
    u_best_c = np.log(canonical(theta_hat, perm))
    if xmap is not None:
        theta_x = exchanged(theta_hat, xmap)
        pred_x = problem.predict_mm(theta_x[None])
        alternatives.append({"estimate": par.as_dict(theta_x), "mlae": float(problem.mlae(pred_x)[0]),
                             "rss": float(problem.rss(pred_x)[0]),
                             "why": "the exact x↔y mode exchange of the estimate (same zero-order SLD)"})
    for i in np.argsort(c_lm):
        if c_lm[i] > thresh:
            continue
        u_i = np.log(canonical(np.exp(u_lm[i]), perm))
        d = np.abs(u_i - u_best_c)
        if (d > np.maximum(0.01, 4 * sd_u)).any() and all(
                np.abs(u_i - np.log(list(a["estimate"].values()))).max() > 0.01 for a in alternatives):
            pred_i = problem.predict_u(u_i[None])
            alternatives.append({"estimate": par.as_dict(np.exp(u_i)), "mlae": float(problem.mlae(pred_i)[0]),
                                 "rss": float(c_lm[i]), "why": "another multi-start solution inside the 95 % joint "
                                                                 "confidence region of the estimate"})
    if alternatives:
        codes.append("alternatives")
        warn.append(f"{len(alternatives)} distinct parameter set(s) explain the points as well as the estimate "
                    "(see alternatives): the data do not determine the parameters uniquely")
    pred_hat = problem.predict_mm(theta_hat[None])
    mlae = float(problem.mlae(pred_hat)[0])
    cuts = problem.cut_report(theta_hat)
    if cuts and (cuts["stable_predicted_chatter"] or cuts["chatter_predicted_stable"]):
        codes.append("test_cuts")
        warn.append(f"test cuts: {cuts['stable_predicted_chatter']} of {cuts['stable_cuts']} stable cuts lie above the "
                    f"fitted limit, {cuts['chatter_predicted_stable']} of {cuts['chatter_cuts']} chatter cuts below it")
    hist_theta = np.exp(np.array(hist_u))
    hist_mlae = problem.mlae(problem.predict_mm(hist_theta))
    return Fit(method="lsq", par=par, estimate=theta_hat, start=np.exp(u0), mlae=mlae, rss=rss, iterations=iterations,
               evaluations=problem.n_sets - sets0, engine_calls=problem.n_calls - calls0,
               time_s=time.perf_counter() - t0, history_theta=hist_theta, history_mlae=hist_mlae,
               history_rss=np.array(hist_rss), std_errors=theta_hat * sd_u, correlation=corr, condition=cond,
               warnings=warn, codes=codes, alternatives=alternatives, symmetry=symmetry, test_cuts=cuts, cutting=problem.cutting,
               settings={"n_candidates": n_candidates, "loss": loss, "f_scale": f_scale,
                         "central": central, "seed": seed, "search": {**SEARCH, **(search or {})},
                         "schedule": [list(x) for x in schedule], "rounds_run": n_rounds, "n_local": n_local, "good_rms": good_rms,
                         "residual": problem.residual, "engine": problem.engine, "lm_iterations": it_lm,
                         "polish_nfev": int(sol.nfev), "polish_status": int(sol.status), "noise": noise})


__all__ = ["LOSSES", "SEARCH", "covariance", "fit_lsq", "fit_lsq_free"]
