"""Compiled (numba) kernels of the semi-discretization. Use :mod:`millstab.stability.sdm` instead.

Model (SI units). Every mode j is a 1-DOF oscillator in direction d_j (x = feed, y = cross-feed):

    q̈_j + 2 ζ_j ω_j q̇_j + ω_j² q_j = F_{d_j}(t) / m_j,     x = Σ_{d_j = x} q_j,  y = Σ_{d_j = y} q_j,
    F(t) = w [A(t)] (u(t) − u(t − T)),   w = ½ b Kt,  u = (x, y),  T = 60 / (N Ω[rpm]),

[A(t)] = Σ_teeth g(φ_j) [[−sin2φ − Kr(1 − cos2φ), −(1 + cos2φ) − Kr sin2φ],
                         [(1 − cos2φ) − Kr sin2φ,    sin2φ − Kr(1 + cos2φ)]],

φ_j the tooth angles (from +y, Altintas), g = 1 inside [φst, φex]. Its average over a tooth period is
(N/2π)[α] (the zero-order matrix). Only the directions that carry modes take part (D ≤ 2 of them).

State z = (q_1..q_M, q̇_1..q̇_M), n = 2M. One tooth period is cut into steps on a grid aligned with
the entry/exit instants; on step i (length h_i) the periodic matrix is replaced by its exact step
average Ā_i and the delayed displacement by its linear interpolation between grid nodes (first-order
semi-discretization):

    z_{i+1} = Φ_i z_i + (F1_i − F2_i/h_i) B_i u_{i−m} + (F2_i/h_i) B_i u_{i−m+1},
    Φ = e^{A h},  F1 = ∫₀ʰ e^{A(h−s)} ds,  F2 = ∫₀ʰ e^{A(h−s)} s ds,

A_i = A0 + w Ê_i − c_pd P̂_i (current-state part of the cutting force, and the process damping
c_pd = b C / V acting on the velocities along the step average P̄_i of Σ_teeth g n nᵀ, n = (sin φ, cos φ):
see :mod:`millstab.stability.process_damping`; c_pd = 0 skips it), B_i the delayed part. Steps where no
tooth cuts have no forcing and are one exact step. Φ, F1, F2 are functions of the small matrix A_i
evaluated in closed form (n = 2, Cayley–Hamilton with divided differences) or by eigendecomposition
(n > 2; an ill-conditioned eigenbasis falls back to a scaled Taylor series of the block matrix).
"""

from __future__ import annotations

import math

import llvmlite.binding as _llvm
import numba as nb
import numpy as np
from numba import types
from numba.extending import get_cython_function_address

TWO_PI = 2.0 * math.pi

# LAPACK dgeev straight from SciPy: numba's own eigvals needs complex input for a real matrix with
# complex eigenvalues, and complex zgeev is ~3× slower than real dgeev on these 20–100 sized matrices.
# It is bound by symbol name (registered with LLVM at import), so the compiled kernels can be cached;
# a ctypes pointer would be a "dynamic global" and force a recompile in every process.
_llvm.add_symbol("millstab_sdm_dgeev", get_cython_function_address("scipy.linalg.cython_lapack", "dgeev"))
_dgeev = types.ExternalFunction("millstab_sdm_dgeev", types.void(*([types.intp] * 14)))

#: condition number of the eigenbasis above which the Taylor fallback is used (n > 2)
COND_MAX = 1e7


# the scalar and 2×2 closed forms live in _linalg (shared with the time-domain simulation)
from millstab.stability._linalg import _expm_2x2, _jfun  # noqa: E402,F401


@nb.njit(cache=True)
def _expm_taylor(A, h, phi, f1, f2):
    """Fallback: exp of the block matrix [[A, I, 0], [0, 0, I], [0, 0, 0]] h by scaling and squaring
    of a Taylor series; its first block row is (Φ, F1, F2) (Van Loan)."""
    n = A.shape[0]
    X = np.zeros((3 * n, 3 * n))
    for i in range(n):
        for j in range(n):
            X[i, j] = A[i, j] * h
        X[i, n + i] = h
        X[n + i, 2 * n + i] = h
    nrm = 0.0
    for j in range(3 * n):
        cs = 0.0
        for i in range(3 * n):
            cs += abs(X[i, j])
        nrm = max(nrm, cs)
    sq = 0
    while nrm > 0.25:
        nrm *= 0.5
        sq += 1
    X *= 0.5 ** sq
    # fix the scaled blocks: exp(X/2^sq)^(2^sq) = exp(X), so scaling all of X is right
    E = np.eye(3 * n)
    term = np.eye(3 * n)
    for k in range(1, 18):
        term = term @ X / k
        E += term
    for _ in range(sq):
        E = E @ E
    for i in range(n):
        for j in range(n):
            phi[i, j] = E[i, j]
            f1[i, j] = E[i, n + j]
            f2[i, j] = E[i, 2 * n + j]


@nb.njit(cache=True)
def _expm_eig(A, h, phi, f1, f2):
    """Φ, F1, F2 of a real n×n matrix by eigendecomposition, Taylor fallback when ill-conditioned."""
    n = A.shape[0]
    Ac = A.astype(np.complex128)
    lam, V = np.linalg.eig(Ac)
    Vi = np.linalg.inv(V)
    c1 = 0.0
    c2 = 0.0
    for j in range(n):
        s1 = 0.0
        s2 = 0.0
        for i in range(n):
            s1 += abs(V[i, j])
            s2 += abs(Vi[i, j])
        c1 = max(c1, s1)
        c2 = max(c2, s2)
    if not (c1 * c2 < COND_MAX):
        _expm_taylor(A, h, phi, f1, f2)
        return
    J = np.empty(2, dtype=np.complex128)
    fe = np.empty(n, dtype=np.complex128)
    ff1 = np.empty(n, dtype=np.complex128)
    ff2 = np.empty(n, dtype=np.complex128)
    for k in range(n):
        z = lam[k] * h
        _jfun(z, 1, J)
        fe[k] = np.exp(z)
        ff1[k] = h * J[0]
        ff2[k] = h * h * (J[0] - J[1])
    for i in range(n):
        for j in range(n):
            se = 0.0j
            s1 = 0.0j
            s2 = 0.0j
            for k in range(n):
                p = V[i, k] * Vi[k, j]
                se += p * fe[k]
                s1 += p * ff1[k]
                s2 += p * ff2[k]
            phi[i, j] = se.real
            f1[i, j] = s1.real
            f2[i, j] = s2.real


@nb.njit(cache=True)
def free_flight(wn, zeta, h):
    """e^{A0 h} for the uncut structure (block diagonal: each mode's 2×2 in closed form)."""
    m = wn.size
    n = 2 * m
    phi = np.zeros((n, n))
    p = np.empty((2, 2))
    f1 = np.empty((2, 2))
    f2 = np.empty((2, 2))
    for j in range(m):
        _expm_2x2(0.0, 1.0, -wn[j] * wn[j], -2.0 * zeta[j] * wn[j], h, p, f1, f2)
        phi[j, j] = p[0, 0]
        phi[j, m + j] = p[0, 1]
        phi[m + j, j] = p[1, 0]
        phi[m + j, m + j] = p[1, 1]
    return phi


# ---------------------------------------------------------------------------------------------------
# the time-periodic directional matrix
# ---------------------------------------------------------------------------------------------------


@nb.njit(cache=True)
def _in_cut(phi, phi_s, phi_e):
    """Whether angle phi [rad] (any value) lies in the cut [φst, φex]."""
    p = phi % TWO_PI
    return phi_s <= p <= phi_e


@nb.njit(cache=True)
def step_average(n_teeth, kr, phi_s, phi_e, th_a, th_b, out):
    """Average of [A(φ)] over tooth-0 angles [th_a, th_b] (all teeth), written to out (2, 2).

    The step must not straddle an entry or exit instant (the grid is aligned), so each tooth is in or
    out of the cut for the whole step, decided at the step's middle. Returns True if any tooth cuts.
    """
    pitch = TWO_PI / n_teeth
    dth = th_b - th_a
    out[:, :] = 0.0
    cutting = False
    for j in range(n_teeth):
        a = th_a + j * pitch
        b = th_b + j * pitch
        if not _in_cut(0.5 * (a + b), phi_s, phi_e):
            continue
        cutting = True
        S = 0.5 * (math.cos(2 * a) - math.cos(2 * b))  # ∫ sin2φ
        C = 0.5 * (math.sin(2 * b) - math.sin(2 * a))  # ∫ cos2φ
        out[0, 0] += -(S + kr * (dth - C))
        out[0, 1] += -((dth + C) + kr * S)
        out[1, 0] += (dth - C) - kr * S
        out[1, 1] += S - kr * (dth + C)
    out /= dth
    return cutting


@nb.njit(cache=True)
def step_contact(n_teeth, phi_s, phi_e, th_a, th_b, out):
    """Average of Σ_teeth g(φ) n nᵀ, n = (sin φ, cos φ), over tooth-0 angles [th_a, th_b], written to
    out (2, 2): the process-damping directions (n nᵀ = ½[[1 − cos2φ, sin2φ], [sin2φ, 1 + cos2φ]]).
    Same in/out decision per tooth as :func:`step_average`."""
    pitch = TWO_PI / n_teeth
    dth = th_b - th_a
    out[:, :] = 0.0
    for j in range(n_teeth):
        a = th_a + j * pitch
        b = th_b + j * pitch
        if not _in_cut(0.5 * (a + b), phi_s, phi_e):
            continue
        S = 0.5 * (math.cos(2 * a) - math.cos(2 * b))  # ∫ sin2φ
        C = 0.5 * (math.sin(2 * b) - math.sin(2 * a))  # ∫ cos2φ
        out[0, 0] += 0.5 * (dth - C)
        out[0, 1] += 0.5 * S
        out[1, 0] += 0.5 * S
        out[1, 1] += 0.5 * (dth + C)
    out /= dth


@nb.njit(cache=True)
def period_grid(n_teeth, kr, phi_s, phi_e, rpm, h_target, mult):
    """The step grid of one tooth period at speed ``rpm``.

    Tooth 0 enters at t = 0. Breakpoints (entry/exit of any tooth) sit at phase 0 and
    (φex − φst) mod pitch; each cutting segment is cut into ceil(len/h_target) equal steps, a segment
    without cutting is one step; ``mult`` multiplies the step count of every cutting segment (so
    mult = 2 halves every step of the mult = 1 grid, as Richardson extrapolation needs). Returns h (m,) [s],
    cut (m,) bool, the step averages Abar (m, 2, 2) of the directional matrix and Pbar (m, 2, 2) of Σ g n nᵀ
    (:func:`step_contact`).
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
    # first pass: count steps
    counts = np.empty(n_seg, dtype=np.int64)
    tmp = np.empty((2, 2))
    for k in range(n_seg):
        a = phi_s + bounds[k]
        b = phi_s + bounds[k + 1]
        if step_average(n_teeth, kr, phi_s, phi_e, a, b, tmp):
            counts[k] = mult * max(1, int(math.ceil((b - a) / omega / h_target - 1e-9)))
        else:
            counts[k] = 1
    m = counts.sum()
    h = np.empty(m)
    cut = np.empty(m, dtype=np.bool_)
    abar = np.empty((m, 2, 2))
    pbar = np.empty((m, 2, 2))
    i = 0
    for k in range(n_seg):
        dth = (bounds[k + 1] - bounds[k]) / counts[k]
        for q in range(counts[k]):
            a = phi_s + bounds[k] + q * dth
            b = a + dth
            cut[i] = step_average(n_teeth, kr, phi_s, phi_e, a, b, abar[i])
            step_contact(n_teeth, phi_s, phi_e, a, b, pbar[i])
            h[i] = dth / omega
            i += 1
    return h, cut, abar, pbar


# ---------------------------------------------------------------------------------------------------
# monodromy and spectral radius
# ---------------------------------------------------------------------------------------------------


@nb.njit(cache=True)
def _eig_real(U, wr, wi, work, ints, chars):
    """Eigenvalues of the real square matrix U (destroyed) via LAPACK dgeev. Returns info (0 = ok)."""
    n = U.shape[0]
    ints[0] = n
    ints[1] = n
    ints[2] = 1
    ints[3] = work.size
    ints[4] = 0
    dummy = np.empty(1)
    # U is C-ordered: LAPACK sees Uᵀ, which has the same eigenvalues
    _dgeev(chars[0:].ctypes.data, chars[1:].ctypes.data, ints[0:].ctypes.data, U.ctypes.data,
           ints[1:].ctypes.data, wr.ctypes.data, wi.ctypes.data, dummy.ctypes.data, ints[2:].ctypes.data,
           dummy.ctypes.data, ints[2:].ctypes.data, work.ctypes.data, ints[3:].ctypes.data,
           ints[4:].ctypes.data)
    return ints[4]


@nb.njit(cache=True)
def history_layout(cut):
    """Which nodes of the previous period enter the recursion, and their column offsets (per D).

    Node p (0 ≤ p < m) is used when step p or step p − 1 cuts; node m is the current node 0.
    Returns hpos (m + 1,) with -1 for unused nodes and the count of used nodes.
    """
    m = cut.size
    hpos = np.full(m + 1, -1, dtype=np.int64)
    c = 0
    for p in range(m):
        if cut[p] or (p >= 1 and cut[p - 1]):
            hpos[p] = c
            c += 1
    return hpos, c



@nb.njit(cache=True, inline="always")
def _matmul_into(P, Z, out):
    """out = P @ Z for the small per-step blocks, written out: a BLAS call per step costs more than the product."""
    for r in range(P.shape[0]):
        for col in range(Z.shape[1]):
            s = 0.0
            for q in range(P.shape[1]):
                s += P[r, q] * Z[q, col]
            out[r, col] = s

@nb.njit(cache=True)
def monodromy(b, kt, wn, zeta, mass, mdir, n_dir, h, cut, abar_d, phi_free, hpos, n_used, cpd, pbar_d):
    """The reduced monodromy matrix over one tooth period at depth b [m], shape (K, K).

    Rows/columns: the modal state (n) followed by D tool-tip displacements at each used node of the
    previous period (unused history nodes only add zero multipliers and are left out).

    Args: kt [N/m²]; wn [rad/s], zeta, mass [kg] (M,); mdir (M,) index of each mode's active
    direction; h, cut, abar_d (m, D, D) the step grid restricted to the active directions;
    phi_free (m, n, n) e^{A0 h_i} for every step (used where the step does not cut); cpd = b C / V the
    process damping [N·s/m] along pbar_d (m, D, D), the step averages of Σ g n nᵀ (0: none, skipped).
    """
    M = wn.size
    n = 2 * M
    D = n_dir
    m = h.size
    K = n + D * n_used
    w = 0.5 * b * kt
    U = np.zeros((K, K))
    Z = np.zeros((n, K))
    for i in range(n):
        Z[i, i] = 1.0
    Znew = np.empty((n, K))
    A = np.empty((n, n))
    phi = np.empty((n, n))
    f1 = np.empty((n, n))
    f2 = np.empty((n, n))
    Bd = np.zeros((n, D))
    G0 = np.empty((n, D))
    G1 = np.empty((n, D))
    for i in range(m):
        if hpos[i] >= 0:  # store this node's displacement as a history row of the next period
            r = n + D * hpos[i]
            for e in range(D):
                for col in range(K):
                    s = 0.0
                    for j in range(M):
                        if mdir[j] == e:
                            s += Z[j, col]
                    U[r + e, col] = s
        if not cut[i]:
            _matmul_into(phi_free[i], Z, Znew)
        else:
            hi = h[i]
            # A_i = A0 + w Ê_i; B_i = −w [0; Ā_i / m_j]
            A[:, :] = 0.0
            for j in range(M):
                A[j, M + j] = 1.0
                A[M + j, j] = -wn[j] * wn[j]
                A[M + j, M + j] = -2.0 * zeta[j] * wn[j]
            for j in range(M):
                for l in range(M):
                    A[M + j, l] += w * abar_d[i, mdir[j], mdir[l]] / mass[j]
                for e in range(D):
                    Bd[M + j, e] = -w * abar_d[i, mdir[j], e] / mass[j]
            if cpd != 0.0:  # process damping: −c_pd P̄_i u̇, u̇ in direction e the sum of its modal velocities
                for j in range(M):
                    for l in range(M):
                        A[M + j, M + l] -= cpd * pbar_d[i, mdir[j], mdir[l]] / mass[j]
            if n == 2:
                _expm_2x2(A[0, 0], A[0, 1], A[1, 0], A[1, 1], hi, phi, f1, f2)
            else:
                _expm_eig(A, hi, phi, f1, f2)
            for r in range(n):
                for e in range(D):
                    s1 = 0.0
                    s2 = 0.0
                    for q in range(M, n):  # Bd is zero in the displacement rows
                        s1 += f1[r, q] * Bd[q, e]
                        s2 += f2[r, q] * Bd[q, e]
                    G1[r, e] = s2 / hi
                    G0[r, e] = s1 - s2 / hi
            _matmul_into(phi, Z, Znew)
            # delayed node i (history) and node i + 1 (history, or the current node 0 at the end)
            c0 = n + D * hpos[i]
            for r in range(n):
                for e in range(D):
                    Znew[r, c0 + e] += G0[r, e]
            if i + 1 < m:
                c1 = n + D * hpos[i + 1]
                for r in range(n):
                    for e in range(D):
                        Znew[r, c1 + e] += G1[r, e]
            else:  # u_0 = C z_0, and z_0 is the identity block of the initial data
                for r in range(n):
                    for j in range(M):
                        Znew[r, j] += G1[r, mdir[j]]
        for r in range(n):
            for col in range(K):
                Z[r, col] = Znew[r, col]
    for r in range(n):
        for col in range(K):
            U[r, col] = Z[r, col]
    return U


@nb.njit(cache=True)
def multipliers(U):
    """All eigenvalues of the square matrix U (copied) via LAPACK dgeev; NaN if LAPACK fails."""
    K = U.shape[0]
    A = U.copy()
    wr = np.empty(K)
    wi = np.empty(K)
    work = np.empty(8 * K + 16)
    ints = np.empty(5, dtype=np.int32)
    chars = np.array([78, 78], dtype=np.uint8)  # 'N', 'N': eigenvalues only
    info = _eig_real(A, wr, wi, work, ints, chars)
    out = np.empty(K, dtype=np.complex128)
    for k in range(K):
        out[k] = complex(wr[k], wi[k]) if info == 0 else complex(np.nan, np.nan)
    return out


@nb.njit(cache=True)
def _dominant(mus):
    """(ρ, dominant multiplier); of a conjugate pair the one with Im ≥ 0 (well-defined frequency).
    ρ = inf when the eigenvalues are not finite (a failed solve is never taken for stable)."""
    best = 0.0
    for k in range(mus.size):
        a = abs(mus[k])
        if not math.isfinite(a):
            return np.inf, complex(np.nan, np.nan)
        best = max(best, a)
    mu = complex(np.nan, np.nan)
    for k in range(mus.size):
        if abs(mus[k]) >= best * (1 - 1e-9) and (not (mu.imag >= 0.0) or mus[k].imag >= 0.0):
            mu = mus[k]
    return best, mu


@nb.njit(cache=True)
def spectral_radius(U):
    """(ρ, dominant multiplier) of the square matrix U."""
    return _dominant(multipliers(U))


@nb.njit(cache=True)
def richardson_multipliers(mu1, mu2, n_top):
    """Multiplier-wise Richardson extrapolation (4 μ_fine − μ_coarse)/3 of the n_top largest fine
    multipliers, each paired with the nearest coarse one (the grids are nested, so they correspond).

    Extrapolating ρ itself would be wrong where two multipliers compete for the largest modulus (the
    dominant one can differ between the grids); per multiplier the error is a smooth O(h²).
    """
    order = np.argsort(-np.abs(mu2))
    n = min(n_top, mu2.size)
    out = np.empty(n, dtype=np.complex128)
    for q in range(n):
        v = mu2[order[q]]
        best = np.inf
        near = v
        for k in range(mu1.size):
            dist = abs(mu1[k] - v)
            if dist < best:
                best = dist
                near = mu1[k]
        out[q] = (4.0 * v - near) / 3.0
    return out


# ---------------------------------------------------------------------------------------------------
# drivers: per speed set up the grid once, then evaluate many depths
# ---------------------------------------------------------------------------------------------------


@nb.njit(cache=True)
def _setup(n_teeth, kr, phi_s, phi_e, rpm, steps, mult, wn, zeta, act):
    """Grid, step averages restricted to active directions, and free-flight exponentials per step."""
    T = 60.0 / (n_teeth * rpm)
    h, cut, abar, pbar = period_grid(n_teeth, kr, phi_s, phi_e, rpm, T / steps, mult)
    m = h.size
    D = act.size
    abar_d = np.empty((m, D, D))
    pbar_d = np.empty((m, D, D))
    for i in range(m):
        for e in range(D):
            for f in range(D):
                abar_d[i, e, f] = abar[i, act[e], act[f]]
                pbar_d[i, e, f] = pbar[i, act[e], act[f]]
    n = 2 * wn.size
    phi_free = np.zeros((m, n, n))
    for i in range(m):
        if not cut[i]:
            phi_free[i] = free_flight(wn, zeta, h[i])
    hpos, n_used = history_layout(cut)
    return h, cut, abar_d, phi_free, hpos, n_used, pbar_d


@nb.njit(cache=True)
def _rho1(b, kt, wn, zeta, mass, mdir, D, h, cut, abar_d, phi_free, hpos, n_used, cpd, pbar_d):
    U = monodromy(b, kt, wn, zeta, mass, mdir, D, h, cut, abar_d, phi_free, hpos, n_used, cpd, pbar_d)
    return multipliers(U)


@nb.njit(cache=True)
def _rho(b, kt, wn, zeta, mass, mdir, D, g1, g2, rich, cv):
    """(ρ, dominant μ) at depth b on grid g1, or Richardson-extrapolated from g1 and its halving g2;
    cv = C / V [N·s/m²] the process damping per unit depth at this speed (0: none)."""
    mu1 = _rho1(b, kt, wn, zeta, mass, mdir, D, g1[0], g1[1], g1[2], g1[3], g1[4], g1[5], cv * b, g1[6])
    if not rich:
        return _dominant(mu1)
    mu2 = _rho1(b, kt, wn, zeta, mass, mdir, D, g2[0], g2[1], g2[2], g2[3], g2[4], g2[5], cv * b, g2[6])
    return _dominant(richardson_multipliers(mu1, mu2, 8))


@nb.njit(cache=True, parallel=True)
def rho_grid(n_teeth, kt, kr, phi_s, phi_e, rpm, steps, rich, depth, wn, zeta, mass, mdir, act, first, last, out, cv):
    """ρ (S, Dp) at speeds rpm (S,) and depths depth (Dp,) [m]; steps (S,) steps per tooth period;
    cv (S,) the process damping per unit depth C / V [N·s/m²] at each speed (zeros: none);
    ``rich``: multiplier-wise Richardson extrapolation from the grid and its halving. Only the speeds
    first..last-1 are computed (the caller runs the grid in chunks, to stay interruptible)."""
    n_d = depth.size
    for q in nb.prange(last - first):
        s = first + q
        g1 = _setup(n_teeth, kr, phi_s, phi_e, rpm[s], steps[s], 1, wn, zeta, act)
        g2 = _setup(n_teeth, kr, phi_s, phi_e, rpm[s], steps[s], 2 if rich else 1, wn, zeta, act)
        for k in range(n_d):
            out[s, k] = _rho(depth[k], kt, wn, zeta, mass, mdir, act.size, g1, g2, rich, cv[s])[0]


@nb.njit(cache=True)
def _illinois(b_lo, f_lo, b_hi, f_hi, mu_hi, rtol, kt, wn, zeta, mass, mdir, D, g1, g2, rich, cv):
    """Shrink the bracket (ρ(b_lo) ≤ 1 < ρ(b_hi)) on ρ − 1 to a relative width rtol (Illinois method)."""
    n_eval = 0
    if not math.isfinite(f_hi):
        f_hi = 1.0
    side = 0
    for _ in range(100):
        if b_hi - b_lo <= rtol * b_hi:
            break
        x = (b_lo * f_hi - b_hi * f_lo) / (f_hi - f_lo)
        # keep the guess well inside the bracket, so the bracket shrinks even when ρ is kinked
        lo_g = b_lo + 0.02 * (b_hi - b_lo)
        hi_g = b_hi - 0.02 * (b_hi - b_lo)
        if not (lo_g <= x <= hi_g):
            x = 0.5 * (b_lo + b_hi)
        r, mu = _rho(x, kt, wn, zeta, mass, mdir, D, g1, g2, rich, cv)
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
def _first_crossing(b_ref, factors, rtol, kt, wn, zeta, mass, mdir, D, g1, g2, rich, cv):
    """First crossing of ρ(b) = 1 from b = 0 upward on one grid.

    Bracket: ρ on the depths b_ref·factors (ascending), stopping at the first unstable one, then
    geometric expansion (×1.5) up to 1e4·b_ref; refined by :func:`_illinois`. Returns (depth [m] or
    inf, dominant multiplier at the unstable bracket end, number of ρ evaluations).
    """
    b_lo = 0.0
    f_lo = _rho(0.0, kt, wn, zeta, mass, mdir, D, g1, g2, rich, cv)[0] - 1.0
    n_eval = 1
    b_hi = -1.0
    f_hi = 0.0
    mu_hi = complex(np.nan, np.nan)
    b = 0.0
    k = 0
    while b < 1e4 * b_ref:
        if k < factors.size:
            b = b_ref * factors[k]
        else:
            b *= 1.5
        k += 1
        r, mu = _rho(b, kt, wn, zeta, mass, mdir, D, g1, g2, rich, cv)
        n_eval += 1
        if r > 1.0:
            b_hi, f_hi, mu_hi = b, r - 1.0, mu
            break
        b_lo, f_lo = b, r - 1.0
    if b_hi < 0:
        return np.inf, complex(np.nan, np.nan), n_eval
    d, mu, c = _illinois(b_lo, f_lo, b_hi, f_hi, mu_hi, rtol, kt, wn, zeta, mass, mdir, D, g1, g2, rich, cv)
    return d, mu, n_eval + c


@nb.njit(cache=True)
def limit_one(n_teeth, kt, kr, phi_s, phi_e, rpm, steps, rich, b_ref, factors, wn, zeta, mass, mdir, act, rtol, cv):
    """Limiting depth [m] at one speed with ``steps`` per tooth period (``rich``: Richardson-extrapolated
    multipliers from that grid and its halving); cv = C / V the process damping per unit depth [N·s/m²]
    (0: none). Returns (depth or inf, dominant μ, ρ evaluations)."""
    g1 = _setup(n_teeth, kr, phi_s, phi_e, rpm, steps, 1, wn, zeta, act)
    g2 = _setup(n_teeth, kr, phi_s, phi_e, rpm, steps, 2 if rich else 1, wn, zeta, act)
    return _first_crossing(b_ref, factors, rtol, kt, wn, zeta, mass, mdir, act.size, g1, g2, rich, cv)


@nb.njit(cache=True, parallel=True)
def limit_batch(n_teeth, kt, kr, phi_s, phi_e, rpm, steps, richardson, b_ref, factors, wn, zeta, mass, mdir, act,
                rtol, first, last, depth, mu, n_eval, cv):
    """Limiting depths for B structures at S speeds: wn, zeta, mass (B, M), kr (B,) (each set's radial-to-tangential
    ratio: the ``per_set_kr`` capability, the cutting's own repeated otherwise); rpm, steps (S,); cv (B, S): the
    process damping per unit depth C / V [N·s/m²] of each set at each speed (zeros for none; a C per set is the
    ``per_set_process_damping`` capability);
    b_ref (B, S). Writes depth (B, S) [m], the dominant multiplier mu (B, S) and evaluation counts
    for the tasks first..last-1 of the B·S (structure, speed) pairs, row-major (the caller runs them
    in chunks, to stay interruptible; each pair is computed alone, so chunking changes no bit)."""
    n_s = rpm.size
    for q in nb.prange(last - first):
        t = first + q
        bi = t // n_s
        s = t % n_s
        d, m_, c = limit_one(n_teeth, kt, kr[bi], phi_s, phi_e, rpm[s], steps[s], richardson, b_ref[bi, s], factors,
                             wn[bi], zeta[bi], mass[bi], mdir, act, rtol, cv[bi, s])
        depth[bi, s] = d
        mu[bi, s] = m_
        n_eval[bi, s] = c
