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
flight. Its eigenvalues (:func:`eig_small`, a compiled QR: 2× faster than LAPACK at this size) are the Floquet
multipliers. The root search's ρ uses :func:`monodromy_small`, the same operator on the reduced history (a tooth's
force depends on its chip thickness only, so the past enters a node through one number per tooth in
the cut, :func:`node_factors`): the same nonzero multipliers with n + Σ(teeth in the cut per node)
rows, half the history at low immersion.

Root finding (:func:`limit_run`): the boundary points are Newton roots (:func:`newton`) of the n × n
characteristic function det(μ I − Ψ(σ)) with its exact Jacobian (:func:`char_d`; Ψ and dΨ/dσ from one
hand-written LU per element, :func:`psi_d`), continued from speed to speed as branches; the dense
eigenvalues of the monodromy (:func:`rho`) run the search from below (:func:`scan_to`), which accepts a
root only where it would not stop below it, and bracket crossings no branch tracked. :func:`char_fn` / :func:`psi` are
the same function without derivatives through numpy's solver (the tests' independent path). Costs measured (x = y one
mode each, a/D = 0.05, p = 6, CPU time on the shared machine): char_d 14–25 µs; ρ on the full monodromy (16–28
rows) 30–79 µs (dgeev 18–54 µs of it), on the reduced one (10–16 rows) 18–41 µs; the envelope figures
are in :mod:`millstab.stability.spectral`.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from millstab.stability._sdm_kernel import _dominant, _in_cut, free_flight

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
def node_factors(n_teeth, kr, phi_s, phi_e, phi0, phi_mid, act, F, G):
    """[A] restricted to the active directions at tooth-0 angle phi0 (teeth in the cut decided at
    phi_mid) as F[:, :r] G[:, :r]ᵀ, F and G (D, D) written in place; returns the rank bound r.

    Why: one tooth's force depends on its chip thickness only, a scalar g·u (g = (sin φ, cos φ)), so
    its [A] is the rank-1 product 2 f gᵀ (f = (−cos φ − kr sin φ, sin φ − kr cos φ)); with fewer teeth
    in the cut than active directions (every low-immersion cut) the delayed displacement enters a node
    through r < D numbers, and the monodromy needs only those as history (:func:`monodromy_small`).
    With r ≥ D teeth cutting: F = [A], G = I, r = D."""
    D = act.size
    pitch = TWO_PI / n_teeth
    m = 0
    for j in range(n_teeth):
        if _in_cut(phi_mid + j * pitch, phi_s, phi_e):
            m += 1
    F[:, :] = 0.0
    G[:, :] = 0.0
    if m >= D:
        tmp = np.empty((2, 2))
        dir_matrix(n_teeth, kr, phi_s, phi_e, phi0, phi_mid, tmp)
        for e in range(D):
            G[e, e] = 1.0
            for f in range(D):
                F[e, f] = tmp[act[e], act[f]]
        return D
    fv = np.empty(2)
    gv = np.empty(2)
    r = 0
    for j in range(n_teeth):
        if not _in_cut(phi_mid + j * pitch, phi_s, phi_e):
            continue
        phi = phi0 + j * pitch
        sn = math.sin(phi)
        cs = math.cos(phi)
        fv[0] = 2.0 * (-cs - kr * sn)
        fv[1] = 2.0 * (sn - kr * cs)
        gv[0] = sn
        gv[1] = cs
        for e in range(D):
            F[e, r] = fv[act[e]]
            G[e, r] = gv[act[e]]
        r += 1
    return r


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
    """Layout plus the free-flight exponentials of the free elements (zero elsewhere), and the factors
    of [A] at every collocation node (:func:`node_factors`: Fq, Gq (E, p + 1, D, D), ranks rk (E, p + 1),
    zero on free elements). Returns (kind, h, Aq, n_col, phi_free, Fq, Gq, rk)."""
    kind, h, Aq, n_col = period_layout(n_teeth, kr, phi_s, phi_e, rpm, elem_len, x, act)
    n = 2 * wn.size
    phi_free = np.zeros((h.size, n, n))
    for i in range(h.size):
        if kind[i] == 0:
            phi_free[i] = free_flight(wn, zeta, h[i])
    # the factors, on the same angles as period_layout's Aq (elements in order, equal angle steps per segment)
    p1 = x.size
    D = act.size
    Fq = np.zeros((h.size, p1, D, D))
    Gq = np.zeros((h.size, p1, D, D))
    rk = np.zeros((h.size, p1), dtype=np.int64)
    omega = TWO_PI * rpm / 60.0
    t0 = 0.0  # element start [s] after tooth 0's entry
    for i in range(h.size):
        if kind[i] == 1:
            a = phi_s + omega * t0
            dth = omega * h[i]
            mid = a + 0.5 * dth  # inside the segment: the same teeth cut as at its mid angle
            for l in range(1, p1):
                rk[i, l] = node_factors(n_teeth, kr, phi_s, phi_e, a + x[l] * dth, mid, act, Fq[i, l], Gq[i, l])
        t0 += h[i]
    return kind, h, Aq, n_col, phi_free, Fq, Gq, rk


@nb.njit(cache=True)
def _element_lhs(L, el, hi, coef, wn, zeta, mass, mdir, Aq, Dm):
    """Fill L (p·n × p·n) of collocation element ``el`` (length hi [s]): the differentiation matrix's
    node block D_kl / hi on each state, minus (A0 + coef E_k C) on the diagonal blocks. ``coef`` is
    w = ½ b Kt (real, :func:`monodromy`) or σ = w (1 − 1/μ) (complex, :func:`psi`); L has its dtype."""
    M = wn.size
    n = 2 * M
    p = Dm.shape[0] - 1
    L[:, :] = 0.0
    for k in range(1, p + 1):
        rk = (k - 1) * n
        for l in range(1, p + 1):
            dkl = Dm[k, l] / hi
            cl = (l - 1) * n
            for r in range(n):
                L[rk + r, cl + r] = dkl
        for j in range(M):
            L[rk + j, rk + M + j] -= 1.0
            L[rk + M + j, rk + j] += wn[j] * wn[j]
            L[rk + M + j, rk + M + j] += 2.0 * zeta[j] * wn[j]
            for l in range(M):
                L[rk + M + j, rk + l] -= coef * Aq[el, k, mdir[j], mdir[l]] / mass[j]


@nb.njit(cache=True)
def _start_state(n, K):
    """The start of a monodromy build (:func:`monodromy`, :func:`monodromy_small`, :func:`monodromy_lr`): U (K, K)
    zero, to receive the history rows, and the state map Z (n, K) = [I | 0] (the state is itself; no history
    column written yet). :func:`_end_state` closes the build."""
    U = np.zeros((K, K))
    Z = np.zeros((n, K))
    for i in range(n):
        Z[i, i] = 1.0
    return U, Z


@nb.njit(cache=True)
def _end_state(U, Z):
    """The end of a monodromy build: its state rows U[:n] ← Z, the state map over the whole period; returns U."""
    for r in range(Z.shape[0]):
        for c in range(U.shape[1]):
            U[r, c] = Z[r, c]
    return U


@nb.njit(cache=True)
def _free_step(phi, Z, Znew, cols):
    """A free-flight element: Z[:, :cols] ← phi Z[:, :cols] (phi (n, n) its exact transition; Znew a work array
    of Z's shape and dtype). Columns from ``cols`` on are zero and stay so."""
    n = phi.shape[0]
    for r in range(n):
        for c in range(cols):
            acc = Z[0, c] * 0.0
            for q in range(n):
                acc += phi[r, q] * Z[q, c]
            Znew[r, c] = acc
    for r in range(n):
        for c in range(cols):
            Z[r, c] = Znew[r, c]


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
    U, Z = _start_state(n, K)
    Znew = np.empty((n, K))
    P = p * n
    L = np.empty((P, P))
    R = np.empty((P, n + D * p))
    X = np.empty((P, K))
    ce = 0  # collocation element counter
    for el in range(h.size):
        if kind[el] == 0:
            _free_step(phi_free[el], Z, Znew, K)
            continue
        hi = h[el]
        _element_lhs(L, el, hi, w, wn, zeta, mass, mdir, Aq, Dm)
        R[:, :] = 0.0
        for k in range(1, p + 1):
            rk = (k - 1) * n
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
    return _end_state(U, Z)


@nb.njit(cache=True)
def _elem_history(rk, el):
    """History rows of element el: the chip thicknesses at its nodes (Σ rk over its nodes 1..p)."""
    he = 0
    for k in range(1, rk.shape[1]):
        he += rk[el, k]
    return he


@nb.njit(cache=True)
def _history_size(kind, rk):
    """History rows of the reduced monodromy: those of every collocation element (kind 1)."""
    H = 0
    for el in range(kind.size):
        if kind[el] == 1:
            H += _elem_history(rk, el)
    return H


@nb.njit(cache=True)
def _history_rhs(R, el, hi, scale, rk, Dm, Fq, mdir, mass, n, M, p):
    """Fill an element's right-hand sides R (P, n + he) in place: − D_k0/h at node k's state rows (the first n
    columns, the element's start state) and ``scale`` · F_k/m at its force rows (the history columns, node by
    node); ``scale`` −w for the monodromy at depth factor w, 1 for the depth-free factor B."""
    col = n
    for k in range(1, p + 1):
        rk0 = (k - 1) * n
        d0 = Dm[k, 0] / hi
        for r in range(n):
            R[rk0 + r, r] = -d0
        for j in range(M):
            for i in range(rk[el, k]):
                R[rk0 + M + j, col + i] = scale * Fq[el, k, mdir[j], i] / mass[j]
        col += rk[el, k]


@nb.njit(cache=True)
def monodromy_small(b, kt, wn, zeta, mass, mdir, kind, h, Aq, phi_free, Fq, Gq, rk, Dm, lend):
    """The monodromy matrix on the reduced history (K, K), K = n + Σ rk: the same nonzero eigenvalues
    as :func:`monodromy`, at depth b [m].

    The delayed displacement enters node k only through Gqᵀ u (rk numbers, the chip thicknesses of the
    teeth in the cut, :func:`node_factors`), so that is the history kept: with U = P Q (Q: u ↦ Gqᵀ u
    per node), Q P has the nonzero eigenvalues of P Q. At low immersion (one tooth in the cut, two
    directions) the history halves: 10 rows instead of 16 with one element of 6 nodes, 16 instead of 28
    with two, and the eigenvalues (O(K³)) cost a quarter."""
    M = wn.size
    n = 2 * M
    p = Dm.shape[0] - 1
    K = n + _history_size(kind, rk)
    w = 0.5 * b * kt
    U, Z = _start_state(n, K)
    Znew = np.empty((n, K))
    P = p * n
    L = np.empty((P, P))
    piv = np.empty(P, dtype=np.int64)
    X = np.empty((P, K))
    hoff = n  # this element's first history column (and row)
    for el in range(h.size):
        if kind[el] == 0:
            _free_step(phi_free[el], Z, Znew, K)
            continue
        hi = h[el]
        he = _elem_history(rk, el)
        _element_lhs(L, el, hi, w, wn, zeta, mass, mdir, Aq, Dm)
        R = np.zeros((P, n + he))
        # right-hand sides: − D_k0 z_0 (first n columns), − w F_k (the old chip thicknesses at node k)
        _history_rhs(R, el, hi, -w, rk, Dm, Fq, mdir, mass, n, M, p)
        _lu_factor(L, piv)  # hand-written (24–48 rows: a LAPACK call's copies cost more than its arithmetic)
        _lu_solve(L, piv, R)
        Y = R
        for r in range(P):
            for c in range(K):
                acc = 0.0
                for q in range(n):
                    acc += Y[r, q] * Z[q, c]
                X[r, c] = acc
            for c in range(he):
                X[r, hoff + c] += Y[r, n + c]
        # this period's chip thicknesses at the nodes (history rows) and the end state
        row = hoff
        for k in range(1, p + 1):
            rk0 = (k - 1) * n
            for i in range(rk[el, k]):
                for c in range(K):
                    acc = 0.0
                    for j in range(M):
                        acc += Gq[el, k, mdir[j], i] * X[rk0 + j, c]
                    U[row, c] = acc
                row += 1
        for r in range(n):
            for c in range(K):
                acc = lend[0] * Z[r, c]
                for k in range(1, p + 1):
                    acc += lend[k] * X[(k - 1) * n + r, c]
                Znew[r, c] = acc
        Z[:, :] = Znew
        hoff += he
    return _end_state(U, Z)


@nb.njit(cache=True)
def low_rank_setup(g, wn, zeta, mass, mdir, nd):
    """The depth-independent part of every collocation element's map, once per speed (layout g from
    :func:`setup`, nodes nd from :func:`gauss_nodes`): (CA, S, LA, LE), zero on free elements.

    Why (issue 28, measured): ρ at ~21 ladder depths per speed is most of the engine's time, and each
    :func:`monodromy_small` factors every element's collocation matrix L(w) = L0 − w B Cᵀ (p·n rows) anew.
    The coupling is low-rank: B = the old-chip factors F / m in the velocity rows, Cᵀ = the new-chip factors
    G on the displacements (rank he = Σ rk, the element's history), and the element's right-hand side is
    [R0 | −w B]. With A = L0⁻¹R0, E = L0⁻¹B and W = (I − w S)⁻¹, S = Cᵀ E (Woodbury), only W depends on
    the depth: the element's history rows are Cᵀ L(w)⁻¹ [R0 | −w B] = [W CᵀA | I − W] and its end state
    (lend₀ I + Λ L(w)⁻¹ R0 | −w Λ L(w)⁻¹ B) = [LA + w LE W CᵀA | −w LE W] (Λ: the end-point weights).
    So a depth costs an he × he solve per element (:func:`monodromy_lr`) instead of a p·n one.
    CA (E, H, n) = CᵀA, S (E, H, H), LA (E, n, n) = lend₀ I + ΛA, LE (E, n, H) = ΛE; H = p·D."""
    kind, h, Aq, rk, Fq, Gq = g[0], g[1], g[2], g[7], g[5], g[6]
    Dm = nd[1]
    lend = nd[2]
    M = wn.size
    n = 2 * M
    p = Dm.shape[0] - 1
    P = p * n
    n_el = h.size
    Hm = p * Fq.shape[2]
    CA = np.zeros((n_el, Hm, n))
    S = np.zeros((n_el, Hm, Hm))
    LA = np.zeros((n_el, n, n))
    LE = np.zeros((n_el, n, Hm))
    L = np.empty((P, P))
    piv = np.empty(P, dtype=np.int64)
    RBw = np.empty((P, n + Hm))
    h_lu = -1.0  # the element length whose L0 is factored in L
    for el in range(n_el):
        if kind[el] == 0:
            continue
        hi = h[el]
        he = _elem_history(rk, el)
        if hi != h_lu:
            # L0 = L(0) depends on the element only through its length (the coupling term is w·Aq, w = 0): the
            # elements of a cutting segment share one length, so one LU serves them (the same factors bit for bit)
            _element_lhs(L, el, hi, 0.0, wn, zeta, mass, mdir, Aq, Dm)
            _lu_factor(L, piv)
            h_lu = hi
        RB = RBw[:, :n + he]
        RB[:, :] = 0.0
        _history_rhs(RB, el, hi, 1.0, rk, Dm, Fq, mdir, mass, n, M, p)
        _lu_solve(L, piv, RB)  # [A | E]
        row = 0
        for k in range(1, p + 1):
            rk0 = (k - 1) * n
            for i in range(rk[el, k]):
                for c in range(n + he):
                    acc = 0.0
                    for j in range(M):
                        acc += Gq[el, k, mdir[j], i] * RB[rk0 + j, c]
                    if c < n:
                        CA[el, row, c] = acc
                    else:
                        S[el, row, c - n] = acc
                row += 1
        for r in range(n):
            for c in range(n + he):
                acc = 0.0
                for k in range(1, p + 1):
                    acc += lend[k] * RB[(k - 1) * n + r, c]
                if c < n:
                    LA[el, r, c] = acc + (lend[0] if c == r else 0.0)
                else:
                    LE[el, r, c - n] = acc
    return CA, S, LA, LE


@nb.njit(cache=True)
def monodromy_lr(b, kt, g, lr):
    """:func:`monodromy_small` (the same matrix, other rounding) at depth b [m] from the per-speed factors
    lr = :func:`low_rank_setup` (g the layout): per collocation element an he × he solve (W = (I − w S)⁻¹)
    and products with the he + n rows the element adds, instead of a p·n collocation solve. Measured
    (issue 28): the same matrix to 1e-9 relative, ρ to 2.4e-12, on random cases (tests/test_spectral_lowrank.py).
    A new matrix; the search builds into its per-speed workspace instead (:func:`_build_lr`)."""
    return _build_lr(b, kt, g, lr, workspace(g, lr)).copy()


@nb.njit(cache=True)
def workspace(g, lr):
    """The work arrays of one speed's ρ evaluations (layout g, factors lr = :func:`low_rank_setup`), made once per
    speed by :func:`with_factors` and reused by every depth: U, Z, Znew, Mx, piv, QW, Ze of :func:`_build_lr`; P, Q
    (the certificate's squarings), A, wr, wi, out (the eigenvalues), d (the balancing scaling the certificate
    reuses, :func:`rho_test`; d[0] = 0: none yet), dn (a balancing's scaling being recorded).

    Why (issue 28): the certificate keeps the speed's balancing scaling from depth to depth (:func:`rho_test`), and
    its squarings write into the workspace; the build costs the same either way (1.9 µs at K ≈ 17, measured)."""
    kind, rk = g[0], g[7]
    CA, S, LA, LE = lr
    n = LA.shape[1]
    Hm = S.shape[1]
    K = n + _history_size(kind, rk)
    d = np.zeros(K)
    return (np.zeros((K, K)), np.zeros((n, K)), np.zeros((n, K)), np.empty((Hm, Hm)), np.empty(Hm, dtype=np.int64),
            np.empty((Hm, n + Hm)), np.empty((n, n)), np.empty((K, K)), np.empty((K, K)), np.empty((K, K)),
            np.empty(K), np.empty(K), np.empty(K, dtype=np.complex128), d, np.ones(K))


@nb.njit(cache=True)
def _build_lr(b, kt, g, lr, ws):
    """The monodromy of :func:`monodromy_lr` built into the workspace ws (:func:`workspace`); returns its U
    (overwritten by the next build at this speed). The same operations, so the same matrix bit for bit."""
    kind, h, phi_free, rk = g[0], g[1], g[4], g[7]
    CA, S, LA, LE = lr
    U, Z, Znew, Mx, piv, QW, Ze = ws[0], ws[1], ws[2], ws[3], ws[4], ws[5], ws[6]
    n = LA.shape[1]
    w = 0.5 * b * kt
    U[:, :] = 0.0
    Z[:, :] = 0.0
    for i in range(n):
        Z[i, i] = 1.0
    hoff = n  # this element's first history column (and row); Z is zero from it on
    for el in range(h.size):
        if kind[el] == 0:
            _free_step(phi_free[el], Z, Znew, hoff)
            continue
        he = _elem_history(rk, el)
        Mh = Mx[:he, :he]
        for r in range(he):
            for c in range(he):
                Mh[r, c] = -w * S[el, r, c]
            Mh[r, r] += 1.0
        B = QW[:he, :n + he]
        for r in range(he):
            for c in range(n):
                B[r, c] = CA[el, r, c]
            for c in range(he):
                B[r, n + c] = 0.0
            B[r, n + r] = 1.0
        _lu_factor(Mh, piv[:he])
        _lu_solve(Mh, piv[:he], B)  # [Q | W], Q = W CᵀA
        # history rows: Q Z, and I − W at this element's history columns
        for r in range(he):
            for c in range(hoff):
                acc = 0.0
                for q in range(n):
                    acc += B[r, q] * Z[q, c]
                U[hoff + r, c] = acc
            for c in range(he):
                U[hoff + r, hoff + c] = (1.0 if r == c else 0.0) - B[r, n + c]
        # the end state: (LA + w LE Q) Z, and −w LE W at the history columns
        for r in range(n):
            for c in range(n):
                acc = LA[el, r, c]
                for q in range(he):
                    acc += w * LE[el, r, q] * B[q, c]
                Ze[r, c] = acc
        for r in range(n):
            for c in range(hoff):
                acc = 0.0
                for q in range(n):
                    acc += Ze[r, q] * Z[q, c]
                Znew[r, c] = acc
            for c in range(he):
                acc = 0.0
                for q in range(he):
                    acc += LE[el, r, q] * B[q, n + c]
                Znew[r, hoff + c] = -w * acc
        hoff += he
        for r in range(n):
            for c in range(hoff):
                Z[r, c] = Znew[r, c]
    return _end_state(U, Z)


_RADIX = 2.0


@nb.njit(cache=True)
def _balance(a, d):
    """Balance a square matrix in place (rows and columns scaled by powers of 2 until their off-diagonal
    norms agree; the eigenvalues are unchanged): the monodromy mixes displacements [m], velocities [m/s]
    (ωn ≈ 6 000 times larger) and chip thicknesses, so unbalanced QR would lose digits. The scaling is
    multiplied into d (K,): the result is D⁻¹ a D, D = diag(d), exactly (powers of 2)."""
    n = a.shape[0]
    sqrdx = _RADIX * _RADIX
    done = False
    while not done:
        done = True
        for i in range(n):
            r = 0.0
            c = 0.0
            for j in range(n):
                if j != i:
                    c += abs(a[j, i])
                    r += abs(a[i, j])
            if c != 0.0 and r != 0.0:
                g = r / _RADIX
                f = 1.0
                s = c + r
                while c < g:
                    f *= _RADIX
                    c *= sqrdx
                g = r * _RADIX
                while c > g:
                    f /= _RADIX
                    c /= sqrdx
                if (c + r) / f < 0.95 * s:
                    done = False
                    g = 1.0 / f
                    d[i] *= f
                    for j in range(n):
                        a[i, j] *= g
                    for j in range(n):
                        a[j, i] *= f


@nb.njit(cache=True)
def _hessenberg(a):
    """Reduce a square matrix in place to upper Hessenberg form by stabilised elementary similarity
    transformations (Gaussian elimination with pivoting; the eigenvalues are unchanged)."""
    n = a.shape[0]
    for m in range(1, n - 1):
        x = 0.0
        i = m
        for j in range(m, n):
            if abs(a[j, m - 1]) > abs(x):
                x = a[j, m - 1]
                i = j
        if i != m:
            for j in range(m - 1, n):
                t = a[i, j]; a[i, j] = a[m, j]; a[m, j] = t
            for j in range(n):
                t = a[j, i]; a[j, i] = a[j, m]; a[j, m] = t
        if x != 0.0:
            for i2 in range(m + 1, n):
                y = a[i2, m - 1]
                if y != 0.0:
                    y /= x
                    a[i2, m - 1] = y
                    for j in range(m, n):
                        a[i2, j] -= y * a[m, j]
                    for j in range(n):
                        a[j, m] += y * a[j, i2]
    # zero below the subdiagonal (the multipliers stored there)
    for i in range(2, n):
        for j in range(i - 1):
            a[i, j] = 0.0


@nb.njit(cache=True)
def _hqr(a, wr, wi):
    """Eigenvalues (wr + i wi) of an upper Hessenberg matrix (destroyed) by the Francis double-shift QR
    iteration with exceptional shifts (EISPACK hqr). Returns 0, or 1 if an eigenvalue did not converge."""
    n = a.shape[0]
    anorm = 0.0
    for i in range(n):
        for j in range(max(i - 1, 0), n):
            anorm += abs(a[i, j])
    nn = n - 1
    t = 0.0
    p = q = r = 0.0
    while nn >= 0:
        its = 0
        while True:
            l = nn
            while l >= 1:
                s = abs(a[l - 1, l - 1]) + abs(a[l, l])
                if s == 0.0:
                    s = anorm
                if abs(a[l, l - 1]) + s == s:
                    a[l, l - 1] = 0.0
                    break
                l -= 1
            x = a[nn, nn]
            if l == nn:
                wr[nn] = x + t
                wi[nn] = 0.0
                nn -= 1
                break
            y = a[nn - 1, nn - 1]
            w = a[nn, nn - 1] * a[nn - 1, nn]
            if l == nn - 1:
                p = 0.5 * (y - x)
                q = p * p + w
                z = math.sqrt(abs(q))
                x += t
                if q >= 0.0:
                    z = p + (z if p >= 0 else -z)
                    wr[nn - 1] = wr[nn] = x + z
                    if z != 0.0:
                        wr[nn] = x - w / z
                    wi[nn - 1] = wi[nn] = 0.0
                else:
                    wr[nn - 1] = wr[nn] = x + p
                    wi[nn - 1] = -z
                    wi[nn] = z
                nn -= 2
                break
            if its == 60:
                return 1
            if its == 10 or its == 20:
                t += x
                for i in range(nn + 1):
                    a[i, i] -= x
                s = abs(a[nn, nn - 1]) + abs(a[nn - 1, nn - 2])
                x = y = 0.75 * s
                w = -0.4375 * s * s
            its += 1
            m = nn - 2
            while m >= l:
                z = a[m, m]
                r = x - z
                s = y - z
                p = (r * s - w) / a[m + 1, m] + a[m, m + 1]
                q = a[m + 1, m + 1] - z - r - s
                r = a[m + 2, m + 1]
                s = abs(p) + abs(q) + abs(r)
                p /= s
                q /= s
                r /= s
                if m == l:
                    break
                u = abs(a[m, m - 1]) * (abs(q) + abs(r))
                v = abs(p) * (abs(a[m - 1, m - 1]) + abs(z) + abs(a[m + 1, m + 1]))
                if u + v == v:
                    break
                m -= 1
            for i in range(m + 2, nn + 1):
                a[i, i - 2] = 0.0
                if i != m + 2:
                    a[i, i - 3] = 0.0
            k = m
            while k <= nn - 1:
                if k != m:
                    p = a[k, k - 1]
                    q = a[k + 1, k - 1]
                    r = 0.0
                    if k != nn - 1:
                        r = a[k + 2, k - 1]
                    x = abs(p) + abs(q) + abs(r)
                    if x != 0.0:
                        p /= x
                        q /= x
                        r /= x
                s = math.sqrt(p * p + q * q + r * r)
                if p < 0:
                    s = -s
                if s != 0.0:
                    if k == m:
                        if l != m:
                            a[k, k - 1] = -a[k, k - 1]
                    else:
                        a[k, k - 1] = -s * x
                    p += s
                    x = p / s
                    y = q / s
                    z = r / s
                    q /= p
                    r /= p
                    for j in range(k, nn + 1):
                        p = a[k, j] + q * a[k + 1, j]
                        if k != nn - 1:
                            p += r * a[k + 2, j]
                            a[k + 2, j] -= p * z
                        a[k + 1, j] -= p * y
                        a[k, j] -= p * x
                    mmin = nn if nn < k + 3 else k + 3
                    for i in range(l, mmin + 1):
                        p = x * a[i, k] + y * a[i, k + 1]
                        if k != nn - 1:
                            p += z * a[i, k + 2]
                            a[i, k + 2] -= p * r
                        a[i, k + 1] -= p * q
                        a[i, k] -= p
                k += 1
            if l >= nn - 1:
                break
    return 0


@nb.njit(cache=True)
def eig_small(U):
    """All eigenvalues of a small square matrix U (copied): balance, Hessenberg, double-shift QR; NaN where
    the iteration fails (a failed solve is never taken for stable, :func:`_dominant`).

    Why not LAPACK dgeev (:func:`millstab.stability._sdm_kernel.multipliers`): for the 10–30 rows of
    the reduced monodromy its fixed costs (workspace, ilaenv queries) dominate; measured 2× faster here
    on 10 and 16 rows, ρ within 1.2e-14 of numpy's on 2 400 random badly scaled matrices of 2–40 rows
    (tests/test_spectral_eig.py)."""
    K = U.shape[0]
    out = np.empty(K, dtype=np.complex128)
    _eig_into(U.copy(), np.ones(K), np.empty(K), np.empty(K), out)
    return out


@nb.njit(cache=True)
def _eig_into(A, d, wr, wi, out):
    """:func:`eig_small`'s eigenvalues of A (destroyed; not yet balanced) into out, the balancing's scaling
    multiplied into d; NaN where an entry is not finite or the QR iteration fails."""
    K = A.shape[0]
    for i in range(K):
        for j in range(K):
            if not math.isfinite(A[i, j]):  # (balancing would never end on an infinite entry)
                out[:] = complex(np.nan, np.nan)
                return
    _balance(A, d)
    _hessenberg(A)
    info = _hqr(A, wr, wi)
    for k in range(K):
        out[k] = complex(wr[k], wi[k]) if info == 0 else complex(np.nan, np.nan)


@nb.njit(cache=True)
def _rho_exact(U, ws):
    """(ρ, dominant multiplier) of U (kept) from its eigenvalues (:func:`eig_small`'s, bit for bit) in the
    workspace ws (:func:`workspace`); the balancing's scaling is kept in ws for the certificates that follow."""
    A, wr, wi, out, d, dn = ws[9], ws[10], ws[11], ws[12], ws[13], ws[14]
    A[:, :] = U
    dn[:] = 1.0
    _eig_into(A, dn, wr, wi, out)
    d[:] = dn
    return _dominant(out)


@nb.njit(cache=True)
def rho(b, kt, wn, zeta, mass, mdir, D, g, nd):
    """(ρ, dominant multiplier) at depth b [m] on the layout g (the reduced monodromy, built from the
    per-speed factors g[8] (:func:`with_factors`) by :func:`monodromy_lr`, in the speed's workspace g[9])."""
    return _rho_exact(_build_lr(b, kt, g, g[8], g[9]), g[9])


#: squarings of the balanced monodromy B tried before its eigenvalues in :func:`rho_test` (ρ ≤ ‖Bᵐ‖^{1/m},
#: m = 2, 4, …, 1 024). Measured (issue 28, 2026-11-27; 4 221 ladder rungs under the root, 20 prior samples × 10
#: cut speeds of the docs/updating.md case, K = 10–22 rows): ‖Bᵐ‖∞ < 1 at 3 / 30 / 62 / 81 / 91 % of them for
#: m = 2 / 4 / 8 / 16 / 32, so most rungs below the root need no eigenvalues. Up to 6 squarings while a squaring
#: was a hand-written loop (0.43 µs at K = 10, a third of the eigenvalues' 5.3 µs); 10 since it is a BLAS product
#: (0.15 µs), so rungs and refined depths with ρ up to ~0.99 of the level are certified too (on the 200-speed
#: envelope's rungs ρ/level 0.97–0.98 needed 7 squarings, 0.98–1 7 to 9), the squarings stopping early where
#: their bound stalls above the level (:func:`rho_test`)
CERT_SQUARINGS = 10
#: unit roundoff of a product's entries (with the row length: |fl(PP) − PP| ≤ K·u·|P||P|)
_U = 1.2e-16


@nb.njit(cache=True)
def rho_below(b, level, kt, wn, zeta, mass, mdir, D, g, nd):
    """ρ at depth b [m] where it may reach ``level`` (≤ 1), else a certified bound below it:
    (ρ or the bound, the dominant multiplier (NaN with a bound), exact).

    Why (issue 28): the eigenvalues are ~90 % of a ρ evaluation, and the search from below only asks
    of most rungs whether ρ < 1 (or < 1 − near). The balanced monodromy B (a similarity by powers of 2:
    the same eigenvalues, exactly) gives ρ ≤ ‖Bᵐ‖^{1/m}; squaring B up to CERT_SQUARINGS times, the
    rung is certified below ``level`` when ‖Bᵐ‖ plus a bound of the squarings' rounding is below levelᵐ
    (:func:`rho_test`). Otherwise the eigenvalues of B (:func:`eig_small`'s QR), as :func:`rho`. So every
    decision ρ > level is the one :func:`rho` makes (up to rounding at ρ = level)."""
    return rho_test(b, level, CERT_SQUARINGS, kt, g)


@nb.njit(cache=True)
def _norms(P):
    """(‖P‖∞, ‖P‖_F) of a square matrix; NaN in P gives a NaN Frobenius norm. Four partial sums per row: one
    running sum was bound by the additions' latency (0.3 µs at K = 17, as much as a BLAS squaring)."""
    K = P.shape[0]
    K4 = K - K % 4
    inf = 0.0
    f0 = f1 = f2 = f3 = 0.0
    for i in range(K):
        a0 = a1 = a2 = a3 = 0.0
        for j in range(0, K4, 4):
            x0 = P[i, j]
            x1 = P[i, j + 1]
            x2 = P[i, j + 2]
            x3 = P[i, j + 3]
            a0 += abs(x0)
            a1 += abs(x1)
            a2 += abs(x2)
            a3 += abs(x3)
            f0 += x0 * x0
            f1 += x1 * x1
            f2 += x2 * x2
            f3 += x3 * x3
        for j in range(K4, K):
            x0 = P[i, j]
            a0 += abs(x0)
            f0 += x0 * x0
        inf = max(inf, (a0 + a1) + (a2 + a3))
    return inf, math.sqrt((f0 + f1) + (f2 + f3))


@nb.njit(cache=True)
def rho_test(b, level, squarings, kt, g):
    """:func:`rho_below` with at most ``squarings`` squarings (0: straight to the eigenvalues, where a caller
    knows ρ is too close to ``level`` for a certificate, :func:`_squarings`), in the speed's workspace g[9].

    The bound is the smaller of ‖Bᵐ‖∞ and ‖Bᵐ‖_F (both consistent norms, each ≥ ρᵐ), each with its own rounding
    bound, propagated through the squarings as e' = 2‖P‖e + e² + K·u·‖P‖² (|fl(PP) − PP| ≤ K·u·|P||P|, and
    ‖|P|‖ = ‖P‖ in both norms). Measured (issue 28, 2026-11-27, the 200-speed envelope's 3 987 rungs below
    the roots): the Frobenius norm certifies 81.5 % of the rungs within 6 squarings (∞ alone 79.5 %), with
    4.13 squarings on average where it does (4.34).

    B = D⁻¹ U D with D the balancing scaling of the last exact ρ at this speed (the first depth's own where
    there is none yet; :func:`_rho_exact` refreshes it): any diagonal similarity gives a valid bound, and the
    balancing of the depth below is nearly this depth's, so the certificates hold as often as with a fresh
    balance at ~1 µs less a rung (the balance took 3.3 sweeps on the update's rungs). Where the certificate
    fails, the exact ρ balances U itself (:func:`_rho_exact`), so every exact value is :func:`rho`'s bit for bit."""
    ws = g[9]
    U = _build_lr(b, kt, g, g[8], ws)
    K = U.shape[0]
    if squarings > 0:
        P, Q, d = ws[7], ws[8], ws[13]
        if d[0] == 0.0:  # no scaling yet at this speed: this depth's balancing
            for i in range(K):
                for j in range(K):
                    if not math.isfinite(U[i, j]):
                        return np.inf, complex(np.nan, np.nan), True
            P[:, :] = U
            d[:] = 1.0
            _balance(P, d)
        for i in range(K):
            inv = 1.0 / d[i]  # (powers of 2: d[j] / d[i] exactly, without a division per entry)
            for j in range(K):
                P[i, j] = U[i, j] * (d[j] * inv)
        n_inf, n_fro = _norms(P)
        if math.isfinite(n_inf) and math.isfinite(n_fro):  # (else the exact path says inf)
            e_inf = 0.0
            e_fro = 0.0
            m = 1
            root_prev = np.inf
            for _ in range(squarings):
                np.dot(P, P, Q)  # BLAS into the workspace: 3× the hand-written loop at K = 10 (CERT_SQUARINGS)
                P, Q = Q, P
                e_inf = 2.0 * n_inf * e_inf + e_inf * e_inf + K * _U * n_inf * n_inf
                e_fro = 2.0 * n_fro * e_fro + e_fro * e_fro + K * _U * n_fro * n_fro
                m *= 2
                n_inf, n_fro = _norms(P)
                if not (min(n_inf, n_fro) < 1e30):
                    break
                bound = min(n_inf + e_inf, n_fro + e_fro)
                if bound < level ** m:
                    return bound ** (1.0 / m), complex(np.nan, np.nan), False
                # ‖Bᵐ‖^{1/m} falls towards ρ from above; where it stalls above the level from m = 8 on, ρ is there
                # (the squarings left would be spent in vain: a cost rule, the decision is the eigenvalues')
                root = bound ** (1.0 / m)
                if m >= 8 and root > level and root > STALL * root_prev:
                    break
                root_prev = root
    r, mu = _rho_exact(U, ws)
    return r, mu, True


@nb.njit(cache=True)
def with_factors(g, wn, zeta, mass, mdir, nd):
    """The layout g of :func:`setup` with its per-speed depth-independent factors appended (g[8],
    :func:`low_rank_setup`) and their workspace (g[9], :func:`workspace`; not to be shared between threads): what
    :func:`rho` needs."""
    lr = low_rank_setup(g, wn, zeta, mass, mdir, nd)
    return g + (lr, workspace(g, lr))


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
def psi(sigma, wn, zeta, mass, mdir, kind, h, Aq, phi_free, Dm, lend):
    """Ψ(σ): the collocation transition (n, n) complex over one tooth period of the ODE
    ż = (A0 + σ E(t) C) z, the same discretisation as :func:`monodromy`.

    Why: a Floquet solution z(t + T) = μ z(t) has z(t − T) = z(t)/μ, so the delay equation becomes this
    ODE with σ = w (1 − 1/μ), and μ is a multiplier iff det(μ I − Ψ(w (1 − 1/μ))) = 0: an n × n
    characteristic equation (n = 2 × modes), exact for the discretised system as well.
    """
    M = wn.size
    n = 2 * M
    p = Dm.shape[0] - 1
    P = p * n
    Z = np.zeros((n, n), dtype=np.complex128)
    for i in range(n):
        Z[i, i] = 1.0
    Znew = np.empty((n, n), dtype=np.complex128)
    L = np.empty((P, P), dtype=np.complex128)
    R = np.empty((P, n), dtype=np.complex128)
    for el in range(h.size):
        if kind[el] == 0:
            _free_step(phi_free[el], Z, Znew, n)
            continue
        hi = h[el]
        _element_lhs(L, el, hi, sigma, wn, zeta, mass, mdir, Aq, Dm)
        for k in range(1, p + 1):
            rk = (k - 1) * n
            d0 = Dm[k, 0] / hi
            for r in range(n):
                for col in range(n):
                    R[rk + r, col] = -d0 * Z[r, col]
        X = np.linalg.solve(L, R)
        for r in range(n):
            for col in range(n):
                acc = lend[0] * Z[r, col]
                for k in range(1, p + 1):
                    acc += lend[k] * X[(k - 1) * n + r, col]
                Znew[r, col] = acc
        for r in range(n):
            for col in range(n):
                Z[r, col] = Znew[r, col]
    return Z


@nb.njit(cache=True)
def char_fn(b, theta, kt, wn, zeta, mass, mdir, g, nd):
    """det(μ I − Ψ(w (1 − 1/μ))) at μ = e^{iθ}, w = ½ b Kt: zero iff a multiplier lies at e^{iθ}."""
    mu = complex(math.cos(theta), math.sin(theta))
    sigma = 0.5 * b * kt * (1.0 - 1.0 / mu)
    P = psi(sigma, wn, zeta, mass, mdir, g[0], g[1], g[2], g[4], nd[1], nd[2])
    n = P.shape[0]
    for i in range(n):
        for j in range(n):
            P[i, j] = -P[i, j]
        P[i, i] += mu
    return np.linalg.det(P)


# -- exact derivatives: Ψ and dΨ/dσ from one LU per element, Newton with the exact Jacobian ---------


@nb.njit(cache=True)
def _lu_factor(A, piv):
    """In-place LU with partial pivoting of the square complex A (piv (P,) the row swaps). Hand-written:
    the matrices are 8–50 rows, where a LAPACK call's copies cost more than the arithmetic, and the
    factors are reused for Ψ's derivative (a second right-hand side that depends on the first)."""
    P = A.shape[0]
    for c in range(P):
        best = c
        big = abs(A[c, c])
        for r in range(c + 1, P):
            a = abs(A[r, c])
            if a > big:
                big = a
                best = r
        piv[c] = best
        if best != c:
            for q in range(P):
                t = A[c, q]
                A[c, q] = A[best, q]
                A[best, q] = t
        d = A[c, c]
        if d == 0.0:
            continue
        inv = 1.0 / d
        for r in range(c + 1, P):
            f = A[r, c] * inv
            A[r, c] = f
            if f != 0.0:
                for q in range(c + 1, P):
                    A[r, q] -= f * A[c, q]


@nb.njit(cache=True)
def _lu_solve(A, piv, B):
    """Solve (LU from :func:`_lu_factor`) X = B in place, B (P, m)."""
    P = A.shape[0]
    m = B.shape[1]
    for c in range(P):
        if piv[c] != c:
            for q in range(m):
                t = B[c, q]
                B[c, q] = B[piv[c], q]
                B[piv[c], q] = t
    for c in range(P):
        for r in range(c + 1, P):
            f = A[r, c]
            if f != 0.0:
                for q in range(m):
                    B[r, q] -= f * B[c, q]
    for c in range(P - 1, -1, -1):
        inv = 1.0 / A[c, c]
        for q in range(m):
            B[c, q] *= inv
        for r in range(c):
            f = A[r, c]
            if f != 0.0:
                for q in range(m):
                    B[r, q] -= f * B[c, q]


@nb.njit(cache=True)
def psi_d(sigma, wn, zeta, mass, mdir, kind, h, Aq, phi_free, Dm, lend):
    """(Ψ(σ), dΨ/dσ), both (n, n) complex: :func:`psi` and its exact derivative.

    On a collocation element L(σ) X = R(Z) with L = L0 − σ G (G the cutting coupling), so
    L X' = G X + R(Z'): the same LU factors give the derivative for one more triangular solve."""
    M = wn.size
    n = 2 * M
    p = Dm.shape[0] - 1
    P = p * n
    Z = np.zeros((n, 2 * n), dtype=np.complex128)  # [Ψ | Ψ'] so far
    for i in range(n):
        Z[i, i] = 1.0
    Znew = np.empty((n, 2 * n), dtype=np.complex128)
    L = np.empty((P, P), dtype=np.complex128)
    R = np.empty((P, 2 * n), dtype=np.complex128)
    piv = np.empty(P, dtype=np.int64)
    for el in range(h.size):
        if kind[el] == 0:
            _free_step(phi_free[el], Z, Znew, 2 * n)
            continue
        hi = h[el]
        _element_lhs(L, el, hi, sigma, wn, zeta, mass, mdir, Aq, Dm)
        _lu_factor(L, piv)
        for k in range(1, p + 1):
            rk = (k - 1) * n
            d0 = Dm[k, 0] / hi
            for r in range(n):
                for col in range(2 * n):
                    R[rk + r, col] = -d0 * Z[r, col]
        Xs = R[:, :n]
        _lu_solve(L, piv, Xs)
        # the derivative's right-hand side: R(Z') (already in R[:, n:]) + G X
        for k in range(1, p + 1):
            rk = (k - 1) * n
            for j in range(M):
                for l in range(M):
                    gq = Aq[el, k, mdir[j], mdir[l]] / mass[j]
                    if gq != 0.0:
                        for col in range(n):
                            R[rk + M + j, n + col] += gq * R[rk + l, col]
        Xd = R[:, n:]
        _lu_solve(L, piv, Xd)
        for r in range(n):
            for col in range(2 * n):
                acc = lend[0] * Z[r, col]
                for k in range(1, p + 1):
                    acc += lend[k] * R[(k - 1) * n + r, col]
                Znew[r, col] = acc
        Z[:, :] = Znew
    return Z[:, :n].copy(), Z[:, n:].copy()


@nb.njit(cache=True)
def psi_d_lr(sigma, g, lr):
    """(Ψ(σ), dΨ/dσ) as :func:`psi_d` (the same matrices to rounding) from the per-speed factors
    lr = :func:`low_rank_setup`: element map E(σ) = LA + σ LE W CA with W = (I − σ S)⁻¹, and
    E'(σ) = LE W² CA (dW/dσ = W S W, so d(σ W)/dσ = W (I + σ S W) = W²): an he × he complex solve per
    element instead of a p·n one (issue 28)."""
    kind, h, phi_free, rk = g[0], g[1], g[4], g[7]
    CA, S, LA, LE = lr
    n = LA.shape[1]
    Hm = S.shape[1]
    Z = np.zeros((n, 2 * n), dtype=np.complex128)  # [Ψ | Ψ'] so far
    for i in range(n):
        Z[i, i] = 1.0
    Znew = np.empty((n, 2 * n), dtype=np.complex128)
    Mx = np.empty((Hm, Hm), dtype=np.complex128)
    piv = np.empty(Hm, dtype=np.int64)
    Qb = np.empty((Hm, n), dtype=np.complex128)
    E = np.empty((n, n), dtype=np.complex128)
    Ed = np.empty((n, n), dtype=np.complex128)
    for el in range(h.size):
        if kind[el] == 0:
            _free_step(phi_free[el], Z, Znew, 2 * n)
            continue
        he = _elem_history(rk, el)
        Mh = Mx[:he, :he]
        for r in range(he):
            for c in range(he):
                Mh[r, c] = -sigma * S[el, r, c]
            Mh[r, r] += 1.0
        Q = Qb[:he, :]
        for r in range(he):
            for c in range(n):
                Q[r, c] = CA[el, r, c]
        _lu_factor(Mh, piv[:he])
        _lu_solve(Mh, piv[:he], Q)  # W CA
        for r in range(n):
            for c in range(n):
                acc = LA[el, r, c] + 0.0j
                for q in range(he):
                    acc += sigma * LE[el, r, q] * Q[q, c]
                E[r, c] = acc
        _lu_solve(Mh, piv[:he], Q)  # W² CA
        for r in range(n):
            for c in range(n):
                acc = 0.0j
                for q in range(he):
                    acc += LE[el, r, q] * Q[q, c]
                Ed[r, c] = acc
        for r in range(n):
            for c in range(n):
                a0 = 0.0j
                a1 = 0.0j
                for q in range(n):
                    a0 += E[r, q] * Z[q, c]
                    a1 += Ed[r, q] * Z[q, c] + E[r, q] * Z[q, n + c]
                Znew[r, c] = a0
                Znew[r, n + c] = a1
        Z[:, :] = Znew
    return Z[:, :n].copy(), Z[:, n:].copy()


@nb.njit(cache=True)
def char_d(b, theta, kt, wn, zeta, mass, mdir, g, nd):
    """(F, ∂F/∂b, ∂F/∂θ) of the characteristic function F(b, θ) = det(μ I − Ψ(σ)), μ = e^{iθ},
    σ = w (1 − 1/μ), w = ½ b Kt. Jacobi's formula: dF = F tr((μ I − Ψ)⁻¹ d(μ I − Ψ)). Ψ and Ψ' from the
    per-speed low-rank factors g[8] (:func:`psi_d_lr`; :func:`char_fn` keeps the element-by-element path)."""
    mu = complex(math.cos(theta), math.sin(theta))
    w = 0.5 * b * kt
    sigma = w * (1.0 - 1.0 / mu)
    P, Pd = psi_d_lr(sigma, g, g[8])
    n = P.shape[0]
    A = np.empty((n, n), dtype=np.complex128)
    for i in range(n):
        for j in range(n):
            A[i, j] = -P[i, j]
        A[i, i] += mu
    piv = np.empty(n, dtype=np.int64)
    _lu_factor(A, piv)
    det = 1.0 + 0.0j
    for i in range(n):
        det *= A[i, i]
        if piv[i] != i:
            det = -det
    if det == 0.0:
        return det, 0.0j, 0.0j
    B = np.zeros((n, 2 * n), dtype=np.complex128)
    for i in range(n):
        B[i, i] = 1.0
        for j in range(n):
            B[i, n + j] = Pd[i, j]
    _lu_solve(A, piv, B)
    t0 = 0.0j  # tr(M⁻¹)
    t1 = 0.0j  # tr(M⁻¹ Ψ')
    for i in range(n):
        t0 += B[i, i]
        t1 += B[i, n + i]
    f_b = -det * t1 * (0.5 * kt * (1.0 - 1.0 / mu))
    f_t = det * (1j * mu * t0 - t1 * (1j * w / mu))
    return det, f_b, f_t


#: the most characteristic-function evaluations one Newton solve may spend
NEWTON_EVALS = 12


@nb.njit(cache=True)
def newton(b, theta, kt, wn, zeta, mass, mdir, g, nd):
    """Newton on the characteristic function for (b, θ) with the exact Jacobian (:func:`char_d`): a
    multiplier e^{iθ} on the unit circle at depth b, θ in [0, π] (conjugate symmetry). Steps longer
    than 20 % in b or 0.3 rad in θ are shortened (they have left the root's neighbourhood); a step
    that does not shrink |F| is halved (at most ``NEWTON_EVALS`` evaluations in all: from a good start
    it converges quadratically in 2–4, from a poor one a search is cheaper). Converged when the step
    is below 1e-6 (relative in b, rad in θ): the step is then taken, and quadratic convergence puts
    the root within ~1e-12.

    Flip (θ = π): F(b, π) is real (F(b, −θ) = conj F(b, θ)), and a flip root is a real root in b alone,
    where the 2-D step, folded at π, would oscillate about the axis. So from θ = π, or once a step
    would cross π, the search continues in b alone on Re F(b, π).
    Returns (b, θ, converged, evaluations)."""
    flip = theta >= math.pi - 1e-12
    if flip:
        theta = math.pi
    n_eval = 1
    f, fb, ft = char_d(b, theta, kt, wn, zeta, mass, mdir, g, nd)
    while n_eval < NEWTON_EVALS:
        if flip:
            if fb.real == 0.0 or not math.isfinite(fb.real):
                return b, theta, False, n_eval
            step_b = -f.real / fb.real
            step_t = 0.0
        else:
            j00, j01, j10, j11 = fb.real, ft.real, fb.imag, ft.imag
            det = j00 * j11 - j01 * j10
            if det == 0.0 or not math.isfinite(det):
                return b, theta, False, n_eval
            step_b = (-f.real * j11 + j01 * f.imag) / det
            step_t = (-j00 * f.imag + j10 * f.real) / det
        scale = max(abs(step_b) / (0.2 * b), abs(step_t) / 0.3, 1.0)
        step_b /= scale
        step_t /= scale
        if scale == 1.0 and abs(step_b) < 1e-6 * b and abs(step_t) < 1e-6:
            return b + step_b, _fold(theta + step_t), True, n_eval
        if not flip and theta + step_t > math.pi:
            # the step crosses the negative real axis: a flip root; go on in b alone at θ = π
            flip = True
            theta = math.pi
            f, fb, ft = char_d(b, theta, kt, wn, zeta, mass, mdir, g, nd)
            n_eval += 1
            continue
        ok = False
        for half in range(4):
            if n_eval >= NEWTON_EVALS:
                break
            b_new = b + step_b
            t_new = _fold(theta + step_t)
            if b_new > 0.0 and math.isfinite(b_new):
                f_new, fb_new, ft_new = char_d(b_new, t_new, kt, wn, zeta, mass, mdir, g, nd)
                n_eval += 1
                a_new = abs(f_new.real) if flip else abs(f_new)
                a_old = abs(f.real) if flip else abs(f)
                if a_new < a_old or (scale == 1.0 and half == 0 and abs(step_b) < 1e-4 * b):
                    ok = True
                    break
            step_b *= 0.5
            step_t *= 0.5
        if not ok:
            return b, theta, False, n_eval
        b, theta, f, fb, ft = b_new, t_new, f_new, fb_new, ft_new
    return b, theta, False, n_eval


@nb.njit(cache=True)
def _fold(theta):
    """θ mod 2π folded into [0, π] (a multiplier and its conjugate are the same boundary)."""
    t = theta % TWO_PI
    return TWO_PI - t if t > math.pi else t


#: branches (boundary roots at one speed, continued in speed) tracked at most at once
N_BRANCH = 4
#: a tracked branch whose depth exceeds this multiple of the boundary is dropped (it has left)
BRANCH_DROP = 3.0
#: roots tried per speed at most (each failed check brackets a lower crossing, whose root is checked in turn)
ATTEMPTS = 6


@nb.njit(cache=True)
def _predict_theta(th_prev, T_prev, T, w_flex):
    """θ at the period T from θ at T_prev: the chatter frequency ω = (±θ + 2πk)/T nearest the flexible
    mode stays, θ moves with T (a flip stays at π)."""
    if th_prev > math.pi - 1e-6:
        return math.pi
    best = np.inf
    w_c = 0.0
    for sg in (-1.0, 1.0):
        k = round((w_flex * T_prev - sg * th_prev) / TWO_PI)
        w_try = (sg * th_prev + TWO_PI * k) / T_prev
        if abs(w_try - w_flex) < best:
            best = abs(w_try - w_flex)
            w_c = w_try
    return _fold(w_c * T)


@nb.njit(cache=True)
def _add_branch(br_b, br_t, br_b2, br_on, b, th):
    """Put the root (b, θ) into the tracked set (a free slot, else the deepest branch's); no-op if
    it is already tracked."""
    for i in range(br_b.size):
        if br_on[i] and abs(br_b[i] / b - 1.0) < 1e-5 and abs(br_t[i] - th) < 1e-4:
            return i
    slot = -1
    for i in range(br_b.size):
        if not br_on[i]:
            slot = i
            break
    if slot < 0:
        slot = 0
        for i in range(br_b.size):
            if br_b[i] > br_b[slot]:
                slot = i
    br_b[slot] = b
    br_t[slot] = th
    br_b2[slot] = 0.0
    br_on[slot] = True
    return slot


@nb.njit(cache=True)
def ladder_depth(b_ref, ladder, k):
    """The k-th depth [m] of the search from below at a speed: b_ref·ladder[k], then ×1.5 per step
    (the sequence :func:`first_crossing` evaluates)."""
    if k < ladder.size:
        return b_ref * ladder[k]
    return b_ref * ladder[ladder.size - 1] * 1.5 ** (k - ladder.size + 1)


#: the search from below refines a ladder step (x_prev, x] into REFINE equal parts where ρ at either end
#: is above 1 − NEAR, or x is unstable: a band narrower than the ladder's step lies where a multiplier
#: grazes the unit circle, so ρ is close to 1 at the rungs beside it (measured: a flip band 3 % of the
#: zero-order depth wide at 12 825 rpm, a/D = 0.5 up milling, had ρ 0.9954 and 0.9941 at the rungs on
#: either side; the ladder alone stepped over it, as SDM's does). Measured and not kept: REFINE 3 with
#: NEAR 0.01 (−19 % evaluations, but the same band at 12 800 rpm was then missed on every grid)
REFINE = 4
NEAR = 0.02
#: the refinement's resolution (issue 28, 2026-11-28): a ladder step under FINE_TOP·b_ref is refined into REFINE parts
#: per FINE_STEP·b_ref (:func:`refine_parts`), so a step over two of SDM's rungs (``spectral.LADDER``'s coarse part)
#: into 2·REFINE parts, which visit the fine ladder's rung and refinement depths between its ends. Why: the rungs far
#: below the root are the cheapest (ρ far below 1: ~4 µs, two or three squarings) but a fifth of a search's
#: evaluations, and a band there narrower than the coarse step with ρ below 1 − NEAR at both coarse rungs is what the
#: fine ladder could find and the coarse one not (measured: ``spectral.py``'s docstring)
FINE_STEP = 0.05
FINE_TOP = 1.2
#: the bracket high of :func:`scan_to` where a censored search passed its cap (−1: no boundary up to 1e4·b_ref)
CENSORED = -2.0


#: squarings tried at a rung (:func:`rho_test`) where the rung below it had ρ above this fraction of the level:
#: none (the eigenvalues at once: ρ mostly rises along the ladder, so a certificate is out of reach), else
#: CERT_SQUARINGS
SKIP_ABOVE = 1.0
#: the squarings of :func:`rho_test` stop where ‖Bᵐ‖^{1/m} (above the level, m ≥ 8) fell by less than this factor's
#: complement over the last squaring: it has reached ρ, which is above the level
STALL = 0.998


@nb.njit(cache=True)
def refine_parts(ladder, k):
    """Parts into which the search from below refines the ladder step ending at rung k (:func:`ladder_depth`):
    REFINE per FINE_STEP of the step under FINE_TOP (so 2·REFINE for a step over two of SDM's rungs), else REFINE."""
    if k < ladder.size and ladder[k] <= FINE_TOP * (1.0 + 1e-9):  # (24 × 0.05 is 1.2 + 1 ulp)
        lo = ladder[k - 1] if k > 0 else 0.0
        return REFINE * max(1, int(round((ladder[k] - lo) / FINE_STEP)))
    return REFINE


@nb.njit(cache=True)
def _squarings(r_prev, level):
    """Squarings for a rung test at ``level`` given ρ (or its bound) r_prev at the rung below (SKIP_ABOVE)."""
    return 0 if r_prev > SKIP_ABOVE * level else CERT_SQUARINGS


@nb.njit(cache=True)
def scan_state(rho0):
    """A fresh state of the search from below at one speed (see :func:`scan_to`)."""
    st = np.empty(8)
    st[0] = 0.0  # the next ladder index
    st[1] = 0.0  # the last ladder depth evaluated [m] (0: the start) ...
    st[2] = rho0 - 1.0  # ... and ρ − 1 there
    st[3] = 0.0  # the highest depth known stable [m] ...
    st[4] = rho0 - 1.0  # ... and ρ − 1 there (or a bound of it, :func:`rho_below`) ...
    st[5] = 0.0  # ... 1 where st[4] is only that bound (:func:`_exact_lo` makes it exact for a bracket)
    st[6] = -1.0  # a ladder index whose exact ρ is known already (a floor's test, :func:`floor_test`; −1: none) ...
    st[7] = 0.0  # ... and that ρ (≤ 1: the rung is stable)
    return st


@nb.njit(cache=True)
def _exact_lo(st, kt, wn, zeta, mass, mdir, D, g, nd):
    """Make st[4] (ρ − 1 at the highest depth known stable, a bracket's low end) exact where a certificate
    left only a bound (:func:`rho_below`): a bracket's secant start and Illinois steps use it, so the roots
    are those of exact ρ values. Returns the evaluations spent (0 or 1)."""
    if st[5] == 0.0:
        return 0
    r, _ = rho(st[3], kt, wn, zeta, mass, mdir, D, g, nd)
    st[4] = r - 1.0
    st[5] = 0.0
    return 1


@nb.njit(cache=True)
def _refine_step(x_prev, x, top, st, parts, kt, wn, zeta, mass, mdir, D, g, nd):
    """ρ at the parts − 1 inner depths of the ladder step (x_prev, x) below top [m] (:func:`refine_parts`),
    ascending, skipping those known stable (≤ st[3]; st updated in place). Returns (an unstable one found, its
    depth, its ρ − 1, its dominant multiplier, ρ evaluations)."""
    n_eval = 0
    for j in range(1, parts):
        y = x_prev + j * (x - x_prev) / parts
        if y >= top:
            break
        if y <= st[3]:
            continue
        r, m_, exact = rho_test(y, 1.0, CERT_SQUARINGS, kt, g)
        n_eval += 1
        if r > 1.0:
            return True, y, r - 1.0, m_, n_eval
        st[3] = y
        st[4] = r - 1.0
        st[5] = 0.0 if exact else 1.0
    return False, 0.0, 0.0, complex(np.nan, np.nan), n_eval


@nb.njit(cache=True)
def scan_to(b_ref, ladder, top, st, near, kt, wn, zeta, mass, mdir, D, g, nd, cap=np.inf):
    """The search from below at one speed, resumed from the state st (:func:`scan_state`, updated in
    place), over the depths below ``top`` [m] (inf: up to the first unstable depth).

    The sequence of depths is fixed by the speed alone: the ladder b_ref·ladder (then ×1.5, up to
    1e4·b_ref, :func:`ladder_depth`), each step refined into :func:`refine_parts` parts (evaluated after its upper end,
    ascending) where it is unstable or ρ at either end is above 1 − near (``NEAR`` by default). A root b found from a
    guess (a continued branch, a warm start) is checked with top = b·(1 − 2e-3) as if the ladder depth above
    it were unstable (the refinement of that step below top), so an accepted root is the one the search
    from below finds at that speed whatever other speeds share the call, or a lower crossing (never a
    higher one). Returns (stable, bracket low [m], its ρ − 1, bracket high [m], its ρ − 1, the dominant
    multiplier there, ρ evaluations); the bracket is (the highest stable depth, the first unstable one);
    stable with bracket high −1 where nothing is unstable up to 1e4·b_ref.

    ``cap`` [m] (a censored search, :data:`CENSORED`): once every depth of the search up to one ≥ cap is stable
    (st[3] ≥ cap), return (True, st[3], its ρ − 1, CENSORED, 0, NaN, evaluations): the search from below would
    stop above st[3], so the limit is at least st[3] (to the bracket's 1e-6), and the caller that only needs to
    know that (a likelihood whose terms no longer change above cap) saves the rungs above and the root."""
    n_eval = 0
    nan = complex(np.nan, np.nan)
    while True:
        if st[3] >= cap:  # every depth of the search up to st[3] is stable: the limit is above cap
            return True, st[3], st[4], CENSORED, 0.0, nan, n_eval
        k = int(st[0])
        x = ladder_depth(b_ref, ladder, k)
        x_prev = st[1]
        if x > 1e4 * b_ref:
            return True, st[3], st[4], -1.0, 0.0, nan, n_eval
        if x >= top:
            # the step holding the root: refined below top (as the search from below refines it when x
            # is unstable)
            bad, y, fy, my, c = _refine_step(x_prev, x, top, st, refine_parts(ladder, k), kt, wn, zeta, mass, mdir,
                                             D, g, nd)
            n_eval += c
            if bad:
                n_eval += _exact_lo(st, kt, wn, zeta, mass, mdir, D, g, nd)
                return False, st[3], st[4], y, fy, my, n_eval
            return True, st[3], st[4], -1.0, 0.0, nan, n_eval
        st[0] = k + 1
        if x <= st[3]:  # known stable (an earlier scan at this speed)
            continue
        # a bound below 1 − near decides this rung as ρ itself would (no refinement, stable)
        if k == int(st[6]):  # its exact ρ is known (a floor's test: ≤ 1), the value rho_test's exact path gives
            r, m_, exact = st[7], nan, True
        else:
            r, m_, exact = rho_test(x, 1.0 - near, _squarings(st[2] + 1.0, 1.0 - near), kt, g)
        n_eval += 1
        f_prev = st[2]
        st[1] = x
        st[2] = r - 1.0
        if r > 1.0 - near or f_prev > -near:  # (r > 1 included)
            bad, y, fy, my, c = _refine_step(x_prev, x, np.inf, st, refine_parts(ladder, k), kt, wn, zeta, mass,
                                             mdir, D, g, nd)
            n_eval += c
            if bad:
                n_eval += _exact_lo(st, kt, wn, zeta, mass, mdir, D, g, nd)
                return False, st[3], st[4], y, fy, my, n_eval
        if r > 1.0:
            n_eval += _exact_lo(st, kt, wn, zeta, mass, mdir, D, g, nd)
            return False, st[3], st[4], x, r - 1.0, m_, n_eval
        st[3] = x
        st[4] = r - 1.0
        st[5] = 0.0 if exact else 1.0


@nb.njit(cache=True)
def check_root(b, b_ref, ladder, st, near, kt, wn, zeta, mass, mdir, D, g, nd, cap=np.inf):
    """Accept a boundary root b [m] found from a guess: :func:`scan_to` below b·(1 − 2e-3), then ρ at
    b·(1 − 2e-3) itself (where ρ is not 1 by rounding). Returns what scan_to returns (``cap``: as scan_to's,
    the bracket high CENSORED where the search passed it)."""
    top = b * (1.0 - 2e-3)
    stable, lo, f_lo, hi, f_hi, m_hi, n_eval = scan_to(b_ref, ladder, top, st, near, kt, wn, zeta, mass, mdir, D, g, nd,
                                                       cap)
    if not stable or top <= st[3] or hi == CENSORED:
        return stable, lo, f_lo, hi, f_hi, m_hi, n_eval
    r, m_, _ = rho_test(top, 1.0, 0, kt, g)  # ρ(top) is within ~1e-3 of 1: no certificate in reach
    n_eval += 1
    if r > 1.0:
        n_eval += _exact_lo(st, kt, wn, zeta, mass, mdir, D, g, nd)
        return False, st[3], st[4], top, r - 1.0, m_, n_eval
    return True, st[3], st[4], -1.0, 0.0, complex(np.nan, np.nan), n_eval


#: a floor's rung lies at or below this fraction of the floor: an accepted root b was checked stable up to top = b·(1 −
#: 2e-3) (:func:`check_root`), so a rung x_k ≥ top unstable gives b ≤ x_k/0.998 < x_k/FLOOR_MARGIN ≤ the floor
FLOOR_MARGIN = 0.997
#: the marker of a floored speed's multiplier (the depth is the floor's rung, :func:`floor_test`)
FLOORED = -3.0


@nb.njit(cache=True)
def floor_rung(b_ref, ladder, floor):
    """(k, x_k [m]): the highest rung of the search from below at ``b_ref`` [m] (:func:`ladder_depth`) at or below
    FLOOR_MARGIN · ``floor`` [m] whose depth is also the one :func:`first_crossing` (the fallback) evaluates, bit for
    bit (above the ladder the two multiply by 1.5 differently); (−1, 0) where there is none."""
    lim = FLOOR_MARGIN * floor
    k_best = -1
    x_best = 0.0
    b = 0.0
    k = 0
    while True:
        if k < ladder.size:
            b = b_ref * ladder[k]
        else:
            b *= 1.5
        if b > lim or b > 1e4 * b_ref:
            break
        if b == ladder_depth(b_ref, ladder, k):
            k_best = k
            x_best = b
        k += 1
    return k_best, x_best


@nb.njit(cache=True)
def floor_test(b_ref, ladder, floor, cap, kt, wn, zeta, mass, mdir, D, g, nd):
    """A floor [m] at one speed (issue 28; the mirror of the ceiling, :func:`scan_to`'s ``cap``): the exact ρ at the
    floor's rung x_k (:func:`floor_rung`). Returns (floored, k, x_k, ρ(x_k), evaluations): floored where ρ(x_k) > 1,
    and then the limit is below the floor: every path of :func:`limit_run` stops there (the search from below
    evaluates x_k unless it stopped lower, :func:`check_root` accepts no root b with b·(1 − 2e-3) < x_k, Illinois
    stays inside a bracket whose high end is the first unstable depth found, the fallback climbs the same rungs).
    Not floored (k −1 where no rung or the rung is not below ``cap``): the search as without a floor (ρ(x_k) then
    saves the rung's own test, :func:`scan_to`; it is no certificate of the rungs below, a band can lie there).
    The workspace's balancing scaling is forgotten after the test, so the certificates below start as they would."""
    if not floor > 0.0:
        return False, -1, 0.0, 0.0, 0
    k, x = floor_rung(b_ref, ladder, floor)
    if k < 0 or not x < cap:
        return False, -1, 0.0, 0.0, 0
    r, _ = rho(x, kt, wn, zeta, mass, mdir, D, g, nd)
    g[9][13][0] = 0.0  # rho_test's "no scaling yet at this speed"
    return r > 1.0, k, x, r, 1


@nb.njit(cache=True)
def secant_start(br_lo, br_hi, f_lo, f_hi):
    """Newton's start inside a bracket [br_lo, br_hi] of ρ − 1 (values f_lo < 0 < f_hi): the secant point,
    kept 5 % / 2 % of the bracket away from its ends."""
    x = (br_lo * f_hi - br_hi * f_lo) / (f_hi - f_lo)
    return min(max(x, br_lo + 0.05 * (br_hi - br_lo)), br_hi - 0.02 * (br_hi - br_lo))


@nb.njit(cache=True)
def limit_run(n_teeth, kt, kr, phi_s, phi_e, rpm, b_ref, ladder, near, wn, zeta, mass, mdir, act, elem_len, nd, rtol,
              w_flex, depth, mu, n_eval, cap, floor, gate):
    """Limiting depths along ascending speeds rpm (S,) for one structure, tracking boundary branches.

    Every boundary root found (b, θ) is a branch, continued from speed to speed by Newton on the
    characteristic function (:func:`newton`, from a prediction linear in speed; θ from the chatter
    frequency nearest w_flex [rad/s]); up to ``N_BRANCH`` branches are tracked at once (the lobe being
    left and the one taking over), so a switch between known lobes costs no search. The candidate is
    the lowest branch; it is accepted only where this speed's search from below would not stop earlier
    (:func:`check_root`: the full monodromy is stable at every depth of it below the root), so the depth
    does not depend on the other speeds of the run. A failed depth brackets the unknown crossing: Newton
    from inside the bracket (θ from its dominant multiplier), the root joins the set and is checked in
    turn. With no branch (first speed, or all lost): the search from below (:func:`scan_to`) to its
    first unstable depth, Newton from the bracket (Illinois on ρ − 1 to 1 % first where that fails),
    the root checked as above; where Newton fails, Illinois to ``rtol``.
    Writes depth, mu (on the unit circle), n_eval (S,) (ρ evaluations and characteristic functions).
    ``cap`` (S,) [m]: a censored search (:func:`scan_to`; inf: none): where every depth of the search up to one ≥
    cap[s] is stable, depth[s] is that depth (a lower bound of the limit, ≥ cap[s]) and mu[s] NaN; the branches
    are left as they were (the next speed's acceptance is its own either way).
    ``floor`` (S,) [m] (≤ 0: none) and ``gate``: at the run's last speed (no speed continues its branches: a floored
    speed skips its search, so a speed after it in the run would start from other branches, a root ~1e-12 off; the
    update's cut speeds are each a run of their own, ``spectral.PHASE_SPLIT``), where b_ref[s] ≤ gate · floor[s],
    :func:`floor_test` first; where it floors, depth[s] is the floor's rung x_k (the limit is below it, ≤ x_k/0.998
    < floor[s]) and mu[s] FLOORED + 0j. Every other depth is the one without floors, bit for bit.
    """
    D = act.size
    br_b = np.zeros(N_BRANCH)
    br_t = np.zeros(N_BRANCH)
    br_b2 = np.zeros(N_BRANCH)  # the branch's depth one speed earlier (0: none, no slope)
    br_t2 = np.zeros(N_BRANCH)  # and its θ
    br_on = np.zeros(N_BRANCH, dtype=np.bool_)
    T_prev = 1.0
    for s in range(rpm.size):
        g = with_factors(setup(n_teeth, kr, phi_s, phi_e, rpm[s], elem_len, nd[0], wn, zeta, act), wn, zeta, mass, mdir,
                         nd)
        T = 60.0 / (n_teeth * rpm[s])
        rho0 = 0.0
        for j in range(wn.size):
            rho0 = max(rho0, math.exp(-zeta[j] * wn[j] * T))
        count = 0
        k_known = -1
        r_known = 0.0
        if floor[s] > 0.0 and s == rpm.size - 1 and b_ref[s] <= gate * floor[s]:
            floored, k_known, x_f, r_known, count = floor_test(b_ref[s], ladder, floor[s], cap[s], kt, wn, zeta, mass,
                                                               mdir, D, g, nd)
            if floored:
                depth[s] = x_f
                mu[s] = complex(FLOORED, 0.0)
                n_eval[s] = count
                continue
        # continue every tracked branch
        for i in range(N_BRANCH):
            if not br_on[i]:
                continue
            b0 = br_b[i]
            if s >= 1 and br_b2[i] > 0.0:  # linear extrapolation in speed, clamped
                b0 = br_b[i] + (br_b[i] - br_b2[i]) / (rpm[s - 1] - rpm[s - 2]) * (rpm[s] - rpm[s - 1])
                b0 = min(1.5 * br_b[i], max(b0, 0.67 * br_b[i]))
            th0 = _predict_theta(br_t[i], T_prev, T, w_flex)
            if br_b2[i] > 0.0 and br_t[i] < math.pi - 1e-6:
                # the branch's own slope (its chatter frequency drifts along a lobe's flank)
                dth = br_t[i] - br_t2[i]
                if abs(dth) < 1.0:
                    th0 = _fold(br_t[i] + dth / (rpm[s - 1] - rpm[s - 2]) * (rpm[s] - rpm[s - 1]))
            b1, th1, ok, c = newton(b0, th0, kt, wn, zeta, mass, mdir, g, nd)
            count += c
            if not ok and b0 != br_b[i]:
                # the extrapolation overshot (a steep flank): once more from the branch's last depth
                b1, th1, ok, c = newton(br_b[i], th0, kt, wn, zeta, mass, mdir, g, nd)
                count += c
            if ok:
                br_b2[i] = br_b[i]
                br_t2[i] = br_t[i]
                br_b[i] = b1
                br_t[i] = th1
            else:
                br_on[i] = False
        # drop duplicates (two branches that met the same root) and branches far above the lowest
        b_min = np.inf
        for i in range(N_BRANCH):
            if br_on[i]:
                for j in range(i):
                    if br_on[j] and abs(br_b[j] / br_b[i] - 1.0) < 1e-6 and abs(br_t[j] - br_t[i]) < 1e-5:
                        br_on[i] = False
                if br_on[i]:
                    b_min = min(b_min, br_b[i])
        for i in range(N_BRANCH):
            if br_on[i] and br_b[i] > BRANCH_DROP * b_min:
                br_on[i] = False
        # Acceptance (the same at every speed, whatever the neighbours): the lowest root known is accepted
        # when the full monodromy is stable on the search from below's ladder under it and at the rungs
        # just below it (check_canonical); a failed rung brackets a crossing below (Newton from the
        # bracket, the root joins the set). With no root left, the ladder itself is climbed (above what
        # the checks already found stable) to its first unstable depth, and Newton starts in that bracket.
        # lo: the depth up to which every ladder rung is known stable at this speed (f_lo: ρ − 1 there).
        st = scan_state(rho0)
        st[6] = k_known
        st[7] = r_known
        scanned = False
        done = False
        for attempt in range(ATTEMPTS):
            best = -1
            for i in range(N_BRANCH):
                if br_on[i] and (best < 0 or br_b[i] < br_b[best]):
                    best = i
            if best < 0:
                if scanned:
                    break
                scanned = True
                _, b_lo, f_lo, b_hi, f_hi, m_hi, c = scan_to(b_ref[s], ladder, np.inf, st, near, kt, wn, zeta, mass,
                                                             mdir, D, g, nd, cap[s])
                count += c
                if b_hi < 0.0:  # stable up to 1e4 times the reference depth (no boundary), or past the cap
                    depth[s] = b_lo if b_hi == CENSORED else np.inf
                    mu[s] = complex(np.nan, np.nan)
                    done = True
                    break
            else:
                b1 = br_b[best]
                stable, b_lo, f_lo, b_hi, f_hi, m_hi, c = check_root(b1, b_ref[s], ladder, st, near, kt, wn, zeta, mass,
                                                                     mdir, D, g, nd, cap[s])
                count += c
                if b_hi == CENSORED:  # stable past the cap under the root: the limit is above the cap
                    depth[s] = b_lo
                    mu[s] = complex(np.nan, np.nan)
                    done = True
                    break
                if stable:
                    depth[s] = b1
                    mu[s] = complex(math.cos(br_t[best]), math.sin(br_t[best]))
                    done = True
                    break
            # a crossing in (b_lo, b_hi): Newton from the secant point of the bracket
            bn, thn, ok, c = newton(secant_start(b_lo, b_hi, f_lo, f_hi), abs(cmath_phase(m_hi)), kt, wn, zeta, mass,
                                    mdir, g, nd)
            count += c
            if not (ok and bn < b_hi * (1.0 + 1e-6) and bn > b_lo * (1.0 - 1e-6)):
                d, m2, c = _illinois(b_lo, f_lo, b_hi, f_hi, m_hi, 0.01, kt, wn, zeta, mass, mdir, D, g, nd)
                count += c
                bn, thn, ok, c = newton(d, abs(cmath_phase(m2)), kt, wn, zeta, mass, mdir, g, nd)
                count += c
                ok = ok and abs(bn / d - 1.0) < 0.006
            if not ok:
                # Newton fails in the bracket: the fine Illinois on ρ − 1 gives the depth (no branch)
                for i in range(N_BRANCH):
                    br_on[i] = False
                d, m2, c = _illinois(b_lo, f_lo, b_hi, f_hi, m_hi, rtol, kt, wn, zeta, mass, mdir, D, g, nd)
                count += c
                depth[s] = d
                mu[s] = m2
                done = True
                break
            _add_branch(br_b, br_t, br_b2, br_on, bn, thn)
        if not done:
            # the attempts ran out (bracket after bracket): the fine Illinois from below at this speed
            for i in range(N_BRANCH):
                br_on[i] = False
            d, m_, c = first_crossing(b_ref[s], ladder, rtol, rho0, kt, wn, zeta, mass, mdir, D, g, nd)
            count += c
            depth[s] = d
            mu[s] = m_
        T_prev = T
        n_eval[s] = count


@nb.njit(cache=True)
def cmath_phase(z):
    return math.atan2(z.imag, z.real)


@nb.njit(cache=True, parallel=True)
def limit_batch(n_teeth, kt, kr, phi_s, phi_e, rpm, starts, b_ref, ladder, near, wn, zeta, mass, mdir, act, elem_len,
                nd, rtol, w_flex, depth, mu, n_eval, cap, floor, gate):
    """Limiting depths for B structures (wn, zeta, mass (B, M)) at ascending speeds rpm (S,), split into
    blocks starting at ``starts`` (each block continues from speed to speed). Parallel over
    (set, block) pairs. kr (B,): each set's radial-to-tangential ratio (the ``per_set_kr`` capability; the cutting's
    own Kr repeated otherwise). b_ref (B, S); writes depth (B, S) [m], mu (B, S), n_eval (B, S); cap (B, S) [m]: the
    censored search's caps (:func:`limit_run`; inf: none); floor (B, S) [m] (≤ 0: none) and gate: the floors
    (:func:`limit_run`)."""
    n_b = wn.shape[0]
    n_blk = starts.size - 1
    for t in nb.prange(n_b * n_blk):
        bi = t // n_blk
        k = t % n_blk
        a = starts[k]
        e = starts[k + 1]
        limit_run(n_teeth, kt, kr[bi], phi_s, phi_e, rpm[a:e], b_ref[bi, a:e], ladder, near, wn[bi], zeta[bi], mass[bi],
                  mdir, act, elem_len[bi], nd, rtol, w_flex[bi], depth[bi, a:e], mu[bi, a:e], n_eval[bi, a:e],
                  cap[bi, a:e], floor[bi, a:e], gate)


@nb.njit(cache=True)
def refine_at(n_teeth, kt, kr, phi_s, phi_e, rpm, b, theta, wn, zeta, mass, mdir, act, elem_len, nd):
    """:func:`newton` at one speed on the layout with nodes ``nd``: the boundary point (b, θ) found
    with other nodes, moved to this discretisation (used by the convergence check)."""
    g = with_factors(setup(n_teeth, kr, phi_s, phi_e, rpm, elem_len, nd[0], wn, zeta, act), wn, zeta, mass, mdir, nd)
    return newton(b, theta, kt, wn, zeta, mass, mdir, g, nd)
