"""One posterior over the holder serves every stickout (issue 30 item 4; docs/tooltip.md, "Into the Bayesian
loop").

A ``[tool]`` + ``[holder]`` config whose holder is given by modes (``[[holder.modes]]``) is updated over the
holder-face modes, not over the tip's: the prior's parameterization is a
:class:`~millstab.tooltip.param.TipParameterization` (θ = the holder modes' fn, k, ζ; the tool is the known
beam), the prior's medians are the config's holder modes and its ``[prior]`` table names the holder's
parameters (``fn``, ``k``, ``zeta``, ``fn2``, …; ``fn_x1``… for ``[holder.x]``/``[holder.y]``). Each cut may
carry its own stickout (:class:`~millstab.update.likelihood.Evidence` ``cut_stickout``): the likelihood
evaluates the cuts of each stickout with the tip at that stickout, one engine call per stickout
(:func:`~millstab.update.likelihood.stickout_groups`). A decision at another stickout (map, recommend,
predict) uses :func:`at_stickout`: the same samples of the holder, the tip at the new stickout.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from millstab.errors import InputError
from millstab.model import Cutting
from millstab.update.prior import Prior, make_prior


def over_holder(config) -> bool:
    """Whether ``config`` is updated over its holder: a ``[tool]`` + ``[holder]`` config whose holder (both
    directions) is given by modes."""
    from millstab.tooltip.holder import ModalHolder, XYHolder

    setup = getattr(config, "tooltip", None)
    if setup is None:
        return False
    h = setup[1]
    parts = (h.x, h.y) if isinstance(h, XYHolder) else (h,)
    return all(isinstance(p, ModalHolder) for p in parts)


def holder_prior(tool, holder, cutting: Cutting, table=None) -> Prior:
    """The prior over the holder-face modes of ``holder`` (medians) for ``tool`` (the tip at its stickout)
    and its ``[prior]`` ``table`` (:func:`~millstab.update.prior.make_prior`)."""
    from millstab.tooltip.param import TipParameterization

    par = TipParameterization.of(tool, holder)
    return make_prior(par.base, cutting, table, par=par)


def config_prior(config) -> Prior:
    """The prior of ``config``: over its holder when :func:`over_holder`, else over its tip modes."""
    if over_holder(config):
        tool, holder = config.tooltip
        return holder_prior(tool, holder, config.cutting, getattr(config, "prior", None))
    return make_prior(config.structure, config.cutting, getattr(config, "prior", None))


def not_over_holder(stickout_m) -> InputError:
    """The error for per-cut stickouts ``stickout_m`` [m] (NaN: none given) where the prior or posterior is over the
    tip's modes: the update, predictions and cross-validation refuse them alike, naming the column and its values."""
    so = np.asarray(stickout_m, dtype=float)
    mm = ", ".join(f"{v:g}" for v in np.unique(so[~np.isnan(so)]) * 1e3)
    return InputError("stickout_mm", f"{mm} mm", "per-cut stickouts need a prior over the holder: a config with [tool] "
                      "and [holder] given by modes ([[holder.modes]]); without the column every cut is at the "
                      "config's tip")


#: the longest stickout [mm] any door takes (the config's [tool] stickout: at most 1 m)
MAX_STICKOUT_MM = 1000.0


def check_stickout_mm(value, field: str, tool=None) -> float:
    """``value`` [mm] as a stickout of ``tool`` (a :class:`~millstab.tooltip.tool.Tool`; ``None``: unknown), else an
    InputError naming ``field``, the value and what is allowed: a number of mm > 0, at most
    :data:`MAX_STICKOUT_MM`, and no shorter than the tool's fluted length (a shorter one would hold the flutes in the
    holder: the beam model has no such tool, and a stickout under 1 mm is said to look like metres). Every door
    (``--stickout``, a ``stickout_mm`` cell of update's or predict's cuts, ``listen --stickout``) checks here, as the
    config refuses such a ``[tool]`` stickout."""
    try:
        mm = float(value)
    except (TypeError, ValueError):
        raise InputError(field, value, "a stickout in mm (holder face to tip), e.g. 45") from None
    fl = 1e3 * getattr(tool, "fluted_length", 0.0) if tool is not None else 0.0
    low = f"at least the tool's fluted length ({fl:g} mm)" if fl > 0 else "> 0"
    allowed = f"a stickout in mm (holder face to tip), {low} and at most {MAX_STICKOUT_MM:g}"
    if not (math.isfinite(mm) and mm > 0 and mm <= MAX_STICKOUT_MM and mm >= fl * (1 - 1e-9)):
        metres = math.isfinite(mm) and 0 < mm < 1  # no tool sticks out under 1 mm: metres written as mm
        raise InputError(field, value, allowed + (f"; {value} looks like metres: {mm * 1e3:g} mm?" if metres else ""))
    return mm


def check_stickouts_mm(values_mm, field: str, tool=None) -> None:
    """:func:`check_stickout_mm` on each given value of ``values_mm`` (n,) [mm] (NaN: the config's), the error
    naming the row: ``field`` with ``{row}`` (1 = the first) filled in."""
    for i, v in enumerate(np.asarray(values_mm, dtype=float)):
        if not np.isnan(v):
            check_stickout_mm(f"{v:g}", field.format(row=i + 1), tool)


def stickout_mm_of(obj) -> float | None:
    """The stickout [mm] a :class:`Prior` or posterior decides at (``None``: over the tip's modes, no stickout)."""
    prior = obj if isinstance(obj, Prior) else obj.prior
    at = getattr(prior.par, "stickout", None)
    return None if at is None or getattr(prior.par, "at", None) is None else float(at) * 1e3


def warn_outside_stickouts(post, stickout_mm: float, stacklevel: int = 2) -> None:
    """Warn when a decision's stickout ``stickout_mm`` [mm] lies more than 10 % beyond the stickouts the posterior's
    cuts were made at (an empty cell: the config's): decisions there lean on the holder model and the prior. The
    mirror of :func:`millstab.update.decide.warn_outside` for the speed range."""
    from millstab.warnlog import warn

    own = stickout_mm_of(post)
    cells = (getattr(post, "cuts", None) or {}).get("stickout_mm")
    n = len((getattr(post, "cuts", None) or {}).get("rpm") or [])
    if own is None or not n:
        return
    cut = np.array([own if c is None else float(c) for c in (cells or [None] * n)], dtype=float)
    lo, hi = float(cut.min()), float(cut.max())
    if stickout_mm < lo / 1.1 or stickout_mm > 1.1 * hi:
        span = f"{lo:g}-{hi:g} mm" if hi > lo else f"{lo:g} mm"
        warn(f"the stickout {stickout_mm:g} mm lies beyond the stickouts of the cuts ({span}): decisions there lean on "
             "the holder model and the prior", UserWarning, stacklevel=stacklevel + 1)


def at_stickout(obj, stickout_m: float | None):
    """A :class:`Prior` or :class:`~millstab.update.Posterior` with the tool at ``stickout_m`` [m] (the same
    holder parameters or samples); ``None``: ``obj`` itself. InputError when ``obj`` is not over a holder."""
    if stickout_m is None:
        return obj
    prior = obj if isinstance(obj, Prior) else obj.prior
    at = getattr(prior.par, "at", None)
    if at is None:
        raise InputError("stickout", f"{stickout_m * 1e3:g} mm", "a decision at another stickout needs a posterior "
                         "over the holder: update a config with [tool] and [holder] given by modes ([[holder.modes]])")
    moved = replace(prior, par=at(float(stickout_m)))
    return moved if isinstance(obj, Prior) else replace(obj, prior=moved)


__all__ = ["MAX_STICKOUT_MM", "at_stickout", "check_stickout_mm", "check_stickouts_mm", "config_prior", "holder_prior",
           "not_over_holder", "over_holder", "stickout_mm_of", "warn_outside_stickouts"]
