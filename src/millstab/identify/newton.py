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
from dataclasses import dataclass

import numpy as np
from millstab.errors import InputError
from millstab.forward import fd_difference
from millstab.identify.search import options_with, pick_distinct, search_box, sobol
from millstab.identify.symmetry import canonical, swap_permutation, xy_symmetry_note
from millstab.identify.objective import Problem
from millstab.identify.quality import check_noise, diagnose
from millstab.identify.result import Fit
from millstab.progress import SolverProgress


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


#: the option checks of :func:`fit_newton`: (test, what is allowed) per option
_RULES = {"alpha": (lambda v, o: 0 < v <= 1, "must be in (0, 1]"), "max_iter": (lambda v, o: v >= 1, "must be >= 1"),
          "n_guesses": (lambda v, o: v >= 1, "must be >= 1"), "jump": (lambda v, o: 0 < v < 1, "must be in (0, 1)"),
          "min_jump": (lambda v, o: 0 < v <= o["jump"], "must be in (0, jump]"),
          "critical_weight": (lambda v, o: v >= 1, "must be >= 1"),
          "fd_step": (lambda v, o: 0 < v < 0.1, "must be in (0, 0.1)")}


def check_options(**options) -> None:
    """InputError naming the first option (of :data:`_RULES`, in their order) outside its range."""
    for name, (ok, allowed) in _RULES.items():
        if name in options and not ok(options[name], options):
            raise InputError(name, options[name], allowed)


def screen_design(par, u_start: np.ndarray, blo: np.ndarray, bhi: np.ndarray, n: int, n_fn_grid: int,
                  seed: int) -> np.ndarray:
    """Candidates (N, P) in ln θ: the start, ``n`` scrambled-Sobol points in the box [blo, bhi] and, with
    one or two fn free, a regular grid of about ``n_fn_grid`` points over the fn columns of the box (every
    other parameter at the start): the natural frequencies dominate the SLD (fn ≫ k > ζ)."""
    p = par.size
    cand = np.vstack([u_start[None], blo + sobol(p, n, seed) * (bhi - blo)])
    fn_cols = [j for j, name in enumerate(par.free) if par.kind(name) == "fn"]
    if n_fn_grid > 0 and 1 <= len(fn_cols) <= 2:
        m_ax = max(2, int(round(n_fn_grid ** (1 / len(fn_cols)))))
        axes = [np.linspace(blo[j], bhi[j], m_ax) for j in fn_cols]
        grid = np.tile(u_start, (m_ax ** len(fn_cols), 1))
        grid[:, fn_cols] = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(fn_cols))
        cand = np.vstack([cand, grid])
    return cand


def refine_design(par, centres: np.ndarray, n_refine: int, refine: dict[str, float], seed: int) -> np.ndarray:
    """``n_refine`` scrambled-Sobol points in a box ×/÷ ``refine[kind]`` around each centre (C, P),
    stacked (C·n_refine, P) in ln θ, inside the bounds."""
    p = par.size
    half = np.log([refine[par.kind(n)] for n in par.free])
    local = (centres[:, None, :] + (2 * sobol(p, n_refine, seed)[None] - 1) * half).reshape(-1, p)
    return np.clip(local, np.log(par.lower), np.log(par.upper))


def initial_guesses(problem: Problem, u_start: np.ndarray, *, n_guesses: int, n_screen: int, n_fn_grid: int,
                    n_centres: int, n_refine: int, refine: dict[str, float], min_distance: float, seed: int,
                    search: dict[str, float] | None, perm) -> np.ndarray:
    """Refinement 3, the diverse initial guesses (G, P) in ln θ: the screening design (:func:`screen_design`)
    ranked by MLAE in ONE call, the finer design around its ``n_centres`` best distinct candidates
    (:func:`refine_design`, one call), then the ``n_guesses`` best pairwise-distinct candidates."""
    if n_guesses <= 1:
        return u_start[None]
    par = problem.par
    blo, bhi = search_box(problem, u_start, {**SEARCH_NEWTON, **(search or {})})
    cand = screen_design(par, u_start, blo, bhi, max(n_screen, n_guesses - 1), n_fn_grid, seed)
    f0 = problem.mlae(problem.predict_mm(np.exp(cand)))
    if n_refine > 0:
        centres = cand[pick_distinct(cand, f0, n_centres, min_distance, perm)]
        local = refine_design(par, centres, n_refine, refine, seed + 1)
        f_local = problem.mlae(problem.predict_mm(np.exp(local)))
        cand, f0 = np.vstack([cand, local]), np.concatenate([f0, f_local])
    return cand[pick_distinct(cand, f0, n_guesses, min_distance, perm)]


def difference_rows(theta: np.ndarray, fd_step: float, scaled: bool) -> np.ndarray:
    """Each guess (G, P) and its P forward-difference points, (G, P + 1, P) [SI]: scaled → u + ε
    (θ·e^ε), literal → p + ε p (the same points, different units of the sensitivity)."""
    p = theta.shape[1]
    rows = np.repeat(theta[:, None, :], p + 1, axis=1)
    idx = np.arange(p)
    rows[:, 1 + idx, idx] = theta * np.exp(fd_step) if scaled else theta * (1 + fd_step)
    return rows


def trial_jumps(best_u: np.ndarray, best_path: list[np.ndarray], signs: np.ndarray, jump: float, lo: np.ndarray,
                hi: np.ndarray) -> np.ndarray:
    """Refinement 1, the trial jumps (J, P) in ln θ from the best point: ×/÷ (1 + ``jump``) along each
    row of ``signs``, then the pattern jumps along the best point's recent progress (best − best
    ``PATTERN_LAGS`` iterations ago, × ``PATTERN_MULTIPLES``), inside the bounds."""
    p = best_u.size
    jumps = best_u + np.log1p(jump) * signs
    if len(best_path) > 1:
        d = best_u[None] - np.array([best_path[max(0, len(best_path) - 1 - lag)] for lag in PATTERN_LAGS])
        d = d[np.abs(d).max(axis=1) > 1e-9]
        if d.size:
            jumps = np.vstack([jumps,
                               (best_u[None, None] + PATTERN_MULTIPLES[None, :, None] * d[:, None]).reshape(-1, p)])
    return np.clip(jumps, lo, hi)


def weighted_mlae(problem: Problem, pg: np.ndarray, critical_weight: float, critical_window: float):
    """Refinement 2: for predictions pg (G, P + 1, n) [mm] of each guess and its difference rows, the
    plain MLAE of the guesses (G,) and the MLAE (G, P + 1) with the points near a critical point of the
    measured or the guess's boundary weighted ``critical_weight``."""
    g, m, _ = pg.shape
    crit = critical_mask(problem.rpm, problem.depth_mm, pg[:, 0], critical_window)
    w = problem.weight * np.where(crit, critical_weight, 1.0)  # (G, n)
    f_w = problem.mlae(pg.reshape(g * m, -1), np.repeat(w, m, axis=0)).reshape(g, m)
    return problem.mlae(pg[:, 0]), f_w


def newton_step(u: np.ndarray, theta: np.ndarray, f_w: np.ndarray, *, fd_step: float, scaled: bool, alpha: float,
                max_step: float, par) -> np.ndarray:
    """The paper's update p ← p − α · MLAE · S / ‖S‖² for each guess (G, P), with S from the forward
    differences f_w (G, P + 1): in u = ln p (scaled; each log step capped at ``max_step``) or in
    physical units (literal). Returns the new guesses in ln θ, inside the bounds."""
    g, p = u.shape
    lo, hi = np.log(par.lower), np.log(par.upper)
    if scaled:
        s = fd_difference(f_w, np.full((g, p), fd_step))[1][:, 0]  # ∂MLAE/∂u (forward differences)
        step = alpha * f_w[:, :1] * s / np.maximum((s * s).sum(axis=1, keepdims=True), 1e-300)
        # safeguard: MLAE/‖S‖ explodes where the objective is flat; cap each log step
        return np.clip(u - np.clip(step, -max_step, max_step), lo, hi)
    s = fd_difference(f_w, theta * fd_step)[1][:, 0]  # ∂MLAE/∂p in physical units (step ε = fd_step·p)
    step = alpha * f_w[:, :1] * s / np.maximum((s * s).sum(axis=1, keepdims=True), 1e-300)
    return np.log(np.clip(theta - step, par.lower, par.upper))


@dataclass(frozen=True)
class NewtonOptions:
    """The tuning of :func:`fit_newton` (the module docstring explains each), checked when built: an
    option out of range is an InputError naming it. ``fit_newton(problem, options=NewtonOptions(alpha=0.5))``
    and ``fit_newton(problem, alpha=0.5)`` are the same call (the keywords replace fields of ``options``)."""

    scaled: bool = True
    alpha: float = 1.0
    max_iter: int = 600
    tol: float = 1e-6
    fd_step: float = 1e-4
    n_guesses: int = 16
    explore_iters: int = 40
    n_screen: int = 2048
    n_centres: int = 8
    n_refine: int = 1024
    refine: dict[str, float] | None = None
    min_distance: float = 0.05
    jump: float = 0.05
    min_jump: float = 0.05 / 256
    max_step: float = 0.1
    patience: int = 3
    improve_tol: float = 0.01
    n_random_jumps: int = 16
    n_fn_grid: int = 1024
    critical_weight: float = 10.0
    critical_window: float = 0.02

    def __post_init__(self) -> None:
        check_options(alpha=self.alpha, max_iter=self.max_iter, n_guesses=self.n_guesses, jump=self.jump,
                      min_jump=self.min_jump, critical_weight=self.critical_weight, fd_step=self.fd_step)


def fit_newton(problem: Problem, theta0: np.ndarray | None = None, *, options: NewtonOptions | None = None,
               seed: int = 0, search: dict[str, float] | None = None, progress: SolverProgress | None = None,
               noise: float | None = None, **tuning) -> Fit:
    """The paper's Newton–Raphson identification (see module docstring for every option), in stages:
    :func:`initial_guesses`, then per iteration :func:`difference_rows` (and :func:`trial_jumps` when
    stagnating) in ONE call, :func:`weighted_mlae`, :func:`newton_step`.

    ``noise`` (stated relative depth noise, or ``None``) only feeds the quality checks
    (:func:`~millstab.identify.quality.diagnose`): this scheme reports no standard errors.

    Args:
        theta0: start [Hz, N/m, -]; default the parameterization's start.
        options: the tuning (:class:`NewtonOptions`, its fields below); keywords named as its fields
            replace them (``fit_newton(problem, alpha=0.5)``).
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
    o = options_with(options, NewtonOptions, tuning, "fit_newton")  # checked when built
    (scaled, alpha, max_iter, tol, fd_step, n_guesses, explore_iters, n_screen, n_centres, n_refine, refine,
     min_distance, jump, min_jump, max_step, patience, improve_tol, n_random_jumps, n_fn_grid,
     critical_weight, critical_window) = (
        o.scaled, o.alpha, o.max_iter, o.tol, o.fd_step, o.n_guesses, o.explore_iters, o.n_screen, o.n_centres,
        o.n_refine, o.refine, o.min_distance, o.jump, o.min_jump, o.max_step, o.patience, o.improve_tol,
        o.n_random_jumps, o.n_fn_grid, o.critical_weight, o.critical_window)
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
    u = initial_guesses(problem, u_start, n_guesses=n_guesses, n_screen=n_screen, n_fn_grid=n_fn_grid,
                        n_centres=n_centres, n_refine=n_refine, refine={**REFINE_NEWTON, **(refine or {})},
                        min_distance=min_distance, seed=seed, search=search, perm=perm)  # (G, P) in ln θ
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
    for it in range(1, max_iter + 1):
        g = u.shape[0]
        theta = np.exp(u)
        all_rows = [difference_rows(theta, fd_step, scaled).reshape(-1, p)]
        jumps = None
        if want_jumps and g == 1:
            signs = np.vstack([jump_signs, rng.integers(-1, 2, (n_random_jumps, p))])  # random ones afresh
            jumps = trial_jumps(best_u, best_path, signs, jump_now, lo, hi)
            all_rows.append(np.exp(jumps))
        pred = problem.predict_mm(np.vstack(all_rows))  # ONE engine call per iteration
        f_plain, f_w = weighted_mlae(problem, pred[:g * (p + 1)].reshape(g, p + 1, -1), critical_weight,
                                     critical_window)
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
        u = newton_step(u, theta, f_w, fd_step=fd_step, scaled=scaled, alpha=alpha, max_step=max_step, par=par)
        if g > 1 and it >= explore_iters:  # exploration over: only the best guess continues
            u = u[[i_best]]
    theta_hat = canonical(np.exp(best_u), perm)
    pred_hat = problem.predict_mm(theta_hat[None])
    warn = []
    codes: list[str] = []
    symmetry = None
    if perm is not None:
        symmetry, text = xy_symmetry_note("(fn_x <= fn_y)")
        codes.append("xy_symmetry")
        warn.append(text)
    if best_f >= tol:
        codes.append("not_converged")
        warn.append(f"stopping threshold MLAE < {tol:g} not reached in {max_iter} iterations (best {best_f:.3g})")
    cuts = problem.cut_report(theta_hat)
    hist_theta = np.exp(np.array(hist_u))
    fit = Fit(method="newton", par=par, estimate=theta_hat, start=np.exp(u_start),
              mlae=float(problem.mlae(pred_hat)[0]),
               rss=float(problem.rss(pred_hat)[0]), iterations=it, evaluations=problem.n_sets - sets0,
               engine_calls=problem.n_calls - calls0, time_s=time.perf_counter() - t0, history_theta=hist_theta,
               history_mlae=np.array(hist_f), history_rss=np.full(len(hist_f), np.nan), warnings=warn,
               codes=codes, symmetry=symmetry, test_cuts=cuts, cutting=problem.cutting,
               settings={"scaled": scaled, "alpha": alpha, "max_iter": max_iter, "tol": tol, "fd_step": fd_step,
                         "n_guesses": n_guesses, "n_guesses_used": g0, "n_fn_grid": n_fn_grid,
                         "explore_iters": explore_iters, "n_screen": n_screen, "jump": jump, "min_jump": min_jump,
                         "patience": patience, "improve_tol": improve_tol, "n_random_jumps": n_random_jumps,
                         "critical_weight": critical_weight, "critical_window": critical_window, "seed": seed,
                         "jumps_tried": n_jumps_tried, "jumps_kept": n_jumps_kept, "engine": problem.engine,
                         "noise": noise})
    return diagnose(fit, problem, noise, problem.residuals(pred_hat)[0])


__all__ = ["NewtonOptions", "check_options", "critical_mask", "difference_rows", "fit_newton", "initial_guesses",
           "jump_directions", "newton_step", "refine_design", "screen_design", "trial_jumps", "weighted_mlae"]
