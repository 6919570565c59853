"""Parameterization: a flat parameter vector θ ↔ modal structures, for every parameter study.

Names (SI units: fn in Hz, k in N/m, zeta dimensionless):

* one mode in a direction: ``fn_x``, ``k_x``, ``zeta_x`` (and ``_y``);
* several modes in a direction: ``fn_x1``, ``fn_x2``, … (1-based); ``fn_x`` then means the
  *dominant* mode of x, the one with the largest peak compliance 1/(2kζ);
* an axisymmetric tool (x and y tied, same number of modes): ``fn``, ``k``, ``zeta`` (or ``fn1``,
  ``fn2``, …; ``fn`` = dominant), each setting the x and the y mode together.

Parameters not free keep the base structure's values. The solvers search u = ln θ themselves
(``np.log`` of :attr:`Parameterization.theta0` and of the bounds; see :mod:`millstab.forward`), which
makes Hz, N/m and ζ comparable and keeps them positive.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np

from millstab.errors import InputError
from millstab.frf import PARAMS, ModalBatch
from millstab.model import Structure

UNITS = {"fn": "Hz", "k": "N/m", "zeta": "-"}


def shown_value(name: str, value: float, digits: int = 5) -> str:
    """A parameter value as printed: ``k…`` in N/µm with its unit, ``fn…`` in Hz, ``zeta…`` bare
    (:data:`millstab.units.SHOWN`)."""
    from millstab.units import shown

    v, unit = shown(value, UNITS[Parameterization.kind(name)])
    return f"{v:.{digits}g}" + (f" {unit}" if unit else "")
_NAME = re.compile(r"^(fn|k|zeta)(?:_([xy]))?(\d*)$")


def _dominant(modes) -> int:
    """Index of the mode with the largest peak compliance 1/(2kζ)."""
    return int(np.argmax([1.0 / (m.k * m.zeta) for m in modes]))


def default_bounds(param: str, value: float) -> tuple[float, float]:
    """Default search bounds around a starting value: fn ×/÷ 2, k ×/÷ 10, ζ ×/÷ 20 within (1e-4, 0.5)."""
    if param == "fn":
        return value / 2.0, value * 2.0
    if param == "k":
        return value / 10.0, value * 10.0
    return max(1e-4, value / 20.0), min(0.5, value * 20.0)


@dataclass(frozen=True, eq=False)
class Parameterization:
    """Which modal parameters are free, how they map onto a base structure, and their bounds.

    Args:
        base: a modal structure supplying every fixed value (and the start).
        free: names of the free parameters (see module docstring); default: every parameter.
        axisymmetric: tie x and y (names without direction suffix).
        bounds: optional {name: (lo, hi)} in physical units, overriding :func:`default_bounds`.
    """

    base: Structure
    free: tuple[str, ...] = ()
    axisymmetric: bool = False
    bounds: Mapping[str, tuple[float, float]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.base.is_modal:
            raise InputError("structure", "measured FRF", "parameter studies need a modal structure")
        if self.axisymmetric and len(self.base.x) != len(self.base.y):
            raise InputError("axisymmetric", f"{len(self.base.x)} x modes, {len(self.base.y)} y modes",
                             "an axisymmetric tool needs the same number of modes in x and y")
        free = tuple(self.free) or self.available()
        canon = tuple(self.canonical(n) for n in free)
        if len(set(canon)) != len(canon):
            raise InputError("free", ",".join(free), "each parameter may be listed once")
        object.__setattr__(self, "free", canon)
        bnds: dict[str, tuple[float, float]] = {}
        given = {self.canonical(k): v for k, v in dict(self.bounds).items()}
        for name, value in zip(canon, self.values(self.base)):
            lo, hi = given.get(name, default_bounds(self.kind(name), value))
            if not 0 < lo < hi:
                raise InputError(f"bounds.{name}", (lo, hi), "need 0 < lower < upper")
            bnds[name] = (float(lo), float(hi))
        object.__setattr__(self, "bounds", bnds)
        # column index into the flat (d, mode, param) layout for each free parameter
        object.__setattr__(self, "_targets", [self._slots(n) for n in canon])

    # --- naming -------------------------------------------------------------------------------
    def _modes(self, d: str):
        return getattr(self.base, d)

    def available(self) -> tuple[str, ...]:
        """Every parameter name of the base structure in canonical form."""
        names = []
        dirs = ("",) if self.axisymmetric else ("x", "y")
        for d in dirs:
            n_modes = len(self._modes(d or "x"))
            for i in range(n_modes):
                for p in PARAMS:
                    suffix = (f"_{d}" if d else "") + (str(i + 1) if n_modes > 1 else "")
                    names.append(p + suffix)
        return tuple(names)

    def canonical(self, name: str) -> str:
        """Canonical form of a parameter name (resolves ``fn_x`` to the dominant mode's name)."""
        m = _NAME.match(name.strip())
        if not m:
            raise InputError("parameter", name, f"unknown name; available: {', '.join(self.available())}")
        p, d, num = m.group(1), m.group(2) or "", m.group(3)
        if self.axisymmetric and d:
            raise InputError("parameter", name, f"an axisymmetric tool has no x/y parameters; use {p}{num}")
        if not self.axisymmetric and not d:
            raise InputError("parameter", name, f"give the direction, e.g. {p}_x{num} (or use the axisymmetric option)")
        modes = self._modes(d or "x")
        if not modes:
            raise InputError("parameter", name, f"direction {d} has no modes (rigid)")
        if num:
            i = int(num) - 1
            if not 0 <= i < len(modes):
                raise InputError("parameter", name, f"direction {d or 'x/y'} has {len(modes)} mode(s)")
        else:
            i = _dominant(modes)
        return p + (f"_{d}" if d else "") + (str(i + 1) if len(modes) > 1 else "")

    @staticmethod
    def kind(name: str) -> str:
        """``fn``, ``k`` or ``zeta`` for a parameter name."""
        return _NAME.match(name).group(1)

    def _slots(self, name: str) -> list[tuple[str, int, str]]:
        m = _NAME.match(name)
        p, d, num = m.group(1), m.group(2), m.group(3)
        i = int(num) - 1 if num else 0
        dirs = ("x", "y") if self.axisymmetric else (d,)
        return [(dd, i, p) for dd in dirs]

    # --- values -------------------------------------------------------------------------------
    @property
    def size(self) -> int:
        """Number of free parameters P."""
        return len(self.free)

    def values(self, structure: Structure) -> np.ndarray:
        """The free parameters' values in a structure (P,) [Hz, N/m, -] (x's value for tied ones)."""
        out = []
        for name in self.free:
            d, i, p = self._slots(name)[0]
            out.append(getattr(getattr(structure, d)[i], p))
        return np.array(out, dtype=float)

    @property
    def theta0(self) -> np.ndarray:
        """The start: the free parameters' values in the base structure."""
        return self.values(self.base)

    @property
    def lower(self) -> np.ndarray:
        return np.array([self.bounds[n][0] for n in self.free])

    @property
    def upper(self) -> np.ndarray:
        return np.array([self.bounds[n][1] for n in self.free])

    def units(self) -> list[str]:
        """Unit of each free parameter."""
        return [UNITS[self.kind(n)] for n in self.free]

    def batch(self, theta: np.ndarray) -> ModalBatch:
        """B structures (a :class:`ModalBatch`) from θ of shape (B, P) or (P,)."""
        t = np.atleast_2d(np.asarray(theta, dtype=float))
        if t.shape[1] != self.size:
            raise InputError("theta", t.shape, f"need {self.size} columns ({', '.join(self.free)})")
        n_b = t.shape[0]
        arrs = {}
        for d in ("x", "y"):
            for p in PARAMS:
                base = np.array([getattr(m, p) for m in self._modes(d)], dtype=float)
                arrs[f"{p}_{d}"] = np.tile(base, (n_b, 1))
        for j, slots in enumerate(self._targets):
            for d, i, p in slots:
                arrs[f"{p}_{d}"][:, i] = t[:, j]
        return ModalBatch(**arrs)

    def structure(self, theta: Sequence[float]) -> Structure:
        """One structure from a parameter vector θ (P,)."""
        return self.batch(np.asarray(theta, dtype=float)[None, :]).structure(0)

    def with_values(self, **values: float) -> np.ndarray:
        """θ0 with some free parameters replaced by name, e.g. ``with_values(fn_x=900)``."""
        theta = self.theta0.copy()
        for name, v in values.items():
            c = self.canonical(name)
            if c not in self.free:
                raise InputError("parameter", name, f"not a free parameter; free: {', '.join(self.free)}")
            theta[self.free.index(c)] = float(v)
        return theta

    def as_dict(self, theta: Sequence[float]) -> dict[str, float]:
        """{name: value} for a parameter vector."""
        return {n: float(v) for n, v in zip(self.free, theta)}

