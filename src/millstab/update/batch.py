"""The test-day (batch) random effect of Bayesian updating: a day's drift of the natural frequencies.

A structure drifts from day to day (the spindle's temperature, the tool's clamping, the machine's
warm-up): a cut made on day g sees fn·exp(δ_g) instead of fn. With ``[prior] batch_effect = "3 %"``
(``millstab update --batch-effect 3%``; off by default) each test day g (the cuts file's ``batch``,
``date``, ``day`` or ``session`` column) gets a shift

    δ_g ~ N(0, τ²)   of ln fn, the same for every mode,

sampled with the parameters as extra coordinates of the sampler's vector (after the modal parameters
and the learned noise levels), so the limit of a cut on day g is evaluated at θ·exp(δ_g) on its fn
coordinates. θ is then the structure of the average day, and the posterior of each δ_g says how far
that day was off.

Why one shift per day for all modes (not one per direction): the causes act on the whole structure at
once (the spindle's bearings and the holder's joint stiffen or soften together), so to first order all
the modes move by the same factor; a shop's day holds 3–10 cuts, which can place one shift but cannot
split it between the x and y modes (and with the zero-order engine the x↔y exchange makes a
per-direction split partly unidentifiable). One coordinate per day keeps the sampler's dimension at
P + Q + G. Only free natural frequencies are shifted: a held fn stays held (the option needs at least
one free fn).

Cuts without a day (an empty ``batch`` cell, or no column) and boundary points form one day of their
own, named ``""``.

Decisions (``map``, ``recommend``, the next test, ``predict``) are for a NEW day: the shift is
marginalised over its prior, i.e. each posterior sample θ_i is used as θ_i·exp(δ_i) with one fresh
δ_i ~ N(0, τ²) on its fn coordinates (:func:`new_day`; a fixed seed, so the same
posterior gives the same decisions). A new day's limit is therefore wider than the average day's by τ
in ln fn, which is what a shop cutting tomorrow faces.

Cost: one engine call per day and likelihood evaluation, each at that day's speeds only (no loop over
cuts or samples). The zero-order engine's cost is mostly per parameter set, so G days cost about G times
the engine work of one call (measured: 4 000 samples, 30 cuts on 4 days, 9.1 s CPU against 2.7 s
without the effect; ``benchmarks/bench_update.py --batch-effect 0.03``); stacking the G shifted copies of
the rows into one call would cost the same sets, so the simpler per-day call is kept.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from millstab.config import MAX_BATCH_EFFECT as MAX_TAU  # the largest τ (a day moving fn > 25 % is not drift)
from millstab.errors import InputError

#: the seed of the new day's shifts used by decisions (same posterior, same decisions)
NEW_DAY_SEED = 20240
_LOG_SQRT_2PI = 0.5 * math.log(2 * math.pi)


def check_tau(tau, field: str = "prior.batch_effect") -> float:
    """τ as a float in [0, :data:`MAX_TAU`] or an :class:`InputError` naming ``field``."""
    try:
        t = float(tau)
    except (TypeError, ValueError):
        raise InputError(field, tau, "the σ of a test day's shift of ln fn, e.g. \"3 %\" or 0.03") from None
    if not (math.isfinite(t) and 0 <= t <= MAX_TAU):
        raise InputError(field, tau, f"the σ of a test day's shift of ln fn, in [0, {MAX_TAU:.0%}] (e.g. \"3 %\"; "
                                     "0: no test-day effect)")
    return t


def fn_columns(prior) -> np.ndarray:
    """Indices of the free natural frequencies in the prior's vector u = ln θ."""
    return np.array([j for j, n in enumerate(prior.par.free) if prior.par.kind(n) == "fn"], dtype=np.int64)


def shift_fn(u: np.ndarray, cols: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """A copy of u (B, P) with ``delta`` (B,) added to the columns ``cols`` (ln fn)."""
    out = np.array(u, dtype=float)
    out[:, cols] += np.asarray(delta, float)[:, None]
    return out


def days_of(evidence) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """(day index of each cut (n_cuts,), of each boundary point (n_pts,), the day names in order of first
    appearance); a cut without a day and every boundary point belong to the day ``""``."""
    cut = [str(b) for b in evidence.cut_batch]
    names = list(dict.fromkeys(cut + ([""] if evidence.pt_rpm.size else [])))
    index = {n: i for i, n in enumerate(names)}
    return (np.array([index[b] for b in cut], dtype=np.int64),
            np.full(evidence.pt_rpm.size, index.get("", 0), dtype=np.int64), tuple(names))


@dataclass(frozen=True, eq=False)
class BatchEffect:
    """The test-day effect of one update: τ, the days, and the likelihood's columns per day.

    Attributes:
        tau: σ of each day's shift δ_g of ln fn (> 0).
        days: the day names (G,), in order of first appearance in the cuts.
        fn_cols: the free natural frequencies' indices in u.
        col_day, col_base: the likelihood's columns (C,): one per (day, column) pair the data use, ``col_base``
            the index of the pair's column among the likelihood's (speed, condition, stickout) columns.
        ic, ip: the column of each cut (n_cuts,) and of each boundary point (n_pts,).
    """

    tau: float
    days: tuple[str, ...]
    fn_cols: np.ndarray
    col_day: np.ndarray
    col_base: np.ndarray
    ic: np.ndarray
    ip: np.ndarray

    @classmethod
    def of(cls, prior, evidence, cut_col: np.ndarray, pt_col: np.ndarray) -> BatchEffect | None:
        """The effect for this prior and evidence, or ``None`` when the prior has none (τ = 0); ``cut_col`` and
        ``pt_col`` are each cut's and boundary point's column among the likelihood's columns.

        Raises:
            InputError: no free natural frequency to shift.
        """
        tau = float(getattr(prior, "batch_effect", 0.0) or 0.0)
        if tau <= 0:
            return None
        cols = fn_columns(prior)
        if cols.size == 0:
            raise InputError("prior.batch_effect", f"{tau:.3g}", "a test-day effect shifts the natural frequencies: "
                                                                 "leave at least one fn free (not in prior.fixed)")
        dc, dp, days = days_of(evidence)
        # one column per (day, column) pair: a day's engine call sees only its own columns
        day = np.r_[dc, dp]
        base = np.r_[np.asarray(cut_col, dtype=np.int64), np.asarray(pt_col, dtype=np.int64)]
        pairs, inv = np.unique(np.column_stack([day, base]), axis=0, return_inverse=True)
        inv = np.asarray(inv).ravel()
        return cls(tau, days, cols, pairs[:, 0].astype(np.int64), pairs[:, 1].astype(np.int64), inv[:dc.size],
                   inv[dc.size:])

    @property
    def size(self) -> int:
        """Number of days G (extra coordinates of the sampler's vector)."""
        return len(self.days)

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """n prior draws of the shifts (n, G)."""
        return self.tau * rng.standard_normal((n, self.size))

    def logpdf(self, delta: np.ndarray) -> np.ndarray:
        """Log prior density of the shifts (B, G) -> (B,)."""
        z = np.atleast_2d(delta) / self.tau
        return (-0.5 * z * z - math.log(self.tau) - _LOG_SQRT_2PI).sum(axis=1)

    def limits(self, limits_fn, u: np.ndarray, delta: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
        """Limiting depths (B, C) [mm] (and frequencies, or ``None``) at the columns, each day's at θ·exp(δ_g).

        ``limits_fn(u, rpm) -> (depth (B, S), hz or None)`` is the likelihood's one forward call; it is
        called once per day, with that day's speeds only. ``delta`` ``None``: every shift 0."""
        b = u.shape[0]
        depth = np.empty((b, self.col_base.size))
        hz = None
        for g in range(self.size):  # a loop over the days (a handful), never over cuts or samples
            cols = np.flatnonzero(self.col_day == g)
            if not cols.size:
                continue
            ug = u if delta is None else shift_fn(u, self.fn_cols, delta[:, g])
            d, h = limits_fn(ug, self.col_base[cols])
            depth[:, cols] = d
            if h is not None:
                if hz is None:
                    hz = np.full_like(depth, np.nan)
                hz[:, cols] = h
        return depth, hz

    def start(self, old: BatchPosterior | None, n: int, rng: np.random.Generator) -> np.ndarray:
        """Starting shifts (n, G) of a sequential update: the earlier posterior's for the days it knew
        (its rows in order, as its samples), prior draws for the new days."""
        out = self.sample(n, rng)
        if old is not None:
            for g, name in enumerate(self.days):
                if name in old.days:
                    out[:, g] = old.shifts[:, old.days.index(name)]
        return out

    def posterior(self, delta: np.ndarray) -> BatchPosterior:
        return BatchPosterior(self.tau, self.days, np.asarray(delta, float))


def new_day(u: np.ndarray, prior) -> np.ndarray:
    """The samples u = ln θ (N, P) for a new day: each row's free fn shifted by a fresh δ ~ N(0, τ²), τ =
    ``prior.batch_effect`` (a fixed seed: the same posterior gives the same decisions); u itself when τ = 0."""
    tau = float(getattr(prior, "batch_effect", 0.0) or 0.0)
    if tau <= 0:
        return u
    return shift_fn(u, fn_columns(prior), tau * np.random.default_rng(NEW_DAY_SEED).standard_normal(u.shape[0]))


def summary_of(shifts: np.ndarray, days) -> dict:
    """{day: {mean, sd, q05, q50, q95}} of the shifts δ_g (of ln fn)."""
    q = np.quantile(shifts, [0.05, 0.5, 0.95], axis=0) if shifts.size else np.zeros((3, 0))
    return {d: {"mean": float(shifts[:, j].mean()), "sd": float(shifts[:, j].std(ddof=1)),
                "q05": float(q[0, j]), "q50": float(q[1, j]), "q95": float(q[2, j])} for j, d in enumerate(days)}


@dataclass(frozen=True, eq=False)
class BatchPosterior:
    """The posterior's test-day shifts: τ, the days, and the shifts δ (N, G) of ln fn, row i with sample i."""

    tau: float
    days: tuple[str, ...]
    shifts: np.ndarray

    def to_record(self) -> dict:
        """The ``batch`` record of the posterior's JSON (plain types)."""
        return {"tau": self.tau, "days": list(self.days), "coordinate": "shift of ln fn, all modes",
                "parameters": summary_of(self.shifts, self.days), "samples": self.shifts.tolist()}

    @classmethod
    def from_record(cls, d, n: int, source: str = "posterior") -> BatchPosterior:
        """Rebuild from :meth:`to_record` output for a posterior of n samples.

        Raises:
            InputError: not a batch record of n rows.
        """
        try:
            days = tuple(str(x) for x in d["days"])
            shifts = np.asarray(d["samples"], dtype=float).reshape(n, len(days))
            tau = check_tau(d["tau"], f"{source} batch.tau")
        except (KeyError, TypeError, ValueError):
            raise InputError(f"{source} batch", type(d).__name__, f"need tau, days and {n} rows of shifts") from None
        if not (tau > 0 and np.isfinite(shifts).all()):
            raise InputError(f"{source} batch", f"tau {tau}", "need tau > 0 and finite shifts")
        return cls(tau, days, shifts)


__all__ = [
    "MAX_TAU",
    "NEW_DAY_SEED",
    "BatchEffect",
    "BatchPosterior",
    "check_tau",
    "days_of",
    "fn_columns",
    "new_day",
    "shift_fn",
    "summary_of",
]
