"""The spectral engine's compiled eigenvalue routine (balance, Hessenberg, double-shift QR) against
closed forms and LAPACK (numpy), on badly scaled matrices and on the engine's own monodromies."""

from __future__ import annotations

import math

import numpy as np
import pytest

from millstab.model import Cutting, Mode, Structure
from millstab.stability import spectral
from millstab.stability._spectral_kernel import eig_small


def _sorted(e):
    e = np.asarray(e)
    return e[np.lexsort((e.imag, e.real))]


def test_known_spectrum_under_a_badly_scaled_similarity():
    """Blocks with eigenvalues r e^{±iφ} and reals, hidden by a random similarity with row scales 1e-4..1e4
    (as the monodromy mixes m, m/s and chip thicknesses)."""
    rng = np.random.default_rng(3)
    for _ in range(50):
        pairs = rng.uniform(0.1, 1.2, 4) * np.exp(1j * rng.uniform(0.05, math.pi - 0.05, 4))
        reals = rng.uniform(-1.1, 1.1, 3)
        K = 2 * pairs.size + reals.size
        J = np.zeros((K, K))
        for i, z in enumerate(pairs):
            J[2 * i:2 * i + 2, 2 * i:2 * i + 2] = [[z.real, -z.imag], [z.imag, z.real]]
        J[8:, 8:] = np.diag(reals)
        scale = np.exp(rng.uniform(-9, 9, K))
        T = scale[:, None] * (np.eye(K) + 0.3 * rng.standard_normal((K, K)))
        A = T @ J @ np.linalg.inv(T)
        want = _sorted(np.concatenate([pairs, pairs.conj(), reals]))
        got = _sorted(eig_small(A))
        np.testing.assert_allclose(got, want, atol=1e-8 * np.abs(want).max())


@pytest.mark.parametrize("K", [1, 2, 3, 7, 12, 16, 30])
def test_matches_lapack_on_random_matrices(K):
    rng = np.random.default_rng(K)
    for _ in range(40):
        A = rng.standard_normal((K, K)) * np.exp(rng.uniform(-6, 6, K))[:, None]
        ours, ref = eig_small(A), np.linalg.eigvals(A)
        assert abs(np.abs(ours).max() / np.abs(ref).max() - 1) < 1e-12
        np.testing.assert_allclose(np.sort(np.abs(ours)), np.sort(np.abs(ref)), rtol=1e-7,
                                   atol=1e-12 * np.abs(ref).max())


def test_monodromy_spectral_radius_matches_lapack():
    """ρ of the engine's monodromies (1-DOF benchmark and a two-direction structure, several immersions,
    speeds and depths up to past the limit) against numpy's eigenvalues of the same matrix."""
    m, fn, z = 0.03993, 922.0, 0.011
    k = m * (2 * math.pi * fn) ** 2
    structs = (Structure(x=(Mode(fn, k, z),)), Structure(x=(Mode(fn, k, z),), y=(Mode(1.3 * fn, 2 * k, 0.02),)))
    for s in structs:
        for imm in (0.05, 0.5, 1.0):
            c = Cutting.from_immersion(2, 6e8, 1 / 3, imm, "down")
            for rpm in (5200.0, 11800.0, 23000.0):
                for depth in (1e-4, 1e-3, 3e-3):
                    U = spectral.monodromy(s, c, rpm, depth)
                    ref = np.abs(np.linalg.eigvals(U)).max()
                    assert abs(np.abs(eig_small(U)).max() / ref - 1) < 1e-11, (imm, rpm, depth)


def test_a_non_finite_matrix_gives_nan_not_a_hang():
    A = np.eye(4)
    A[1, 2] = np.inf
    assert np.isnan(eig_small(A)).all()
    A[1, 2] = np.nan
    assert np.isnan(eig_small(A)).all()
