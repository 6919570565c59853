"""Monte Carlo sensitivity of the SLD (the seed paper's Algorithm 2, Table 6).

N paths; each draws every parameter uniformly in [(1 − t)p, (1 + t)p], makes that path's SLD, then
scales each parameter in turn by (1 + ε) and records MSE = mean_i (b*_i − b'_i)² in **mm²**. Mean and
population SD (1/N, as the paper's Algorithm 2) per parameter, plus the standard error of the mean.

No Python loop over paths: for a chunk of C paths the (1 + P) rows per path (the reference and the P
perturbed sets) are stacked into one (C·(1 + P), P) batch, the engine runs once on it, the depths are
reduced to a (C, P) MSE block at once and dropped. Only the (N, P) MSE array is kept, so N = 10^6 runs
in bounded memory. Draws come from ``numpy.random.default_rng(seed)`` chunk after chunk in path order,
so the result does not depend on the chunk size.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from millstab.errors import InputError
from millstab.model import Cutting, Structure
from millstab.params import Parameterization
from millstab.sensitivity._core import (Progress, as_parameterization, centre, check_neighbourhood, check_scalar, depths,
                                        engine_module, mse_mm2, rows_per_call)
from millstab.sensitivity.results import MCResult
from millstab.stability.zoa import check_rpm

#: the paper's Algorithm 2 settings (tab:MC): N = 10 000 paths, t = 0.1, ε = 1 %
PAPER_N, PAPER_T, PAPER_EPS = 10_000, 0.1, 0.01


def check_seed(seed) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError("seed", seed, "must be a non-negative integer")
    return int(seed)


def monte_carlo(model: Structure | Parameterization, cutting: Cutting, rpm, n: int = PAPER_N, t: float = PAPER_T,
                eps: float = PAPER_EPS, seed: int = 0, *, theta: Sequence[float] | None = None, engine: str = "zoa",
                chunk_paths: int | None = None, progress: Progress | None = None) -> MCResult:
    """Monte Carlo sensitivity: per parameter the mean and SD of the MSE [mm²] after a (1 + ε) change,
    over N random centres drawn in the ±t neighbourhood of ``theta``.

    Args:
        model: a modal structure (all parameters vary) or a :class:`Parameterization`.
        cutting: cutting conditions; rpm: speeds of the SLD [rev/min].
        n: number of paths N (≥ 2). t: neighbourhood half-width, 0 ≤ t < 1. eps: relative change, > −1.
        seed: seed of the numpy Generator; the same seed gives the same table.
        theta: centre (P,) [SI], default the structure's values.
        engine: ``zoa``, ``sdm`` or ``spectral``.
        chunk_paths: paths per engine call (default: a ~32 MB depth block); does not change the result.
        progress: called as ``progress(paths_done, n)`` after each chunk.

    Raises:
        InputError: bad n/t/eps/seed, or a corner (1 ± t)(1 + ε)p outside the valid range (ζ ≥ 1, …),
            checked before any work.
    """
    par = as_parameterization(model)
    th = centre(par, theta)
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise InputError("n", n, "number of Monte Carlo paths must be an integer >= 2")
    n = int(n)
    t = check_scalar("t", t, 0.0, 1.0, "neighbourhood half-width t must be in [0, 1)", lo_open=False)
    eps = check_scalar("eps", eps, -1.0, np.inf, "perturbation must be finite and > -1")
    seed = check_seed(seed)
    check_neighbourhood(par, th, t, eps)
    r = check_rpm(rpm)
    eng = engine_module(engine)
    n_p = par.size
    per = 1 + n_p
    if chunk_paths is None:
        chunk_paths = max(1, rows_per_call(r.size, eng) // per)
    elif isinstance(chunk_paths, bool) or not isinstance(chunk_paths, (int, np.integer)) or chunk_paths < 1:
        raise InputError("chunk_paths", chunk_paths, "must be a positive integer")
    rng = np.random.default_rng(seed)
    mse = np.empty((n, n_p))
    # the (1 + ε) factor sits on the diagonal of rows 1..P of each path's block
    factor = np.ones((per, n_p))
    factor[1:][np.diag_indices(n_p)] = 1.0 + eps
    for start in range(0, n, chunk_paths):
        c = min(chunk_paths, n - start)
        # uniform in [(1 − t)p, (1 + t)p]; drawn chunk by chunk, the stream is the same for any chunk size
        star = th * (1.0 + t * (2.0 * rng.random((c, n_p)) - 1.0))
        rows = (star[:, None, :] * factor[None, :, :]).reshape(c * per, n_p)
        d = depths(eng, par, rows, cutting, r).reshape(c, per, r.size)
        mse[start:start + c] = mse_mm2(d[:, :1, :], d[:, 1:, :])  # (c, P) [mm²]; the depths are dropped
        if progress:
            progress(start + c, n)
    if not np.isfinite(mse).all():
        # modal two-direction structures always have a finite limit; a rigid direction might not
        j = int(np.argwhere(~np.isfinite(mse))[0, 1])
        raise InputError("rpm", f"{r.min():g}..{r.max():g}", f"some SLDs have no finite limit (MSE of {par.free[j]} "
                         "is not finite); choose speeds where every structure has a chatter boundary")
    return MCResult(par.free, th, t, eps, seed, n, r, mse, engine)
