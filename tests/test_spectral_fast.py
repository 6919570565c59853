"""The spectral engine's cheaper rung tests (issue 28) against independent re-computations.

1. The rung test with a squaring budget (``_spectral_kernel.rho_test``: a bound from ‖Bᵐ‖∞ or ‖Bᵐ‖_F of the
   balanced monodromy, else its eigenvalues) is ρ itself, bit for bit, where it reports an exact value, and a
   bound at or above ρ and below the level where it certifies, for every budget (0 to 8 squarings), on random
   structures, cuts, node counts, speeds and depths; a budget that skips the squarings changes no decision.
2. The limit at a speed is the search from below of that speed, re-computed here without the engine's
   search: ρ from numpy's eigenvalues of the FULL monodromy (``spectral.monodromy``: no low-rank factors, no
   reduced history, no certificate, no compiled QR) on the same ladder (b_ref·LADDER, refined near ρ = 1 in
   REFINE parts, twice as many in its coarse part), then bisection of the first unstable step, and on the fine
   ladder before the coarse part (SDM's rungs, issue 28). Random structures, cuts and node counts, at
   random speeds of a random grid: the engine's depth equals it (1e-5; the bisection stops at 1e-6) or is a
   lower crossing where the full monodromy is unstable just above it (allowed: a root of the characteristic
   equation is a true crossing), and equals the same speed computed alone (1e-9).
"""

from __future__ import annotations

import numpy as np
import pytest
from spectral_cases import random_case

from millstab.frf import ModalBatch
from millstab.stability import _spectral_kernel as k
from millstab.stability import sdm, spectral
from millstab.stability.sdm import _arrays


def _layout(structure, cut, rpm, nodes):
    wn, zeta, mass, act, mdir = _arrays(ModalBatch.from_structures([structure]))
    nd = k.gauss_nodes(nodes)
    g = k.setup(cut.teeth, cut.kr, cut.entry, cut.exit, rpm, float(spectral._elem_len(wn)[0]), nd[0], wn[0],
                zeta[0], act)
    return k.with_factors(g, wn[0], zeta[0], mass[0], mdir, nd), (wn[0], zeta[0], mass[0], mdir, act.size, nd)


def test_rung_test_is_rho_or_a_bound_above_it_for_every_budget():
    rng = np.random.default_rng(2813)
    n_bound = n_all = 0
    for _ in range(5):
        structure, cut = random_case(rng)
        nodes = int(rng.integers(3, 9))
        rpm = float(rng.uniform(4000, 20000))
        b_lim = spectral.envelope_batch(ModalBatch.from_structures([structure]), cut, [rpm], nodes=nodes,
                                        near=0.0)[0, 0]
        if not np.isfinite(b_lim):
            continue
        gf, (wn, zeta, mass, mdir, D, nd) = _layout(structure, cut, rpm, nodes)
        for b in b_lim * np.concatenate([np.linspace(0.05, 0.95, 8), [0.999, 1.01]]):
            r, mu = k.rho(b, cut.kt, wn, zeta, mass, mdir, D, gf, nd)
            for level in (1.0, 0.98):
                for sq in range(9):
                    got, mu_t, exact = k.rho_test(b, level, sq, cut.kt, gf)
                    n_all += 1
                    if exact:
                        assert got == r and (mu_t == mu or (np.isnan(mu) and np.isnan(mu_t)))
                    else:
                        n_bound += 1
                        assert sq > 0 and r <= got * (1 + 1e-12) and got < level and np.isnan(mu_t)
                    # the decision (above the level or not) is the one the eigenvalues make
                    assert (got > level) == (r > level)
    assert n_bound > 0.3 * n_all, (n_bound, n_all)


def _rho_full(structure, cut, rpm, b, nodes):
    return np.abs(np.linalg.eigvals(spectral.monodromy(structure, cut, rpm, b, nodes=nodes))).max()


def _search_from_below(structure, cut, rpm, b_ref, nodes, near, fine=False):
    """The definition, in plain numpy: ρ of the full monodromy on b_ref·LADDER (then ×1.5), each step refined into
    REFINE parts per 0.05·b_ref under 1.2·b_ref (twice as many in the ladder's coarse part, ``refine_parts``) where ρ at
    either end is above 1 − near or its top is unstable; bisection of the first unstable step to 1e-6. ``fine``: the
    ladder before its coarse part (SDM's, every step 0.05·b_ref up to 1.2, REFINE parts each)."""
    ladder = sdm.FACTORS if fine else spectral.LADDER
    lo, f_lo = 0.0, -1.0  # ρ(0) < 1 (free damped vibration)
    kk = 0
    while True:
        x = k.ladder_depth(b_ref, ladder, kk)
        parts = k.REFINE  # per 0.05·b_ref of a step under 1.2·b_ref (two of SDM's steps: twice as many)
        if kk < ladder.size and ladder[kk] <= 1.2 + 1e-9:
            parts *= max(1, round((ladder[kk] - (ladder[kk - 1] if kk else 0.0)) / 0.05))
        kk += 1
        if x > 1e4 * b_ref:
            return np.inf
        r = _rho_full(structure, cut, rpm, x, nodes)
        hi = None
        if r > 1.0 - near or f_lo > -near:
            for j in range(1, parts):
                y = lo + j * (x - lo) / parts
                if _rho_full(structure, cut, rpm, y, nodes) > 1.0:
                    hi = y
                    break
                lo = y
        if hi is None and r > 1.0:
            hi = x
        if hi is not None:
            while hi - lo > 1e-6 * hi:
                mid = 0.5 * (lo + hi)
                if _rho_full(structure, cut, rpm, mid, nodes) > 1.0:
                    hi = mid
                else:
                    lo = mid
            return 0.5 * (lo + hi)
        lo, f_lo = x, r - 1.0


@pytest.mark.slow
def test_limit_is_the_dense_search_from_below_on_a_random_grid_and_alone():
    rng = np.random.default_rng(2814)
    n_checked = 0
    for case in range(4):
        structure, cut = random_case(rng)
        nodes = int(rng.integers(4, 8))
        near = (0.0, spectral.NEAR)[case % 2]
        batch = ModalBatch.from_structures([structure])
        grid = np.sort(rng.uniform(3000.0, 20000.0, 30))
        on_grid = spectral.envelope_batch(batch, cut, grid, nodes=nodes, near=near)[0]
        b_ref = spectral._b_ref(batch, cut, grid)[0]
        for i in rng.choice(grid.size, 2, replace=False):
            alone = spectral.envelope_batch(batch, cut, [grid[i]], nodes=nodes, near=near)[0, 0]
            assert on_grid[i] == alone or abs(on_grid[i] / alone - 1) < 1e-9, (case, grid[i], on_grid[i], alone)
            ref = _search_from_below(structure, cut, grid[i], b_ref[i], nodes, near)
            if not np.isfinite(ref):
                assert not np.isfinite(on_grid[i])
                continue
            n_checked += 1
            # the ladder's coarse part finds what the fine ladder before it found (or a lower true crossing)
            for r in (ref, _search_from_below(structure, cut, grid[i], b_ref[i], nodes, near, fine=True)):
                if abs(on_grid[i] / r - 1) > 1e-5:  # only a lower true crossing may differ
                    assert on_grid[i] < r, (case, grid[i], on_grid[i], r)
                    assert _rho_full(structure, cut, grid[i], on_grid[i] * (1 + 1e-4), nodes) > 1.0
    assert n_checked >= 6


def test_every_speed_of_a_random_grid_equals_that_speed_alone():
    """Random structures, cuts and node counts, 16 random speeds (a grid whose branches continue between
    neighbours) with the engine's default ``near`` and with 0: each speed's depth equals the same speed's
    search alone to 1e-10 (Newton's roots are converged to ~1e-12 on both paths)."""
    rng = np.random.default_rng(2815)
    for case in range(3):
        structure, cut = random_case(rng)
        nodes = int(rng.integers(4, 8))
        near = (spectral.NEAR, 0.0)[case % 2]
        batch = ModalBatch.from_structures([structure])
        grid = np.sort(rng.uniform(3000.0, 20000.0, 16))
        on_grid = spectral.envelope_batch(batch, cut, grid, nodes=nodes, near=near)[0]
        alone = np.array([spectral.envelope_batch(batch, cut, [r], nodes=nodes, near=near)[0, 0] for r in grid])
        same = (on_grid == alone) | (np.abs(on_grid / alone - 1) < 1e-10)
        assert same.all(), (case, grid[~same], on_grid[~same], alone[~same])


def test_the_speed_workspace_gives_what_fresh_arrays_give_whatever_came_before():
    """The per-speed workspace (``with_factors``' g[9]: the monodromy built in place, the certificate's squarings and
    balancing scaling carried from depth to depth, issue 28) changes no value: at depths visited in a random order,
    after other depths, levels and budgets, the built matrix is a fresh ``monodromy_lr``'s and ρ the eigenvalues'
    of that matrix (``eig_small``, fresh arrays) bit for bit, on random structures, cuts and node counts; where the
    rung test certifies, its bound is at or above that ρ and below the level."""
    rng = np.random.default_rng(2829)
    n_cert = 0
    for _ in range(4):
        structure, cut = random_case(rng)
        nodes = int(rng.integers(3, 8))
        rpm = float(rng.uniform(4000, 20000))
        gf, (wn, zeta, mass, mdir, D, nd) = _layout(structure, cut, rpm, nodes)
        g_fresh = _layout(structure, cut, rpm, nodes)[0]
        b0 = spectral._b_ref(ModalBatch.from_structures([structure]), cut, np.array([rpm]))[0, 0]
        for b in b0 * rng.uniform(0.05, 2.0, 12):
            U = k.monodromy_lr(b, cut.kt, g_fresh, g_fresh[8])
            ref, mu_ref = k._dominant(k.eig_small(U))
            assert np.array_equal(k._build_lr(b, cut.kt, gf, gf[8], gf[9]), U)
            r, mu = k.rho(b, cut.kt, wn, zeta, mass, mdir, D, gf, nd)
            assert r == ref and (mu == mu_ref or (np.isnan(mu) and np.isnan(mu_ref)))
            level = float(rng.choice([1.0, 0.98, 0.9]))
            got, _, exact = k.rho_test(b, level, int(rng.integers(0, 11)), cut.kt, gf)
            if exact:
                assert got == ref
            else:
                n_cert += 1
                assert ref <= got * (1 + 1e-12) and got < level
    assert n_cert > 0


def test_norms_are_numpys_and_nan_is_not_finite():
    """The certificate's norms (``_norms``, four partial sums per row) against numpy's, on random sizes; a NaN entry
    makes the Frobenius norm NaN (the rung test then takes the exact path, which reports ρ = inf)."""
    rng = np.random.default_rng(5)
    for K in (1, 3, 4, 7, 16, 22):
        P = rng.standard_normal((K, K)) * 10.0 ** rng.uniform(-3, 3, (K, K))
        inf, fro = k._norms(P)
        assert inf == pytest.approx(np.abs(P).sum(axis=1).max(), rel=1e-14)
        assert fro == pytest.approx(np.linalg.norm(P), rel=1e-14)
        P[K // 2, K - 1] = np.nan
        assert np.isnan(k._norms(P)[1])
