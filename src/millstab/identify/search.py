"""Search tools shared by the solvers (:mod:`~millstab.identify.lsq`, :mod:`~millstab.identify.newton`):
the search box around a start, scrambled-Sobol designs in it and picking distinct low-cost candidates.
Everything works in log-parameters u = ln θ.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import qmc

#: default search box half-widths (multiplicative) around the start, per parameter kind
SEARCH = {"fn": 1.5, "k": 2.5, "zeta": 2.5}


def search_box(problem, u0: np.ndarray, search: dict[str, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The screening box in log-parameters: start ×/÷ SEARCH[kind] (``search`` overrides), inside the bounds."""
    s = {**SEARCH, **(search or {})}
    half = np.log([s[problem.par.kind(n)] for n in problem.par.free])
    lo, hi = np.log(problem.par.lower), np.log(problem.par.upper)
    return np.maximum(lo, u0 - half), np.minimum(hi, u0 + half)


def sobol(p: int, n: int, seed) -> np.ndarray:
    """The first ``n`` points (n, p) in [0, 1)^p of a scrambled Sobol sequence (seeded; drawn as the
    smallest power of two ≥ n, at least 2, as Sobol balance wants)."""
    m = max(1, int(np.ceil(np.log2(max(n, 2)))))
    return qmc.Sobol(p, scramble=True, seed=seed).random_base2(m)[:n]


def pick_distinct(u: np.ndarray, cost: np.ndarray, k: int, min_dist: float, perm=None) -> np.ndarray:
    """Indices of the k lowest-cost rows whose log-distance (max-norm, up to x↔y swap) to every already
    picked row exceeds ``min_dist``."""
    order = np.argsort(cost, kind="stable")
    picked: list[int] = []
    for i in order:
        if not np.isfinite(cost[i]):
            break
        d_ok = True
        for j in picked:
            d = np.abs(u[i] - u[j]).max()
            if perm is not None:
                d = min(d, np.abs(u[i][perm] - u[j]).max())
            if d < min_dist:
                d_ok = False
                break
        if d_ok:
            picked.append(int(i))
            if len(picked) == k:
                break
    return np.array(picked, dtype=int)


def options_with(options, cls: type, tuning: dict, caller: str):
    """``options`` (default ``cls()``) with the fields named in ``tuning`` replaced; TypeError naming
    ``caller`` for a keyword that is no field (as a misspelt keyword argument always was)."""
    import dataclasses

    names = {f.name for f in dataclasses.fields(cls)}
    for key in tuning:
        if key not in names:
            raise TypeError(f"{caller}() got an unexpected keyword argument {key!r}")
    base = cls() if options is None else options
    return dataclasses.replace(base, **tuning) if tuning else base


__all__ = ["SEARCH", "options_with", "pick_distinct", "search_box", "sobol"]
