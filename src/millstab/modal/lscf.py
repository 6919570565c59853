"""Poles of one measured FRF by the least-squares complex-frequency method (LSCF), over model orders.

The FRF is modelled as a ratio of polynomials in z = exp(iωTs) with real coefficients (Ts = 1/(2 f_max),
so the band maps onto the upper half of the unit circle, where the powers of z are well conditioned):

    H(ω) ≈ B(z)/A(z),   A(z) = Σ_j a_j z^j,  B(z) = Σ_j b_j z^j,  a_n = 1.

The linearised error B − A·H is least-squares fitted; eliminating B (the "reduced normal equations")
leaves an n×n real system for a, and A's roots z_r give the poles s_r = ln(z_r)/Ts [rad/s]. All
orders share the leading blocks of one set of matrices, so the stabilisation diagram over orders
2, 4, ... n_max costs one matrix product plus one small solve per order.

A pole is *stable* at order n when order n − 2 has a pole within :data:`STABLE_DF` in frequency and
:data:`STABLE_DZETA` in damping (the usual stabilisation-diagram test). Physical poles (the modes)
stay put as the order grows; poles that fit noise or truncation wander. :func:`stable_clusters`
groups the stable poles by frequency and returns one candidate per cluster seen at enough orders.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: a pole is frequency-stable when an order-(n−2) pole lies within this relative distance
STABLE_DF = 0.01
#: ... and damping-stable when that pole's ζ is within this relative distance
STABLE_DZETA = 0.10
#: physical damping ratios accepted as modes of a tool tip (structural damping is far below this)
MAX_ZETA = 0.3
#: stable poles closer than this (relative) belong to one cluster (one mode)
CLUSTER_DF = 0.005
#: a cluster is a mode candidate when it is stable at this share of the orders (at least 3 orders)
MIN_SHARE = 0.3


@dataclass(frozen=True)
class Stabilisation:
    """Poles of every model order, for the stabilisation diagram.

    Attributes:
        orders: model orders (polynomial degree n; n/2 conjugate pole pairs) (K,).
        fn: natural frequencies [Hz] of the physical poles, one array per order.
        zeta: their damping ratios [-], one array per order.
        stable: 0 new, 1 frequency-stable, 2 frequency- and damping-stable, one array per order.
    """

    orders: np.ndarray
    fn: list[np.ndarray]
    zeta: list[np.ndarray]
    stable: list[np.ndarray]


def lscf(freq_hz: np.ndarray, h: np.ndarray, max_order: int) -> Stabilisation:
    """Poles of ``h`` [any unit] at ``freq_hz`` [Hz] for the even orders 2..``max_order``.

    Only poles with Im s > 0, 0 < ζ < :data:`MAX_ZETA` and fn inside the band are kept.
    """
    f = np.asarray(freq_hz, float)
    hs = np.asarray(h, complex) / np.max(np.abs(h))  # unit scale: the normal matrices stay well scaled
    ts = 1.0 / (2.0 * f[-1] * 1.0001)  # the top line just inside the half circle
    z = np.exp(1j * 2 * np.pi * f * ts)
    n_max = int(max_order)
    gam = z[:, None] ** np.arange(n_max + 1)[None, :]
    hg = hs[:, None] * gam
    r = (gam.conj().T @ gam).real
    s = -(gam.conj().T @ hg).real
    t = (hg.conj().T @ hg).real
    orders = np.arange(2, n_max + 1, 2)
    fns, zetas = [], []
    lo, hi = f[0], f[-1]
    for n in orders:
        k = n + 1
        rk, sk, tk = r[:k, :k], s[:k, :k], t[:k, :k]
        m = tk - sk.T @ np.linalg.solve(rk, sk)
        try:
            a = np.linalg.solve(m[:n, :n], -m[:n, n])
        except np.linalg.LinAlgError:  # a singular order (exact data of lower order): no new poles
            fns.append(np.empty(0))
            zetas.append(np.empty(0))
            continue
        roots = np.roots(np.append(a, 1.0)[::-1]).astype(complex)  # all-real roots come back as a real array
        roots = roots[np.abs(roots) > 0]
        p = np.log(roots) / ts
        fn = np.abs(p) / (2 * np.pi)
        zeta = -p.real / np.abs(p)
        keep = (p.imag > 0) & (zeta > 0) & (zeta < MAX_ZETA) & (fn >= lo) & (fn <= hi)
        order = np.argsort(fn[keep])
        fns.append(fn[keep][order])
        zetas.append(zeta[keep][order])
    stable = [np.zeros(fns[0].size, int)]
    for i in range(1, len(orders)):
        stable.append(_stability(fns[i], zetas[i], fns[i - 1], zetas[i - 1]))
    return Stabilisation(orders, fns, zetas, stable)


def _stability(fn: np.ndarray, zeta: np.ndarray, fn_prev: np.ndarray, zeta_prev: np.ndarray) -> np.ndarray:
    """0/1/2 per pole of this order against the nearest pole (in frequency) of the previous order."""
    if fn.size == 0 or fn_prev.size == 0:
        return np.zeros(fn.size, int)
    j = np.argmin(np.abs(fn[:, None] - fn_prev[None, :]), axis=1)
    df = np.abs(fn - fn_prev[j]) / fn
    dz = np.abs(zeta - zeta_prev[j]) / zeta
    return np.where(df < STABLE_DF, np.where(dz < STABLE_DZETA, 2, 1), 0)


@dataclass(frozen=True)
class Candidate:
    """A mode candidate: median fn [Hz] and ζ [-] of a cluster of stable poles, and its support."""

    fn: float
    zeta: float
    n_stable: int
    n_orders: int


def stable_clusters(stab: Stabilisation) -> list[Candidate]:
    """One candidate per frequency cluster of frequency- and damping-stable poles seen often enough."""
    fn = np.concatenate([f[s == 2] for f, s in zip(stab.fn, stab.stable)]) if stab.fn else np.empty(0)
    zeta = np.concatenate([z[s == 2] for z, s in zip(stab.zeta, stab.stable)]) if stab.fn else np.empty(0)
    if fn.size == 0:
        return []
    order = np.argsort(fn)
    fn, zeta = fn[order], zeta[order]
    breaks = np.flatnonzero(np.diff(fn) / fn[1:] > CLUSTER_DF) + 1
    need = max(3, int(np.ceil(MIN_SHARE * len(stab.orders))))
    out = []
    for idx in np.split(np.arange(fn.size), breaks):
        if idx.size >= need:
            out.append(Candidate(float(np.median(fn[idx])), float(np.median(zeta[idx])), int(idx.size),
                                 len(stab.orders)))
    return out
