"""One-at-a-time sensitivity of the SLD (the seed paper's Algorithm 1, Fig. SENS).

For each parameter p_j and each ε of a grid, the SLD at the same speeds with p_j → (1 + ε)p_j (all
other parameters kept) is compared with the original by MSE = mean_i (b*_i − b'_i)² in **mm²**.
All (parameter, ε) rows and the original go through ONE batched engine call.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from millstab.errors import InputError
from millstab.model import Cutting, Structure
from millstab.params import Parameterization
from millstab.sensitivity._core import (DEFAULT_EPS_GRID, as_parameterization, centre, check_neighbourhood, depths,
                                        engine_module, mse_mm2, warn_percent)
from millstab.sensitivity.results import OATResult
from millstab.stability import check_rpm


def oat(model: Structure | Parameterization, cutting: Cutting, rpm, eps: Sequence[float] | None = None, *,
        theta: Sequence[float] | None = None, engine: str = "zoa") -> OATResult:
    """One-at-a-time MSE [mm²] of the SLD for each parameter scaled by (1 + ε).

    Args:
        model: a modal structure (all its parameters vary) or a :class:`Parameterization`.
        cutting: cutting conditions.
        rpm: spindle speeds [rev/min] of the SLD.
        eps: relative changes (default −0.25 … +0.25 step 0.05; the paper's grid is
            :data:`~millstab.sensitivity.PAPER_EPS_GRID`), each > −1.
        theta: centre values (P,) [SI]; default the structure's own.
        engine: ``zoa``, ``sdm`` or ``spectral``.

    Raises:
        InputError: an ε ≤ −1, or a scaled parameter leaving its valid range (ζ ≥ 1, …), before any work.
    """
    par = as_parameterization(model)
    th = centre(par, theta)
    e = np.asarray(DEFAULT_EPS_GRID if eps is None else eps, dtype=float).ravel()
    if e.size == 0:
        raise InputError("eps", list(e), "need at least one perturbation")
    check_neighbourhood(par, th, 0.0, e)
    warn_percent("eps", e)
    r = check_rpm(rpm)
    n_p, n_e = par.size, e.size
    # row 0 the original; then parameter-major rows: p_j scaled by (1 + eps_k)
    rows = np.repeat(th[None, :], 1 + n_p * n_e, axis=0)
    for j in range(n_p):
        rows[1 + j * n_e: 1 + (j + 1) * n_e, j] = th[j] * (1.0 + e)
    d = depths(engine_module(engine), par, rows, cutting, r)
    mse = mse_mm2(d[:1], d[1:]).reshape(n_p, n_e)
    # rows equal to the original (eps = 0) are exactly zero by construction: same input, same depth
    return OATResult(par.free, th, e, mse, r, d[0] * 1e3, engine)
