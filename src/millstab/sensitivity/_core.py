"""Shared pieces of the sensitivity studies: parameterization, range checks, MSE, chunked engine calls.

Units: parameters in SI (fn [Hz], k [N/m], ζ [-]); spindle speeds [rev/min]; depths from the engine
in m; every MSE here is in **mm²** (depths converted to mm before squaring), as in the seed paper.
"""

from __future__ import annotations

import warnings
from typing import Sequence

import numpy as np

from millstab.errors import InputError, UnitWarning
from millstab.progress import CountProgress
from millstab.forward import Pinned, forward
from millstab.model import Cutting, Structure
from millstab.params import Parameterization

#: default one-at-a-time grid: −0.25 … +0.25 step 0.05 (the issue's default)
DEFAULT_EPS_GRID = np.round(np.arange(-0.25, 0.25 + 1e-9, 0.05), 10) + 0.0  # + 0.0: no −0.0 in the grid
#: the seed paper's Algorithm 1 grid: −0.20 … +0.20 step 0.05
PAPER_EPS_GRID = np.round(np.arange(-0.20, 0.20 + 1e-9, 0.05), 10) + 0.0



def as_parameterization(model: Structure | Parameterization) -> Parameterization:
    """Every modal parameter free (``fn_x, k_x, zeta_x, fn_y, k_y, zeta_y`` for one mode per
    direction) unless a :class:`Parameterization` is given."""
    if isinstance(model, Parameterization):
        return model
    if isinstance(model, Structure):
        return Parameterization(model)
    raise InputError("structure", type(model).__name__, "need a modal Structure or a Parameterization")


def centre(par: Parameterization, theta: Sequence[float] | None) -> np.ndarray:
    """The parameter vector the study is centred on (P,) [SI]; θ0 of ``par`` when ``theta`` is None."""
    if theta is None:
        return par.theta0.copy()
    th = np.asarray(theta, dtype=float)
    if th.shape != (par.size,):
        raise InputError("theta", th.shape, f"need {par.size} values ({', '.join(par.free)})")
    _check_values(par, th[None, :], "theta")
    return th


def _allowed(kind: str) -> tuple[float, float, str]:
    if kind == "zeta":
        return 0.0, 1.0, "damping ratio must stay in (0, 1)"
    unit = "Hz" if kind == "fn" else "N/m"
    return 0.0, np.inf, f"must stay > 0 {unit}"


def _check_values(par: Parameterization, values: np.ndarray, what: str) -> None:
    """Raise InputError when any column of ``values`` (R, P) leaves its parameter's valid range."""
    for j, name in enumerate(par.free):
        lo, hi, allowed = _allowed(par.kind(name))
        col = values[:, j]
        bad = ~np.isfinite(col) | (col <= lo) | (col >= hi)
        if bad.any():
            raise InputError(f"{what}.{name}", float(col[bad][0]), allowed)


def check_scalar(field: str, value: float, lo: float, hi: float, allowed: str, lo_open: bool = True,
                 hi_open: bool = True) -> float:
    """A finite float inside (lo, hi) (ends open or closed as told), else InputError(field, value, allowed)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(field, value, allowed) from None
    ok = np.isfinite(v) and (v > lo if lo_open else v >= lo) and (v < hi if hi_open else v <= hi)
    if not ok:
        raise InputError(field, value, allowed)
    return v


def check_neighbourhood(par: Parameterization, theta: np.ndarray, t: float, eps: Sequence[float] | float) -> None:
    """Reject, before any work, a study whose draws could leave a parameter's valid range.

    Every value a study can produce lies in [(1 − t)·min(1, 1 + ε)·p, (1 + t)·max(1, 1 + ε)·p]; the
    corners are checked analytically (fn, k > 0; 0 < ζ < 1), so no NaN can appear mid-run.

    Raises:
        InputError: naming ``t`` or ``eps``, the parameter and the offending corner value.
    """
    t = check_scalar("t", t, 0.0, 1.0, "neighbourhood half-width t must be in [0, 1)", lo_open=False)
    e = np.atleast_1d(np.asarray(eps, dtype=float))
    if e.size == 0 or not np.isfinite(e).all() or (e <= -1).any():
        raise InputError("eps", eps, "perturbations must be finite and > -1 (a factor 1 + eps > 0)")
    f_lo = (1 - t) * min(1.0, 1.0 + e.min())
    f_hi = (1 + t) * max(1.0, 1.0 + e.max())
    for j, name in enumerate(par.free):
        lo, hi, allowed = _allowed(par.kind(name))
        for f, f_t, e_end in ((f_lo, 1 - t, e.min()), (f_hi, 1 + t, e.max())):
            v = f * theta[j]
            if not (lo < v < hi):
                # blame t when the neighbourhood alone already leaves the range, else the perturbation
                field, value = ("t", t) if not (lo < f_t * theta[j] < hi) else ("eps", float(e_end))
                raise InputError(field, value, f"{name} would reach {v:.6g} (= {theta[j]:.6g} x {f:.6g}, "
                                 f"the corner (1 +/- t)(1 + eps)); {allowed}")


def warn_percent(field: str, eps: Sequence[float] | float) -> None:
    """Warn (:class:`~millstab.errors.UnitWarning`) when a relative change is ±100 % or more: allowed (a factor
    1 + ε > 0), but almost surely a percentage typed as a fraction (``--eps 1`` meant as the paper's 1 %, a grid
    ``0:20:5`` meant in %), which scales a parameter by 2 (or 21) without a word."""
    e = np.atleast_1d(np.asarray(eps, dtype=float))
    big = e[np.abs(e) >= 1]
    if big.size:
        v = float(big[np.argmax(np.abs(big))])
        warnings.warn(f"{field} = {v:g} is a relative change of {v * 100:+g} % (parameter x {1 + v:g}); changes are "
                      f"fractions (0.01 is 1 %): did you mean {v / 100:g} ({v:g} %)?", UnitWarning, stacklevel=3)


def bounds_from(par: Parameterization, theta: np.ndarray, t: float,
                bounds: dict[str, tuple[float, float]] | None = None) -> np.ndarray:
    """Input ranges (P, 2) [SI] for global methods: [(1 − t)p, (1 + t)p], or user bounds by name.

    User bounds replace the ±t range for the parameters they name; every range must satisfy
    lower < upper and stay valid (fn, k > 0; 0 < ζ < 1).
    """
    check_neighbourhood(par, theta, t, 0.0)
    out = np.column_stack([(1 - t) * theta, (1 + t) * theta])
    for name, lohi in (bounds or {}).items():
        try:
            c = par.canonical(name)
        except InputError as exc:  # say which input held the name (the parameterization calls it "parameter")
            raise InputError("bounds", name, exc.allowed) from None
        if c not in par.free:
            raise InputError("bounds", name, f"not a free parameter; free: {', '.join(par.free)}")
        try:
            lo, hi = (float(v) for v in lohi)
        except (TypeError, ValueError):
            raise InputError(f"bounds.{name}", lohi, "need (lower, upper)") from None
        if not lo < hi:
            raise InputError(f"bounds.{name}", (lo, hi), "need lower < upper")
        out[par.free.index(c)] = lo, hi
    if (out[:, 0] == out[:, 1]).any():
        j = int(np.argmax(out[:, 0] == out[:, 1]))
        raise InputError("t", t, f"{par.free[j]} has an empty range; need t > 0 or bounds for it")
    _check_values(par, out.T.copy(), "bounds")
    return out


def mse_mm2(ref_m: np.ndarray, other_m: np.ndarray) -> np.ndarray:
    """Mean over speeds (last axis) of the squared depth difference, in mm² (depths given in m).

    Where both depths are +inf (no chatter boundary) the difference counts as 0; where only one is,
    the MSE is inf (the boundary appeared or vanished).
    """
    a, b = np.asarray(ref_m), np.asarray(other_m)
    with np.errstate(invalid="ignore"):  # inf − inf is resolved just below
        d = (a - b) * 1e3
    if not (np.isfinite(a).all() and np.isfinite(b).all()):
        d = np.where(np.isinf(a) & (a == b), 0.0, d)
    return np.mean(d * d, axis=-1)


def rows_per_call(n_speeds: int, engine: str = "zoa") -> int:
    """Engine rows per call: the named engine's own chunk size (its ``chunk_rows``), so one call's (rows, S)
    outputs stay bounded (~100 MB) whatever the number of speeds."""
    from millstab.stability import get_engine

    return get_engine(engine).chunk_rows(n_speeds)


def engine_module(name: str) -> str:
    """The engine name, validated now (an unknown name fails before any work); the studies pass it to
    :func:`depths`, which evaluates through the one forward model :func:`millstab.forward.forward`."""
    from millstab.stability import get_engine

    get_engine(name)
    return name


def depths(engine: str, par: Parameterization, theta_rows: np.ndarray, cutting: Cutting, rpm: np.ndarray) -> np.ndarray:
    """Limiting depths (R, S) [m] of R parameter rows: ONE batched engine call."""
    return forward(par, cutting, engine)(theta_rows, rpm)


def pin(engine: str, par: Parameterization, cutting: Cutting, rpm: np.ndarray, bounding_rows: np.ndarray, *,
        at: np.ndarray) -> Pinned:
    """A study's forward model at the speeds ``rpm`` with the engine's discretisation pinned for the whole
    study (:meth:`millstab.forward.Forward.pinned`): ``at`` (P,) [SI] is the centre (spectral chooses
    there) and ``bounding_rows`` (K, P) [SI] rows that bound every row the study will evaluate (sdm's steps follow the
    highest natural frequency). Then neither the chunks nor a cluster change a number."""
    return forward(par, cutting, engine).pinned(rpm, bounding_rows, at=at)


def depths_chunked(f: Pinned, theta_rows: np.ndarray, progress: CountProgress | None = None, client=None,
                   chunk_rows: int | None = None) -> np.ndarray:
    """Depths (R, S) [m] for many rows through the pinned model ``f`` (:func:`pin`), one engine call per chunk
    of ``chunk_rows`` rows (default the engine's chunk; progress in rows); with ``client`` (a
    ``distributed.Client``) the chunks are tasks on its Dask cluster (:func:`millstab.cluster.depths`).
    The discretisation is pinned and every row is evaluated alone, so neither the chunk size nor the
    cluster changes a number."""
    if chunk_rows is not None and (isinstance(chunk_rows, bool) or not isinstance(chunk_rows, (int, np.integer))
                                   or chunk_rows < 1):
        raise InputError("chunk_rows", chunk_rows, "must be a positive integer")
    if client is not None:  # the tasks call the same pinned model (the forward layer imports no cluster)
        from millstab.cluster import map_pinned

        return map_pinned(client, f, theta_rows, progress, chunk_rows)
    return f.map(theta_rows, chunk_rows=chunk_rows, progress=progress)
