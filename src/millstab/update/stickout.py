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


__all__ = ["at_stickout", "config_prior", "holder_prior", "not_over_holder", "over_holder"]
