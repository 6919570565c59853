"""Comparing an estimate with a known truth (benchmarks, tests, the report): up to the x ↔ y symmetries
of :mod:`millstab.identify.symmetry`, which the points cannot resolve.
"""

from __future__ import annotations

import numpy as np

from millstab.identify.symmetry import exchanged


def oriented(theta: np.ndarray, truth: np.ndarray, perm=None, std_errors: np.ndarray | None = None):
    """θ (and its standard errors) in the x↔y orientation closer to the truth: θ itself, or its image
    under ``perm`` when that is closer in the largest relative error.

    ``perm`` may be an index permutation (:func:`swap_permutation`) or a (perm, shift) exchange map
    (:func:`exchange_map`; standard errors scale with their parameters). Returns (θ, std_errors)."""
    t, tr = np.asarray(theta, float), np.asarray(truth, float)
    if perm is None:
        return t, std_errors
    move = (lambda v: exchanged(v, perm)) if isinstance(perm, tuple) else (lambda v: np.asarray(v)[perm])  # noqa: E731
    t2 = move(t)
    if np.abs(t2 / tr - 1).max() < np.abs(t / tr - 1).max():
        return t2, None if std_errors is None else move(std_errors)
    return t, std_errors


def rel_error(theta: np.ndarray, truth: np.ndarray, perm=None) -> np.ndarray:
    """|θ/θ_true − 1| per parameter, up to the x↔y symmetry when ``perm`` is given (the better of the two:
    see :func:`oriented`)."""
    t, _ = oriented(theta, truth, perm)
    return np.abs(t / np.asarray(truth, float) - 1)


__all__ = ["oriented", "rel_error"]
