"""Global sensitivity of the SLD: Sobol indices (first and total order) and Morris screening (SALib).

Inputs are uniform on ranges [(1 − t)p, (1 + t)p] around the centre (or user bounds). Outputs:

* ``mse`` -- the SLD's MSE [mm²] against the nominal SLD (the centre's), over the speeds;
* ``minimum`` -- the envelope minimum min_Ω b_lim [mm];
* ``blim`` -- b_lim [mm] at each speed (Sobol only), i.e. indices against spindle speed.

Sampling: SALib's Sobol-sequence Saltelli design (``SALib.sample.sobol``, N·(P + 2) structures, no
second order) and Morris trajectories (``SALib.sample.morris``). Analysis: ``SALib.analyze.sobol`` and
``SALib.analyze.morris`` for the scalar outputs. For b_lim at S speeds the same estimators (Saltelli
2010 first order, Jansen total order, bootstrap confidence half-widths with the same resample indices)
are applied to all speeds at once by :func:`sobol_indices`, which reproduces ``SALib.analyze.sobol``
exactly for a single output (tested) while avoiding S separate calls.
"""

from __future__ import annotations

import warnings
from typing import Callable, Sequence

import numpy as np
from scipy.stats import norm

from millstab import bounds as _bounds
from millstab.errors import InputError
from millstab.model import Cutting, Structure
from millstab.params import Parameterization
from millstab.progress import CountProgress
from millstab.sensitivity._core import (as_parameterization, bounds_from, centre, check_scalar,
                                        depths_chunked, engine_module, mse_mm2, pin)
from millstab.sensitivity.montecarlo import check_seed
from millstab.sensitivity.results import MorrisResult, SobolResult
from millstab.stability import check_rpm

#: speeds per block in the vectorized bootstrap: bounds its (N, R, block) arrays to a few tens of MB
_SPEED_BLOCK = 8


def problem(names: Sequence[str], bounds: np.ndarray) -> dict:
    """A SALib problem dict for uniform inputs."""
    return {"num_vars": len(names), "names": list(names), "bounds": np.asarray(bounds, float).tolist()}


def _bootstrap_seed(seed: int) -> int:
    # SALib.analyze.sobol ignores a seed of 0 (``if seed:``) and then draws from the global state;
    # shifting by one keeps every seed, 0 included, reproducible
    return seed + 1


def check_power_of_two(n, field: str = "n") -> int:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2 or (int(n) & (int(n) - 1)):
        raise InputError(field, n, "Sobol base sample size must be a power of 2 >= 2 (e.g. 256, 1024, 4096)")
    return int(n)


def sobol_sample(prob: dict, n: int, seed: int) -> np.ndarray:
    """Saltelli design from a scrambled Sobol sequence: (n·(P + 2), P) rows (no second order)."""
    from SALib.sample import sobol as ss

    return ss.sample(prob, check_power_of_two(n), calc_second_order=False, scramble=True, seed=seed)


def _split(Y: np.ndarray, d: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    step = d + 2
    return Y[0::step], Y[step - 1::step], np.stack([Y[j + 1::step] for j in range(d)], axis=1)


def _first(A, ABj, B):
    v = np.var(np.concatenate([A, B], axis=0), axis=0)
    return np.divide(np.mean(B * (ABj - A), axis=0), v, out=np.zeros_like(v), where=v > np.finfo(float).eps)


def _total(A, ABj, B):
    v = np.var(np.concatenate([A, B], axis=0), axis=0)
    return np.divide(0.5 * np.mean((A - ABj) ** 2, axis=0), v, out=np.zeros_like(v), where=v > np.finfo(float).eps)


def sobol_indices(n_vars: int, Y: np.ndarray, seed: int, num_resamples: int = 100,
                  conf_level: float = 0.95) -> dict[str, np.ndarray]:
    """First/total-order indices of every output column of a Saltelli-design result, vectorized.

    The estimators, the standardization of Y, the bootstrap indices (``default_rng(seed + 1)``) and
    the half-widths Z·std are those of ``SALib.analyze.sobol.analyze(..., seed=seed + 1)``.

    Args:
        n_vars: P; Y: outputs (n·(P + 2),) or (n·(P + 2), K) in design row order.
    Returns:
        {S1, S1_conf, ST, ST_conf}, each (P,) for 1-D Y or (K, P) for 2-D Y.
    """
    Y = np.asarray(Y, float)
    one = Y.ndim == 1
    Y2 = Y[:, None] if one else Y
    if Y2.shape[0] % (n_vars + 2):
        raise InputError("Y", Y.shape, f"rows must be a multiple of P + 2 = {n_vars + 2} (Saltelli design)")
    n = Y2.shape[0] // (n_vars + 2)
    sd = Y2.std(axis=0)
    Ys = np.divide(Y2 - Y2.mean(axis=0), sd, out=np.zeros_like(Y2), where=sd > 0)  # constant output: indices 0
    A, B, AB = _split(Ys, n_vars)
    r = np.random.default_rng(_bootstrap_seed(seed)).integers(n, size=(n, num_resamples))
    z = norm.ppf(0.5 + conf_level / 2)
    k = Y2.shape[1]
    out = {key: np.zeros((k, n_vars)) for key in ("S1", "S1_conf", "ST", "ST_conf")}
    for j in range(n_vars):
        out["S1"][:, j] = _first(A, AB[:, j], B)
        out["ST"][:, j] = _total(A, AB[:, j], B)
    for lo in range(0, k, _SPEED_BLOCK):
        cols = slice(lo, min(k, lo + _SPEED_BLOCK))
        Ar, Br = A[r, cols], B[r, cols]  # (n, R, block)
        spread = np.ptp(np.concatenate([Ar, Br], axis=0), axis=(0, 1)) != 0
        for j in range(n_vars):
            ABr = AB[:, j, cols][r]
            out["S1_conf"][cols, j] = np.where(spread, z * _first(Ar, ABr, Br).std(axis=0, ddof=1), 0.0)
            out["ST_conf"][cols, j] = np.where(spread, z * _total(Ar, ABr, Br).std(axis=0, ddof=1), 0.0)
    return {key: v[0] for key, v in out.items()} if one else out


def salib_sobol(prob: dict, Y: np.ndarray, seed: int, num_resamples: int = 100,
                conf_level: float = 0.95) -> dict[str, np.ndarray]:
    """``SALib.analyze.sobol.analyze`` of one output (first and total order), as arrays (P,)."""
    from SALib.analyze import sobol as sa

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # SALib warns on constant output; indices are then 0
        res = sa.analyze(prob, np.asarray(Y, float), calc_second_order=False, num_resamples=num_resamples,
                         conf_level=conf_level, seed=_bootstrap_seed(seed))
    return {key: np.asarray(res[key], float) for key in ("S1", "S1_conf", "ST", "ST_conf")}


def sobol_function(func: Callable[[np.ndarray], np.ndarray], names: Sequence[str], bounds: np.ndarray, n: int = 1024,
                   seed: int = 0, num_resamples: int = 100, conf_level: float = 0.95) -> dict[str, np.ndarray]:
    """Sobol indices of any vectorized ``func(X (R, P)) -> (R,)`` over uniform ``bounds`` (P, 2): the
    same sampling and analysis path as :func:`sobol` (used to test it on functions with known indices)."""
    prob = problem(names, bounds)
    X = sobol_sample(prob, n, seed)
    return salib_sobol(prob, np.asarray(func(X), float), seed, num_resamples, conf_level)


def _prepare(model, cutting, rpm, t, bounds, seed, theta, engine, client=None):
    if client is not None:  # a wrong client fails before any work
        from millstab.cluster import check_client

        check_client(client)
    par = as_parameterization(model)
    th = centre(par, theta)
    seed = check_seed(seed)
    t = check_scalar("t", t, 0.0, 1.0, "neighbourhood half-width t must be in [0, 1)", lo_open=False)
    bnds = bounds_from(par, th, t, bounds)
    r = check_rpm(rpm)
    eng = engine_module(engine)
    f = pin(eng, par, cutting, r, np.vstack([th, bnds[:, 1]]), at=th)  # the centre, then the box's upper corner
    return par, th, seed, bnds, r, f, f(th[None, :])


def sobol(model: Structure | Parameterization, cutting: Cutting, rpm, n: int = 1024, t: float = 0.1,
          bounds: dict[str, tuple[float, float]] | None = None, seed: int = 0, *, theta: Sequence[float] | None = None,
          engine: str = "zoa", num_resamples: int = 100, conf_level: float = 0.95,
          progress: CountProgress | None = None, client=None, chunk_rows: int | None = None) -> SobolResult:
    """First- and total-order Sobol indices of the SLD's MSE [mm²], the envelope minimum [mm] and b_lim
    at each speed [mm], for uniform inputs in the ±t neighbourhood of the centre (or ``bounds``).

    Args:
        n: SALib base sample size, a power of 2; the engine evaluates n·(P + 2) structures.
        bounds: {name: (lower, upper)} [SI] replacing the ±t range for the parameters named.
        progress: ``progress(rows_done, rows_total)`` after each engine chunk.
        client: a ``distributed.Client``: the structures are evaluated on its Dask cluster (same numbers,
            bit for bit: every row is evaluated alone and the design is drawn here); None: in this process.
        chunk_rows: rows per engine call / cluster task (default: the engine's chunk; on a cluster ~2 s
            of work); does not change the result.
    """
    n = check_power_of_two(n)
    conf_level = check_scalar("conf_level", conf_level, 0.0, 1.0, "confidence level must be in (0, 1)")
    par, th, seed, bnds, r, f, nominal = _prepare(model, cutting, rpm, t, bounds, seed, theta, engine, client)
    # what is held at once [bytes]: per design row the design (P) and five (rows, S) arrays (the depths, in mm,
    # and the temporaries of their MSE or their standardized copy), and sobol_indices' five (n, resamples, speed
    # block) bootstrap arrays (measured: n 4 096 at 201 speeds, 0.46 GB over the interpreter; this says 0.40)
    per_n = 8 * ((par.size + 2) * (par.size + 5 * r.size) + 5 * int(num_resamples) * _SPEED_BLOCK)
    largest = 2 ** max(1, int(np.floor(np.log2(max(2.0, _bounds.memory_room(per_n))))))
    _bounds.check_memory("n", n, n * per_n, f"{n * (par.size + 2):,} structures x {r.size} speeds", largest)
    prob = problem(par.free, bnds)
    X = sobol_sample(prob, n, seed)
    d = depths_chunked(f, X, progress, client, chunk_rows)
    if not np.isfinite(d).all():
        raise InputError("rpm", f"{r.min():g}..{r.max():g}", "some sampled SLDs have no finite limit there; "
                         "choose speeds where every structure has a chatter boundary")
    mse = mse_mm2(nominal, d)
    b_mm = d * 1e3
    res_mse = salib_sobol(prob, mse, seed, num_resamples, conf_level)
    res_min = salib_sobol(prob, b_mm.min(axis=1), seed, num_resamples, conf_level)
    res_b = sobol_indices(par.size, b_mm, seed, num_resamples, conf_level)
    return SobolResult(par.free, bnds, n, seed, r, nominal[0] * 1e3, res_mse, res_min, res_b, conf_level, engine)


def morris(model: Structure | Parameterization, cutting: Cutting, rpm, trajectories: int = 50, levels: int = 4,
           t: float = 0.1, bounds: dict[str, tuple[float, float]] | None = None, seed: int = 0, *,
           theta: Sequence[float] | None = None, engine: str = "zoa", num_resamples: int = 100,
           conf_level: float = 0.95, progress: CountProgress | None = None, client=None,
           chunk_rows: int | None = None) -> MorrisResult:
    """Morris screening (elementary effects; a cheap preview of Sobol): μ, μ*, σ and μ*'s confidence
    half-width for the SLD's MSE [mm²] against the nominal and the envelope minimum [mm].

    Args:
        trajectories: number of Morris trajectories r (≥ 2); the engine evaluates r·(P + 1) structures.
        levels: grid levels p (even, ≥ 2).
        client, chunk_rows: as :func:`sobol` (a Dask cluster evaluates the structures; same numbers).
    """
    from SALib.analyze import morris as ma
    from SALib.sample import morris as ms

    if isinstance(trajectories, bool) or not isinstance(trajectories, (int, np.integer)) or trajectories < 2:
        raise InputError("n", trajectories, "number of Morris trajectories must be an integer >= 2")
    if isinstance(levels, bool) or not isinstance(levels, (int, np.integer)) or levels < 2 or levels % 2:
        raise InputError("levels", levels, "number of Morris levels must be an even integer >= 2")
    par, th, seed, bnds, r, f, nominal = _prepare(model, cutting, rpm, t, bounds, seed, theta, engine, client)
    per_r = 8 * (par.size + 1) * (par.size + 5 * r.size)  # [bytes] per trajectory: as sobol's design rows
    largest = max(2, int(_bounds.memory_room(per_r)))
    _bounds.check_memory("n", trajectories, trajectories * per_r,
                 f"{trajectories * (par.size + 1):,} structures x {r.size} speeds", largest)
    prob = problem(par.free, bnds)
    X = ms.sample(prob, int(trajectories), num_levels=int(levels), seed=seed)
    d = depths_chunked(f, X, progress, client, chunk_rows)
    if not np.isfinite(d).all():
        raise InputError("rpm", f"{r.min():g}..{r.max():g}", "some sampled SLDs have no finite limit there")
    outs = {}
    for name, y in (("mse", mse_mm2(nominal, d)), ("minimum", d.min(axis=1) * 1e3)):
        res = ma.analyze(prob, X, y, num_resamples=num_resamples, conf_level=conf_level, num_levels=int(levels),
                         seed=seed)
        outs[name] = {key: np.asarray(res[key], float) for key in ("mu", "mu_star", "sigma", "mu_star_conf")}
    return MorrisResult(par.free, bnds, int(trajectories), int(levels), seed, r, outs, engine)
