"""The milling model: structural modes, the structure at the tool tip, and the cutting conditions.

All classes are small frozen dataclasses, validated on construction, SI inside:

* :class:`Mode` -- one mode of the tool tip in one direction: natural frequency ``fn`` [Hz],
  modal stiffness ``k`` [N/m], damping ratio ``zeta`` [-].
* :class:`Structure` -- any number of modes in the feed (x) and cross-feed (y) direction, or a
  measured frequency response (:class:`MeasuredFRF`). A direction without modes is rigid.
* :class:`Cutting` -- number of teeth, tangential cutting coefficient ``kt`` [N/m²], the ratio
  ``kr`` of radial to tangential coefficient, and the entry/exit angles [rad] (Altintas' convention:
  0..π is slotting, down milling exits at π, up milling enters at 0); optionally the process-damping
  coefficient ``process_damping`` C [N/m] and the tool ``diameter`` [m] its cutting speed needs.

A plain number is SI; a string with units (``Mode(903, "12.53 N/um", 0.03)``, ``kt="556 MPa"``,
``entry="90 deg"``) or a pint Quantity is converted to SI as in a config file (:mod:`millstab.units`).
Invalid input raises :class:`millstab.errors.InputError` naming the field, the value and what is
allowed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np

from millstab.bounds import MAX_TEETH
from millstab.errors import FRFWarning, InputError, UnitWarning
from millstab.units import is_quantity, parse_quantity
from millstab.warnlog import quiet, warn

#: Below this modal stiffness [N/m] a value is almost surely N/µm typed as N/m (the seed paper's
#: Table 1 prints "12.53 N/m" for 12.53 N/µm).
SUSPICIOUS_STIFFNESS = 1e4
#: Above this modal stiffness [N/m] (10 000 N/µm) a value is no tool tip's: tool-tip modes measure ~1–100 N/µm
#: and the stiffest spindle modes a few hundred; a larger value is a unit slip (N/mm or MN/m read as N/m, or
#: units applied twice).
IMPLAUSIBLE_STIFFNESS = 1e10
#: Above this tangential cutting coefficient [N/m²] (20 000 MPa) no metal cuts: Kt ≈ 500–1 000 MPa for aluminium,
#: 1 500–3 000 MPa for steels and titanium, ~5 000 MPa for hardened steel.
IMPLAUSIBLE_KT = 2e10
#: Above this Kr = Kn/Kt [-] the radial coefficient is no ratio: measured Kr lie between ~0.1 and ~1.5; a value
#: like 300 is the radial coefficient Kn itself (in MPa), and 40 a percentage.
IMPLAUSIBLE_KR = 5.0
#: Above this tool diameter [m] a value is mm written as m: the largest face mills measure ~1 m (a config refuses
#: a bigger one, the model warns)
LARGEST_DIAMETER = 2.0


def _finite(field_name: str, value: object, dimension: str) -> float:
    """Return ``value`` as a float in SI, or raise if it is not a finite real number.

    A number is SI; a string with units (``"12.53 N/um"``, ``"600 MPa"``, ``"90 deg"``) or a pint Quantity is
    converted from its units to SI as in a config file (:func:`millstab.units.parse_quantity` for ``dimension``),
    which is what the unit warnings below tell a reader to write."""
    if isinstance(value, bool):
        raise InputError(field_name, value, "must be a number, not a boolean")
    if not isinstance(value, float) and (isinstance(value, str) or is_quantity(value)):  # floats: the hot path
        return parse_quantity(value, field_name, dimension)
    try:
        x = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise InputError(field_name, value, "must be a real number") from None
    if not math.isfinite(x):
        raise InputError(field_name, value, "must be a finite number (not NaN or infinity)")
    return x


def check_stiffness(field_name: str, k: float, *, si_only: bool = False, stacklevel: int = 2) -> None:
    """Warn (:class:`UnitWarning`) when a modal stiffness ``k`` [N/m] is almost surely a unit slip: below
    :data:`SUSPICIOUS_STIFFNESS` (N/µm written as N/m) or above :data:`IMPLAUSIBLE_STIFFNESS`. ``field_name`` names
    it as the user wrote it (``structure.x[0].k``, ``--initial k_x``); ``si_only``: the field takes plain SI
    numbers only (``--initial``), so the fix named is the number in N/m rather than a unit."""
    if k < SUSPICIOUS_STIFFNESS:
        fix = (f"write {k * 1e6:g} (N/m: the values are SI)" if si_only
               else f"Give units explicitly, e.g. \"{k:g} N/um\".")
        warn(f"{field_name} = {k:g} N/m is very low for a tool tip; did you mean {k:g} N/um (= {k * 1e6:g} N/m)? "
             f"{fix}", UnitWarning, stacklevel=stacklevel)
    elif k > IMPLAUSIBLE_STIFFNESS:
        unit = "the values are SI (N/m)" if si_only else "a plain number is N/m, e.g. \"12.53 N/um\""
        warn(f"{field_name} = {k:g} N/m ({k * 1e-6:g} N/um) is far stiffer than any tool tip (tool-tip modes "
             f"measure ~1-100 N/um, the stiffest spindle modes a few hundred); check its unit: {unit}",
             UnitWarning, stacklevel=stacklevel)


@dataclass(frozen=True)
class Mode:
    """One structural mode in one direction.

    Attributes:
        fn: undamped natural frequency [Hz], > 0.
        k: modal stiffness [N/m], > 0.
        zeta: viscous damping ratio [-], in (0, 1).
        name: the field name used in error messages (e.g. ``structure.x[0]``).
    """

    fn: float
    k: float
    zeta: float
    name: str = field(default="mode", compare=False, repr=False)

    def __post_init__(self) -> None:
        fn = _finite(f"{self.name}.fn", self.fn, "frequency")
        k = _finite(f"{self.name}.k", self.k, "stiffness")
        zeta = _finite(f"{self.name}.zeta", self.zeta, "dimensionless")
        if fn <= 0:
            raise InputError(f"{self.name}.fn", self.fn, "natural frequency must be > 0 Hz")
        if k <= 0:
            raise InputError(f"{self.name}.k", self.k, "stiffness must be > 0 N/m")
        if not 0 < zeta < 1:
            raise InputError(f"{self.name}.zeta", self.zeta, "damping ratio must be in (0, 1)")
        check_stiffness(f"{self.name}.k", k, stacklevel=4)
        object.__setattr__(self, "fn", fn)
        object.__setattr__(self, "k", k)
        object.__setattr__(self, "zeta", zeta)

    @property
    def omega(self) -> float:
        """Natural frequency [rad/s]."""
        return 2.0 * math.pi * self.fn

    @property
    def mass(self) -> float:
        """Modal mass k/ωn² [kg]."""
        return self.k / self.omega**2


#: at a resonance the imaginary part dominates a receptance: |Im G| ≈ |G| (1/(2ζk) against |Re G| → 0);
#: a sample where Im G > 0 carries at least this share of |G| is a resonance seen with the wrong sign
_RESONANT_SHARE = 0.5


def wrong_sign_resonance(h: np.ndarray) -> int | None:
    """Index of the resonance of a direct receptance whose imaginary part is positive, or ``None``.

    millstab's receptance follows x(t) = Re(G F e^{iωt}): for a mode G = 1/(k(1 − r² + 2iζr)), so a
    passive structure's direct term has Im G ≤ 0 at every frequency, and Im G ≈ −|G| at a resonance.
    Data written in the e^{−iωt} convention (or with the imaginary column negated) have Im G > 0
    there. The test looks at the sample with the largest |Im G| (the strongest resonance) and
    reports it when Im G is positive there and dominates |G|, so a flat or noisy term does not trip it.
    """
    h = np.asarray(h)
    if h.size == 0:
        return None
    i = int(np.argmax(np.abs(h.imag)))
    return i if h.imag[i] > _RESONANT_SHARE * abs(h[i]) else None


def sign_convention_message(term: str, freq_hz: float, h: complex) -> str:
    """The warning text for :func:`wrong_sign_resonance` (``term`` names the term and its file)."""
    return (f"{term}: the imaginary part is positive at the resonance near {freq_hz:.6g} Hz (Im G = {h.imag:.3g} m/N); "
            f"millstab's receptance has Im G < 0 at a resonance (e^{{iωt}} convention, G = 1/(k(1 - r^2 + 2iζr))). "
            f"The data look conjugated (the e^{{-iωt}} sign convention, or a negated imaginary column): negate the "
            f"imaginary part, or the stability limit will be wrong")


@dataclass(frozen=True, eq=False)
class MeasuredFRF:
    """A measured tool-tip frequency response, receptance in m/N, on a common frequency axis.

    ``xx`` and ``yy`` are the direct terms; ``xy``/``yx`` the cross terms (``None`` = not measured,
    taken as zero). A direction given as ``None`` in both its direct term is rigid.

    Convention: x(t) = Re(G F e^{iωt}), so a direct term has Im G < 0 at a resonance; a direct term
    with Im G > 0 there (conjugated data) gives an :class:`~millstab.errors.FRFWarning`.

    Attributes:
        freq_hz: strictly increasing frequencies [Hz], all > 0.
        xx, yy, xy, yx: complex receptances [m/N] at ``freq_hz`` (or ``None``).
    """

    freq_hz: np.ndarray
    xx: np.ndarray | None
    yy: np.ndarray | None
    xy: np.ndarray | None = None
    yx: np.ndarray | None = None

    def __post_init__(self) -> None:
        f = np.asarray(self.freq_hz, dtype=float)
        if f.ndim != 1 or f.size < 4:
            raise InputError("frf.freq_hz", f"{f.size} values", "need at least 4 frequencies")
        if not np.all(np.isfinite(f)) or np.any(f <= 0):
            raise InputError("frf.freq_hz", "non-positive or non-finite value", "frequencies must be > 0 Hz")
        if np.any(np.diff(f) <= 0):
            raise InputError("frf.freq_hz", "unsorted", "frequencies must be strictly increasing")
        object.__setattr__(self, "freq_hz", f)
        if self.xx is None and self.yy is None:
            raise InputError("frf", "no xx and no yy", "a measured FRF needs at least one direct term")
        for term in ("xx", "yy", "xy", "yx"):
            h = getattr(self, term)
            if h is None:
                continue
            h = np.asarray(h, dtype=complex)
            if h.shape != f.shape:
                raise InputError(f"frf.{term}", f"{h.size} values", f"must have one value per frequency ({f.size})")
            if not np.all(np.isfinite(h)):
                raise InputError(f"frf.{term}", "NaN or infinity", "FRF values must be finite")
            object.__setattr__(self, term, h)
            i = wrong_sign_resonance(h) if term in ("xx", "yy") else None
            if i is not None:
                warn(sign_convention_message(f"frf.{term}", f[i], h[i]), FRFWarning, stacklevel=3)

    def matrix(self) -> np.ndarray:
        """The 2×2 receptance matrix per frequency, shape (F, 2, 2), missing terms zero [m/N]."""
        g = np.zeros((self.freq_hz.size, 2, 2), dtype=complex)
        for (i, j), term in zip(((0, 0), (1, 1), (0, 1), (1, 0)), ("xx", "yy", "xy", "yx")):
            h = getattr(self, term)
            if h is not None:
                g[:, i, j] = h
        return g


@dataclass(frozen=True)
class Structure:
    """Tool-tip dynamics: modes in x (feed) and y (cross-feed), or a measured FRF.

    A direction with no modes is rigid (e.g. the classic x-only one-degree-of-freedom benchmark).
    A structure with no mode at all (and no FRF) is an error.
    """

    x: tuple[Mode, ...] = ()
    y: tuple[Mode, ...] = ()
    frf: MeasuredFRF | None = None

    def __post_init__(self) -> None:
        for direction in ("x", "y"):
            modes = getattr(self, direction)
            if isinstance(modes, Mode):  # Structure(x=Mode(...)): one mode, not a tuple of one
                modes = (modes,)
            elif modes is None:
                modes = ()
            try:
                modes = tuple(modes)
            except TypeError:
                raise InputError(f"structure.{direction}", modes, "a Mode or a sequence of Modes") from None
            object.__setattr__(self, direction, modes)
        for direction in ("x", "y"):
            for m in getattr(self, direction):
                if not isinstance(m, Mode):
                    raise InputError(f"structure.{direction}", m, "each entry must be a Mode")
        if self.frf is not None and (self.x or self.y):
            raise InputError("structure", "modes and a measured FRF", "give either modes or a measured FRF, not both")
        if self.frf is None and not (self.x or self.y):
            raise InputError("structure", "no modes", "at least one mode in x or y (or a measured FRF) is required")

    @property
    def is_modal(self) -> bool:
        """True when the structure is given by modal parameters (not a measured FRF)."""
        return self.frf is None

    @property
    def modes(self) -> tuple[Mode, ...]:
        """All modes, x first then y."""
        return self.x + self.y

    def swapped(self) -> Structure:
        """The same structure with x and y interchanged."""
        if self.frf is not None:
            f = self.frf
            with quiet(FRFWarning):  # the terms were checked when this FRF was built
                return Structure(frf=MeasuredFRF(f.freq_hz, f.yy, f.xx, f.yx, f.xy))
        return Structure(x=self.y, y=self.x)

    @classmethod
    def symmetric(cls, fn: float, k: float, zeta: float) -> Structure:
        """One identical mode in x and y (an axisymmetric tool)."""
        return cls(x=(Mode(fn, k, zeta, "structure.x[0]"),), y=(Mode(fn, k, zeta, "structure.y[0]"),))


Milling = Literal["down", "up"]


@dataclass(frozen=True)
class Cutting:
    """Cutting conditions of a straight-fluted end mill with equally spaced teeth.

    Attributes:
        teeth: number of teeth N, a positive integer.
        kt: tangential cutting force coefficient [N/m²] (1 MPa = 1 N/mm² = 1e6 N/m²).
        kr: radial-to-tangential coefficient ratio Kr = Kn/Kt [-] (the seed paper's k_n), ≥ 0.
        entry: entry (start) angle φst [rad], in [0, π).
        exit: exit angle φex [rad], in (0, π], > entry.
        process_damping: the process-damping (flank indentation) coefficient C [N/m], ≥ 0; 0 (the
            default) is no process damping. Each tooth in the cut adds the force −(C b / V)(n·u̇) n
            along its surface normal n, V = π D Ω / 60 the cutting speed (docs/engines.md).
        diameter: tool diameter D [m] (> 0), needed for the cutting speed when process_damping > 0.
    """

    teeth: int
    kt: float
    kr: float
    entry: float = 0.0
    exit: float = math.pi
    process_damping: float = 0.0
    diameter: float | None = None

    def __post_init__(self) -> None:
        if isinstance(self.teeth, bool) or not isinstance(self.teeth, (int, np.integer)):
            if isinstance(self.teeth, float) and self.teeth.is_integer():
                object.__setattr__(self, "teeth", int(self.teeth))
            else:
                raise InputError("cutting.teeth", self.teeth, "number of teeth must be a positive integer")
        if not 1 <= self.teeth <= MAX_TEETH:
            raise InputError("cutting.teeth", self.teeth, f"number of teeth must be a positive integer, at most "
                                                          f"{MAX_TEETH} (the largest face mills carry ~100 inserts)")
        object.__setattr__(self, "teeth", int(self.teeth))
        kt = _finite("cutting.kt", self.kt, "pressure")
        kr = _finite("cutting.kr", self.kr, "dimensionless")
        entry = _finite("cutting.entry", self.entry, "angle")
        exit_ = _finite("cutting.exit", self.exit, "angle")
        if kt <= 0:
            raise InputError("cutting.kt", self.kt, "tangential cutting coefficient must be > 0 N/m^2")
        if kt < 1e5:
            warn(
                f"cutting.kt = {kt:g} N/m^2 is very low for metal cutting; did you mean {kt:g} N/mm^2 (MPa)? "
                f"Give units explicitly, e.g. \"{kt:g} MPa\".",
                UnitWarning,
                stacklevel=3,
            )
        elif kt > IMPLAUSIBLE_KT:
            warn(f"cutting.kt = {kt:g} N/m^2 ({kt * 1e-6:g} MPa) is far above any metal's (Kt is ~500-1 000 MPa for "
                 f"aluminium, 1 500-3 000 MPa for steels, ~5 000 MPa for hardened steel); check its unit: a plain "
                 f"number is N/m^2, e.g. \"2173 MPa\"", UnitWarning, stacklevel=3)
        if kr < 0:
            raise InputError("cutting.kr", self.kr, "radial-to-tangential ratio must be >= 0")
        if kr > IMPLAUSIBLE_KR:
            warn(f"cutting.kr = {kr:g} is no radial-to-tangential ratio Kr = Kn/Kt (measured ones lie between ~0.1 "
                 f"and ~1.5): is it the radial coefficient Kn itself, or a percentage? Give kr = Kn / Kt, e.g. 0.3",
                 UnitWarning, stacklevel=3)
        tol = 1e-12
        if not -tol <= entry <= math.pi + tol:
            raise InputError("cutting.entry", self.entry, "entry angle must be in [0, pi] rad (0..180 deg)")
        if not -tol <= exit_ <= math.pi + tol:
            raise InputError("cutting.exit", self.exit, "exit angle must be in [0, pi] rad (0..180 deg)")
        if entry >= exit_:
            raise InputError("cutting.entry", self.entry,
                             f"entry angle must be less than the exit angle ({exit_:g} rad)")
        object.__setattr__(self, "kt", kt)
        object.__setattr__(self, "kr", kr)
        object.__setattr__(self, "entry", min(max(entry, 0.0), math.pi))
        object.__setattr__(self, "exit", min(max(exit_, 0.0), math.pi))
        pd = _finite("cutting.process_damping", self.process_damping, "stiffness")
        if pd < 0:
            raise InputError("cutting.process_damping", self.process_damping,
                             "process-damping coefficient C must be >= 0 N/m (0: no process damping)")
        object.__setattr__(self, "process_damping", pd)
        if self.diameter is not None:
            d = _finite("cutting.diameter", self.diameter, "length")
            if d <= 0:
                raise InputError("cutting.diameter", self.diameter, "tool diameter must be > 0 m")
            if d > LARGEST_DIAMETER:
                warn(f"cutting.diameter = {d:g} m is very large for a milling tool; did you mean {d:g} mm? "
                     f"Give units explicitly, e.g. \"{d:g} mm\".", UnitWarning, stacklevel=3)
            object.__setattr__(self, "diameter", d)
        if pd > 0 and self.diameter is None:
            raise InputError("cutting.diameter", None, "needed with process damping (the cutting speed "
                                                       "V = pi D n / 60 sets its size); give the tool diameter")

    @property
    def teeth_in_cut(self) -> float:
        """The mean number of teeth in the cut, N (φex − φst) / 2π: below 1 no tooth cuts for part of every tooth
        period (a/D 0.1 with 2 teeth: 0.20; a slot with 2 teeth: 1; with 4 teeth: 2)."""
        return self.teeth * (self.exit - self.entry) / (2 * math.pi)

    @property
    def time_invariant(self) -> bool:
        """Whether the directional matrix [A(t)] is the same at every instant of the tooth period (then the
        zero-order model is the exact stability boundary, not an average: a slot with 4, 6, 8 … teeth).

        Tooth j at angle φ_j adds 2 f(φ_j) g(φ_j)ᵀ, whose entries are a constant, sin 2φ_j and cos 2φ_j; so [A(t)]
        is constant for every Kr iff the number of teeth in the cut is (the engagement φex − φst is k pitches
        2π/N, k ≥ 1 a whole number) and the sum of e^{2iφ_j} over those k teeth is too; that sum turns with φ
        unless it is zero, and Σ_{m<k} e^{4πim/N} = 0 iff N ≥ 3 and 2k is a multiple of N."""
        k = self.teeth_in_cut
        whole = round(k)
        return bool(self.teeth >= 3 and whole >= 1 and abs(k - whole) <= 1e-9 * max(k, 1.0)
                    and (2 * whole) % self.teeth == 0)

    @classmethod
    def from_immersion(cls, teeth: int, kt: float, kr: float, radial_immersion: float, milling: Milling = "down",
                       **extra) -> Cutting:
        """Cutting conditions from the radial immersion a/D in (0, 1] and the milling direction.

        Down (climb) milling: φst = arccos(2a/D − 1), φex = π. Up (conventional) milling: φst = 0,
        φex = arccos(1 − 2a/D). ``extra``: the other fields (``process_damping``, ``diameter``).
        """
        ri = _finite("cutting.radial_immersion", radial_immersion, "dimensionless")
        if not 0 < ri <= 1:
            raise InputError("cutting.radial_immersion", radial_immersion, "radial immersion a/D must be in (0, 1]")
        if milling == "down":
            return cls(teeth, kt, kr, math.acos(2 * ri - 1), math.pi, **extra)
        if milling == "up":
            return cls(teeth, kt, kr, 0.0, math.acos(1 - 2 * ri), **extra)
        raise InputError("cutting.milling", milling, 'must be "down" or "up"')

    @property
    def is_slotting(self) -> bool:
        """True for full immersion (entry 0, exit π)."""
        return self.entry <= 1e-12 and self.exit >= math.pi - 1e-12

    def scaled_kt(self, factor: float) -> Cutting:
        """A copy with Kt multiplied by ``factor``."""
        return replace(self, kt=self.kt * factor)

    @property
    def has_process_damping(self) -> bool:
        """True when the process-damping coefficient is > 0."""
        return self.process_damping > 0

    def without_process_damping(self) -> Cutting:
        """A copy with no process damping (C = 0; the diameter is kept)."""
        return replace(self, process_damping=0.0)

    def process_damping_per_depth(self, rpm) -> np.ndarray:
        """C / V [N·s/m²] at each spindle speed [rpm]: the process damping per unit depth, so that a
        tooth in the cut at depth b [m] carries the damping coefficient b · C / V [N·s/m] along its
        surface normal. V = π D Ω / 60 [m/s]. Zeros when there is no process damping."""
        r = np.asarray(rpm, dtype=float)
        if not self.has_process_damping:
            return np.zeros(r.shape)
        return self.process_damping / (math.pi * self.diameter * r / 60.0)


def condition_index(index, n_conditions: int, field: str = "conditions.index") -> np.ndarray:
    """``index`` as a 1-D int64 array of indices into ``n_conditions`` conditions (integral floats
    accepted); InputError naming ``field`` for anything else."""
    idx = np.asarray(index)
    if idx.ndim != 1:
        raise InputError(field, index, "a 1-D list of condition indices")
    if idx.size and idx.dtype.kind not in "iu":
        if idx.dtype.kind == "f" and np.all(np.isfinite(idx)) and np.all(idx == np.round(idx)):
            idx = idx.astype(np.int64)
        else:
            raise InputError(field, index, "condition indices must be integers")
    idx = idx.astype(np.int64)
    bad = (idx < 0) | (idx >= n_conditions)
    if bad.any():
        raise InputError(field, int(idx[bad][0]), f"an index into the {n_conditions} cutting conditions "
                                                  f"(0..{n_conditions - 1})")
    return idx


@dataclass(frozen=True, eq=False)
class Conditions:
    """The cutting condition of each speed column of one engine call: column s is cut under
    ``cuttings[index[s]]``.

    A shop's test cuts come at several widths, directions and tools, and one set of modal parameters
    must explain them all; the engines evaluate every (speed, condition) column in ONE call
    (:mod:`millstab.stability.base`). The same speed under two conditions is two columns. Build with
    :meth:`of`; a plain :class:`Cutting` stays accepted everywhere (one condition for all columns).

    Attributes:
        cuttings: the distinct conditions (C,), each a validated :class:`Cutting`.
        index: the condition of each column (S,), int in [0, C).
    Properties ``teeth`` (S,) int, ``kt`` (S,) [N/m²], ``kr`` (S,), ``entry``/``exit`` (S,) [rad]: per column.
    """

    cuttings: tuple[Cutting, ...]
    index: np.ndarray

    @classmethod
    def of(cls, cuttings, index=None) -> Conditions:
        """Conditions from a sequence of :class:`Cutting` (or one) and the condition index per column
        (default: one column per cutting, in order)."""
        cs = (cuttings,) if isinstance(cuttings, Cutting) else tuple(cuttings)
        if not cs:
            raise InputError("conditions", "no cutting condition", "give at least one Cutting")
        for i, c in enumerate(cs):
            if not isinstance(c, Cutting):
                raise InputError(f"conditions[{i}]", c, "each condition must be a Cutting")
        idx = np.arange(len(cs)) if index is None else condition_index(index, len(cs))
        if idx.size == 0:
            raise InputError("conditions.index", index, "one condition index per speed column (a non-empty 1-D list)")
        idx.setflags(write=False)
        return cls(cs, idx)

    @classmethod
    def coerce(cls, cutting: Cutting | Conditions, n_columns: int) -> Conditions:
        """``cutting`` as conditions of ``n_columns`` columns (a plain Cutting: the same for every column);
        InputError when a Conditions has another number of columns."""
        if isinstance(cutting, Conditions):
            cutting.check_columns(n_columns)
            return cutting
        if not isinstance(cutting, Cutting):
            raise InputError("cutting", cutting, "a Cutting or a Conditions (one condition per speed column)")
        return cls.of((cutting,), np.zeros(int(n_columns), dtype=np.int64))

    def __len__(self) -> int:
        return int(self.index.size)

    def check_columns(self, n_columns: int) -> None:
        """InputError unless there is one condition per column of ``n_columns`` speeds."""
        if self.index.size != n_columns:
            raise InputError("conditions", f"{self.index.size} conditions",
                             f"one condition per speed column ({n_columns} speeds)")

    def _column(self, attr: str, dtype=float) -> np.ndarray:
        return np.array([getattr(c, attr) for c in self.cuttings], dtype=dtype)[self.index]

    @property
    def teeth(self) -> np.ndarray:
        return self._column("teeth", np.int64)

    @property
    def kt(self) -> np.ndarray:
        return self._column("kt")

    @property
    def kr(self) -> np.ndarray:
        return self._column("kr")

    @property
    def entry(self) -> np.ndarray:
        return self._column("entry")

    @property
    def exit(self) -> np.ndarray:
        return self._column("exit")

    def unique(self) -> tuple[tuple[Cutting, ...], np.ndarray]:
        """(the distinct conditions used, in order of first use, and each column's index into them (S,)):
        equal :class:`Cutting` values given twice are one condition."""
        distinct: dict[Cutting, int] = {}
        remap = np.empty(len(self.cuttings), dtype=np.int64)
        for i, c in enumerate(self.cuttings):
            remap[i] = distinct.setdefault(c, len(distinct))
        used, inverse = np.unique(remap[self.index], return_inverse=True)
        order = list(distinct)
        return tuple(order[u] for u in used), inverse.astype(np.int64).ravel()

    def groups(self) -> list[tuple[Cutting, np.ndarray]]:
        """(condition, its columns (ascending indices)) for each distinct condition used."""
        cuts, inverse = self.unique()
        return [(c, np.flatnonzero(inverse == g)) for g, c in enumerate(cuts)]

    def subset(self, columns) -> Conditions:
        """The conditions of the selected columns (an index array or boolean mask)."""
        return Conditions.of(self.cuttings, self.index[np.asarray(columns)])

    def with_kt(self, factor: float) -> Conditions:
        """A copy with every condition's Kt multiplied by ``factor``."""
        return Conditions.of(tuple(c.scaled_kt(factor) for c in self.cuttings), self.index)

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, Conditions) and self.cuttings == other.cuttings
                and np.array_equal(self.index, other.index))

    def __hash__(self) -> int:
        return hash((self.cuttings, self.index.tobytes()))

    def key(self) -> bytes:
        """A hashable summary (a settings-cache key): the conditions and the index."""
        return repr(self.cuttings).encode() + self.index.tobytes()
