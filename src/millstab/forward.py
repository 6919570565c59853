"""The one forward model and the one finite-difference log-Jacobian.

:func:`forward` binds a parameterization, the cutting conditions and an engine into a frozen callable
``f(θ[B, P], rpm[S]) → depth[B, S]`` [m]: ONE batched engine call (``envelope_batch``; the engine
chunks the rows itself). ``f(θ, rpm, conditions)`` evaluates each speed column under its own
condition (:class:`millstab.model.Conditions`, default the bound cutting for every column), still in
ONE engine call. Every consumer (identification, design, synthetic data, sensitivity,
updating, the callers of the plots) evaluates SLDs through it.

:func:`log_jacobian` differentiates ``ln b`` with respect to ``ln θ`` (optionally also ``ln Ω``) by
finite differences from ONE call of ``f`` on all perturbed rows. :func:`fd_rows` and
:func:`fd_difference` are its two halves, shared with the least-squares solver, which differentiates
its residuals on the same rows.
"""

from __future__ import annotations

import inspect
import math
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from millstab.errors import InputError
from millstab.model import Conditions, Cutting
from millstab.params import Parameterization
from millstab.progress import cancel_point
from millstab.stability import get_engine
from millstab.stability.process_damping import reject as reject_process_damping

#: speed lists whose engine settings a Forward remembers
SETTINGS_CACHE = 16
#: default step in ln θ (1e-4 ⇒ 0.01 % relative; the engines resolve ~1e-8)
FD_STEP = 1e-4
#: keywords of an engine's ``envelope_batch`` that are not its discretisation (never ``options``; the spectral
#: engine's ``warm`` is its own settings' choice, per purpose; ``ceiling`` a censored search's per-call caps)
NOT_OPTIONS = frozenset({"ceiling", "chunk", "floor", "kr", "process_damping", "progress", "warm"})


def per_row(kr: np.ndarray | None, process_damping: np.ndarray | None) -> dict:
    """The per-row cutting keywords of an engine call: only those given (an engine without the capability is never
    handed a keyword it does not take)."""
    return {k: v for k, v in (("kr", kr), ("process_damping", process_damping)) if v is not None}


@dataclass(frozen=True)
class Forward:
    """``f(θ, rpm)``: limiting depths [m] of parameter rows θ (B, P) [Hz, N/m, -] at speeds rpm (S,) [rev/min]."""

    par: Parameterization
    cutting: Cutting
    engine: str = "zoa"
    #: what the engine's ``settings`` choose the discretisation for: ``"fit"`` (a search differentiating the
    #: depths) or ``"sample"`` (a sampler comparing them with a depth noise: the spectral engine's converged
    #: node count, :data:`millstab.stability.spectral.PURPOSES`); ignored by engines without ``settings``
    purpose: str = "fit"
    #: the engine's discretisation fixed by the caller, as (keyword, value) pairs of its ``envelope_batch``
    #: (sdm ``steps`` per tooth period, spectral ``nodes``, ...): they override what ``settings`` or
    #: ``split_settings`` choose, in every call (:func:`engine_options`; ``()``: the engine chooses)
    options: tuple = ()
    _engine_mod: object = field(default=None, init=False, repr=False, compare=False)
    #: the engine's discretisation per speed list (``settings`` capability), chosen once
    _settings: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        # resolve (and validate) the engine name once, not per call
        object.__setattr__(self, "_engine_mod", get_engine(self.engine))
        if not getattr(self._engine_mod, "process_damping", False):  # an engine without the capability
            reject_process_damping(self.cutting, self.engine)
        object.__setattr__(self, "options", engine_options(self.engine, dict(self.options)))

    def __reduce__(self):  # an engine module does not pickle: a Dask task gets the model by the engine's name
        return Forward, (self.par, self.cutting, self.engine, self.purpose, self.options)

    def _with_options(self, chosen: dict) -> dict:
        """The engine's chosen settings with the caller's :attr:`options` over them."""
        return {**chosen, **dict(self.options)} if self.options else chosen

    def __call__(self, theta: np.ndarray, rpm: np.ndarray, conditions: Conditions | Cutting | None = None,
                 kr: np.ndarray | None = None, process_damping: np.ndarray | None = None) -> np.ndarray:
        """Depths (B, S) [m]; ``inf`` where a row has no finite limit. One batched engine call.

        ``conditions``: the condition of each speed column (``None``: the bound cutting for all); ``kr``: a
        Kr per row (B,) overriding the conditions' (engines with the ``per_set_kr`` capability only);
        ``process_damping``: a coefficient C [N/m] per row (B,) (engines with ``per_set_process_damping``)."""
        t = np.atleast_2d(np.asarray(theta, dtype=float))
        r = np.asarray(rpm, dtype=float)
        cut = self.cutting if conditions is None else conditions
        extra = per_row(kr, process_damping)
        return self._engine_mod.envelope_batch(self.par.batch(t), cut, r, **self.settings(r, t[0], conditions),
                                               **extra)

    def _purpose(self) -> dict:
        """The ``purpose`` keyword of the engine's ``settings`` (none for the default, so an engine whose
        ``settings`` takes no purpose still works)."""
        return {} if self.purpose == "fit" else {"purpose": self.purpose}

    def _key(self, r: np.ndarray, conditions) -> bytes:
        """The settings-cache key of (speeds, conditions)."""
        if conditions is None or (isinstance(conditions, Cutting) and conditions == self.cutting):
            return r.tobytes()
        if isinstance(conditions, Cutting):
            return r.tobytes() + repr(conditions).encode()
        return r.tobytes() + conditions.key()

    def settings(self, rpm: np.ndarray, theta: np.ndarray | None = None,
                 conditions: Conditions | Cutting | None = None) -> dict:
        """The engine's discretisation at speeds rpm [rev/min] under ``conditions`` (default the bound cutting)
        (keywords of ``envelope_batch``): chosen once per (speed list, conditions), at the first row of the
        first call (``theta`` (P,), default the start θ0; in a fit, the start), so every call of one problem
        evaluates the same smooth function and a single call is evaluated as the engine alone would; ``{}``
        for an engine without ``settings``."""
        if getattr(self._engine_mod, "settings", None) is None:
            return dict(self.options)
        r = np.asarray(rpm, dtype=float)
        row = self.par.theta0 if theta is None else np.asarray(theta, dtype=float)
        return self._remembered(self._key(r, conditions), r, row, conditions)

    def _settings_at(self, r: np.ndarray, row: np.ndarray, conditions) -> dict:
        """The engine's settings chosen at the parameter row ``row`` (P,): cached under (speeds, conditions,
        row), apart from :meth:`settings`' first-row choice, so a pinned study's discretisation depends on
        the row it names, not on which call came first."""
        return self._remembered(b"at" + self._key(r, conditions) + row.tobytes(), r, row, conditions)

    def _choose(self, r: np.ndarray, row: np.ndarray, conditions) -> dict:
        """The engine's settings at speeds ``r`` chosen at the parameter row ``row`` (P,), the caller's options
        over the choice (before, a pinned spectral model dropped a fixed node count)."""
        cut = self.cutting if conditions is None else conditions
        return self._with_options(dict(self._engine_mod.settings(self.par.batch(np.atleast_2d(row)), cut, r,
                                                                 **self._purpose())))

    def _remembered(self, key: bytes, r: np.ndarray, row: np.ndarray, conditions) -> dict:
        """:meth:`_choose`'s settings, chosen once per cache ``key``."""
        if key not in self._settings:
            if len(self._settings) >= SETTINGS_CACHE:  # bounded: a caller sweeping speed lists
                self._settings.pop(next(iter(self._settings)))
            self._settings[key] = self._choose(r, row, conditions)
        return self._settings[key]

    def refine(self, theta: np.ndarray, rpm: np.ndarray, conditions: Conditions | Cutting | None = None) -> bool:
        """Re-check the discretisation at the parameter row ``theta`` (P,) [SI] (e.g. a fitted solution):
        where the engine chooses other settings there, they replace the chosen ones for these speeds (and
        conditions). Returns whether they changed (the caller then evaluates again, e.g. polishes the fit)."""
        if getattr(self._engine_mod, "settings", None) is None:
            return False
        r = np.asarray(rpm, dtype=float)
        old = self.settings(r, None, conditions)
        new = self._choose(r, np.asarray(theta, dtype=float), conditions)
        self._settings[self._key(r, conditions)] = new
        return new != old

    def pinned(self, rpm: np.ndarray, theta_rows: np.ndarray | None = None,
               conditions: Conditions | Cutting | None = None, *, at: np.ndarray | None = None) -> Pinned:
        """This model at the speeds ``rpm`` (S,) [rev/min] with the engine's discretisation fixed now for a
        whole problem whose parameter rows are (or are bounded by) ``theta_rows`` (R, P) [SI] (default the
        start θ0): an engine with ``settings`` (spectral) chooses it at the row ``at`` (P,) [SI] (a study's
        centre, a prior's θ0; default the first of ``theta_rows``), whatever this model chose before for a
        fit (the choice at ``at`` is kept apart from :meth:`settings`' first-row choice); one with
        ``split_settings`` (sdm: the steps follow the highest natural frequency) from all the rows; ``{}``
        otherwise (zoa evaluates every row alone). Every later evaluation, of any subset of rows, in any
        chunks, here or on a cluster, then gives the numbers of ONE call on all of them. ``conditions``: the
        condition of each speed column (default the bound cutting for all)."""
        r = np.asarray(rpm, dtype=float)
        rows = np.atleast_2d(np.asarray(self.par.theta0 if theta_rows is None else theta_rows, dtype=float))
        cut = self.cutting if conditions is None else conditions
        if isinstance(cut, Conditions):
            cut.check_columns(r.size)
        if getattr(self._engine_mod, "settings", None) is not None:
            chosen = self._settings_at(r, rows[0] if at is None else np.ravel(np.asarray(at, dtype=float)),
                                        conditions)
        else:
            split = getattr(self._engine_mod, "split_settings", None)
            chosen = self._with_options(dict(split(self.par.batch(rows), cut, r)) if split is not None else {})
        return Pinned(self, r, chosen, cut)


@dataclass(frozen=True, eq=False)
class Pinned:
    """A forward model at fixed speeds with a fixed discretisation (:meth:`Forward.pinned`): ``f(θ)`` →
    depths (B, S) [m]; :meth:`map` evaluates many rows in chunks or on a Dask cluster, same numbers."""

    forward: Forward
    rpm: np.ndarray
    settings: MappingProxyType
    #: the condition of each speed column (None: the forward model's cutting for all)
    conditions: Conditions | Cutting | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "rpm", np.asarray(self.rpm, dtype=float))
        object.__setattr__(self, "settings", MappingProxyType(dict(self.settings)))
        if self.conditions is None:
            object.__setattr__(self, "conditions", self.forward.cutting)

    def __reduce__(self):  # a read-only mapping does not pickle; a Dask task gets a copy
        return Pinned, (self.forward, self.rpm, dict(self.settings), self.conditions)

    def __call__(self, theta: np.ndarray, kr: np.ndarray | None = None,
                 ceiling: np.ndarray | None = None, floor: np.ndarray | None = None,
                 process_damping: np.ndarray | None = None) -> np.ndarray:
        """Depths (B, S) [m] of parameter rows θ (B, P) [SI]: ONE batched engine call; ``kr`` (B,): a Kr per row
        (engines with ``per_set_kr``); ``ceiling`` (B, S) [m]: a censored search (engines with ``takes_ceiling``,
        e.g. :func:`millstab.stability.spectral.envelope_batch`: above it, a certified lower bound of the limit);
        ``floor`` (B, S) [m]: floors (engines with ``takes_floor``: a depth below it where the limit is);
        ``process_damping`` (B,) [N/m]: a coefficient C per row (engines with ``per_set_process_damping``)."""
        t = np.atleast_2d(np.asarray(theta, dtype=float))
        f = self.forward
        extra = per_row(kr, process_damping)
        if ceiling is not None:
            extra["ceiling"] = ceiling
        if floor is not None:
            extra["floor"] = floor
        cancel_point()  # a cancelled web job stops here, between engine calls (millstab.progress)
        return f._engine_mod.envelope_batch(f.par.batch(t), self.conditions, self.rpm, **self.settings, **extra)

    @property
    def reports_frequency(self) -> bool:
        """Whether :meth:`with_frequency` gives chatter frequencies (the engine's ``reports_chatter_frequency``)."""
        return bool(getattr(self.forward._engine_mod, "reports_chatter_frequency", False))

    def with_frequency(self, theta: np.ndarray, kr: np.ndarray | None = None,
                       process_damping: np.ndarray | None = None, ceiling: np.ndarray | None = None,
                       floor: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(depths (B, S) [m], chatter frequencies (B, S) [Hz]) of rows θ, one call of an engine that
        :attr:`reports_frequency`, under the same pinned discretisation as :meth:`__call__`; ``ceiling``, ``floor``:
        as :meth:`__call__` (an engine with ``takes_ceiling`` / ``takes_floor``; NaN frequencies there)."""
        t = np.atleast_2d(np.asarray(theta, dtype=float))
        f = self.forward
        extra = per_row(kr, process_damping)
        if ceiling is not None:
            extra["ceiling"] = ceiling
        if floor is not None:
            extra["floor"] = floor
        cancel_point()
        return f._engine_mod.envelope_batch_hz(f.par.batch(t), self.conditions, self.rpm, **self.settings, **extra)

    def map(self, rows: np.ndarray, *, chunk_rows: int | None = None, progress=None) -> np.ndarray:
        """Depths (R, S) [m] of many rows (R, P) [SI], one engine call per chunk of ``chunk_rows`` rows
        (default the engine's ``chunk_rows``; ``progress(rows_done, R)`` after each). The discretisation is
        pinned, so the chunk size changes no number; a Dask cluster's tasks call this model too
        (:func:`millstab.cluster.map_pinned`: the studies hand it over, so that this layer imports none above)."""
        rows = np.atleast_2d(np.asarray(rows, dtype=float))
        f = self.forward
        per = int(chunk_rows or f._engine_mod.chunk_rows(self.rpm.size))
        out = np.empty((rows.shape[0], self.rpm.size))
        for start in range(0, rows.shape[0], per):
            stop = min(rows.shape[0], start + per)
            out[start:stop] = self(rows[start:stop])
            if progress:
                progress(stop, rows.shape[0])
        return out


def forward(par: Parameterization, cutting: Cutting, engine: str = "zoa", purpose: str = "fit",
            options: dict | None = None) -> Forward:
    """The forward model of ``par`` under ``cutting`` with the named engine (see :class:`Forward`; ``purpose``:
    what the engine's discretisation is chosen for, ``"fit"`` or ``"sample"``; ``options``: the discretisation
    fixed instead, e.g. ``{"steps": 40}`` for sdm, :func:`engine_options`)."""
    return Forward(par, cutting, engine, purpose, tuple(sorted((options or {}).items())))


def _whole(lo: int, hi: int):
    return lambda v: isinstance(v, (int, np.integer)) and not isinstance(v, bool) and lo <= v <= hi


#: the most sdm steps per tooth period a user may fix: the monodromy has ~steps² entries (8 MB at 1 000 steps, per
#: set and thread; 10^6 steps failed for memory and 10^8 grew past 12 GB), and its accuracy control asks for 20-300
MAX_STEPS = 2_000
#: the most spectral collocation nodes per element (converged at 6-8 on every benchmark: spectral.py)
MAX_NODES = 40


def _real(ok):
    return lambda v: isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) and ok(float(v))


#: the values each discretisation keyword takes (what its engine accepts, checked before any work so that a bad
#: value fails in one line at the door, not after the sampler's first stage): keyword -> (test, what is allowed)
OPTION_VALUES = {
    "steps": (_whole(1, MAX_STEPS), f"a whole number of steps per tooth period in 1..{MAX_STEPS:,}"),
    "fn_max_hz": (_real(lambda x: math.isfinite(x) and x > 0), "the highest natural frequency [Hz], > 0"),
    "nodes": (_whole(2, MAX_NODES), f"a whole number of collocation nodes per element in 2..{MAX_NODES}"),
    "near": (_real(lambda x: 0.0 <= x < 1.0), "the refinement margin near rho = 1, in [0, 1)"),
}


def option_keywords(engine: str) -> tuple[list[str], str]:
    """The named engine's discretisation keywords (those of its ``envelope_batch`` with a default, less
    :data:`NOT_OPTIONS`), sorted, and the phrase that names them in errors and in the doors' help
    ("the sdm engine's discretisation keywords: fn_max_hz, steps")."""
    params = inspect.signature(get_engine(engine).envelope_batch).parameters
    allowed = sorted(k for k, p in params.items() if p.default is not inspect.Parameter.empty and k not in NOT_OPTIONS)
    return allowed, f"the {engine} engine's discretisation keywords: " + (", ".join(allowed) if allowed else
                                                                            "none (it chooses its own grid)")


def engine_options(engine: str, options: dict | None, field: str = "engine_options") -> tuple:
    """``options`` checked against the named engine's ``envelope_batch`` keywords (its discretisation: sdm
    ``steps``/``fn_max_hz``, spectral ``nodes``/``near``; zoa has none; :func:`option_keywords`) and their values
    (:data:`OPTION_VALUES`), as sorted (keyword, value) pairs. InputError naming ``field``, the keyword (and
    the value) and the engine's keywords."""
    opts = dict(options or {})
    if not opts:
        return ()
    allowed, keys = option_keywords(engine)
    for key, value in opts.items():
        if key not in allowed:
            raise InputError(field, key, keys)
        test, what = OPTION_VALUES.get(key, (lambda v: True, ""))
        if not test(value):
            raise InputError(f"{field} {key}", value, f"{what} ({keys})")
    return tuple(sorted((k, v.item() if isinstance(v, np.generic) else v) for k, v in opts.items()))


def fd_rows(u: np.ndarray, lo: np.ndarray, hi: np.ndarray, h: float = FD_STEP, central: bool = False):
    """Rows to evaluate for forward (or central) differences around each row of u (K, P).

    Returns (rows (K·m, P), steps (K, P)) with m = P + 1 (forward: [u, u + h_j e_j]) or 2P + 1
    (central: [u, u + h e_j, u − h e_j]); a step that would leave the bounds is taken backwards.
    """
    k, p = u.shape
    eye = np.eye(p)
    steps = np.where(u + h <= hi, h, -h) * np.ones((k, p))
    plus = u[:, None, :] + steps[:, :, None] * eye[None]
    parts = [u[:, None, :], plus]
    if central:
        parts.append(u[:, None, :] - steps[:, :, None] * eye[None])
    return np.concatenate(parts, axis=1).reshape(-1, p), steps


def fd_difference(values: np.ndarray, steps: np.ndarray, central: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """From value rows (K·m, n) laid out as :func:`fd_rows`: values at u (K, n) and J (K, n, P)."""
    k, p = steps.shape
    m = 2 * p + 1 if central else p + 1
    r = values.reshape(k, m, -1)
    r0 = r[:, 0]
    if central:
        jac = (r[:, 1:p + 1] - r[:, p + 1:]) / (2 * steps[:, :, None])
    else:
        jac = (r[:, 1:p + 1] - r0[:, None]) / steps[:, :, None]
    return r0, np.transpose(jac, (0, 2, 1))


def log_jacobian(f, theta: np.ndarray, rpm: np.ndarray, *, rel_step: float = FD_STEP, central: bool = True,
                 bounds: tuple[np.ndarray, np.ndarray] | None = None, speed: bool = False):
    """∂ ln b/∂ ln θ at each row of ``theta`` (B, P) [SI] and speed of ``rpm`` (S,) [rev/min].

    ``f`` is a forward model (:func:`forward`). All perturbed rows (and, with ``speed``, the speeds
    Ω·e^{±h}) go through ONE call of ``f``. ``rel_step`` is h, the step in ln θ; ``central`` picks
    central (error O(h²)) or forward differences; with ``bounds`` (lower, upper) [SI] a step that would
    leave the upper bound is taken backwards (as :func:`fd_rows`).

    Returns J (B, S, P); with ``speed=True`` also slope (B, S) = ∂ ln b/∂ ln Ω (central, same h).
    Entries are ``nan`` where b is not finite; the caller decides what that means.
    """
    t = np.atleast_2d(np.asarray(theta, dtype=float))
    u = np.log(t)
    p = u.shape[1]
    lo, hi = (np.full(p, -np.inf), np.full(p, np.inf)) if bounds is None else (np.log(bounds[0]), np.log(bounds[1]))
    rows, steps = fd_rows(u, lo, hi, rel_step, central)
    r = np.asarray(rpm, dtype=float)
    speeds = np.concatenate([r, r * math.exp(rel_step), r / math.exp(rel_step)]) if speed else r
    with np.errstate(divide="ignore", invalid="ignore"):
        d0, jac = fd_difference(np.log(f(np.exp(rows), speeds)), steps, central)
        if not speed:
            return jac
        m = r.size
        slope = (d0[:, m:2 * m] - d0[:, 2 * m:]) / (2 * rel_step)
    return jac[:, :m], slope


__all__ = ["FD_STEP", "Forward", "Pinned", "engine_options", "fd_difference", "fd_rows", "forward", "log_jacobian",
           "option_keywords"]
