"""Monte Carlo sensitivity of the SLD (the seed paper's Algorithm 2, Table 6).

N paths; each draws every parameter uniformly in [(1 − t)p, (1 + t)p], makes that path's SLD, then
scales each parameter in turn by (1 + ε) and records MSE = mean_i (b*_i − b'_i)² in **mm²**. Mean and
population SD (1/N, as the paper's Algorithm 2) per parameter, plus the standard error of the mean.

No Python loop over paths: for a chunk of C paths the (1 + P) rows per path (the reference and the P
perturbed sets) are stacked into one (C·(1 + P), P) batch, the engine runs once on it, the depths are
reduced to a (C, P) MSE block at once and dropped. Only the (N, P) MSE array is kept, so N = 10^6 runs
in bounded memory. The draws are those of ``numpy.random.default_rng(seed).random((N, P))``, row k for
path k, each block of paths jumping straight to its first row (PCG64 ``advance``), so the result does not
depend on the chunk size nor on where the blocks run: with ``client=`` (a ``distributed.Client``) the
blocks are tasks on a Dask cluster (:mod:`millstab.cluster`) and the table is the same, bit for bit.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from millstab import bounds as _bounds
from millstab.errors import InputError
from millstab.model import Cutting, Structure
from millstab.params import Parameterization
from millstab.forward import Pinned, forward
from millstab.progress import CountProgress
from millstab.sensitivity._core import (as_parameterization, centre, check_neighbourhood,
                                        check_scalar, engine_module, mse_mm2, pin, rows_per_call, warn_percent)
from millstab.sensitivity.results import MCResult
from millstab.stability import check_rpm

#: the paper's Algorithm 2 settings (tab:MC): N = 10 000 paths, t = 0.1, ε = 1 %
PAPER_N, PAPER_T, PAPER_EPS = 10_000, 0.1, 0.01


def check_seed(seed) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError("seed", seed, "must be a non-negative integer")
    return int(seed)


def monte_carlo(model: Structure | Parameterization, cutting: Cutting, rpm, n: int = PAPER_N, t: float = PAPER_T,
                eps: float = PAPER_EPS, seed: int = 0, *, theta: Sequence[float] | None = None, engine: str = "zoa",
                chunk_paths: int | None = None, progress: CountProgress | None = None, client=None) -> MCResult:
    """Monte Carlo sensitivity: per parameter the mean and SD of the MSE [mm²] after a (1 + ε) change,
    over N random centres drawn in the ±t neighbourhood of ``theta``.

    Args:
        model: a modal structure (all parameters vary) or a :class:`Parameterization`.
        cutting: cutting conditions; rpm: speeds of the SLD [rev/min].
        n: number of paths N (≥ 2). t: neighbourhood half-width, 0 ≤ t < 1. eps: relative change, > −1.
        seed: seed of the numpy Generator; the same seed gives the same table.
        theta: centre (P,) [SI], default the structure's values.
        engine: ``zoa``, ``sdm`` or ``spectral``.
        chunk_paths: paths per engine call, or per cluster task with ``client`` (default: the engine's chunk;
            on a cluster ~2 s of work, timed on the workers); does not change the result.
        progress: called as ``progress(paths_done, n)`` after each chunk (with ``client``: as results arrive).
        client: a ``distributed.Client``: run the blocks on its Dask cluster (same numbers); None: here.

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
    if eps == 0:  # every path's change would be zero: an all-zero table and NaN ratios, not a study
        raise InputError("eps", eps, "a relative change of 0 changes nothing: give one such as 0.01 (1 %) or -0.01")
    seed = check_seed(seed)
    check_neighbourhood(par, th, t, eps)
    warn_percent("eps", eps)
    r = check_rpm(rpm)
    eng = engine_module(engine)
    n_p = par.size
    per = 1 + n_p
    if chunk_paths is not None and (isinstance(chunk_paths, bool) or not isinstance(chunk_paths, (int, np.integer))
                                    or chunk_paths < 1):
        raise InputError("chunk_paths", chunk_paths, "must be a positive integer")
    # every path's MSE (n, P) is kept, and the result's running statistics make three more such arrays
    per_path = 4 * 8 * n_p  # [bytes]
    _bounds.check_memory("n", n, n * per_path, f"{n:,} paths x {n_p} parameters, kept",
                         max(2, int(_bounds.memory_room(per_path))))
    mse = np.empty((n, n_p))
    # every row of every path lies in [(1 − t)p, (1 + t)(1 + ε⁺)p]: pin the discretisation on the centre and that
    # corner once, so the blocks (their size, where they run) change no number
    settings = dict(pin(eng, par, cutting, r, np.vstack([th, th * (1 + t) * max(1.0, 1.0 + eps)]), at=th).settings)
    spec = (eng, par, cutting, r, th, t, eps, seed, settings)
    if client is None:
        per_block = int(chunk_paths or max(1, rows_per_call(r.size, eng) // per))
        for start in range(0, n, per_block):
            c = min(per_block, n - start)
            mse[start:start + c] = _block(*spec, start, c)
            if progress:
                progress(start + c, n)
    else:
        _on_cluster(client, spec, mse, chunk_paths, progress)
    if not np.isfinite(mse).all():
        # modal two-direction structures always have a finite limit; a rigid direction might not
        j = int(np.argwhere(~np.isfinite(mse))[0, 1])
        raise InputError("rpm", f"{r.min():g}..{r.max():g}", f"some SLDs have no finite limit (MSE of {par.free[j]} "
                         "is not finite); choose speeds where every structure has a chatter boundary")
    return MCResult(par.free, th, t, eps, seed, n, r, mse, engine)


def draws(seed: int, start: int, count: int, n_p: int) -> np.ndarray:
    """Uniform [0, 1) draws (count, P) of paths ``start .. start + count − 1``: rows ``start:start + count``
    of ``default_rng(seed).random((N, P))``. PCG64 spends one 64-bit output per double, so advancing the
    generator by start·P outputs lands on path ``start``'s first draw (tested against the plain stream)."""
    bits = np.random.PCG64(seed)
    bits.advance(start * n_p)
    return np.random.Generator(bits).random((count, n_p))


def _block(engine: str, par: Parameterization, cutting: Cutting, rpm: np.ndarray, th: np.ndarray, t: float, eps: float,
           seed: int, settings: dict, start: int, count: int) -> np.ndarray:
    """MSE (count, P) [mm²] of paths ``start .. start + count − 1``: ONE engine call on their (1 + P) rows each,
    under the study's pinned discretisation ``settings``."""
    n_p = th.size
    per = 1 + n_p
    # the (1 + ε) factor sits on the diagonal of rows 1..P of each path's block
    factor = np.ones((per, n_p))
    factor[1:][np.diag_indices(n_p)] = 1.0 + eps
    # uniform in [(1 − t)p, (1 + t)p]
    star = th * (1.0 + t * (2.0 * draws(seed, start, count, n_p) - 1.0))
    rows = (star[:, None, :] * factor[None, :, :]).reshape(count * per, n_p)
    d = Pinned(forward(par, cutting, engine), rpm, settings)(rows).reshape(count, per, rpm.size)
    return mse_mm2(d[:, :1, :], d[:, 1:, :])  # (count, P) [mm²]; the depths are dropped here


def _task(*args) -> np.ndarray:
    """One block on a cluster worker (numba on one thread: the cluster is the parallelism)."""
    from millstab.cluster import one_thread

    one_thread()
    return _block(*args)


def _on_cluster(client, spec: tuple, mse: np.ndarray, chunk_paths: int | None, progress: CountProgress | None) -> None:
    """Fill ``mse`` (N, P) block by block from tasks on the client's cluster, as results arrive."""
    from millstab import cluster

    cluster.check_client(client)
    eng, par, cutting, r = spec[:4]
    n, n_p = mse.shape
    if chunk_paths is None:
        sec_per_row = cluster.warm(client, eng, par, cutting, r)
        chunk_paths = max(1, cluster.task_rows(sec_per_row, rows_per_call(r.size, eng)) // (1 + n_p))
    else:
        cluster.warm(client, eng, par, cutting, r)
    starts = range(0, n, int(chunk_paths))
    cluster.stream(client, _task, [(s, min(int(chunk_paths), n - s)) for s in starts],
                   cluster.rows_into(mse, starts, progress), common=spec, name="mc")
