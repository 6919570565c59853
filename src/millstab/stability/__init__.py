"""Stability engines behind one contract (:mod:`millstab.stability.base`): ``envelope(structure,
cutting, rpm)`` → Envelope and ``envelope_batch(batch, cutting, rpm)`` → (B, S) depths [m], plus
declared capabilities that consumers ask for instead of testing names.

* ``zoa`` -- zero-order (Altintas–Budak), fast, exact for time-invariant directional matrices;
* ``sdm`` -- semi-discretization (Insperger–Stépán), time domain, captures flip lobes at low immersion;
* ``spectral`` -- spectral-element collocation of the cutting intervals (time domain, exact free flight):
  as accurate as converged SDM, flip and Hopf lobes, far faster; the engine for low radial immersion.

A new engine is one module with the contract's attributes and one :func:`register` call. The built-in
engines are registered by module path so that importing this package does not compile them.
"""

from __future__ import annotations

import importlib
from collections.abc import Sequence
from types import ModuleType

from millstab.errors import InputError
from millstab.stability.base import (Engine, Envelope, by_condition, check_rpm,  # noqa: F401  (the contract)
                                     directional_matrix, missing_attributes, per_set_kr,
                                     per_set_process_damping)

#: name → engine object, or the module path of a built-in engine not imported yet
_REGISTRY: dict[str, object] = {}


class _Names(Sequence):
    """The registered names, read from the registry at each use (so engines registered later count)."""

    def __getitem__(self, i):
        return tuple(_REGISTRY)[i]

    def __len__(self):
        return len(_REGISTRY)

    def __contains__(self, name):
        return name in _REGISTRY

    def __eq__(self, other):
        return tuple(_REGISTRY) == tuple(other)

    def __hash__(self):
        return hash(tuple(_REGISTRY))

    def __repr__(self):
        return repr(tuple(_REGISTRY))


#: the registered engine names (a live view of the registry: ``"x" in ENGINES`` and ``", ".join(ENGINES)``
#: see engines registered after import)
ENGINES: Sequence[str] = _Names()


def register(engine: object, module: str | None = None) -> object:
    """Register ``engine`` (an object or module satisfying :class:`~millstab.stability.base.Engine`)
    under ``engine.name``; or, with ``module``, register the name ``engine`` (a str) to be imported from
    that module path on first use. Re-registering a name replaces it. Returns what was registered.

    Raises:
        InputError: for an object missing contract attributes or a name that is not a plain word.
    """
    if module is not None:
        name = engine
    else:
        missing = missing_attributes(engine)
        if missing:
            raise InputError("engine", repr(engine), f"lacks the engine contract attributes {', '.join(missing)}")
        name = engine.name
    if not isinstance(name, str) or not name.isidentifier():
        raise InputError("engine.name", name, "must be a plain word (letters, digits, underscores)")
    _REGISTRY[name] = module if module is not None else engine
    return _REGISTRY[name]


def unregister(name: str) -> None:
    """Remove ``name`` from the registry (no error when absent); for tests and plug-ins."""
    _REGISTRY.pop(name, None)


def get_engine(name: str) -> Engine | ModuleType:
    """The registered engine called ``name`` (built-ins: ``zoa``, ``sdm``, ``spectral``).

    Raises:
        InputError: naming the allowed engines when ``name`` is not registered.
    """
    if not isinstance(name, str) or name not in _REGISTRY:
        raise InputError("engine", name, f"must be one of {', '.join(_REGISTRY)}")
    engine = _REGISTRY[name]
    if isinstance(engine, str):
        # importing a built-in module runs its own register(...) call, which replaces the path
        engine = importlib.import_module(engine)
        _REGISTRY[name] = engine
    return engine


def check_engine_name(name: object, field: str = "--engine") -> str:
    """``name`` when it is a registered engine's, without importing it (a check before any work, where the option
    ``field`` was given).

    Raises:
        InputError: naming ``field``, the value and the registered engines.
    """
    if not isinstance(name, str) or name not in _REGISTRY:
        raise InputError(field, name, f"must be one of {', '.join(_REGISTRY)}")
    return name


def engine_with(**capabilities: object) -> Engine | ModuleType:
    """The first registered engine whose declared capabilities equal all of ``capabilities`` (e.g.
    ``engine_with(cheap=True)``, ``engine_with(accepts_measured_frf=True)``): how a consumer outside
    this package chooses an engine, by what it needs rather than by name.

    The order is the registration order, which is the built-ins' order of preference: ``zoa`` (the
    cheapest: closed-form per frequency), ``sdm``, ``spectral``, then plug-ins. Engines are imported
    only as far as needed (``engine_with(cheap=True)`` imports ``zoa`` alone).

    Raises:
        InputError: naming the capabilities when no registered engine has them all.
    """
    for name in list(_REGISTRY):
        engine = get_engine(name)
        if all(getattr(engine, cap, None) == want for cap, want in capabilities.items()):
            return engine
    wanted = ", ".join(f"{cap}={want!r}" for cap, want in capabilities.items())
    raise InputError("engine", wanted, f"no registered engine ({', '.join(_REGISTRY)}) declares all of these")


def accurate_engine(cutting=None) -> str:
    """The name of the engine to check or refit a time-averaged (zero-order) result with, chosen by capability: the
    cheapest that keeps the interrupted cutting (spectral among the built-ins), or, for a ``cutting`` carrying process
    damping, one that models it (sdm)."""
    if getattr(cutting, "has_process_damping", False):
        return engine_with(time_averaged=False, process_damping=True).name
    return engine_with(time_averaged=False, cheap=True).name


#: teeth in the cut on average below which a cut counts as interrupted (:func:`time_averaged_note`): a gap under
#: 0.5 % of the tooth period is a slot whose exit was written 3.14159 rad ("no tooth cuts for 0% ..." was warned)
INTERRUPTED_BELOW = 0.995


def time_averaged_note(engine: str, cutting, where: str) -> str | None:
    """The first half of a warning when ``engine`` averages the cutting force over the tooth period (the zero-order
    model) and ``cutting`` (described by ``where``, e.g. "a/D 0.1 down milling, 2 teeth") has under one tooth in
    the cut on average (:attr:`millstab.model.Cutting.teeth_in_cut`), else ``None``. There the average misses
    what the interruption does (flip lobes, moved pockets): measured against semi-discretization
    (``benchmarks/bench_zoa_error.py``, 19 tools and conditions), at 0.2-0.75 teeth in the cut the zero-order
    limit is up to 1.0-4.4× too high at single speeds (down milling the worst), at 1-2 teeth at most 1.24×."""
    n = cutting.teeth_in_cut
    if n >= INTERRUPTED_BELOW or not getattr(get_engine(engine), "time_averaged", False):
        return None
    return (f"the {engine} engine averages the cutting force over the tooth period, but in {where} no tooth cuts for "
            f"{1 - n:.0%} of every tooth period ({n:.2f} teeth in the cut on average): its limits there can be off by "
            "a factor at single speeds (flip lobes, moved pockets)")


register("zoa", "millstab.stability.zoa")
register("sdm", "millstab.stability.sdm")
register("spectral", "millstab.stability.spectral")

__all__ = ["ENGINES", "Engine", "Envelope", "accurate_engine", "by_condition", "check_engine_name", "check_rpm",
           "engine_with", "per_set_kr", "per_set_process_damping", "directional_matrix", "get_engine", "register",
           "time_averaged_note", "unregister"]
