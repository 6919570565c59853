"""The seed paper's multivariate Newton–Raphson scheme (Section 2), with its three refinements.

Per iteration, for the current guess p (all guesses while exploring):

* objective: MLAE = Σ w_i log(1 + |b_exp,i − b*_i|) / Σ w_i (paper eq. 4; depths in mm; w = 1 gives eq. 4
  exactly; the critical-point weights below make it the paper's "more weight on critical points");
* sensitivities by forward differences (paper eq. ``partial``): S_i = (MLAE(p + ε_i e_i) − MLAE(p)) / ε_i;
* update (paper eq. ``newton``): p ← p − α · MLAE · S / ‖S‖².

What is literal and what is scaled:

* ``scaled=False`` (literal): p, ε and S in physical units (Hz, N/m, -), ε_i = ``fd_step`` · p_i (the paper
  says only "a small value"; a relative ε makes it usable for Hz and N/m alike). Because S_ζ ≫ S_fn ≫ S_k
  in these units, ‖S‖² is dominated by ζ and the step moves almost only ζ (the fn and k steps are
  smaller by the squared unit ratios) — the paper's update taken literally.
* ``scaled=True`` (default): the same formula in log coordinates u = ln p (S_i = ∂MLAE/∂ ln p_i, ε = ``fd_step``
  in u), so every parameter moves in proportion: u ← u − α · MLAE · S / ‖S‖². This is the only change.

The refinements (all three, as the paper describes them; what is the paper's and what is ours):

1. **Trial jumps** (paper: "if the algorithm was not able to improve the objective at least by that
   threshold after a certain number of consecutive iterations, one may add some e.g. 5 % jumps in
   each/some parameters ... only applied if they can successfully improve the objective"). When the best
   MLAE has not improved by a relative ``improve_tol`` (1 %) for ``patience`` (3) consecutive iterations,
   the next iterations also evaluate jumps from the best point so far (:func:`jump_directions`), each
   ×/÷ (1 + ``jump``) per moved parameter (symmetric in ln p): each parameter alone, each pair (± ±;
   these include the valley moves k↑ζ↓ and k↓ζ↑ of one mode, along which k·ζ and so the lobe minima
   stay fixed), each kind together (all fn, all k, all ζ), the valley moves of all modes at once;
   ``n_random_jumps`` (16) random {−1, 0, 1} combinations drawn afresh each round (seeded); and — ours —
   *pattern jumps* along the best point's recent progress (best − best 1, 3, 10, 30 iterations ago,
   × 0.5 … 8), which can follow a curved valley that no fixed direction follows. The best jump replaces
   the guess only if it lowers the best MLAE. Scaled (ours): a round where no jump helps halves the
   jump size (down to ``min_jump`` = 5 %/256); a kept jump doubles it again (up to ``jump``).
2. **Critical points.** Points within a relative speed window ``critical_window`` (2 %) of a *critical
   point* get weight ``critical_weight`` (10) in the objective. Critical points are the cusps and lobe
   minima of the boundary, found as the strict local maxima (cusps: two lobes meet) and strict local
   minima (lobe bottoms) of the depth over the sorted speeds — of the measured points and of the current
   guessed SLD at the same speeds (so the set follows the guess, iteration by iteration).
3. **Diverse initial guesses** (paper: "a diverse set of initial guesses ... initially may try different
   guesses, but after a few iterations, only continues with the best guess"). The start plus
   ``n_screen`` (2048) scrambled-Sobol points (seeded) in the box ``SEARCH_NEWTON`` around the start
   (fn ×/÷ 1.5, k and ζ ×/÷ 2.5, inside the bounds; the same box as the lsq screen) are ranked by MLAE
   in ONE engine call, together with (ours) a regular ``n_fn_grid`` (1024 = 32 × 32) grid over the fn
   columns of the same box (one or two fn free), every other parameter at the start: the natural
   frequencies dominate the SLD (fn ≫ k > ζ), and 2048 random points in a 6-D box resolve fn too
   coarsely — without the grid, Example 3 (modes 900/950 Hz) from ±10 % starts (bench_identify starts
   1, 2) got only guesses in a wrong fn_x basin (the x mode nearly switched off, k_x × 1.5–7; errors
   11–150 %, MLAE 0.15–0.35). Added (ours): a second, finer design of ``n_refine`` (1024) Sobol points in a
   small box (``REFINE_NEWTON``: fn ×/÷ 1.02, k and ζ ×/÷ 1.15) around each of the ``n_centres`` (8)
   best distinct candidates, again one call. The ``n_guesses`` (16) best pairwise-distinct candidates
   (log max-distance ≥ ``min_distance``, up to the x↔y swap) iterate together, stacked in one call per
   iteration, for ``explore_iters`` (40) iterations; then only the best continues. (A design over the
   whole bounds box — fn ×/÷ 2, k ×/÷ 10, ζ ×/÷ 20 — was tried: 2048 points in that 6-D box leave
   Example 3's guesses outside the basin the first-order update can converge from.)

Budget: ``max_iter`` = 600 iterations (the paper shows 60) and ``tol`` = 1e-6; the update and the
jumps are first-order/pattern moves, so convergence along the k–ζ valleys is slow (linear) and stops
where the MLAE's kinks (|Δb| and the lobe envelope's min) leave no improving direction among the
jumps. From Table 3's ±30 % start this reaches the paper's Predicted-row accuracy on Examples 1–3 (seeds
0–2) in 48 000–65 000 parameter sets (≈ 3–4.5 s at ~15 000 sets/s); it does not reach lsq's 1e-6.

A safeguard not in the paper: each scaled step is capped at ``max_step`` (0.1 in ln p) per parameter,
because MLAE/‖S‖ explodes where the objective is flat.

Every iteration is ONE batched engine call: all guesses, their P forward-difference rows and any trial
jumps stacked. Every iteration's parameters and (unweighted) MLAE are recorded (``Fit.history_*``); the
result is the best iterate. Stops when the MLAE falls below ``tol`` or after ``max_iter`` iterations.
"""

from __future__ import annotations

import itertools
import time

import numpy as np
from scipy.stats import qmc

from millstab.errors import InputError
from millstab.forward import fd_difference
from millstab.identify.lsq import Progress, pick_distinct, search_box
from millstab.identify.objective import Problem, canonical, swap_permutation
from millstab.identify.quality import check_noise, diagnose
from millstab.identify.result import Fit


#: the guesses' box around the start (×/÷): narrower than lsq's, because this first-order scheme only
#: converges from near the basin and a wide box lets a low-MLAE guess in a wrong basin win the exploration
SEARCH_NEWTON = {"fn": 1.5, "k": 2.5, "zeta": 2.5}
#: pattern jumps: best − best `lag` iterations ago, times each multiple
PATTERN_LAGS = (1, 3, 10, 30)
PATTERN_MULTIPLES = np.array([0.5, 1.0, 2.0, 4.0, 8.0])
#: the half-widths (×/÷) of the finer design around the best screened candidates
REFINE_NEWTON = {"fn": 1.02, "k": 1.15, "zeta": 1.15}


def critical_mask(rpm: np.ndarray, depth_meas: np.ndarray, depth_guess: np.ndarray, window: float) -> np.ndarray:
    """Points (n,) within ±``window``·Ω of a cusp or lobe minimum of the measured or the guessed boundary.

    Cusps and lobe minima = strict local maxima and minima of depth over the sorted speeds (end
    points excluded). ``depth_guess`` may be (n,) or (B, n); the mask then has the same shape.
    """
    order = np.argsort(rpm, kind="stable")
    r = rpm[order]
    g = np.atleast_2d(depth_guess)[:, order]
    m = np.broadcast_to(depth_meas[order], g.shape)

    def extrema(d: np.ndarray) -> np.ndarray:
        e = np.zeros(d.shape, bool)
        left, mid, right = d[:, :-2], d[:, 1:-1], d[:, 2:]
        e[:, 1:-1] = ((mid > left) & (mid > right)) | ((mid < left) & (mid < right))
        return e

    ext = extrema(m) | extrema(g)
    # each point is critical when some extremum lies within the window of its speed
    near = np.abs(r[None, :] - r[:, None]) <= window * r[None, :]  # near[e, i]: extremum e near point i
    crit_sorted = (ext.astype(float) @ near.astype(float)) > 0
    out = np.empty_like(crit_sorted)
    out[:, order] = crit_sorted
    return out if np.ndim(depth_guess) > 1 else out[0]


def jump_directions(par) -> np.ndarray:
    """Signs (J, P) of the structured trial jumps (each entry −1, 0 or +1, applied as ×/÷ (1 + jump)):

    * each parameter alone (±) and each pair of parameters (±, ±) — the paper's "jumps in each/some
      parameters"; the pairs include the valley moves of one mode (k up and ζ down, k down and ζ up),
      along which k·ζ, and so the depth of the lobe minima, stays fixed;
    * all parameters of one kind together (all fn, all k, all ζ: ±), and the valley moves of every mode
      at once in each combination of directions (k_x↑ζ_x↓ with k_y↑ζ_y↓ or k_y↓ζ_y↑, …).

    Random jumps are drawn afresh for every round (in :func:`fit_newton`)."""
    p = par.size
    rows = [np.eye(p), -np.eye(p)]
    for i in range(p):
        for j in range(i + 1, p):
            for si, sj in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
                r = np.zeros(p)
                r[i], r[j] = si, sj
                rows.append(r[None])
    kinds = np.array([par.kind(n) for n in par.free])
    for kind in ("fn", "k", "zeta"):
        if (kinds == kind).sum() > 1:
            r = (kinds == kind).astype(float)
            rows += [r[None], -r[None]]
    # the k–ζ valley of each mode: k and ζ free with the same suffix (k_x & zeta_x, k & zeta, k_y2 & zeta_y2)
    valleys = [(par.free.index(n), par.free.index("zeta" + n[1:])) for n in par.free
               if par.kind(n) == "k" and "zeta" + n[1:] in par.free]
    if 1 < len(valleys) <= 4:
        for signs in itertools.product((1, -1), repeat=len(valleys)):
            r = np.zeros(p)
            for (ik, iz), sg in zip(valleys, signs):
                r[ik], r[iz] = sg, -sg
            rows.append(r[None])
    return np.unique(np.vstack(rows), axis=0)


def fit_newton(problem: Problem, theta0: np.ndarray | None = None, *, scaled: bool = True, alpha: float = 1.0,
               max_iter: int = 600, tol: float = 1e-6, fd_step: float = 1e-4, n_guesses: int = 16,
               explore_iters: int = 40, n_screen: int = 2048, n_centres: int = 8, n_refine: int = 1024,
               refine: dict[str, float] | None = None, min_distance: float = 0.05, jump: float = 0.05,
               min_jump: float = 0.05 / 256, max_step: float = 0.1, patience: int = 3, improve_tol: float = 0.01,
               n_random_jumps: int = 16, n_fn_grid: int = 1024, critical_weight: float = 10.0, critical_window: float = 0.02, seed: int = 0,
               search: dict[str, float] | None = None, progress: Progress | None = None,
               noise: float | None = None) -> Fit:
    """The paper's Newton–Raphson identification (see module docstring for every option).

    ``noise`` (stated relative depth noise, or ``None``) only feeds the quality checks
    (:func:`~millstab.identify.quality.diagnose`): this scheme reports no standard errors.

    Args:
        theta0: start [Hz, N/m, -]; default the parameterization's start.
        scaled: update in log coordinates (default) or literally in physical units.
        alpha: the paper's pace α in (0, 1].
        tol: stopping threshold on the (unweighted) MLAE [log(1 + mm)].
        n_guesses: initial guesses (1 = only the start); explore_iters: iterations before keeping the best.
        n_screen: size of the Sobol design the guesses are picked from; n_fn_grid: points of the regular
            grid over the (one or two) fn columns screened with it (0: none); min_distance: the least
            log-distance (max-norm, up to the x↔y swap) between two guesses.
        search: {kind: ×/÷ half-width} to screen a box around the start instead of the whole bounds box.
        jump, min_jump: the first and the smallest trial-jump size (relative).
        critical_weight: weight of points near critical points (1 = the unweighted eq. 4).
        seed: seed of the initial-guess design and the random jumps.
    """
    for name, v, ok in (("alpha", alpha, 0 < alpha <= 1), ("max_iter", max_iter, max_iter >= 1),
                        ("n_guesses", n_guesses, n_guesses >= 1), ("jump", jump, 0 < jump < 1),
                        ("min_jump", min_jump, 0 < min_jump <= jump),
                        ("critical_weight", critical_weight, critical_weight >= 1), ("fd_step", fd_step, 0 < fd_step < 0.1)):
        if not ok:
            raise InputError(name, v, {"alpha": "must be in (0, 1]", "max_iter": "must be >= 1", "n_guesses": "must be >= 1",
                                       "jump": "must be in (0, 1)", "min_jump": "must be in (0, jump]",
                                       "critical_weight": "must be >= 1", "fd_step": "must be in (0, 0.1)"}[name])
    noise = check_noise(noise)
    t0 = time.perf_counter()
    sets0, calls0 = problem.n_sets, problem.n_calls
    par = problem.par
    p = par.size
    lo, hi = np.log(par.lower), np.log(par.upper)
    perm = swap_permutation(par, problem.cutting)
    start = par.theta0 if theta0 is None else np.asarray(theta0, dtype=float)
    u_start = np.clip(np.log(start), lo, hi)
    rng = np.random.default_rng(seed)
    refine = {**REFINE_NEWTON, **(refine or {})}
    u = u_start[None]  # (G, P) current guesses in log coordinates
    if n_guesses > 1:
        # a diverse set of initial guesses: the start plus a scrambled-Sobol design over the whole bounds box
        # (or the ``search`` box around the start), ranked by MLAE in ONE engine call; the n_guesses best
        # that are pairwise distinct go on to explore
        blo, bhi = search_box(problem, u_start, {**SEARCH_NEWTON, **(search or {})})
        m = int(np.ceil(np.log2(max(n_screen, n_guesses, 2))))
        sob = qmc.Sobol(p, scramble=True, seed=seed).random_base2(m)[:max(n_screen, n_guesses - 1)]
        cand = np.vstack([u_start[None], blo + sob * (bhi - blo)])
        fn_cols = [j for j, n in enumerate(par.free) if par.kind(n) == "fn"]
        if n_fn_grid > 0 and 1 <= len(fn_cols) <= 2:
            # the natural frequencies dominate the SLD (fn ≫ k > ζ): a regular grid over the fn columns
            # of the box, every other parameter at the start
            m_ax = max(2, int(round(n_fn_grid ** (1 / len(fn_cols)))))
            axes = [np.linspace(blo[j], bhi[j], m_ax) for j in fn_cols]
            grid = np.tile(u_start, (m_ax ** len(fn_cols), 1))
            grid[:, fn_cols] = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(fn_cols))
            cand = np.vstack([cand, grid])
        f0 = problem.mlae(problem.predict_mm(np.exp(cand)))
        if n_refine > 0:
            # a second, finer design: n_refine Sobol points in a small box around each of the
            # ``n_centres`` best distinct candidates (all in ONE engine call)
            centres = cand[pick_distinct(cand, f0, n_centres, min_distance, perm)]
            half = np.log([refine[par.kind(n)] for n in par.free])
            m2 = int(np.ceil(np.log2(max(n_refine, 2))))
            sob2 = qmc.Sobol(p, scramble=True, seed=seed + 1).random_base2(m2)[:n_refine]
            local = np.clip((centres[:, None, :] + (2 * sob2[None] - 1) * half).reshape(-1, p), lo, hi)
            f_local = problem.mlae(problem.predict_mm(np.exp(local)))
            cand, f0 = np.vstack([cand, local]), np.concatenate([f0, f_local])
        u = cand[pick_distinct(cand, f0, n_guesses, min_distance, perm)]
    g0 = u.shape[0]
    hist_u: list[np.ndarray] = []
    hist_f: list[float] = []
    best_path: list[np.ndarray] = []  # the best point so far, per iteration
    best_u, best_f = u_start.copy(), np.inf
    since_improve = 0
    ref_f = np.inf  # best MLAE at the last "real" improvement (for the stagnation test)
    want_jumps = False
    jump_signs = jump_directions(par)
    jump_now = jump
    n_jumps_tried = n_jumps_kept = 0
    it = 0
    base_w = problem.weight
    for it in range(1, max_iter + 1):
        g = u.shape[0]
        theta = np.exp(u)
        # forward-difference rows: scaled → u + ε; literal → p + ε p (the same points, different units of S)
        rows = np.repeat(theta[:, None, :], p + 1, axis=1)
        idx = np.arange(p)
        rows[:, 1 + idx, idx] = theta * np.exp(fd_step) if scaled else theta * (1 + fd_step)
        all_rows = [rows.reshape(-1, p)]
        jumps = None
        if want_jumps and g == 1:
            signs = np.vstack([jump_signs, rng.integers(-1, 2, (n_random_jumps, p))])  # random ones afresh
            jumps = best_u + np.log1p(jump_now) * signs
            # pattern jumps: along the recent progress of the best point (its path down a curved valley),
            # extrapolated by several multiples
            if len(best_path) > 1:
                d = best_u[None] - np.array([best_path[max(0, len(best_path) - 1 - lag)] for lag in PATTERN_LAGS])
                d = d[np.abs(d).max(axis=1) > 1e-9]
                if d.size:
                    jumps = np.vstack([jumps, (best_u[None, None] + PATTERN_MULTIPLES[None, :, None] * d[:, None]).reshape(-1, p)])
            jumps = np.clip(jumps, lo, hi)
            all_rows.append(np.exp(jumps))
        pred = problem.predict_mm(np.vstack(all_rows))  # ONE engine call per iteration
        pg = pred[:g * (p + 1)].reshape(g, p + 1, -1)
        f_plain = problem.mlae(pg[:, 0])
        # critical-point weights from the measured and the current guessed boundary
        crit = critical_mask(problem.rpm, problem.depth_mm, pg[:, 0], critical_window)
        w = base_w * np.where(crit, critical_weight, 1.0)  # (G, n)
        f_w = problem.mlae(pg.reshape(g * (p + 1), -1), np.repeat(w, p + 1, axis=0)).reshape(g, p + 1)
        # record this iteration (the guess being evaluated, unweighted MLAE)
        i_best = int(np.argmin(f_plain))
        hist_u.append(u[i_best].copy())
        hist_f.append(float(f_plain[i_best]))
        if f_plain[i_best] < best_f:
            best_u, best_f = u[i_best].copy(), float(f_plain[i_best])
        best_path.append(best_u.copy())
        jumped = False
        if jumps is not None:
            n_jumps_tried += 1
            fj = problem.mlae(pred[g * (p + 1):])
            j = int(np.argmin(fj))
            if fj[j] < best_f:  # kept only when it improves the objective (on the best so far)
                n_jumps_kept += 1
                best_u, best_f = jumps[j].copy(), float(fj[j])
                u = jumps[j][None].copy()
                jumped = True
                jump_now = min(2 * jump_now, jump)  # a kept jump: the next ones may be larger again
            else:  # no jump helped: try smaller ones next time
                jump_now = max(jump_now / 2, min_jump)
        if progress is not None:
            progress("newton", it, best_f)
        if best_f < tol:
            break
        # stagnation bookkeeping → trial jumps next iteration
        if best_f < ref_f * (1 - improve_tol):
            ref_f, since_improve = best_f, 0
        else:
            since_improve += 1
        want_jumps = since_improve >= patience
        if jumped:
            continue
        # the Newton step (paper eq. newton), in u (scaled) or in physical units (literal)
        if scaled:
            s = fd_difference(f_w, np.full((g, p), fd_step))[1][:, 0]  # ∂MLAE/∂u (forward differences)
            step = alpha * f_w[:, :1] * s / np.maximum((s * s).sum(axis=1, keepdims=True), 1e-300)
            # safeguard: MLAE/‖S‖ explodes where the objective is flat; cap each log step
            u = np.clip(u - np.clip(step, -max_step, max_step), lo, hi)
        else:
            s = fd_difference(f_w, theta * fd_step)[1][:, 0]  # ∂MLAE/∂p in physical units (step ε = fd_step·p)
            step = alpha * f_w[:, :1] * s / np.maximum((s * s).sum(axis=1, keepdims=True), 1e-300)
            theta_new = np.clip(theta - step, par.lower, par.upper)
            u = np.log(theta_new)
        if g > 1 and it >= explore_iters:  # exploration over: only the best guess continues
            u = u[[i_best]]
    theta_hat = canonical(np.exp(best_u), perm)
    pred_hat = problem.predict_mm(theta_hat[None])
    warn = []
    codes: list[str] = []
    symmetry = None
    if perm is not None:
        symmetry = ("x and y are interchangeable: swapping the x and y parameters leaves this cut's SLD unchanged "
                    "exactly (α_xx = α_yy, e.g. slotting); the estimate is given in canonical order (fn_x <= fn_y)")
        codes.append("xy_symmetry")
        warn.append("x/y symmetry: " + symmetry.split(":", 1)[1].strip())
    if best_f >= tol:
        codes.append("not_converged")
        warn.append(f"stopping threshold MLAE < {tol:g} not reached in {max_iter} iterations (best {best_f:.3g})")
    cuts = problem.cut_report(theta_hat)
    hist_theta = np.exp(np.array(hist_u))
    fit = Fit(method="newton", par=par, estimate=theta_hat, start=np.exp(u_start), mlae=float(problem.mlae(pred_hat)[0]),
               rss=float(problem.rss(pred_hat)[0]), iterations=it, evaluations=problem.n_sets - sets0,
               engine_calls=problem.n_calls - calls0, time_s=time.perf_counter() - t0, history_theta=hist_theta,
               history_mlae=np.array(hist_f), history_rss=np.full(len(hist_f), np.nan), warnings=warn,
               codes=codes, symmetry=symmetry, test_cuts=cuts, cutting=problem.cutting,
               settings={"scaled": scaled, "alpha": alpha, "max_iter": max_iter, "tol": tol, "fd_step": fd_step,
                         "n_guesses": n_guesses, "n_guesses_used": g0, "n_fn_grid": n_fn_grid, "explore_iters": explore_iters, "n_screen": n_screen, "jump": jump, "min_jump": min_jump, "patience": patience,
                         "improve_tol": improve_tol, "n_random_jumps": n_random_jumps,
                         "critical_weight": critical_weight, "critical_window": critical_window, "seed": seed,
                         "jumps_tried": n_jumps_tried, "jumps_kept": n_jumps_kept, "engine": problem.engine,
                         "noise": noise})
    return diagnose(fit, problem, noise, problem.residuals(pred_hat)[0])


__all__ = ["critical_mask", "fit_newton", "jump_directions"]
