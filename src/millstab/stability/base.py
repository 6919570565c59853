"""The engine contract shared by every stability engine: the :class:`Envelope` result and the
:class:`Engine` protocol (name, the two entry points and the declared capabilities).

An engine is any object (usually a module) with these attributes; consumers ask for a capability
(``engine.exact_xy_exchange``) instead of testing the engine's name, so a new engine is one module
plus one :func:`millstab.stability.register` call.

Units: spindle speed in rpm, depth in m (``Envelope.depth_mm`` for mm), chatter frequency in Hz.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any, Callable, Protocol, runtime_checkable

import numpy as np

from millstab.errors import InputError
from millstab.units import is_quantity, quantity_values
from millstab.jsondoc import check_schema, floats_in, floats_out, ints_in, need

#: outputs (sets × speeds) one batched call should hold at most: a few float64 arrays of this many
#: cells stay ~100 MB whatever the number of speeds
CHUNK_CELLS = 4_000_000

#: the attributes every engine must have (checked by :func:`missing_attributes` on registration)
CONTRACT = ("name", "envelope", "envelope_batch", "chunk_rows", "exact_xy_exchange", "accepts_measured_frf",
            "reports_lobe_type", "reports_progress", "cheap", "reports_chatter_frequency", "time_averaged",
            "depth_accuracy")
#: what a consumer outside ``millstab.stability`` may use of an engine beyond :data:`CONTRACT`: the optional
#: capabilities of :class:`Engine` (each declared or checked with ``hasattr``/``engine_with``); any other public
#: function of an engine module (``rho_map``, ``monodromy``, …) is the engine's own (tests/test_layers.py)
OPTIONAL = ("per_set_kr", "process_damping", "per_set_process_damping", "settings", "split_settings",
            "envelope_batch_hz", "lobes",
            "reports_multipliers", "critical_multipliers", "takes_ceiling", "likelihood_ceiling", "takes_floor")

#: the ``"schema"`` of :meth:`Envelope.to_json`
ENVELOPE_SCHEMA = "millstab.envelope/1"


def check_rpm(rpm) -> np.ndarray:
    """Spindle speeds as a 1-D float array [rev/min] (a pint Quantity converted from its unit); InputError for an
    empty list or a speed that is not finite and > 0. Shared by every engine and by the studies (a helper of the
    contract, not of one engine)."""
    if is_quantity(rpm):  # 100 Hz is 6000 rpm: numpy alone would strip the unit and read 100 rpm
        rpm = quantity_values(rpm, "rpm", "frequency") * 60.0
    try:
        r = np.atleast_1d(np.asarray(rpm, dtype=float))
    except (TypeError, ValueError):  # ["5000", "x"], a dict: numpy's message names no field
        raise InputError("rpm", rpm, "need a non-empty 1-D list of spindle speeds, numbers in rev/min") from None
    if r.ndim != 1 or r.size == 0:
        raise InputError("rpm", rpm, "need a non-empty 1-D list of spindle speeds")
    bad = ~np.isfinite(r) | (r <= 0)
    if bad.any():
        raise InputError("rpm", float(r[bad][0]), "spindle speeds must be finite and > 0 rev/min")
    # contiguous always: a strided view (rpm[::2]) would make numba compile each kernel a second time, for
    # layout 'A', after `millstab warmup` had compiled the 'C' one (seen in `make demo`)
    return np.ascontiguousarray(r)


def check_ceiling(ceiling, n_sets: int, n_speeds: int) -> np.ndarray | None:
    """A censored search's ceiling (the ``takes_ceiling`` capability) as a float array (B, S) [m], or None; InputError
    for another shape or a value that is NaN or not positive (inf: no ceiling at that entry)."""
    if ceiling is None:
        return None
    c = np.asarray(ceiling, dtype=float)
    if c.shape != (n_sets, n_speeds) or np.isnan(c).any() or (c <= 0).any():
        raise InputError("ceiling", f"shape {c.shape}",
                         f"a depth > 0 [m] (inf: none) per set and speed, ({n_sets}, {n_speeds})")
    return c


def _per_set(values, n_sets: int, field: str, each: str, allowed: str) -> np.ndarray | None:
    """A per-set value (B,) as a float array, or None; InputError on ``field`` for another length or a value not
    finite and ≥ 0 (``each``: what one value is; ``allowed``: the message for a bad one)."""
    if values is None:
        return None
    v = np.atleast_1d(np.asarray(values, dtype=float))
    if v.shape != (n_sets,):
        raise InputError(field, f"{v.size} values", f"one {each} per parameter set ({n_sets})")
    bad = ~np.isfinite(v) | (v < 0)
    if bad.any():
        raise InputError(field, float(v[bad][0]), allowed)
    return v


def check_kr(kr, n_sets: int) -> np.ndarray | None:
    """A per-set Kr (the ``per_set_kr`` capability) as a float array (B,), or None; InputError for another length or
    a value not finite and ≥ 0."""
    return _per_set(kr, n_sets, "kr", "radial-to-tangential ratio",
                    "radial-to-tangential ratio must be finite and >= 0")


def check_process_damping(pd, n_sets: int) -> np.ndarray | None:
    """A per-set process-damping coefficient C [N/m] (the ``per_set_process_damping`` capability) as a float array
    (B,), or None; InputError for another length or a value not finite and ≥ 0."""
    return _per_set(pd, n_sets, "process_damping", "coefficient C [N/m]",
                    "the process-damping coefficient C [N/m] must be finite and >= 0")


def kr_sets(cutting, kr: np.ndarray | None, n_sets: int) -> np.ndarray:
    """Each set's Kr (B,) for a kernel that reads one per set: ``kr`` (checked by :func:`check_kr`) or the cutting's
    own Kr repeated."""
    return np.full(n_sets, float(cutting.kr)) if kr is None else np.ascontiguousarray(kr, dtype=float)


def check_floor(floor, n_sets: int, n_speeds: int) -> np.ndarray | None:
    """A floored search's floor (the ``takes_floor`` capability) as a float array (B, S) [m], or None; InputError for
    another shape or a NaN (≤ 0 or −inf: no floor at that entry)."""
    if floor is None:
        return None
    f = np.asarray(floor, dtype=float)
    if f.shape != (n_sets, n_speeds) or np.isnan(f).any():
        raise InputError("floor", f"shape {f.shape}", f"a depth [m] (<= 0: none) per set and speed, ({n_sets}, "
                         f"{n_speeds})")
    return f


def directional_matrix(cutting) -> np.ndarray:
    """The 2×2 matrix [α] of directional-coefficient brackets (dimensionless) of ``cutting``.

    α_xx = ½[cos2φ − 2Krφ + Kr sin2φ], α_xy = ½[−sin2φ − 2φ + Kr cos2φ],
    α_yx = ½[−sin2φ + 2φ + Kr cos2φ], α_yy = ½[−cos2φ − 2Krφ − Kr sin2φ], each from φst to φex (the one compiled
    implementation, shared with the zero-order kernel).
    """
    from millstab.stability._zoa_kernel import directional_brackets

    a = directional_brackets(cutting.kr, cutting.entry, cutting.exit)
    return np.array([[a[0], a[1]], [a[2], a[3]]])


@dataclass(frozen=True, eq=False)
class Envelope:
    """The lower envelope of the lobes at given speeds.

    Attributes:
        rpm: spindle speeds (S,) [rev/min].
        depth: limiting axial depth b_lim (S,) [m]; ``inf`` where no chatter boundary exists.
        lobe: lobe number k of the limiting lobe (S,), -1 where none (or not reported).
        chatter_hz: chatter frequency of the limiting lobe (S,) [Hz].
    """

    rpm: np.ndarray
    depth: np.ndarray
    lobe: np.ndarray
    chatter_hz: np.ndarray

    @property
    def depth_mm(self) -> np.ndarray:
        """Limiting depth in mm."""
        return self.depth * 1e3

    def summary(self) -> str:
        """One line: the speeds, the lowest limit [mm] and its speed, and at how many speeds no limit exists."""
        finite = np.isfinite(self.depth)
        line = f"{self.rpm.size} speeds {self.rpm.min():g}..{self.rpm.max():g} rpm; "
        if not finite.any():
            return line + f"no limit at any of the {self.rpm.size} speeds"
        i = int(np.argmin(np.where(finite, self.depth, np.inf)))
        line += f"minimum limit {self.depth_mm[i]:.4g} mm at {self.rpm[i]:.6g} rpm"
        n_inf = int((~finite).sum())
        return line + (f"; no limit at {n_inf} speed{'s' if n_inf > 1 else ''}" if n_inf else "")

    def table(self) -> tuple[list[str], list]:
        """(header, columns) of the SLD CSV: rpm, blim_mm, lobe, chatter_hz (``millstab lobes --out``; ∞: no
        limit, NaN: no chatter frequency)."""
        return ["rpm", "blim_mm", "lobe", "chatter_hz"], [self.rpm, self.depth_mm, self.lobe, self.chatter_hz]

    def figure(self, ax=None, *, title: str | None = None):
        """The limit over speed with its stable region shaded (:func:`millstab.plot.sld.plot_sld`), into
        ``ax`` or a new figure, which it returns."""
        from millstab.plot.sld import plot_sld

        return plot_sld(self.rpm, self.depth_mm, title=title, ax=ax)

    def to_json(self) -> dict[str, Any]:
        """The JSON form (plain types, schema ``millstab.envelope/1``): ``rpm`` [rev/min], ``depth`` [m]
        with ``"inf"`` where no chatter boundary exists, ``lobe`` (integers, -1: none), ``chatter_hz`` [Hz]
        with ``null`` where not defined (no boundary); conventions of :mod:`millstab.jsondoc`. An engine's
        extra fields (e.g. the spectral engine's ``kind``) are not part of this record.

        Raises:
            ValueError: a NaN speed or depth (a result never carries one silently).
        """
        return {"schema": ENVELOPE_SCHEMA, "units": {"rpm": "rev/min", "depth": "m", "chatter_hz": "Hz"},
                "rpm": floats_out(self.rpm, "envelope.rpm"), "depth": floats_out(self.depth, "envelope.depth"),
                "lobe": [int(v) for v in np.asarray(self.lobe).ravel()],
                "chatter_hz": floats_out(self.chatter_hz, "envelope.chatter_hz", nan_ok=True)}

    @staticmethod
    def from_json(doc: Any, source: str = "envelope") -> "Envelope":
        """Rebuild an :class:`Envelope` from :meth:`to_json` output.

        Raises:
            InputError: another schema, a missing field, or arrays of other lengths (named with ``source``).
        """
        check_schema(doc, ENVELOPE_SCHEMA, source)
        rpm = floats_in(need(doc, "rpm", source, list), f"{source}: rpm")
        depth = floats_in(need(doc, "depth", source, list), f"{source}: depth")
        lobe = ints_in(need(doc, "lobe", source, list), f"{source}: lobe")
        hz = floats_in(need(doc, "chatter_hz", source, list), f"{source}: chatter_hz", nan_ok=True)
        for name, arr in (("depth", depth), ("lobe", lobe), ("chatter_hz", hz)):
            if arr.shape != rpm.shape:
                raise InputError(f"{source}: {name}", f"{arr.size} values", f"one per speed ({rpm.size})")
        return Envelope(rpm, depth, lobe, hz)


@runtime_checkable
class Engine(Protocol):
    """What a stability engine provides (a module with these names satisfies it).

    Attributes:
        name: the registry key (``--engine`` value).
        exact_xy_exchange: the generalised x↔y mode exchange (see
            :func:`millstab.identify.symmetry.exchange_map`) leaves its boundary unchanged exactly
            (true of the zero-order model only).
        accepts_measured_frf: ``envelope`` takes a measured-FRF structure (else modal structures only).
        reports_lobe_type: ``envelope`` tells flip from Hopf boundaries (``kind`` per speed).
        reports_progress: ``envelope``/``envelope_batch`` take ``progress=(stage, done, total)``.
        cheap: fast enough (≲ ms per set and speed) for global multi-start searches over thousands of sets.
        reports_chatter_frequency: the batched path gives the limiting lobe's chatter frequency too:
            ``envelope_batch_hz(batch, cutting, rpm)`` → (depth (B, S) [m], chatter_hz (B, S) [Hz]).
        time_averaged: the zero-order model (cutting forces averaged over the tooth period), which is a
            poor one at low radial immersion.
        depth_accuracy: relative accuracy of a limiting depth [-]; residuals below ~10× this are numerical.

    Conditions: ``cutting`` may be a :class:`millstab.model.Conditions` with one condition per speed
        column instead of one :class:`~millstab.model.Cutting`; then depth[b, s] is set b's limit under
        condition s at rpm[s] (the same speed under two conditions is two columns). An engine whose
        kernel works per speed gets this from :func:`by_condition` (one decorator line); the zero-order
        engine shares each set's frequency grid over the conditions in one compiled call.
    per_set_kr (optional capability, default False; :func:`per_set_kr`): ``envelope_batch`` (and
        ``envelope_batch_hz`` where the engine has it) takes ``kr=`` (B,), each set's radial-to-tangential ratio,
        overriding the conditions' Kr (Kr is a property of the tool and material, shared by every condition);
        zoa, sdm and spectral.

    Optional (consumers check with ``hasattr``; an engine without it is called with no keywords):
        process_damping: the engine carries ``Cutting.process_damping`` (absent = False: a cut with
            process damping is an InputError before the engine is called, see
            :mod:`millstab.stability.process_damping`).
        per_set_process_damping: ``envelope_batch`` takes ``process_damping=`` (B,) [N/m], each set's coefficient C,
            overriding every condition's (C belongs to the tool's flank and the material, like Kr; the conditions'
            tool diameter gives the cutting speed): an updating that learns C (sdm).
        settings(batch, cutting, rpm) -> dict: keyword arguments of ``envelope_batch`` that fix the
            engine's discretisation for a whole problem (e.g. the spectral engine's ``{"nodes": p}``),
            chosen once from set 0 of ``batch`` at the speeds ``rpm``. :class:`millstab.forward.Forward`
            asks once per speed list and passes them to every call, so the depths of one problem are
            one smooth function of the parameters (finite differences, least squares); an engine that
            chose its discretisation per call could change it between the calls of one search.
            It may take ``purpose=`` (``"fit"``, the default, or ``"sample"``: a sampler comparing the
            depths with a depth noise, which may need a coarser discretisation); :class:`Forward` passes
            it only when not ``"fit"``.
        critical_multipliers(structure, cutting, rpm) -> (S,) complex: the dominant Floquet multiplier at
            the limiting depth of each speed (modulus ≈ 1; μ ≈ −1 a flip boundary, a complex pair a Hopf one), for
            an engine declaring ``reports_multipliers = True`` (sdm): a consumer asks
            ``engine_with(reports_multipliers=True)``, never an engine by name.
        takes_ceiling: ``envelope_batch`` takes ``ceiling=`` (B, S) [m], a censored search: where every depth of
            the search up to one at or above the ceiling is stable it returns that depth, a certified lower bound
            of the limit, instead of the limit (spectral; with per-column conditions too; its ``envelope_batch_hz``
            takes it too, with NaN frequencies where it applied; read by the decisions and
            the updating's likelihood, whose label terms no
            longer change above it: :meth:`millstab.update.likelihood.Likelihood.ceilings`).
        likelihood_ceiling: ``envelope_batch`` takes ``ceiling=`` as above and only the updating's likelihood uses it,
            not the decisions (zoa: it returns the ceiling itself above it; a cheap engine whose decisions read each
            limit once from their memo).
        takes_floor: ``envelope_batch`` takes ``floor=`` (B, S) [m], the mirror of a ceiling: where it can show cheaply
            that the limit is below the floor it returns a depth below the floor instead of the limit, elsewhere the
            limit itself (spectral; read only by the updating's likelihood, whose label terms no longer change below
            it: :meth:`millstab.update.likelihood.Likelihood.floors`).
    """

    name: str
    exact_xy_exchange: bool
    accepts_measured_frf: bool
    reports_lobe_type: bool
    reports_progress: bool
    cheap: bool
    reports_chatter_frequency: bool
    time_averaged: bool
    depth_accuracy: float

    def envelope(self, structure, cutting, rpm) -> Envelope:
        """The limiting depth [m] at each spindle speed [rpm] (any order) for one structure."""

    def envelope_batch(self, batch, cutting, rpm) -> np.ndarray:
        """Limiting depths (B, S) [m] for B modal parameter sets at S spindle speeds [rpm]."""

    def chunk_rows(self, n_speeds: int) -> int:
        """Parameter sets per ``envelope_batch`` call that callers streaming many sets should use."""


def per_set_kr(engine: object) -> bool:
    """Whether ``engine`` takes a Kr per parameter set (``kr=`` (B,) of ``envelope_batch``)."""
    return bool(getattr(engine, "per_set_kr", False))


def per_set_process_damping(engine: object) -> bool:
    """Whether ``engine`` takes a process-damping coefficient per parameter set (``process_damping=`` (B,))."""
    return bool(getattr(engine, "per_set_process_damping", False))


def merge_settings(parts: list[dict], source: str = "settings") -> dict:
    """One settings dict from the settings chosen per condition: a key all agree on keeps its value; numbers
    that differ take the largest (node counts, steps per period, frequency bounds: the finer discretisation
    serves every condition); anything else that differs is an error of the engine."""
    out: dict = {}
    for key in dict.fromkeys(k for p in parts for k in p):
        values = [p[key] for p in parts if key in p]
        if all(v == values[0] for v in values):
            out[key] = values[0]
        elif all(isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) for v in values):
            out[key] = max(values)
        else:
            raise ValueError(f"{source}: the conditions chose different {key!r} ({values}) and they cannot be merged")
    return out


def by_condition(entry: Callable) -> Callable:
    """Let an engine entry point written for one Cutting (``entry(batch, cutting, rpm, ...)``) take a
    :class:`~millstab.model.Conditions`: the columns are grouped by condition, each group is one call of
    ``entry`` on its own speeds (a kernel that works speed by speed does the same work as one call),
    and the results are put back in column order (a ``ceiling=`` or ``floor=`` (B, S) goes to each group by its
    columns).
    Array results (B, S) and tuples of them are assembled column by column; a dict
    (``settings``/``split_settings``) is merged by :func:`merge_settings`. A plain Cutting goes straight
    through (the same numbers, bit for bit)."""

    @functools.wraps(entry)
    def grouped(batch, cutting, rpm, *args, **kwargs):
        from millstab.model import Conditions

        if not isinstance(cutting, Conditions):
            return entry(batch, cutting, rpm, *args, **kwargs)
        r = check_rpm(rpm)
        cutting.check_columns(r.size)
        # a censored search's ceiling (B, S) is per column: each group gets its own columns' (``takes_ceiling``), and
        # so does a floor (``takes_floor``)
        cap = check_ceiling(kwargs.pop("ceiling", None), batch.size, r.size)
        low = check_floor(kwargs.pop("floor", None), batch.size, r.size)

        def own(cols):
            return {**kwargs, **{name: a[:, cols] for name, a in (("ceiling", cap), ("floor", low)) if a is not None}}

        parts = [(cols, entry(batch, c, r[cols], *args, **own(cols))) for c, cols in cutting.groups()]
        first = parts[0][1]
        if isinstance(first, dict):
            return merge_settings([p for _, p in parts], f"{getattr(entry, '__module__', '')}.{entry.__name__}")
        if isinstance(first, tuple):
            return tuple(_columns([(cols, p[i]) for cols, p in parts], r.size) for i in range(len(first)))
        return _columns(parts, r.size)

    return grouped


def _columns(parts: list[tuple[np.ndarray, Any]], n_columns: int):
    """Arrays (B, S_g) of each group placed at their columns of one (B, S) array (None stays None)."""
    if parts[0][1] is None:
        return None
    first = np.asarray(parts[0][1])
    out = np.empty(first.shape[:-1] + (n_columns,), dtype=first.dtype)
    for cols, part in parts:
        out[..., cols] = part
    return out


def missing_attributes(engine: object) -> list[str]:
    """The contract attributes ``engine`` lacks (empty when it satisfies :class:`Engine`); an engine
    declaring ``reports_chatter_frequency`` needs ``envelope_batch_hz`` too."""
    missing = [a for a in CONTRACT if not hasattr(engine, a)]
    if getattr(engine, "reports_chatter_frequency", False) and not hasattr(engine, "envelope_batch_hz"):
        missing.append("envelope_batch_hz")
    return missing


def memory_chunk_rows(n_speeds: int, most: int) -> int:
    """Sets per call: at most ``most`` and at most CHUNK_CELLS / n_speeds (≥ 1)."""
    return max(1, min(most, CHUNK_CELLS // max(int(n_speeds), 1)))
