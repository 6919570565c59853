"""Warm-started boundary points for the spectral engine (compiled): Newton from a guess, then the checks.

A warm start replaces the root search at one (set, speed) when a good guess (depth b, multiplier angle
θ) is known: the boundary of a nearly equal parameter set (the rows of a finite-difference Jacobian
differ by 1e-4 in ln θ), or the zero-order boundary. It is accepted by the same rule that accepts a
continued branch in :func:`millstab.stability._spectral_kernel.limit_run`: Newton on the characteristic
function converges, and the search from below at that speed would not stop below the root
(:func:`~millstab.stability._spectral_kernel.check_root`: the full monodromy is stable on that search's
depths under it, ladder b_ref·ladder on the row's own zero-order depth, refined near ρ = 1); a failed
depth brackets the crossing below, Newton from inside the bracket gives that root and it is checked in
turn. So an accepted point is the boundary the search from below finds for that row at that speed, to
Newton's ~1e-12, whatever the head row or the other speeds (or a lower true crossing: a root of the
characteristic equation is never below the first crossing). Where Newton fails or leaves its bracket,
the entry is reported not converged and the caller solves it cold (:func:`cold_entries`: the search
from below at that speed alone).

Kept apart from ``_spectral_kernel.limit_run`` (whose logic it mirrors without changing it).
Its compiled functions call into ``_spectral_kernel``: numba's on-disk cache of a function is refreshed only when its
own file changes, so an edit of that kernel that this file must see (issue 28: the per-speed workspace g[9] of
``with_factors``) comes with an edit here.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from millstab.stability._spectral_kernel import (
    check_root,
    cmath_phase,
    limit_run,
    newton,
    scan_state,
    secant_start,
    setup,
    with_factors,
)

#: attempts of the check loop (a failed check yields a lower root, checked in turn), as limit_run
ATTEMPTS = 4


@nb.njit(cache=True)
def warm_point(n_teeth, kt, kr, phi_s, phi_e, rpm, b0, th0, b_ref, ladder, near, wn, zeta, mass, mdir, act, elem_len,
               nd):
    """The boundary at one speed [rpm] from the guess (b0 [m], θ0 [rad] in [0, π]); b_ref [m] the zero-order
    depth there (the search from below's ladder is b_ref·ladder, :func:`check_canonical`).

    Returns (depth [m], θ, accepted, evaluations); depth NaN where not accepted."""
    if not (math.isfinite(b0) and b0 > 0.0 and math.isfinite(th0)):
        return np.nan, np.nan, False, 0
    D = act.size
    g = with_factors(setup(n_teeth, kr, phi_s, phi_e, rpm, elem_len, nd[0], wn, zeta, act), wn, zeta, mass, mdir, nd)
    T = 60.0 / (n_teeth * rpm)
    rho0 = 0.0
    for j in range(wn.size):
        rho0 = max(rho0, math.exp(-zeta[j] * wn[j] * T))
    b, th, ok, count = newton(b0, th0, kt, wn, zeta, mass, mdir, g, nd)
    if not ok:
        return np.nan, np.nan, False, count
    st = scan_state(rho0)
    for _ in range(ATTEMPTS):
        stable, br_lo, f_lo, br_hi, f_hi, m_hi, c = check_root(b, b_ref, ladder, st, near, kt, wn, zeta, mass, mdir, D,
                                                               g, nd)
        count += c
        if stable:
            return b, th, True, count
        # a crossing below the root: Newton from the secant point of the bracket (as limit_run)
        b, th, ok, c = newton(secant_start(br_lo, br_hi, f_lo, f_hi), abs(cmath_phase(m_hi)), kt, wn, zeta, mass, mdir,
                              g, nd)
        count += c
        if not (ok and br_lo * (1.0 - 1e-6) < b < br_hi * (1.0 + 1e-6)):
            return np.nan, np.nan, False, count
    return np.nan, np.nan, False, count


@nb.njit(cache=True, parallel=True)
def warm_batch(n_teeth, kt, kr, phi_s, phi_e, rpm, row, b0, th0, b_ref, ladder, near, wn, zeta, mass, mdir, act,
               elem_len, nd, depth, theta, ok, n_eval):
    """:func:`warm_point` for sets ``row`` (E,) (indices into wn, zeta, mass (B, M), elem_len (B,), kr (B,)) at every
    speed rpm (S,), guesses b0, th0 (E, S), zero-order depths b_ref (E, S) [m]. Parallel over (entry, speed). Writes
    depth, theta, ok, n_eval (E, S)."""
    n_e = row.size
    n_s = rpm.size
    for t in nb.prange(n_e * n_s):
        e = t // n_s
        s = t % n_s
        i = row[e]
        d, th, good, c = warm_point(n_teeth, kt, kr[i], phi_s, phi_e, rpm[s], b0[e, s], th0[e, s], b_ref[e, s], ladder,
                                    near, wn[i], zeta[i], mass[i], mdir, act, elem_len[i], nd)
        depth[e, s] = d
        theta[e, s] = th
        ok[e, s] = good
        n_eval[e, s] = c


@nb.njit(cache=True, parallel=True)
def cold_entries(n_teeth, kt, kr, phi_s, phi_e, rpm, row, col, b_ref, ladder, near, wn, zeta, mass, mdir, act, elem_len,
                 nd, rtol, w_flex, depth, mu, n_eval):
    """The search from below (``limit_run`` on one speed) for single entries (set row[e], speed rpm[col[e]]),
    b_ref (E,) the ladder's reference depth [m]; kr (B,) per set. Parallel over entries. Writes depth, mu, n_eval
    (E,)."""
    for e in nb.prange(row.size):
        i = row[e]
        s = col[e]
        limit_run(n_teeth, kt, kr[i], phi_s, phi_e, rpm[s:s + 1], b_ref[e:e + 1], ladder, near, wn[i], zeta[i], mass[i],
                  mdir, act, elem_len[i], nd, rtol, w_flex[i], depth[e:e + 1], mu[e:e + 1], n_eval[e:e + 1],
                  np.full(1, np.inf), np.zeros(1), 0.0)
