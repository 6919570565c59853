"""The stability lobe diagram as a service: limits of a config at given speeds with any registered
engine, an optional second engine for comparison, the CSV table and the figure."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from millstab.progress import Progress
from millstab.errors import InputError
from millstab.config import Config
from millstab.points import PointSet, condition_text
from millstab.stability import ENGINES, Envelope, accurate_engine, check_engine_name, engine_with, get_engine
from millstab.stability import time_averaged_note
from millstab.warnlog import warn

#: the schema tag of :meth:`Lobes.to_json`
SCHEMA = "millstab.lobes/1"


def cheapest_engine() -> str:
    """The name of the cheapest registered engine (the first that declares ``cheap``: ``zoa``), the one a
    caller that must answer at once (the app's own callback) runs without a background job."""
    return engine_with(cheap=True).name


@dataclass(frozen=True, eq=False)
class Lobes:
    """The SLD of one config: ``envelope`` by ``engine`` and, with ``compare``, ``other`` by that engine.

    Units: rpm [rev/min], depths [m] in the envelopes (``*_mm`` helpers in mm), chatter frequency [Hz].
    """

    config: Config
    engine: str
    envelope: Envelope
    compare: str | None = None
    other: Envelope | None = None

    @property
    def rpm(self) -> np.ndarray:
        return self.envelope.rpm

    def minimum(self) -> tuple[float, float]:
        """(rpm, depth [mm]) of the lowest finite limit."""
        d = np.where(np.isfinite(self.envelope.depth), self.envelope.depth, np.inf)
        i = int(np.argmin(d))
        return float(self.rpm[i]), float(self.envelope.depth_mm[i])

    def difference(self) -> tuple[float, float, float] | None:
        """The compared engine against the main one: (max |relative difference|, its rpm, mean), or None."""
        if self.other is None:
            return None
        ok = np.isfinite(self.other.depth) & np.isfinite(self.envelope.depth)
        if not ok.any():
            return None
        rel = np.abs(self.other.depth[ok] / self.envelope.depth[ok] - 1)
        return float(rel.max()), float(self.rpm[ok][np.argmax(rel)]), float(rel.mean())

    def table(self) -> tuple[list[str], list]:
        """(header, columns) of the CSV: rpm, blim_mm, lobe, chatter_hz[, blim_mm_<compare>]."""
        header, cols = self.envelope.table()
        if self.other is not None:
            header, cols = header + [f"blim_mm_{self.compare}"], cols + [self.other.depth_mm]
        return header, cols

    def csv(self) -> str:
        """The CSV text ``millstab lobes --out`` writes."""
        from millstab.io.results import csv_text

        return csv_text(*self.table())

    def summary(self) -> str:
        """What the command prints: the speeds, the engine and the minimum limit; with ``compare`` the
        largest and mean relative difference of the two engines (one line each)."""
        r, d = self.minimum()
        lines = [f"{self.config.name}: {self.rpm.size} speeds {self.rpm.min():g}..{self.rpm.max():g} rpm "
                 f"({self.engine}); minimum limit {d:.4g} mm at {r:.6g} rpm"]
        diff = self.difference()
        if diff is not None:
            lines.append(f"{self.compare} vs {self.engine}: max |difference| {100 * diff[0]:.2f} % at {diff[1]:.6g} "
                         f"rpm, mean {100 * diff[2]:.2f} %")
        return "\n".join(lines)

    def figure(self, ax=None, *, points: PointSet | None = None, lobes=None):
        """The SLD (:func:`millstab.plot.sld.plot_sld`): the limit, the compared engine, and the given raw
        ``lobes`` and measured ``points``; drawn into ``ax`` or a new figure, which it returns."""
        from millstab.plot.sld import plot_sld

        others = [(f"{self.compare} limit", self.rpm, self.other.depth_mm)] if self.other is not None else []
        return plot_sld(self.rpm, self.envelope.depth_mm, label=f"{self.engine} limit", lobes=lobes, points=points,
                        others=others, ax=ax, title=sld_title(self.config))

    def to_json(self) -> dict:
        """``{"schema": "millstab.lobes/1", "config": …, "engine", "envelope", "compare", "other"}``: the
        envelopes in their own schema (:class:`~millstab.stability.Envelope`), the config as a result keeps it
        (:func:`millstab.jsondoc.config_out`: name, cutting, structure)."""
        from millstab.jsondoc import config_out

        return {"schema": SCHEMA, "config": config_out(self.config), "engine": self.engine,
                "envelope": self.envelope.to_json(), "compare": self.compare,
                "other": None if self.other is None else self.other.to_json()}

    @classmethod
    def from_json(cls, doc, source: str = "lobes") -> "Lobes":
        """Rebuild from :meth:`to_json` output. Raises InputError (wrong schema, missing or bad field)."""
        from millstab.jsondoc import check_schema, config_in, need

        check_schema(doc, SCHEMA, source)
        other = need(doc, "other", source, (dict, type(None)))
        return cls(config_in(need(doc, "config", source), f"{source}: config"), need(doc, "engine", source, str),
                   Envelope.from_json(need(doc, "envelope", source, dict), f"{source}: envelope"),
                   need(doc, "compare", source, (str, type(None))),
                   None if other is None else Envelope.from_json(other, f"{source}: other"))


def envelope(cfg: Config, rpm: np.ndarray, engine: str = "zoa", progress: Progress | None = None) -> Envelope:
    """One engine's envelope of ``cfg`` at ``rpm``; an engine that reports progress reports to ``progress``
    (and is cancelled through it). ``cfg``: what :func:`millstab.api.config` takes (a Config, a file,
    ``"example:NAME"``, its tables); ``rpm`` within :func:`millstab.bounds.check_speeds`'s bounds."""
    from millstab.api.inputs import config
    from millstab.bounds import check_speeds

    cfg, rpm = config(cfg), check_speeds(rpm, "rpm")
    eng = get_engine(engine)
    if not cfg.structure.is_modal and not eng.accepts_measured_frf:
        raise InputError("engine", engine, "needs a modal structure; this config's structure is a measured FRF "
                                           "(use zoa, or fit its modes with `millstab modal`)")
    if eng.reports_progress and progress is not None:
        return eng.envelope(cfg.structure, cfg.cutting, rpm, progress=progress)
    return eng.envelope(cfg.structure, cfg.cutting, rpm)


def lobes(cfg: Config, rpm: np.ndarray, *, engine: str = "zoa", compare: str | None = None,
          progress: Progress | None = None, check: bool = True) -> Lobes:
    """The SLD of ``cfg`` at the speeds ``rpm`` [rev/min] with ``engine``, and with ``compare`` beside it.

    A time-averaged engine's SLD is warned of where less than one tooth cuts on average
    (:func:`config_time_averaged_note`) and, with ``check`` where that rule is silent, where its limits at up to 40 of
    the speeds exceed the spectral engine's by more than 1.25× (:func:`averaged_error_note`; ~10–130 ms: the app's
    live redraw leaves it out).

    Raises:
        InputError: an unknown engine, ``compare`` equal to ``engine``, or an engine that cannot take the
            config's structure.
    """
    from millstab.api.inputs import config
    from millstab.bounds import check_speeds

    if compare and compare == engine:
        raise InputError("--compare", compare, f"must differ from --engine ({engine})")
    cfg, rpm = config(cfg), check_speeds(rpm, "rpm")  # a file or example name too, as every task takes it
    env = envelope(cfg, rpm, engine, progress)
    other = envelope(cfg, rpm, compare, progress) if compare else None
    note = config_time_averaged_note(cfg, engine)
    beside = compare and not get_engine(compare).time_averaged  # the time domain drawn beside: nothing to warn
    if note and not beside:
        warn(f"{note}; compare with a time-domain engine (--compare sdm, or --engine spectral)", UserWarning,
             stacklevel=2)
    elif check and not beside and (error := averaged_error_note(cfg, engine, env)):
        warn(error, UserWarning, stacklevel=2)
    return Lobes(cfg, engine, env, compare or None, other)


def averaged_error_note(cfg: Config, engine: str, env: Envelope) -> str | None:
    """The warning for a time-averaged ``engine``'s SLD ``env`` of ``cfg`` where its limits at (up to 40 of) its
    speeds exceed the accurate engine's by more than :data:`millstab.update.model_check.MEDIAN_RATIO`, else None (an
    engine that does not average, a constant directional matrix, a structure the accurate engine does not take)."""
    from millstab.update.model_check import averaged_here, checked_speeds, worst_ratio

    if not averaged_here(engine, cfg.cutting):
        return None
    if not cfg.structure.is_modal or cfg.cutting.process_damping > 0:
        return None
    r = np.asarray(env.rpm, float)
    pick = np.isin(r, checked_speeds(r))
    acc = accurate_engine()
    check = worst_ratio(r[pick], np.asarray(env.depth_mm, float)[pick],
                        get_engine(acc).envelope(cfg.structure, cfg.cutting, r[pick]).depth_mm)
    if check is None or not check["warn"]:
        return None
    return (f"checked against interrupted cutting: the {engine} limits of {cfg.name}'s cut "
            f"({condition_text(cfg.cutting)}) are up to {check['ratio']:.2f}× the {acc} engine's (at "
            f"{check['rpm']:.0f} rpm; median {check['median']:.2f}× over {check['speeds']} speeds): the {engine} model "
            f"averages the force over the tooth period; use --engine {acc} (or --compare {acc})")


def config_time_averaged_note(cfg: Config, engine: str) -> str | None:
    """:func:`millstab.stability.time_averaged_note` for the config's own cut, in the words every study of a config
    uses (``lobes``, ``sensitivity``): "the zoa engine averages ... in ex3's cut (a/D 0.1998 down milling, 3 teeth) ..."
    or None."""
    return time_averaged_note(engine, cfg.cutting, f"{cfg.name}'s cut ({condition_text(cfg.cutting)})")


def sld_title(cfg: Config) -> str:
    """The title of an SLD of ``cfg``: its name, the cutting condition (an SLD holds for one) and the coefficients,
    "t12: a/D 0.3 up milling, 3 teeth, Kt 700 MPa, Kr 0.3"."""
    c = cfg.cutting
    return f"{cfg.name}: {condition_text(c)}, Kt {c.kt / 1e6:g} MPa, Kr {c.kr:g}"


def raw_lobes(cfg: Config, rpm: np.ndarray, engine: str = "zoa") -> list:
    """The individual lobes over the range of ``rpm`` (objects with ``rpm``, ``depth`` [m], ``k``), from an engine
    with the optional ``lobes`` capability (zoa's zero-order lobes).

    Raises:
        InputError: the engine draws no individual lobes.
    """
    eng = get_engine(engine)
    if getattr(eng, "lobes", None) is None:
        with_lobes = [n for n in ENGINES if getattr(get_engine(n), "lobes", None) is not None]
        raise InputError("--raw-lobes", engine,
                         f"needs an engine that draws individual lobes ({', '.join(with_lobes)})")
    return eng.lobes(cfg.structure, cfg.cutting, float(np.min(rpm)), float(np.max(rpm)))


def lobes_figure(result: Lobes, points: PointSet | None = None, raw: bool = False, ax=None):
    """The SLD figure ``millstab lobes --plot`` saves: the limit, the compared engine, the raw lobes and
    the measured points (:meth:`Lobes.figure`; the raw lobes are computed here, the figure only draws)."""
    return result.figure(ax, points=points, lobes=raw_lobes(result.config, result.rpm) if raw else None)
