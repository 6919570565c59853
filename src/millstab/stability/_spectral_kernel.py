"""Compiled (numba) kernels of the spectral-element engine. Use :mod:`millstab.stability.spectral` instead.

Model (SI units, the same as :mod:`millstab.stability._sdm_kernel`): mode j is a 1-DOF oscillator in
direction d_j; state z = (q_1..q_M, q̇_1..q̇_M), n = 2M;

    ż(t) = A0 z(t) + w E(t) (u(t) − u(t − T)),   u = C z (tool-tip displacements),   w = ½ b Kt,

E(t) maps the displacements through the periodic directional matrix [A(t)] onto the velocity rows
(E[M+j, e] = A_{d_j e}(t) / m_j). One tooth period is cut at every entry/exit instant into segments;
a segment where no tooth cuts is one exact free-flight step e^{A0 h}; a cutting segment (where [A(t)]
is a smooth trigonometric function) is cut into elements of at most ``elem_len`` seconds, and on each
element z is a polynomial of degree p collocated at the Chebyshev–Lobatto nodes τ_1..τ_p (τ_0 is the
element's start, where z is continuous):

    Σ_l D_kl z_l − (A0 + w E_k C) z_k = − w E_k u_old,k      (k = 1..p),

D the Chebyshev differentiation matrix on the element. The delayed displacement at a node is the
previous period's value at the same node (the grid is the same every period), so there is no
interpolation: the only discretisation error is the collocation error, which falls spectrally with p.

The monodromy matrix maps (z at the period start, u at every collocation node of the previous
period) to the same quantities one period later; its size n + D·(nodes) does not grow with the free
flight. Its eigenvalues (LAPACK dgeev, shared with the SDM kernel) are the Floquet multipliers.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from millstab.stability._sdm_kernel import _dominant, _in_cut, free_flight, multipliers

TWO_PI = 2.0 * math.pi


def gauss_nodes(p: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Element nodes x = (0, c_1..c_p) on [0, 1] (c the Gauss–Legendre points), the differentiation
    matrix of the degree-p interpolant through them (p + 1, p + 1), and its value weights at 1 (p + 1,).

    Collocation at Gauss points has order 2p at the element ends (superconvergence), so a few nodes
    give the transition over an element to ~1e-6.
    """
    c = 0.5 * (np.polynomial.legendre.leggauss(p)[0] + 1.0)
    x = np.concatenate([[0.0], c])
    diff = x[:, None] - x[None, :]
    np.fill_diagonal(diff, 1.0)
    wb = 1.0 / diff.prod(axis=1)  # barycentric weights
    D = (wb[None, :] / wb[:, None]) / diff
    np.fill_diagonal(D, 0.0)
    np.fill_diagonal(D, -D.sum(axis=1))
    d1 = 1.0 - x
    lend = (wb / d1) / np.sum(wb / d1)
    return np.ascontiguousarray(x), np.ascontiguousarray(D), np.ascontiguousarray(lend)


@nb.njit(cache=True)
def dir_matrix(n_teeth, kr, phi_s, phi_e, phi0, phi_mid, out):
    """[A] at tooth-0 angle phi0, with the teeth in the cut decided at the segment's mid angle phi_mid
    (one-sided values at entry/exit instants). Writes out (2, 2); returns True if any tooth cuts."""
    pitch = TWO_PI / n_teeth
    out[:, :] = 0.0
    cutting = False
    for j in range(n_teeth):
        if not _in_cut(phi_mid + j * pitch, phi_s, phi_e):
            continue
        cutting = True
        phi = phi0 + j * pitch
        s2 = math.sin(2 * phi)
        c2 = math.cos(2 * phi)
        out[0, 0] += -s2 - kr * (1.0 - c2)
        out[0, 1] += -(1.0 + c2) - kr * s2
        out[1, 0] += (1.0 - c2) - kr * s2
        out[1, 1] += s2 - kr * (1.0 + c2)
    return cutting


@nb.njit(cache=True)
def period_layout(n_teeth, kr, phi_s, phi_e, rpm, elem_len, x, act):
    """Elements of one tooth period (tooth 0 enters at t = 0).

    Returns kind (E,) (0 free flight, 1 collocation), h (E,) [s], Aq (E, p + 1, D, D) the directional
    matrix at the element's nodes (restricted to the active directions), and the number of
    collocation elements.
    """
    omega = TWO_PI * rpm / 60.0
    pitch = TWO_PI / n_teeth
    width = phi_e - phi_s
    s1 = width % pitch
    if width >= pitch - 1e-12 * pitch:
        if s1 < 1e-9 * pitch or pitch - s1 < 1e-9 * pitch:
            bounds = np.array([0.0, pitch])
        else:
            bounds = np.array([0.0, s1, pitch])
    else:
        bounds = np.array([0.0, width, pitch])
    n_seg = bounds.size - 1
    tmp = np.empty((2, 2))
    counts = np.empty(n_seg, dtype=np.int64)
    cuts = np.empty(n_seg, dtype=np.bool_)
    for k in range(n_seg):
        a = phi_s + bounds[k]
        b = phi_s + bounds[k + 1]
        cuts[k] = dir_matrix(n_teeth, kr, phi_s, phi_e, a, 0.5 * (a + b), tmp)
        if cuts[k]:
            counts[k] = max(1, int(math.ceil((b - a) / omega / elem_len - 1e-9)))
        else:
            counts[k] = 1
    E = counts.sum()
    p = x.size - 1
    D = act.size
    kind = np.empty(E, dtype=np.int64)
    h = np.empty(E)
    Aq = np.zeros((E, p + 1, D, D))
    i = 0
    n_col = 0
    for k in range(n_seg):
        dth = (bounds[k + 1] - bounds[k]) / counts[k]
        mid = phi_s + 0.5 * (bounds[k] + bounds[k + 1])
        for q in range(counts[k]):
            a = phi_s + bounds[k] + q * dth
            h[i] = dth / omega
            kind[i] = 1 if cuts[k] else 0
            if cuts[k]:
                n_col += 1
                for l in range(p + 1):
                    dir_matrix(n_teeth, kr, phi_s, phi_e, a + x[l] * dth, mid, tmp)
                    for e in range(D):
                        for f in range(D):
                            Aq[i, l, e, f] = tmp[act[e], act[f]]
            i += 1
    return kind, h, Aq, n_col


@nb.njit(cache=True)
def setup(n_teeth, kr, phi_s, phi_e, rpm, elem_len, x, wn, zeta, act):
    """Layout plus the free-flight exponentials of the free elements (zero elsewhere)."""
    kind, h, Aq, n_col = period_layout(n_teeth, kr, phi_s, phi_e, rpm, elem_len, x, act)
    n = 2 * wn.size
    phi_free = np.zeros((h.size, n, n))
    for i in range(h.size):
        if kind[i] == 0:
            phi_free[i] = free_flight(wn, zeta, h[i])
    return kind, h, Aq, n_col, phi_free


@nb.njit(cache=True)
def monodromy(b, kt, wn, zeta, mass, mdir, D, kind, h, Aq, n_col, phi_free, Dm, lend):
    """The monodromy matrix (K, K), K = n + D·p·(collocation elements), at depth b [m].

    Columns/rows: z at the period start (n), then u at every collocation node τ_1..τ_p of every
    collocation element (D each), previous period → this period.
    """
    M = wn.size
    n = 2 * M
    p = Dm.shape[0] - 1
    K = n + D * p * n_col
    w = 0.5 * b * kt
    U = np.zeros((K, K))
    Z = np.zeros((n, K))
    for i in range(n):
        Z[i, i] = 1.0
    Znew = np.empty((n, K))
    P = p * n
    L = np.empty((P, P))
    R = np.empty((P, n + D * p))
    X = np.empty((P, K))
    ce = 0  # collocation element counter
    for el in range(h.size):
        if kind[el] == 0:
            for r in range(n):
                for col in range(K):
                    s = 0.0
                    for q in range(n):
                        s += phi_free[el, r, q] * Z[q, col]
                    Znew[r, col] = s
            for r in range(n):
                for col in range(K):
                    Z[r, col] = Znew[r, col]
            continue
        hi = h[el]
        L[:, :] = 0.0
        R[:, :] = 0.0
        for k in range(1, p + 1):
            rk = (k - 1) * n
            for l in range(1, p + 1):
                dkl = Dm[k, l] / hi
                cl = (l - 1) * n
                for r in range(n):
                    L[rk + r, cl + r] = dkl
            # − (A0 + w E_k C) on the diagonal block
            for j in range(M):
                L[rk + j, rk + M + j] -= 1.0
                L[rk + M + j, rk + j] += wn[j] * wn[j]
                L[rk + M + j, rk + M + j] += 2.0 * zeta[j] * wn[j]
                for l in range(M):
                    L[rk + M + j, rk + l] -= w * Aq[el, k, mdir[j], mdir[l]] / mass[j]
            # right-hand sides: − D_k0 z_0 (first n columns), − w E_k u_old,k (node k's D columns)
            d0 = Dm[k, 0] / hi
            for r in range(n):
                R[rk + r, r] = -d0
            for j in range(M):
                for e in range(D):
                    R[rk + M + j, n + (k - 1) * D + e] = -w * Aq[el, k, mdir[j], e] / mass[j]
        Y = np.linalg.solve(L, R)
        # node states in the global columns: X = Y[:, :n] Z + Y[:, n:] at this element's history columns
        c0 = n + D * p * ce
        for r in range(P):
            for col in range(K):
                s = 0.0
                for q in range(n):
                    s += Y[r, q] * Z[q, col]
                X[r, col] = s
            for c in range(D * p):
                X[r, c0 + c] += Y[r, n + c]
        # this period's displacements at the nodes (history rows of U), and the end state
        for k in range(1, p + 1):
            rk = (k - 1) * n
            for e in range(D):
                row = n + D * (p * ce + k - 1) + e
                for col in range(K):
                    s = 0.0
                    for j in range(M):
                        if mdir[j] == e:
                            s += X[rk + j, col]
                    U[row, col] = s
        # the end state from the interpolant (Gauss nodes are interior): z(h) = Σ_l ℓ_l(1) z_l
        for r in range(n):
            for col in range(K):
                s = lend[0] * Z[r, col]
                for k in range(1, p + 1):
                    s += lend[k] * X[(k - 1) * n + r, col]
                Znew[r, col] = s
        for r in range(n):
            for col in range(K):
                Z[r, col] = Znew[r, col]
        ce += 1
    for r in range(n):
        for col in range(K):
            U[r, col] = Z[r, col]
    return U


@nb.njit(cache=True)
def rho(b, kt, wn, zeta, mass, mdir, D, g, nd):
    """(ρ, dominant multiplier) at depth b [m] on the layout g."""
    U = monodromy(b, kt, wn, zeta, mass, mdir, D, g[0], g[1], g[2], g[3], g[4], nd[1], nd[2])
    return _dominant(multipliers(U))


@nb.njit(cache=True)
def _illinois(b_lo, f_lo, b_hi, f_hi, mu_hi, rtol, kt, wn, zeta, mass, mdir, D, g, nd):
    """Shrink the bracket (ρ(b_lo) ≤ 1 < ρ(b_hi)) on ρ − 1 to a relative width rtol (Illinois method)."""
    n_eval = 0
    if not math.isfinite(f_hi):
        f_hi = 1.0
    side = 0
    for _ in range(100):
        if b_hi - b_lo <= rtol * b_hi:
            break
        x = (b_lo * f_hi - b_hi * f_lo) / (f_hi - f_lo)
        # keep the guess inside the bracket, so it shrinks even where ρ is kinked (dominance switch)
        lo_g = b_lo + 0.02 * (b_hi - b_lo)
        hi_g = b_hi - 0.02 * (b_hi - b_lo)
        if not (lo_g <= x <= hi_g):
            x = 0.5 * (b_lo + b_hi)
        r, mu = rho(x, kt, wn, zeta, mass, mdir, D, g, nd)
        n_eval += 1
        fx = r - 1.0
        if fx > 0.0:
            b_hi, f_hi, mu_hi = x, fx, mu
            if side == 1:
                f_lo *= 0.5
            side = 1
        else:
            b_lo, f_lo = x, fx
            if side == -1:
                f_hi *= 0.5
            side = -1
    return 0.5 * (b_lo + b_hi), mu_hi, n_eval


@nb.njit(cache=True)
def first_crossing(guess, ladder, rtol, rho0, kt, wn, zeta, mass, mdir, D, g, nd):
    """First crossing of ρ(b) = 1 from b = 0 upward.

    ρ on the depths guess·ladder (ascending), stopping at the first unstable one, then geometric
    expansion (×1.5) up to 1e4·guess; the bracket is refined by :func:`_illinois`. ``rho0`` = ρ(0)
    (free decay, known in closed form). Returns (depth [m] or inf, dominant multiplier at the
    unstable end, number of ρ evaluations).
    """
    b_lo = 0.0
    f_lo = rho0 - 1.0
    n_eval = 0
    b_hi = -1.0
    f_hi = 0.0
    mu_hi = complex(np.nan, np.nan)
    b = 0.0
    k = 0
    while b < 1e4 * guess:
        if k < ladder.size:
            b = guess * ladder[k]
        else:
            b *= 1.5
        k += 1
        r, mu = rho(b, kt, wn, zeta, mass, mdir, D, g, nd)
        n_eval += 1
        if r > 1.0:
            b_hi, f_hi, mu_hi = b, r - 1.0, mu
            break
        b_lo, f_lo = b, r - 1.0
    if b_hi < 0:
        return np.inf, complex(np.nan, np.nan), n_eval
    d, mu, c = _illinois(b_lo, f_lo, b_hi, f_hi, mu_hi, rtol, kt, wn, zeta, mass, mdir, D, g, nd)
    return d, mu, n_eval + c


@nb.njit(cache=True)
def limit_run(n_teeth, kt, kr, phi_s, phi_e, rpm, b_ref, ladder, ladder_cont, wn, zeta, mass, mdir, act, elem_len,
              nd, rtol, depth, mu, n_eval):
    """Limiting depths along ascending speeds rpm (S,) for one structure, continuing from speed to speed.

    The first speed's ladder is b_ref·``ladder`` (b_ref the zero-order depth). Later speeds use
    ``ladder_cont`` times a guess extrapolated linearly from the two previous depths (clamped to
    [0.5, 2] times the last one): the boundary is continuous in speed except where a new unstable
    island appears, which the low rungs must catch. Writes depth, mu, n_eval (S,).
    """
    prev = np.inf
    prev2 = np.inf
    for s in range(rpm.size):
        g = setup(n_teeth, kr, phi_s, phi_e, rpm[s], elem_len, nd[0], wn, zeta, act)
        T = 60.0 / (n_teeth * rpm[s])
        rho0 = 0.0
        for j in range(wn.size):
            rho0 = max(rho0, math.exp(-zeta[j] * wn[j] * T))
        if math.isfinite(prev):
            guess = prev
            if s >= 2 and math.isfinite(prev2):
                slope = (prev - prev2) / (rpm[s - 1] - rpm[s - 2])
                guess = min(2.0 * prev, max(0.5 * prev, prev + slope * (rpm[s] - rpm[s - 1])))
            d, m_, c = first_crossing(guess, ladder_cont, rtol, rho0, kt, wn, zeta, mass, mdir, act.size, g, nd)
        else:
            d, m_, c = first_crossing(b_ref[s], ladder, rtol, rho0, kt, wn, zeta, mass, mdir, act.size, g, nd)
        depth[s] = d
        mu[s] = m_
        n_eval[s] = c
        prev2 = prev
        prev = d


@nb.njit(cache=True, parallel=True)
def limit_batch(n_teeth, kt, kr, phi_s, phi_e, rpm, starts, b_ref, ladder, ladder_cont, wn, zeta, mass, mdir, act,
                elem_len, nd, rtol, depth, mu, n_eval):
    """Limiting depths for B structures (wn, zeta, mass (B, M)) at ascending speeds rpm (S,), split into
    blocks starting at ``starts`` (each block continues from speed to speed). Parallel over
    (set, block) pairs. b_ref (B, S); writes depth (B, S) [m], mu (B, S), n_eval (B, S)."""
    n_b = wn.shape[0]
    n_blk = starts.size - 1
    for t in nb.prange(n_b * n_blk):
        bi = t // n_blk
        k = t % n_blk
        a = starts[k]
        e = starts[k + 1]
        limit_run(n_teeth, kt, kr, phi_s, phi_e, rpm[a:e], b_ref[bi, a:e], ladder, ladder_cont, wn[bi], zeta[bi],
                  mass[bi], mdir, act, elem_len[bi], nd, rtol, depth[bi, a:e], mu[bi, a:e], n_eval[bi, a:e])
