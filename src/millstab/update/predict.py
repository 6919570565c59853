"""Predictions for given cuts from a posterior: the chance that each cut is stable (the process) and
the chance that an operator writes "chatter" for it (the label model of the likelihood).

Units: rpm and mm at this interface.
"""

from __future__ import annotations

import numpy as np

from millstab.errors import InputError
from millstab.update.likelihood import limits
from millstab.update.posterior import Posterior


def predict_cuts(post: Posterior, rpm, depth_mm) -> tuple[np.ndarray, np.ndarray]:
    """``(p_stable, p_label_chatter)`` (n,) for n cuts at ``rpm`` (n,) [rev/min] and ``depth_mm`` (n,) [mm],
    in the input order; one engine call for every distinct speed.

    ``p_stable``: the fraction of posterior samples whose limiting depth lies above the cut's depth.
    ``p_label_chatter``: P(the written label says chatter) = ε + (1 − 2ε)·(1 − p_stable), ε the label
    error of the posterior's label model (see :mod:`millstab.update.likelihood`).

    Raises:
        InputError: lengths differ, a speed or depth not finite and > 0.
    """
    r = np.atleast_1d(np.asarray(rpm, dtype=float))
    d = np.atleast_1d(np.asarray(depth_mm, dtype=float))
    if r.shape != d.shape or r.ndim != 1:
        raise InputError("cuts", f"{r.size} speeds and {d.size} depths", "need one depth per speed")
    for name, a, unit in (("rpm", r, "rev/min"), ("depth_mm", d, "mm")):
        bad = ~(np.isfinite(a) & (a > 0))
        if bad.any():
            i = int(np.argmax(bad))
            raise InputError(f"cuts.{name}[{i}]", float(a[i]), f"must be a finite number > 0 {unit}")
    if r.size == 0:
        return np.zeros(0), np.zeros(0)
    speeds, idx = np.unique(r, return_inverse=True)
    blim, _ = limits(post.prior, post.u, speeds, post.engine)
    p_stable = (blim[:, idx] > d[None, :]).mean(axis=0)
    eps = float(post.prior.label_error)
    return p_stable, eps + (1.0 - 2.0 * eps) * (1.0 - p_stable)


__all__ = ["predict_cuts"]
