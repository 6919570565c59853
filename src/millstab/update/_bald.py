"""Compiled kernel of the next-test criterion: the mean label probability and the mutual information
between a cut's label and θ on a speed × depth grid, from posterior limits (one fused pass).

The NumPy form builds (M samples, S speeds, D depths) arrays of Φ and of the binary entropy, i.e.
~7·10⁶ erf and 2 log evaluations per call at the defaults; here each (speed, sample) column is read once,
and cells more than :data:`Z_FAR` noise widths from a sample's limit contribute their exact limits
(π = 0 or 1, entropy 0, both within 1e-16) without any transcendental function.

With a label error ε (the label swapped with probability ε) the label probability is
ε + (1 − 2ε)·π: far cells then have probability ε or 1 − ε and entropy h(ε), computed once per sample.
Each sample m carries its own ε_m and depth-noise factor s_m (the posterior's learned label model):
π = Φ((b − b_lim,m)/(s_m·σ_b(b))).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

#: |z| beyond which Φ(z) is within 1e-16 of 0 or 1 (and its binary entropy below 1e-14)
Z_FAR = 8.3


@nb.njit(cache=True, inline="always")
def _h(p: float) -> float:
    """Binary entropy [nats], with p clipped to [1e-12, 1 - 1e-12] as the NumPy form does."""
    q = min(max(p, 1e-12), 1.0 - 1e-12)
    return -(q * math.log(q) + (1.0 - q) * math.log(1.0 - q))


@nb.njit(cache=True, parallel=True)
def _bald(blim_t: np.ndarray, depths: np.ndarray, sig: np.ndarray, eps: np.ndarray,
          fac: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    s_n, m_n = blim_t.shape
    d_n = depths.size
    h_far = np.empty(m_n)  # the entropy of a far cell's label per sample (0 without label errors)
    for m in range(m_n):
        h_far[m] = _h(eps[m]) if eps[m] > 0 else 0.0
    pbar = np.zeros((s_n, d_n))
    info = np.zeros((s_n, d_n))
    proc = np.zeros((s_n, d_n))
    r2 = 1.0 / math.sqrt(2.0)
    for s in nb.prange(s_n):
        hsum = np.zeros(d_n)
        for m in range(m_n):
            b = blim_t[s, m]
            e = eps[m]
            keep = 1.0 - 2.0 * e
            inv = 1.0 / fac[m]
            for d in range(d_n):
                z = (depths[d] - b) / sig[d] * inv
                if z > Z_FAR:
                    pbar[s, d] += 1.0 - e
                    proc[s, d] += 1.0
                    hsum[d] += h_far[m]
                elif z >= -Z_FAR:
                    phi = 0.5 * math.erfc(-z * r2)
                    p = e + keep * phi
                    pbar[s, d] += p
                    proc[s, d] += phi
                    hsum[d] += _h(p)
                else:
                    pbar[s, d] += e
                    hsum[d] += h_far[m]
        for d in range(d_n):
            pbar[s, d] /= m_n
            proc[s, d] /= m_n
            info[s, d] = _h(pbar[s, d]) - hsum[d] / m_n
    return pbar, info, proc


def label_information(blim_mm: np.ndarray, depth_mm: np.ndarray, sigma_mm: np.ndarray,
                      label_error=0.0, sigma_factor=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(P(chatter label) (S, D), mutual information [nats] (S, D), P(the process chatters) (S, D)) of cuts
    at the grid's depths [mm], averaged over the M samples.

    Args:
        blim_mm: posterior limits (M, S) [mm]; ``inf`` = no boundary (the label is surely stable).
        depth_mm: depths (D,) [mm]; sigma_mm: the likelihood's depth noise at each depth (D,) [mm].
        label_error: probability ε ∈ [0, ½) that a label is swapped: one value, or one per sample (M,).
        sigma_factor: the factor s on ``sigma_mm`` per sample (M,) (the learned depth noise); ``None``: 1.
    """
    b = np.where(np.isnan(blim_mm), np.inf, blim_mm)
    m = b.shape[0]
    # writable copies: a read-only broadcast view (one ε per sample) is another numba signature than a fresh
    # array, so the kernel compiled twice and `millstab warmup` could not cover both
    eps = np.array(np.broadcast_to(np.asarray(label_error, float), (m,)))
    fac = np.ones(m) if sigma_factor is None else np.array(np.broadcast_to(np.asarray(sigma_factor, float), (m,)))
    return _bald(np.ascontiguousarray(b.T, dtype=float), np.ascontiguousarray(depth_mm, float),
                 np.ascontiguousarray(sigma_mm, float), eps, fac)
