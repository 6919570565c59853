"""The one result type of every identification solver: :class:`Fit`, and its JSON form.

JSON contract (``Fit.to_json()``; keys may be added, never removed or renamed):

* ``"parameters"``: the identified structure's dominant mode per direction, ``fn_x, k_x, zeta_x, fn_y,
  k_y, zeta_y`` in Hz, N/m and dimensionless (an axisymmetric tool: ``fn, k, zeta``);
* ``"mlae"``: the paper's objective (eq. 4, depths in mm) at the estimate;
* beside them: ``free`` (names), ``estimate`` ({free name: value}), ``units``, ``std_errors``,
  ``correlation``, ``rss``, ``method``, ``iterations``, ``evaluations``, ``time_s``, ``warnings``,
  ``alternatives``, ``symmetry``, ``test_cuts``, ``history`` ({theta, mlae, rss} per iteration),
  ``structure`` (every mode), ``settings``;
* the fit's reliability: ``dof`` (residual degrees of freedom n − p), ``n_points``, ``noise`` (the σ the
  standard errors use and where it comes from: residual scatter, stated or assumed), ``warning_codes``
  (one code per warning kind, :mod:`~millstab.identify.quality`), ``checks`` (χ² and runs tests);
* ``residuals``: one record per boundary point in speed order, ``{rpm, depth_mm, fitted_mm, residual,
  outlier}`` (rev/min, mm, mm, the fit's residual: relative for log residuals, mm for mm ones; outlier: flagged
  by :func:`~millstab.identify.quality.outliers`, its points named in the ``outliers`` warning); empty in
  files written before it;
* ``cutting``: the cutting conditions the points were fitted under (teeth, kt [N/m²], kr, entry and exit
  [rad]), so a fit file cannot be used with a config of other conditions;
* provenance (each optional): ``config`` (the config's name) and ``points`` (the points file the fit was
  made from), the same from the command line and the web app;
* ``schema``: ``"millstab.fit/1"``; ``parameterization``: what :meth:`Fit.from_json` needs to rebuild
  the object exactly: the base structure (``{"x": [{fn, k, zeta}], "y": [...]}``, the fixed values),
  ``free``, ``axisymmetric`` and the search ``bounds`` ({name: [lower, upper]}, SI).

``warning_codes[i]`` is the code of ``warnings[i]`` (every warning carries one code; the solvers raise
each kind once, so the list is also the set of codes in the order raised). Non-finite floats are written
as ``null`` (the convention of :func:`millstab.io.results.to_jsonable`): in ``history`` a ``null`` is
"not computed" (the Newton scheme has no RSS) and reads back as NaN; ``condition`` is ``null`` for
"not computed" (Newton, no standard errors) or for an exactly singular JᵀJ (standard errors present),
which reads back as ∞.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from millstab.errors import InputError
from millstab.jsondoc import check_schema, need
from millstab.model import Cutting, Mode, Structure
from millstab.params import Parameterization

SCHEMA = "millstab.fit/1"
#: the provenance keys of a fit's JSON (top level, each optional): the config's name and the points file
PROVENANCE = ("config", "points")


@dataclass(frozen=True, eq=False)
class Fit:
    """An identification result, frozen: a solver builds it once (later stages make a new one with
    :func:`dataclasses.replace`), and it never changes after it is returned.

    Attributes:
        method: ``lsq`` or ``newton``.
        names: free parameter names (P,); units: their units (Hz, N/m, -).
        estimate: the identified free parameters (P,) [Hz, N/m, -] (canonical x/y order when the data
            are x↔y symmetric).
        start: the starting values (P,).
        mlae: MLAE (paper eq. 4, mm) at the estimate; rss: residual sum of squares of the fitted residuals.
        iterations: solver iterations (all stages); evaluations: parameter sets evaluated by the engine;
        engine_calls: batched engine calls; time_s: wall time [s].
        history_theta: (I, P) the best parameters after each iteration; history_mlae, history_rss: (I,).
        std_errors: approximate standard errors (P,) [same units], ``None`` when not computed (newton).
        correlation: (P, P) correlation matrix of the estimate, or ``None``.
        condition: condition number of JᵀJ in log-parameters, or ``None``.
        warnings: identifiability, convergence and quality warnings (one line each), a tuple.
        codes: the code of each warning, ``codes[i]`` that of ``warnings[i]`` (e.g. ``no_dof``, ``poor_fit``,
            ``residual_structure``, ``zoa_model``, ``xy_symmetry``, ``xy_tied``;
            :mod:`~millstab.identify.quality`), a tuple; :attr:`notes` pairs them.
        dof: residual degrees of freedom n − p (``None`` before :func:`~millstab.identify.quality.diagnose`);
            n_points: boundary points fitted.
        noise: the residual σ the standard errors use: {"sigma" (relative), "source" (``residuals``,
            ``stated`` or ``assumed``), "estimated" (σ̂ = √(RSS/dof), relative), "stated", "assumed"}.
        checks: test statistics behind the quality warnings (χ² p-value, runs test, RMS residual).
        residuals: per boundary point in speed order, {"rpm" [rev/min], "depth_mm", "fitted_mm" [mm],
            "residual", "outlier" (bool)} (:func:`~millstab.identify.quality.point_residuals`), a tuple; empty
            before :func:`~millstab.identify.quality.diagnose`.
        cutting: the cutting conditions of the fitted points, or ``None``.
        alternatives: other parameter sets as good as the estimate: ({"estimate": {...}, "mlae", "rss", "why"}, ...).
        symmetry: a line describing an exact symmetry of the data (x↔y), or ``None``.
        test_cuts: how the fitted SLD classifies the labelled test cuts (counts), or ``None``.
        settings: solver settings used (for reproducibility); ``settings["xy_tie_test"]`` is the x = y
            test's record (:attr:`tie`).
        provenance: what the fit was made from, ``{"config": the config's name, "points": the points file}``
            (either may be absent), set by :func:`millstab.api.identify` and written as the JSON's top-level
            ``"config"`` and ``"points"``: the command line and the web app write the same file (issue 26).

    Frozen means no field is reassigned; the dicts inside (settings, noise, checks, test_cuts, the
    alternatives) are plain dicts for the JSON and must be treated as read-only too.
    """

    method: str
    par: Parameterization
    estimate: np.ndarray
    start: np.ndarray
    mlae: float
    rss: float
    iterations: int
    evaluations: int
    engine_calls: int
    time_s: float
    history_theta: np.ndarray
    history_mlae: np.ndarray
    history_rss: np.ndarray
    std_errors: np.ndarray | None = None
    correlation: np.ndarray | None = None
    condition: float | None = None
    warnings: tuple[str, ...] = ()
    alternatives: tuple[dict[str, Any], ...] = ()
    symmetry: str | None = None
    test_cuts: dict[str, int] | None = None
    settings: dict[str, Any] = field(default_factory=dict)
    codes: tuple[str, ...] = ()
    dof: int | None = None
    n_points: int | None = None
    noise: dict[str, Any] | None = None
    checks: dict[str, Any] = field(default_factory=dict)
    cutting: Cutting | None = None
    provenance: dict[str, str] = field(default_factory=dict)
    residuals: tuple[dict[str, Any], ...] = ()

    def __post_init__(self) -> None:
        for name in ("warnings", "codes", "alternatives", "residuals"):
            object.__setattr__(self, name, tuple(getattr(self, name)))
        if len(self.codes) != len(self.warnings):
            raise ValueError(f"every warning needs its code: {len(self.warnings)} warnings, {len(self.codes)} codes")

    def with_warnings(self, notes, first: bool = False, **changes: Any) -> "Fit":
        """A new fit with the (code, message) pairs ``notes`` added (before the others with ``first``),
        and any other field ``changes`` (:func:`dataclasses.replace`)."""
        import dataclasses

        codes = tuple(c for c, _ in notes)
        texts = tuple(t for _, t in notes)
        if first:
            codes, texts = codes + self.codes, texts + self.warnings
        else:
            codes, texts = self.codes + codes, self.warnings + texts
        return dataclasses.replace(self, codes=codes, warnings=texts, **changes)

    @property
    def notes(self) -> tuple[dict[str, str], ...]:
        """The warnings with their codes: ({"code", "message"}, ...)."""
        return tuple({"code": c, "message": w} for c, w in zip(self.codes, self.warnings))

    @property
    def tie(self) -> dict[str, Any] | None:
        """The x = y test (:mod:`~millstab.identify.tie`): {"F", "p_value", "tied_pairs", "rss_tied", "rss_free",
        "alpha", "tied_iterations", "chosen": "tied" or "free"}, or ``None`` where it was not run."""
        return self.settings.get("xy_tie_test") or None

    @property
    def tied(self) -> bool:
        """Whether the estimate is the tied (x = y) one."""
        return (self.tie or {}).get("chosen") == "tied"

    @property
    def symmetry_kind(self) -> str | None:
        """The exact symmetry of the data ``symmetry`` describes: ``"xy_swap"`` (x and y interchangeable,
        α_xx = α_yy; a tied fit came from such a cut), ``"xy_exchange"`` (the zero-order x↔y mode exchange)
        or ``None``."""
        if "xy_symmetry" in self.codes or "xy_tied" in self.codes:
            return "xy_swap"
        if "xy_exchange" in self.codes:
            return "xy_exchange"
        return None

    @property
    def names(self) -> tuple[str, ...]:
        return self.par.free

    @property
    def units(self) -> list[str]:
        return self.par.units()

    @property
    def structure(self) -> Structure:
        """The identified structure (fixed parameters from the start structure)."""
        return self.par.structure(self.estimate)

    def as_dict(self) -> dict[str, float]:
        """{free name: value} [Hz, N/m, -]."""
        return self.par.as_dict(self.estimate)

    def parameters(self) -> dict[str, float]:
        """The JSON contract's ``parameters``: dominant mode per direction (or fn, k, zeta if axisymmetric)."""
        s = self.structure
        out: dict[str, float] = {}
        dirs = ("",) if self.par.axisymmetric else ("x", "y")
        for d in dirs:
            modes = s.x if d in ("", "x") else s.y
            if not modes:
                continue
            m = modes[int(np.argmax([1.0 / (mm.k * mm.zeta) for mm in modes]))]
            suffix = f"_{d}" if d else ""
            out.update({f"fn{suffix}": m.fn, f"k{suffix}": m.k, f"zeta{suffix}": m.zeta})
        return out

    def figure(self, ax=None):
        """The objective against iteration (:func:`millstab.plot.identify.plot_convergence`; the identified
        SLD over the points needs the engine: ``millstab.api.fit_figure``), into ``ax`` or a new figure."""
        from millstab.plot.identify import plot_convergence

        return plot_convergence(self, ax=ax)

    def table(self) -> tuple[tuple[str, ...], tuple[list, ...]]:
        """(header, columns) of the fitted parameters as the trade reads them (stiffness N/µm, fn Hz, ζ bare;
        :data:`millstab.units.SHOWN`): parameter, start, estimate, std_error (NaN: not computed), unit."""
        from millstab.units import shown

        rows = [(name, shown(self.start[i], unit), shown(self.estimate[i], unit),
                 shown(math.nan if self.std_errors is None else self.std_errors[i], unit))
                for i, (name, unit) in enumerate(zip(self.names, self.units))]
        return (("parameter", "start", "estimate", "std_error", "unit"),
                ([r[0] for r in rows], [r[1][0] for r in rows], [r[2][0] for r in rows], [r[3][0] for r in rows],
                 [r[1][1] for r in rows]))

    def loose(self, rel: float = 0.05) -> tuple[str, ...]:
        """The free parameters whose relative standard error exceeds ``rel`` (none without standard errors):
        what further tests (``millstab design --fit``) would pin."""
        if self.std_errors is None:
            return ()
        return tuple(n for n, se, v in zip(self.names, self.std_errors, self.estimate) if se / v > rel)

    def summary(self) -> str:
        """What the fit says beside its table, one line each: MLAE and RSS, the degrees of freedom and where
        the standard errors' noise comes from, the test cuts, the warnings, the alternatives."""
        from millstab.params import shown_value

        residual = self.settings.get("residual", "log")
        lines = [f"MLAE {self.mlae:.4g} (mm, eq. 4); RSS {self.rss:.4g} ({residual} residuals)"]
        if self.dof is not None:
            p = self.n_points - self.dof
            line = f"degrees of freedom: {self.n_points} boundary points − {p} parameters = {self.dof}"
            nz = self.noise or {}
            if self.std_errors is not None and nz:
                pct = f"{100 * nz['sigma']:.3g} %"
                how = {"residuals": f"the residual scatter ({pct})", "stated": f"the stated depth noise ({pct})",
                       "assumed": f"an assumed depth noise ({pct}; give --noise)"}[nz["source"]]
                if nz.get("points") is not None:  # a robust fit's σ from the points it keeps
                    how = f"{how} of the {nz['points']} points kept (outliers left out)"
                line = f"{line}; standard errors from {how}"
            lines.append(line)
        if self.test_cuts:
            c = self.test_cuts
            lines.append(f"test cuts: {c['stable_predicted_chatter']} of {c['stable_cuts']} stable cuts predicted "
                         f"chatter; {c['chatter_predicted_stable']} of {c['chatter_cuts']} chatter cuts predicted "
                         "stable")
        lines += [f"warning: {w}" for w in self.warnings]
        for a in self.alternatives:
            vals = ", ".join(f"{k}={shown_value(k, v)}" for k, v in a["estimate"].items())
            lines.append(f"alternative: {vals} (MLAE {a['mlae']:.4g}, RSS {a['rss']:.4g})")
        return "\n".join(lines)

    def to_json(self) -> dict[str, Any]:
        """The JSON form (see module docstring), plain JSON types only."""
        from millstab.io.results import to_jsonable

        s = self.structure
        se = None if self.std_errors is None else {n: float(v) for n, v in zip(self.names, self.std_errors)}
        return to_jsonable({
            "schema": SCHEMA,
            "parameters": self.parameters(),
            "mlae": float(self.mlae),
            "rss": float(self.rss),
            "method": self.method,
            "free": list(self.names),
            "units": dict(zip(self.names, self.units)),
            "estimate": self.as_dict(),
            "start": self.par.as_dict(self.start),
            "std_errors": se,
            "correlation": None if self.correlation is None else self.correlation,
            "condition": self.condition,
            "iterations": int(self.iterations),
            "evaluations": int(self.evaluations),
            "engine_calls": int(self.engine_calls),
            "time_s": float(self.time_s),
            "warnings": list(self.warnings),
            "alternatives": list(self.alternatives),
            "symmetry": self.symmetry,
            "test_cuts": self.test_cuts,
            "structure": _structure_record(s),
            "settings": self.settings,
            "dof": None if self.dof is None else int(self.dof),
            "n_points": None if self.n_points is None else int(self.n_points),
            "noise": self.noise,
            "warning_codes": list(self.codes),
            "checks": self.checks,
            "residuals": list(self.residuals),
            "cutting": None if self.cutting is None else cutting_record(self.cutting),
            "history": {"theta": self.history_theta, "mlae": self.history_mlae, "rss": self.history_rss},
            **{k: self.provenance[k] for k in PROVENANCE if k in self.provenance},
            "parameterization": {"base": _structure_record(self.par.base), "free": list(self.par.free),
                                 "axisymmetric": bool(self.par.axisymmetric),
                                 "bounds": {n: list(b) for n, b in self.par.bounds.items()}},
        })

    @classmethod
    def from_json(cls, doc: Any, source: str = "fit") -> "Fit":
        """Rebuild a fit from :meth:`to_json` output (e.g. a ``millstab identify --out`` file read with
        :func:`millstab.io.read_json`); ``source`` (the file name) is named in every error.

        A file written before the schema existed (no ``"schema"``, no ``"parameterization"``) is read
        too: its parameterization is the identified structure with the default bounds around it.

        Raises:
            InputError: another schema, a missing field, or a field of the wrong kind (named).
        """
        if isinstance(doc, dict) and "schema" not in doc and "parameterization" not in doc and "free" in doc:
            par = _legacy_parameterization(doc, source)
        else:
            check_schema(doc, SCHEMA, source)
            par = _parameterization(need(doc, "parameterization", source, dict), f"{source}: parameterization")
        names = par.free

        def vector(key: str, optional: bool = False) -> np.ndarray | None:
            rec = need(doc, key, source, (dict, type(None)) if optional else dict)
            if rec is None:
                return None
            missing = [n for n in names if n not in rec]
            if missing:
                raise InputError(f"{source}: {key}.{missing[0]}", "missing",
                                 f"one value per free parameter ({', '.join(names)})")
            return _floats([rec[n] for n in names], f"{source}: {key}")

        hist = need(doc, "history", source, dict)
        corr = need(doc, "correlation", source, (list, type(None)))
        std_errors = vector("std_errors", optional=True)
        condition = need(doc, "condition", source, (int, float, type(None)))
        if condition is None and std_errors is not None:
            condition = math.inf  # an exactly singular JᵀJ (module docstring)
        # "cutting" is absent from fits written before the cutting record (read as unknown)
        cut = need(doc, "cutting", source, (dict, type(None))) if "cutting" in doc else None
        warnings = _strings(need(doc, "warnings", source, list), f"{source}: warnings")
        codes = _strings(need(doc, "warning_codes", source, list), f"{source}: warning_codes")
        if len(codes) != len(warnings):
            raise InputError(f"{source}: warning_codes", f"{len(codes)} codes for {len(warnings)} warnings",
                             "one code per warning")
        optional_int = (int, type(None))
        try:
            return cls(
                method=need(doc, "method", source, str), par=par, estimate=vector("estimate"), start=vector("start"),
                mlae=float(need(doc, "mlae", source, (int, float))), rss=float(need(doc, "rss", source, (int, float))),
                iterations=need(doc, "iterations", source, int), evaluations=need(doc, "evaluations", source, int),
                engine_calls=need(doc, "engine_calls", source, int),
                time_s=float(need(doc, "time_s", source, (int, float))),
                history_theta=_floats(need(hist, "theta", f"{source}: history", list), f"{source}: history.theta",
                                      null_nan=True, shape=(None, len(names))),
                history_mlae=_floats(need(hist, "mlae", f"{source}: history", list), f"{source}: history.mlae",
                                     null_nan=True),
                history_rss=_floats(need(hist, "rss", f"{source}: history", list), f"{source}: history.rss",
                                    null_nan=True),
                std_errors=std_errors,
                correlation=None if corr is None else _floats(corr, f"{source}: correlation",
                                                              shape=(len(names), len(names))),
                condition=None if condition is None else float(condition),
                warnings=warnings, codes=codes,
                alternatives=tuple(need(doc, "alternatives", source, list)),
                symmetry=need(doc, "symmetry", source, (str, type(None))),
                test_cuts=need(doc, "test_cuts", source, (dict, type(None))),
                settings=need(doc, "settings", source, dict),
                dof=need(doc, "dof", source, optional_int), n_points=need(doc, "n_points", source, optional_int),
                noise=need(doc, "noise", source, (dict, type(None))), checks=need(doc, "checks", source, dict),
                cutting=None if cut is None else _cutting(cut, f"{source}: cutting"),
                # absent from fits written before the per-point record
                residuals=tuple(need(doc, "residuals", source, list)) if "residuals" in doc else (),
                provenance={k: need(doc, k, source, str) for k in PROVENANCE if k in doc})
        except ValueError as exc:  # e.g. warnings without codes
            raise InputError(source, "fit record", str(exc)) from None


def _structure_record(s: Structure) -> dict[str, list[dict[str, float]]]:
    """{"x": [{fn, k, zeta}, ...], "y": [...]} of a modal structure (Hz, N/m, -)."""
    return {d: [{"fn": m.fn, "k": m.k, "zeta": m.zeta} for m in getattr(s, d)] for d in ("x", "y")}


def _structure(rec: Any, source: str) -> Structure:
    """The inverse of :func:`_structure_record` (the modes validate their own values)."""
    if not isinstance(rec, dict):
        raise InputError(source, type(rec).__name__, "must be an object {\"x\": [modes], \"y\": [modes]}")
    modes = {}
    for d in ("x", "y"):
        items = need(rec, d, source, list)
        out = []
        for i, m in enumerate(items):
            where = f"{source}.{d}[{i}]"
            if not isinstance(m, dict):
                raise InputError(where, type(m).__name__, "a mode is an object {fn, k, zeta}")
            out.append(Mode(*(float(need(m, key, where, (int, float))) for key in ("fn", "k", "zeta")), where))
        modes[d] = tuple(out)
    return Structure(**modes)


def _parameterization(rec: dict, source: str) -> Parameterization:
    """The fit's parameterization from its record (base structure, free names, axisymmetric, bounds)."""
    base = _structure(need(rec, "base", source, dict), f"{source}.base")
    free = _strings(need(rec, "free", source, list), f"{source}.free")
    axi = need(rec, "axisymmetric", source, bool)
    bounds = need(rec, "bounds", source, dict)
    pairs = {}
    for name, b in bounds.items():
        if not (isinstance(b, list) and len(b) == 2):
            raise InputError(f"{source}.bounds.{name}", b, "a [lower, upper] pair")
        pairs[name] = tuple(_floats(b, f"{source}.bounds.{name}"))
    return Parameterization(base, free, axi, pairs)


def _legacy_parameterization(doc: dict, source: str) -> Parameterization:
    """A fit file without ``parameterization``: the identified structure, default bounds around it."""
    names = _strings(need(doc, "free", source, list), f"{source}: free")
    base = _structure(need(doc, "structure", source, dict), f"{source}: structure")
    return Parameterization(base, names, all("_" not in n for n in names))


def _cutting(rec: dict, source: str) -> Cutting:
    """Cutting conditions from :func:`cutting_record` (the conditions validate themselves)."""
    vals = {k: need(rec, k, source, (int, float)) for k in ("teeth", "kt", "kr", "entry", "exit")}
    if "process_damping" in rec:
        vals |= {k: need(rec, k, source, (int, float)) for k in ("process_damping", "diameter")}
    return Cutting(**{k: (v if k == "teeth" else float(v)) for k, v in vals.items()})


def _strings(items: list, source: str) -> tuple[str, ...]:
    if not all(isinstance(v, str) for v in items):
        raise InputError(source, items, "must be a list of strings")
    return tuple(items)


def _floats(values: Any, source: str, null_nan: bool = False, shape: tuple | None = None) -> np.ndarray:
    """A float array from JSON lists; ``null`` is NaN only with ``null_nan`` (else InputError)."""
    flat = np.asarray(values, dtype=object).ravel() if values != [] else np.zeros(0, dtype=object)
    bad = [v for v in flat if not (isinstance(v, (int, float)) and not isinstance(v, bool) or v is None and null_nan)]
    if bad:
        raise InputError(source, bad[0], "must be numbers" + (" (null: not computed)" if null_nan else ""))
    try:
        arr = np.array(values, dtype=float)
    except (ValueError, TypeError):
        raise InputError(source, "ragged lists", "rows must have equal lengths") from None
    if shape is not None:
        if arr.size == 0 and shape[0] is None:
            arr = arr.reshape(0, shape[1])
        if arr.ndim != len(shape) or any(want is not None and got != want for got, want in zip(arr.shape, shape)):
            want = tuple("any" if w is None else w for w in shape)
            raise InputError(source, f"shape {arr.shape}", f"need shape {want}")
    return arr


def cutting_record(cutting: Cutting) -> dict[str, float]:
    """The JSON record of cutting conditions: teeth, kt [N/m²], kr [-], entry and exit [rad]; with
    process damping also process_damping [N/m] and diameter [m] (absent: none)."""
    rec = {"teeth": int(cutting.teeth), "kt": float(cutting.kt), "kr": float(cutting.kr),
           "entry": float(cutting.entry), "exit": float(cutting.exit)}
    if cutting.has_process_damping:
        rec |= {"process_damping": float(cutting.process_damping), "diameter": float(cutting.diameter)}
    return rec


def cutting_difference(record, cutting: Cutting) -> str | None:
    """How a recorded cutting (:func:`cutting_record`, e.g. from a fit file) differs from ``cutting``
    (first differing field, both values shown as a user writes them), or ``None`` when the same
    (relative tolerance 1e-9)."""
    import math

    want = cutting_record(cutting)
    show = {"teeth": lambda v: f"{v:g}", "kt": lambda v: f"{v / 1e6:.6g} MPa", "kr": lambda v: f"{v:.6g}",
            "entry": lambda v: f"{math.degrees(v):.6g}°", "exit": lambda v: f"{math.degrees(v):.6g}°"}
    for key, fmt in show.items():
        got = record.get(key) if isinstance(record, dict) else None
        if isinstance(got, bool) or not isinstance(got, (int, float)):
            return f"cutting {key} is missing from the fit's record ({got!r})"
        if not math.isclose(float(got), want[key], rel_tol=1e-9, abs_tol=1e-12):
            return f"cutting {key} is {fmt(float(got))} in the fit but {fmt(want[key])} here"
    # process damping: absent from a record means none (records written before it existed)
    got_pd = record.get("process_damping", 0.0) if isinstance(record, dict) else 0.0
    if isinstance(got_pd, (int, float)) and not isinstance(got_pd, bool) and not math.isclose(
            float(got_pd), want.get("process_damping", 0.0), rel_tol=1e-9, abs_tol=1e-12):
        return (f"cutting process_damping is {float(got_pd):.6g} N/m in the fit but "
                f"{want.get('process_damping', 0.0):.6g} N/m here")
    return None


__all__ = ["SCHEMA", "Fit", "cutting_difference", "cutting_record"]
