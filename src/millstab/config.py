"""A loaded config, the model type of a run's inputs: cutting conditions, tool-tip structure, default
speeds and the ``[prior]`` table. Parsed from TOML (schema and errors) by :mod:`millstab.io.config`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

import numpy as np

from millstab.model import Cutting, Structure


@dataclass(frozen=True, eq=False)
class Config:
    """A loaded config.

    Attributes:
        cutting: the cutting conditions.
        structure: the tool-tip structure (modes or measured FRF).
        name: display name (``name`` key, else the file stem or example name).
        path: the config file, or ``None`` for a config parsed from text.
        rpm: default spindle speeds [rev/min] from ``[speeds]``, or ``None``.
        description: free text from the file ("" if none).
        prior: the ``[prior]`` table (:class:`PriorTable`), or ``None`` when the file has none.
        tooltip: ``(Tool, Holder)`` of a ``[tool]`` + ``[holder]`` config (its structure is their tip FRF), else
            ``None``: updating over a holder given by modes serves every stickout (:mod:`millstab.update.stickout`).
        diameter_m, feed_per_tooth_m: the tool diameter and the feed per tooth [m], or ``None``.
    """

    cutting: Cutting
    structure: Structure
    name: str
    path: Path | None = None
    rpm: np.ndarray | None = None
    description: str = ""
    prior: PriorTable | None = None
    tooltip: tuple | None = None
    #: the tool diameter [m] (``[cutting] diameter`` or ``[tool] diameter``), or ``None``
    diameter_m: float | None = None
    #: the feed per tooth [m] of the cuts (``[cutting] feed_per_tooth``), or ``None``
    feed_per_tooth_m: float | None = None

    @property
    def diameter_mm(self) -> float | None:
        return None if self.diameter_m is None else self.diameter_m * 1e3


#: the largest test-day spread ``[prior] batch_effect`` (σ of ln fn): a day that moves fn by more than 25 % is not drift
MAX_BATCH_EFFECT = 0.25


@dataclass(frozen=True, eq=False)
class PriorTable:
    """The ``[prior]`` table of a config, as written (defaults are applied by :mod:`millstab.update.prior`).

    Attributes:
        spreads: {name: σ of ln(value)} for kinds (``fn``, ``k``, ``zeta``), parameter names
            (``fn_x``, ``k_y2``) and cutting coefficients (``kt``, ``kr``, ``process_damping``), each > 0.
        fixed: parameter names held at the structure's values.
        sigma_depth_m: absolute depth noise [m], or ``None``.
        sigma_depth_rel: relative depth noise (fraction of the cut's depth), or ``None``.
        sigma_chatter_hz: chatter-frequency noise [Hz], or ``None``.
        label_error: probability that a cut's label is swapped, in [0, 0.5), or ``None``.
        tails: the tails of the spreads (``multivariate_t_shift``, ``multivariate_t``, ``student``, ``normal``,
            ``mixture``), or ``None`` (default ``multivariate_t_shift``).
        batch_effect: σ of a test day's shift of ln fn (:mod:`millstab.update.batch`), or ``None`` (off).
        chatter_hz_alias: the chance that a measured chatter frequency is another member of its family than the
            one near the mode, in (0, 1], or ``None`` (default 0.1; 1: any member alike;
            :mod:`millstab.update.likelihood`).
    """

    spreads: Mapping[str, float]
    fixed: tuple[str, ...] = ()
    sigma_depth_m: float | None = None
    sigma_depth_rel: float | None = None
    sigma_chatter_hz: float | None = None
    label_error: float | None = None
    tails: str | None = None
    batch_effect: float | None = None
    chatter_hz_alias: float | None = None


__all__ = ["Config", "MAX_BATCH_EFFECT", "PriorTable"]
