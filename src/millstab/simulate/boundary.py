"""The stability boundary of the simulation itself, for validation against the SLD engines.

At small vibration (no tooth leaves the cut) the simulation is linear about the forced periodic
motion, and the tooth-to-tooth changes of the once-per-tooth samples grow or decay with the dominant
Floquet multiplier μ of the simulation. :func:`simulated_limit` bisects the depth on |μ| − 1, μ fitted
by :func:`millstab.simulate.detect.growth_multiplier` to a cut started on the forced motion with a
bump of 1e-4 f_t; the fit uses the samples before the tooth-to-tooth change first exceeds 1 % of f_t,
far below the chip thickness.
"""

from __future__ import annotations

import math

import numpy as np

from millstab.errors import InputError
from millstab.model import Cutting, Structure
from millstab.simulate import simulate_cut
from millstab.simulate.detect import growth_multiplier

#: initial bump in units of the feed per tooth (keeps the run linear)
SMALL = 1e-4
#: tooth-to-tooth changes beyond this share of the feed are left out of the fit (still linear)
LINEAR = 1e-2
#: feed per tooth used for the linear runs [m] (the linear boundary does not depend on it)
FEED = 1e-4


def multiplier(structure: Structure, cutting: Cutting, rpm: float, depth: float, periods: int = 400,
               steps_per_tooth: int | None = None) -> complex:
    """Dominant multiplier of the simulated once-per-tooth map at depth [m] (linear regime)."""
    res = simulate_cut(structure, cutting, rpm, depth, FEED, revs=periods / cutting.teeth,
                       steps_per_tooth=steps_per_tooth, start="steady", perturbation=SMALL)
    if res.diverged:
        return complex(math.inf, 0.0)
    try:
        return growth_multiplier(res, max_level=LINEAR * FEED)
    except ValueError:
        # so few periods below the level that the growth is fast: its mean rate is enough here
        d = np.abs(np.diff(res.once_x)) + np.abs(np.diff(res.once_y))
        i = int(np.argmax(d > LINEAR * FEED))
        return complex((d[i] / d[0]) ** (1.0 / max(i, 1)), 0.0)


def simulated_limit(structure: Structure, cutting: Cutting, rpm: float, lo: float, hi: float, rtol: float = 1e-3,
                    periods: int = 400, steps_per_tooth: int | None = None) -> tuple[float, complex]:
    """Depth [m] where |μ| of the simulation crosses 1, by bisection in [lo, hi] (|μ(lo)| < 1 < |μ(hi)|).

    Returns (depth, μ at the unstable end of the final bracket).
    Raises:
        InputError: the bracket does not enclose a crossing.
    """
    mu_lo = multiplier(structure, cutting, rpm, lo, periods, steps_per_tooth)
    mu_hi = multiplier(structure, cutting, rpm, hi, periods, steps_per_tooth)
    if not (abs(mu_lo) < 1.0 < abs(mu_hi)):
        raise InputError("bracket", (lo, hi),
                         f"|mu| = {abs(mu_lo):.5f}, {abs(mu_hi):.5f}: need |mu(lo)| < 1 < |mu(hi)|")
    while hi - lo > rtol * hi:
        mid = 0.5 * (lo + hi)
        mu = multiplier(structure, cutting, rpm, mid, periods, steps_per_tooth)
        if abs(mu) > 1.0:
            hi, mu_hi = mid, mu
        else:
            lo = mid
    return 0.5 * (lo + hi), mu_hi
