"""The tool tip of a config's [tool] in its [holder] (receptance coupling) as a service: the tip FRF, its
first modes and, over a range of stickouts, the minimum limiting depth per stickout ("which stickout?").

Units: stickout and depths in mm where a name says ``_mm`` (else m), frequencies Hz, receptance m/N.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from millstab.progress import Progress
from millstab.errors import InputError
from millstab.io.config import load_tool_setup
from millstab.config import Config
from millstab.stability import get_engine
from millstab.tooltip import Tool, XYHolder, peaks, tip_structure
from millstab.tooltip.holder import Holder

#: modes reported per stickout
N_MODES = 3
#: the ``"schema"`` of :meth:`TipFRF.to_json`
SCHEMA = "millstab.tooltip.tip/1"
#: speeds of the sweep when neither the caller nor the config gives any [rpm]: START, STOP, STEP
FALLBACK_RPM = (2000.0, 30000.0, 50.0)


def tool_config(source: str | os.PathLike) -> tuple[Config, Tool, Holder]:
    """``(Config, Tool, Holder)`` of a config file (or ``example:NAME``) with [tool] and [holder]."""
    return load_tool_setup(source)


@dataclass(frozen=True, eq=False)
class StickoutSweep:
    """Per stickout (S,) [m]: the first natural frequencies ``fn_hz`` (S, N_MODES) and peak receptances
    ``peak`` (S, N_MODES) [m/N] of the tip (NaN where fewer peaks lie in the band), and the minimum limiting
    depth ``min_depth_mm`` over the speeds at ``rpm_at_min`` [rev/min], by ``engine``."""

    stickout: np.ndarray
    fn_hz: np.ndarray
    peak: np.ndarray
    min_depth_mm: np.ndarray
    rpm_at_min: np.ndarray
    engine: str
    rpm: np.ndarray

    def best(self) -> int:
        """Index of the stickout with the highest minimum limiting depth."""
        return int(np.nanargmax(self.min_depth_mm))

    def table(self) -> tuple[list[str], list]:
        """(header, columns): stickout_mm, fn1_hz.., peak1_um_per_n.., min_blim_mm, rpm_at_min."""
        cols = {"stickout_mm": self.stickout * 1e3}
        for i in range(self.fn_hz.shape[1]):
            cols[f"fn{i + 1}_hz"] = self.fn_hz[:, i]
        for i in range(self.peak.shape[1]):
            cols[f"peak{i + 1}_um_per_n"] = self.peak[:, i] * 1e6
        cols["min_blim_mm"] = self.min_depth_mm
        cols["rpm_at_min"] = self.rpm_at_min
        return list(cols), list(cols.values())


@dataclass(frozen=True, eq=False)
class TipFRF:
    """The tip FRF of ``tool`` in ``holder``: ``freq_hz`` (F,), ``g`` (F,) complex [m/N] (x), its first modes
    ``fn_hz`` / ``peak`` [Hz, m/N], where asked a :class:`StickoutSweep`, and ``g_y`` (y) where the holder
    differs in y (an :class:`~millstab.tooltip.XYHolder`; else ``None``: y = x)."""

    config: Config
    tool: Tool
    holder: Holder
    freq_hz: np.ndarray
    g: np.ndarray
    fn_hz: np.ndarray
    peak: np.ndarray
    sweep: StickoutSweep | None = None
    g_y: np.ndarray | None = None

    SCHEMA = SCHEMA

    def to_json(self) -> dict:
        """The tip FRF as plain JSON (``"schema"``; SI: Hz, m/N, m): what it was computed from (the config's name,
        cutting and structure, :func:`millstab.jsondoc.config_out`; the tool and the holder, field by field), the
        receptances ``{"re", "im"}``, its modes (NaN where fewer peaks lie in the band) and the sweep, if any."""
        from millstab.jsondoc import complex_out, config_out, fields_out, floats_out

        c = self.config
        return {"schema": SCHEMA, "config": config_out(c), "speeds": floats_out(c.rpm, "speeds"),
                "diameter_m": c.diameter_m, "feed_per_tooth_m": c.feed_per_tooth_m, "tool": _tool_out(self.tool),
                "holder": _holder_out(self.holder), "freq_hz": floats_out(self.freq_hz, "freq_hz"),
                "g": complex_out(self.g, "g"), "g_y": complex_out(self.g_y, "g_y"),
                "fn_hz": floats_out(self.fn_hz, "fn_hz", nan_ok=True),
                "peak": floats_out(self.peak, "peak", nan_ok=True),
                "sweep": None if self.sweep is None else fields_out(self.sweep, "millstab.tooltip.sweep/1")}

    @classmethod
    def from_json(cls, doc: dict, source: str = "tip") -> TipFRF:
        """Rebuild a tip FRF from :meth:`to_json` output (its config with the tool and holder as ``tooltip``).

        Raises:
            InputError: another schema, or a missing or malformed field (named ``source: field``).
        """
        import dataclasses

        from millstab.jsondoc import check_schema, complex_in, config_in, fields_in, floats_in, need

        check_schema(doc, SCHEMA, source)
        tool = _tool_in(need(doc, "tool", source, dict), f"{source}: tool")
        holder = _holder_in(need(doc, "holder", source), f"{source}: holder")
        speeds = doc.get("speeds")
        cfg = dataclasses.replace(config_in(need(doc, "config", source), f"{source}: config"),
                                  rpm=None if speeds is None else floats_in(speeds, f"{source}: speeds"),
                                  tooltip=(tool, holder), diameter_m=doc.get("diameter_m"),
                                  feed_per_tooth_m=doc.get("feed_per_tooth_m"))
        sweep = doc.get("sweep")
        return cls(cfg, tool, holder, floats_in(need(doc, "freq_hz", source), f"{source}: freq_hz"),
                   complex_in(need(doc, "g", source), f"{source}: g"),
                   floats_in(need(doc, "fn_hz", source), f"{source}: fn_hz", nan_ok=True),
                   floats_in(need(doc, "peak", source), f"{source}: peak", nan_ok=True),
                   None if sweep is None else fields_in(StickoutSweep, sweep, "millstab.tooltip.sweep/1",
                                                        f"{source}: sweep"),
                   complex_in(doc.get("g_y"), f"{source}: g_y"))

    def table(self, direction: str = "x") -> tuple[list[str], list]:
        """(header, columns) of the FRF CSV configs read: freq_hz, real, imag [Hz, m/N], of x (or ``"y"``)."""
        g = self.g_y if direction == "y" and self.g_y is not None else self.g
        return ["freq_hz", "real", "imag"], [self.freq_hz, g.real, g.imag]

    def figure(self, ax=None):
        """The tip FRF and, with a sweep, "which stickout?" (:func:`millstab.plot.tooltip.plot_tooltip`), into
        ``ax``'s place or a new figure, which it returns (``millstab tooltip --plot``)."""
        from millstab.plot.tooltip import plot_tooltip

        t = self.tool
        return plot_tooltip(self.freq_hz, self.g, sweep=self.sweep, stickout=t.stickout, ax=ax,
                            title=f"{self.config.name}: {t.diameter * 1e3:g} mm tool, {t.stickout * 1e3:g} mm stickout")

    def summary(self) -> str:
        """What ``millstab tooltip`` prints: the setup, the tip FRF's modes and, with a sweep, its table."""
        t = self.tool
        modes = ", ".join(f"{f:.5g} Hz ({p * 1e6:.3g} um/N)" for f, p in zip(self.fn_hz, self.peak) if np.isfinite(f))
        xy = "" if self.g_y is None else " x"
        lines = [f"{self.config.name}: {t.diameter * 1e3:g} mm {t.material.name} tool at {t.stickout * 1e3:g} mm "
                 f"stickout, {self.holder.describe()}",
                 f"  tip FRF{xy} {self.freq_hz[0]:.4g}..{self.freq_hz[-1]:.6g} Hz ({self.freq_hz.size} lines), static "
                 f"{abs(self.g[0]) * 1e6:.4g} um/N; modes: {modes or 'none in the band'}"]
        if self.g_y is not None:
            fy, py = peaks(self.freq_hz, self.g_y, N_MODES)
            my = ", ".join(f"{f:.5g} Hz ({p * 1e6:.3g} um/N)" for f, p in zip(fy, py) if np.isfinite(f))
            lines.append(f"  tip FRF y: static {abs(self.g_y[0]) * 1e6:.4g} um/N; modes: {my or 'none in the band'}")
        s = self.sweep
        if s is not None:
            b = s.best()
            lines.append(f"  stickout {s.stickout[0] * 1e3:g}..{s.stickout[-1] * 1e3:g} mm ({s.stickout.size}), "
                         f"{s.engine}, {s.rpm.size} speeds: highest minimum limit {s.min_depth_mm[b]:.4g} mm at "
                         f"{s.stickout[b] * 1e3:g} mm stickout; {s.min_depth_mm[-1]:.4g} mm at "
                         f"{s.stickout[-1] * 1e3:g} mm")
            lines.append("  stickout [mm]   fn1 [Hz]   fn2 [Hz]   peak1 [um/N]   min b_lim [mm]   at [rpm]")
            for i in range(s.stickout.size):
                mark = "  <- best" if i == b else ""
                lines.append(f"  {s.stickout[i] * 1e3:13.4g}   {s.fn_hz[i, 0]:8.5g}   {s.fn_hz[i, 1]:8.5g}   "
                             f"{s.peak[i, 0] * 1e6:12.4g}   {s.min_depth_mm[i]:14.4g}   {s.rpm_at_min[i]:8.6g}{mark}")
        return "\n".join(lines)


def _tool_out(t: Tool) -> dict:
    """A tool field by field (SI), its material by name and constants."""
    m = t.material
    return {"diameter": t.diameter, "stickout": t.stickout, "fluted_length": t.fluted_length,
            "flute_ratio": t.flute_ratio, "zeta": t.zeta, "elements": t.elements,
            "material": {"name": m.name, "E": m.E, "density": m.density, "nu": m.nu, "source": m.source}}


def _tool_in(doc: dict, source: str) -> Tool:
    """The inverse of :func:`_tool_out` (the tool validates itself: InputError)."""
    from millstab.jsondoc import int_in, need, number_in
    from millstab.tooltip.beam import Material

    m = need(doc, "material", source, dict)
    mat = Material(need(m, "name", f"{source}.material", str),
                   *(number_in(need(m, k, f"{source}.material"), f"{source}.material.{k}")
                     for k in ("E", "density", "nu")),
                   m.get("source", ""))
    num = {k: number_in(need(doc, k, source), f"{source}.{k}")
           for k in ("diameter", "stickout", "fluted_length", "flute_ratio", "zeta")}
    return Tool(num["diameter"], num["stickout"], mat, num["fluted_length"], num["flute_ratio"], num["zeta"],
                int_in(need(doc, "elements", source), f"{source}.elements"))


def _holder_out(h) -> dict:
    """A holder by its kind: rigid, modal (face modes), measured (receptances ``{"re", "im"}``) or x/y."""
    from millstab.jsondoc import complex_out, floats_out
    from millstab.tooltip.holder import MeasuredHolder, ModalHolder, RigidHolder

    if isinstance(h, RigidHolder):
        return {"kind": "rigid"}
    if isinstance(h, ModalHolder):
        return {"kind": "modal", "modes": [{"fn": m.fn, "k": m.k, "zeta": m.zeta, "slope": m.slope} for m in h.modes]}
    if isinstance(h, MeasuredHolder):
        return {"kind": "measured", "freq_hz": floats_out(h.freq_hz, "holder.freq_hz"), "source": h.source,
                **{t: complex_out(getattr(h, t), f"holder.{t}") for t in ("h", "l", "n", "p")}}
    if isinstance(h, XYHolder):
        return {"kind": "xy", "x": _holder_out(h.x), "y": _holder_out(h.y)}
    raise TypeError(f"holder: cannot write a {type(h).__name__} to JSON")


def _holder_in(doc, source: str):
    """The inverse of :func:`_holder_out`."""
    from millstab.jsondoc import complex_in, floats_in, need, number_in
    from millstab.tooltip.holder import FaceMode, MeasuredHolder, ModalHolder, RigidHolder

    kind = need(doc, "kind", source, str)
    if kind == "rigid":
        return RigidHolder()
    if kind == "modal":
        return ModalHolder(tuple(FaceMode(*(number_in(need(m, k, f"{source}.modes[{i}]"), f"{source}.modes[{i}].{k}")
                                            for k in ("fn", "k", "zeta", "slope")))
                                 for i, m in enumerate(need(doc, "modes", source, list))))
    if kind == "measured":
        return MeasuredHolder(floats_in(need(doc, "freq_hz", source), f"{source}.freq_hz"),
                              *(complex_in(need(doc, t, source), f"{source}.{t}") for t in ("h", "l", "n", "p")),
                              need(doc, "source", source, str))
    if kind == "xy":
        return XYHolder(_holder_in(need(doc, "x", source), f"{source}.x"),
                        _holder_in(need(doc, "y", source), f"{source}.y"))
    raise InputError(f"{source}.kind", kind, "rigid, modal, measured or xy")


def stickouts_mm(spec: str | np.ndarray | None, field: str = "--stickout") -> np.ndarray | None:
    """Stickouts [m] from ``START:STOP:STEP`` in mm (or a sequence of mm values)."""
    if spec is None:
        return None
    if isinstance(spec, str):
        from millstab.parsing import parse_grid

        mm = parse_grid(spec, field, "mm", positive=True, example="30:80:5")
    else:
        mm = np.asarray(spec, dtype=float).ravel()
        if mm.size == 0 or not np.all(np.isfinite(mm)) or np.any(mm <= 0):
            raise InputError(field, spec, "stickouts must be finite lengths > 0 mm")
    if np.max(mm) > 1000:
        raise InputError(field, spec, "stickouts are in mm; more than 1000 mm is not a tool")
    return mm * 1e-3


def stickout_sweep(cfg: Config, tool: Tool, holder: Holder, stickouts: np.ndarray, rpm: np.ndarray, engine: str = "zoa",
          progress: Progress | None = None) -> StickoutSweep:
    """The tip modes and the minimum limiting depth of ``cfg``'s cut at each stickout [m] over ``rpm``."""
    eng = get_engine(engine)
    if not eng.accepts_measured_frf:
        raise InputError("--engine", engine, "the stickout sweep needs an engine that takes a measured FRF (zoa)")
    s = np.asarray(stickouts, dtype=float)
    if np.any(s <= 0):
        raise InputError("stickout", float(s.min()), "must be > 0 m")
    n = s.size
    fn = np.full((n, N_MODES), np.nan)
    pk = np.full((n, N_MODES), np.nan)
    dmin = np.empty(n)
    rmin = np.empty(n)
    for i, L in enumerate(s):  # one compiled envelope per stickout (no batch engine takes FRFs)
        st = tip_structure(tool.at(L), holder)
        frf = st.frf
        fn[i], pk[i] = peaks(frf.freq_hz, frf.xx, N_MODES)  # x: the feed direction
        env = eng.envelope(st, cfg.cutting, rpm)
        d = np.where(np.isfinite(env.depth), env.depth, np.inf)
        j = int(np.argmin(d))
        dmin[i], rmin[i] = env.depth_mm[j], env.rpm[j]
        if progress is not None:
            progress("stickouts", i + 1, n)
    return StickoutSweep(s, fn, pk, dmin, rmin, engine, np.asarray(rpm, float))


def tip_frf(cfg: Config, tool: Tool, holder: Holder, *, stickouts: np.ndarray | None = None,
            rpm: np.ndarray | None = None, engine: str = "zoa", progress: Progress | None = None) -> TipFRF:
    """The tip FRF of ``tool`` in ``holder`` and, with ``stickouts`` [m], the sweep over them at ``rpm``
    (default: the config's [speeds], else 2000..30000 rpm in steps of 50)."""
    frf = tip_structure(tool, holder).frf
    f, g = frf.freq_hz, frf.xx
    g_y = frf.yy if isinstance(holder, XYHolder) else None
    fn, pk = peaks(f, g, N_MODES)
    sw = None
    if stickouts is not None:
        from millstab.api.inputs import speeds

        r = speeds(rpm, cfg, FALLBACK_RPM)
        sw = stickout_sweep(cfg, tool, holder, stickouts, r, engine, progress)
    return TipFRF(cfg, tool, holder, f, g, fn, pk, sw, g_y)


def tip_figure(result: TipFRF):
    """The figure ``millstab tooltip --plot`` saves: :meth:`TipFRF.figure`."""
    return result.figure()


__all__ = ["FALLBACK_RPM", "SCHEMA", "StickoutSweep", "TipFRF", "stickout_sweep", "stickouts_mm", "tip_figure",
           "tip_frf", "tool_config"]
