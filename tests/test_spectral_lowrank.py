"""The spectral engine's fast paths of issue 28, each against an independent re-computation.

1. ρ's monodromy from the per-speed low-rank factors (``_spectral_kernel.monodromy_lr``, Woodbury on each
   element's collocation matrix) against the element-by-element collocation solve (``monodromy_small``) and
   the full monodromy's eigenvalues (public ``spectral.monodromy``, numpy), on random structures (1–2 modes
   per direction, one or two directions), cuts (1–4 teeth, a/D 0.03–1, up and down), node counts, speeds and
   depths: a wrong factor, sign or history column moves ρ by far more than the tolerance; the same for the
   characteristic function's Ψ(σ) and dΨ/dσ (``psi_d_lr``) against the element-by-element ``psi_d``.
2. Sparse speeds (an update's cut speeds) are searched each on its own (``PHASE_SPLIT``), and every speed's
   depth is the one it gets alone and the first crossing of a dense ρ scan of the full monodromy.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from spectral_cases import random_case

from millstab.frf import ModalBatch
from millstab.model import Cutting, Mode, Structure
from millstab.stability import _spectral_kernel as k
from millstab.stability import spectral
from millstab.stability.sdm import _arrays


def test_low_rank_monodromy_equals_the_collocation_solve_and_the_full_monodromy():
    rng = np.random.default_rng(28)
    for _ in range(10):
        structure, cut = random_case(rng)
        wn, zeta, mass, act, mdir = _arrays(ModalBatch.from_structures([structure]))
        nodes = int(rng.integers(3, 9))
        nd = k.gauss_nodes(nodes)
        rpm = float(rng.uniform(3000, 25000))
        g = k.setup(cut.teeth, cut.kr, cut.entry, cut.exit, rpm, float(spectral._elem_len(wn)[0]), nd[0], wn[0],
                    zeta[0], act)
        gf = k.with_factors(g, wn[0], zeta[0], mass[0], mdir, nd)
        for b in rng.uniform(1e-5, 1e-2, 3):
            small = k.monodromy_small(b, cut.kt, wn[0], zeta[0], mass[0], mdir, g[0], g[1], g[2], g[4], g[5], g[6],
                                      g[7], nd[1], nd[2])
            fast = k.monodromy_lr(b, cut.kt, gf, gf[8])
            assert fast.shape == small.shape
            assert np.abs(fast - small).max() <= 1e-9 * max(1.0, np.abs(small).max())
            full = np.linalg.eigvals(spectral.monodromy(structure, cut, rpm, b, nodes=nodes))
            r_fast, _ = k.rho(b, cut.kt, wn[0], zeta[0], mass[0], mdir, act.size, gf, nd)
            assert r_fast == np.abs(full).max() or abs(r_fast / np.abs(full).max() - 1) < 1e-9
            # Ψ(σ) and dΨ/dσ (Newton's characteristic function) at a complex σ = w (1 − 1/μ)
            mu = np.exp(1j * rng.uniform(0.0, math.pi))
            sigma = 0.5 * b * cut.kt * (1.0 - 1.0 / mu)
            psi, dpsi = k.psi_d(sigma, wn[0], zeta[0], mass[0], mdir, g[0], g[1], g[2], g[4], nd[1], nd[2])
            psi_lr, dpsi_lr = k.psi_d_lr(sigma, gf, gf[8])
            assert np.abs(psi_lr - psi).max() <= 1e-9 * max(1.0, np.abs(psi).max())
            assert np.abs(dpsi_lr - dpsi).max() <= 1e-9 * max(1.0, np.abs(dpsi).max())


@pytest.mark.slow
def test_sparse_speeds_are_searched_alone_and_give_the_first_crossing():
    """Cut speeds of an update (10 in 5 000–12 000 rpm, two random structures of Example 1's kind):
    each speed is a block of its own, its depth is that of the speed alone (to 1e-9), and a dense ρ scan of
    the full monodromy (numpy eigenvalues, 2 more nodes) is stable on 30 depths up to 0.99 of it and unstable
    at 1.005 of it."""
    rng = np.random.default_rng(2811)
    rpm = np.linspace(5000.0, 12000.0, 10) + rng.uniform(-100.0, 100.0, 10)
    cut = Cutting.from_immersion(2, 556.31e6, 0.404, 0.1, "down")
    for _ in range(2):
        f = rng.uniform(0.8, 1.2, 6)
        s = Structure(x=(Mode(685.0 * f[0], 12.7e6 * f[1], 0.029 * f[2]),),
                      y=(Mode(694.0 * f[3], 13.6e6 * f[4], 0.037 * f[5]),))
        batch = ModalBatch.from_structures([s])
        starts = spectral._block_starts(batch, cut, rpm, 6)
        assert starts.tolist() == list(range(rpm.size + 1))
        got = spectral.envelope_batch(batch, cut, rpm, nodes=6, near=0.0)[0]
        for i, r in enumerate(rpm):
            alone = spectral.envelope_batch(batch, cut, [r], nodes=6, near=0.0)[0, 0]
            assert abs(got[i] / alone - 1) < 1e-9
            rho = spectral.rho_map(s, cut, [r], np.linspace(0.02 * got[i], 0.99 * got[i], 30), nodes=8)[0]
            assert rho.max() < 1.0, (r, got[i])
            big = spectral.rho_map(s, cut, [r], [1.005 * got[i]], nodes=8)[0, 0]
            assert big > 1.0, (r, got[i])


def test_dense_speeds_still_continue_branches():
    """Neighbouring speeds within PHASE_SPLIT of phase stay one block (the branch continuation pays there)."""
    s = Structure(x=(Mode(922.0, 0.03993 * (2 * math.pi * 922.0) ** 2, 0.011),))
    cut = Cutting.from_immersion(2, 6e8, 1 / 3, 0.05, "down")
    rpm = np.linspace(15000.0, 25000.0, 101)
    phase = spectral._phase_steps(ModalBatch.from_structures([s]), cut, rpm)
    assert phase.max() < spectral.PHASE_SPLIT
    starts = spectral._block_starts(ModalBatch.from_structures([s] * 2), cut, rpm, 6)
    assert np.all(np.diff(starts) >= min(spectral.BLOCK, rpm.size // 2))  # only the cost-balanced blocks, if any


def test_certified_rungs_bound_rho_from_above():
    """``rho_below`` (the search's rung test: a bound from squarings of the balanced monodromy where it is
    below the level, else the eigenvalues): every bound lies at or above ρ from :func:`rho` and below the
    level, every exact value is ρ itself, and the bound is used on most rungs well below the boundary
    (random structures and cuts as above, depths 5–95 % of the first crossing at 6 nodes, levels 1 and 0.98)."""
    rng = np.random.default_rng(2812)
    n_bound = n_all = 0
    for _ in range(10):
        structure, cut = random_case(rng)
        batch = ModalBatch.from_structures([structure])
        wn, zeta, mass, act, mdir = _arrays(batch)
        nd = k.gauss_nodes(6)
        rpm = float(rng.uniform(4000, 20000))
        b_lim = spectral.envelope_batch(batch, cut, [rpm], nodes=6, near=0.0)[0, 0]
        if not np.isfinite(b_lim):
            continue
        g = k.setup(cut.teeth, cut.kr, cut.entry, cut.exit, rpm, float(spectral._elem_len(wn)[0]), nd[0], wn[0],
                    zeta[0], act)
        gf = k.with_factors(g, wn[0], zeta[0], mass[0], mdir, nd)
        for b in b_lim * np.linspace(0.05, 0.95, 12):
            r, _ = k.rho(b, cut.kt, wn[0], zeta[0], mass[0], mdir, act.size, gf, nd)
            for level in (1.0, 0.98):
                got, mu, exact = k.rho_below(b, level, cut.kt, wn[0], zeta[0], mass[0], mdir, act.size, gf, nd)
                n_all += 1
                if exact:
                    assert got == r
                else:
                    n_bound += 1
                    assert r <= got * (1 + 1e-12) and got < level and np.isnan(mu)
    assert n_bound > 0.3 * n_all, (n_bound, n_all)
