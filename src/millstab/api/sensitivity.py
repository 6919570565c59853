"""Sensitivity studies as a service: one-at-a-time, Monte Carlo (the paper's Table 6), Sobol' and Morris,
around a config's structure or the paper's predicted values, locally or on a Dask cluster."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from millstab.api.inputs import modal
from millstab.progress import Progress, count_progress
from millstab.errors import InputError
from millstab.config import Config

METHODS = ("oat", "mc", "sobol", "morris")
PRESETS = ("paper",)
#: defaults of n per method: MC paths, Sobol base sample (power of 2), Morris trajectories
DEFAULT_N = {"mc": 10_000, "sobol": 1024, "morris": 50}
#: default neighbourhood half-width t and MC's relative change eps
DEFAULT_T, DEFAULT_EPS = 0.1, 0.01


#: the schema tag of :meth:`Study.to_json`
STUDY_SCHEMA = "millstab.sensitivity.study/1"


@dataclass(frozen=True, eq=False)
class Study:
    """A sensitivity study's result (``result``: OATResult, MCResult, SobolResult or MorrisResult) with
    what it was run on: the config, the speeds [rpm], the engine and where its centre came from.
    For Monte Carlo, ``paper`` holds the paper's Table 6 when the parameters are the paper's, and
    ``paper_comparable`` says whether the run used the paper's centre and settings."""

    method: str
    result: Any
    config: Config
    rpm: np.ndarray
    engine: str
    preset: str | None
    centre_source: str
    paper_example: str | None
    paper: dict | None = None
    paper_comparable: bool = False
    extras: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        """``{"schema": "millstab.sensitivity.study/1", "method", "result": the result's own document (Monte
        Carlo with every path), "config" (:func:`millstab.jsondoc.config_out`), "rpm", "engine", "preset",
        "centre_source", "paper_example", "paper", "paper_comparable", "extras"}``: what :meth:`from_json`
        rebuilds the study from. The command line writes :meth:`report_json` (the result's own schema)."""
        from millstab.jsondoc import config_out, floats_out, plain

        result = self.result.to_json(paper=self.paper, paths=True) if self.method == "mc" else self.result.to_json()
        return {"schema": STUDY_SCHEMA, "method": self.method, "result": result, "config": config_out(self.config),
                "rpm": floats_out(self.rpm, "rpm"), "engine": self.engine, "preset": self.preset,
                "centre_source": self.centre_source, "paper_example": self.paper_example,
                "paper": plain(self.paper, "paper"), "paper_comparable": bool(self.paper_comparable),
                "extras": plain(self.extras, "extras", nan_ok=True)}

    @classmethod
    def from_json(cls, doc: Any, source: str = "sensitivity study") -> "Study":
        """Rebuild from :meth:`to_json` output. Raises InputError (wrong schema, missing or bad field)."""
        from millstab.jsondoc import check_schema, config_in, floats_in, need, number_in
        from millstab.sensitivity.results import MCResult, MorrisResult, OATResult, SobolResult

        check_schema(doc, STUDY_SCHEMA, source)
        method = need(doc, "method", source, str)
        kinds = {"oat": OATResult, "mc": MCResult, "sobol": SobolResult, "morris": MorrisResult}
        if method not in kinds:
            raise InputError(f"{source}: method", method, f"must be one of {', '.join(METHODS)}")
        paper = need(doc, "paper", source, (dict, type(None)))
        if paper is not None:
            paper = {k: {s: number_in(v, f"{source}: paper.{k}.{s}") for s, v in need(paper, k, f"{source}: paper",
                                                                                   dict).items()} for k in paper}
        opt = (str, type(None))
        return cls(method, kinds[method].from_json(need(doc, "result", source, dict), f"{source}: result"),
                   config_in(need(doc, "config", source), f"{source}: config"),
                   floats_in(need(doc, "rpm", source, list), f"{source}: rpm"), need(doc, "engine", source, str),
                   need(doc, "preset", source, opt), need(doc, "centre_source", source, str),
                   need(doc, "paper_example", source, opt), paper, need(doc, "paper_comparable", source, bool),
                   need(doc, "extras", source, dict))

    def report_json(self) -> dict:
        """What ``millstab sensitivity --out`` writes: the result's own document (its ``"schema"``; Monte Carlo
        without the paths, the statistics only) and the run's context (config name, preset, centre)."""
        doc = self.result.to_json(paper=self.paper, paths=False) if self.method == "mc" else self.result.to_json()
        if self.method == "mc":
            doc["paper_comparable"] = self.paper_comparable
        doc.update({"config": self.config.name, "preset": self.preset, "centre_source": self.centre_source,
                    "paper_example": self.paper_example})
        return doc

    def header(self) -> str:
        """One line: the config, the speeds, the engine and the centre."""
        r = self.rpm
        return (f"{self.config.name}: {r.size} speeds {r.min():g}..{r.max():g} rpm ({self.engine}); "
                f"centre: {self.centre_source}")

    def summary(self) -> str:
        """The study as the command line prints it: :meth:`header`, then its table (OAT: MSE per parameter
        and change; MC: mean, SD and SEM beside the paper's Table 6; Sobol': S1 and ST; Morris: μ* and σ)."""
        return self.header() + "\n" + _table_text(self)

    def table(self) -> tuple[list[str], list]:
        """(header, columns), one row per parameter, of the numbers :meth:`summary` prints: the result's own
        ``table()`` (OAT the MSE per change; Monte Carlo mean, SD and SEM, with the paper's Table 6 where given;
        Sobol's and Morris' indices)."""
        return self.result.table(self.paper) if self.method == "mc" else self.result.table()

    def figure(self, ax=None):
        """The study's figure (``millstab sensitivity ... --plot``): its result's figure, with the config's name
        (OAT) and the paper's Table 6 where the run is comparable (MC); into ``ax``'s place or a new figure."""
        if self.method == "oat":
            title = f"{self.config.name}: one-at-a-time sensitivity ({self.rpm.size} speeds)"
            return self.result.figure(ax, title=title)
        if self.method == "mc":
            return self.result.figure(ax, paper=self.paper if self.paper_comparable else None)
        return self.result.figure(ax)


def parse_eps(method: str, text: str | None) -> np.ndarray | float | None:
    """``--eps`` as written: for ``oat`` ``START:STOP:STEP`` or a comma list of relative changes
    (``-0.2:0.2:0.05``); for ``mc`` one relative change (``0.01``); ``None`` when not given (the default).
    Other methods take none.

    Raises:
        InputError: text that is not such a grid or number (named ``--eps``).
    """
    if text is None or method not in ("oat", "mc"):
        return None
    if method == "mc":
        try:
            return float(text)
        except ValueError:
            raise InputError("--eps", text, "for mc: one relative change, e.g. 0.01") from None
    if not text:
        return None
    try:
        if ":" in text:
            start, stop, step = (float(p) for p in text.split(":"))
            if not step > 0 or stop < start:
                raise ValueError
            return np.round(start + step * np.arange(int(np.floor((stop - start) / step + 1e-9)) + 1), 12) + 0.0
        return np.array([float(p) for p in text.split(",") if p.strip()])
    except ValueError:
        raise InputError("--eps", text,
                         "for oat: START:STOP:STEP with STEP > 0, or a comma list, e.g. -0.25:0.25:0.05") from None


def parse_bounds(items: Sequence[str]) -> dict[str, tuple[float, float]]:
    """``--bound`` items ``NAME=LOWER:UPPER`` [SI] → {name: (lower, upper)}.

    Raises:
        InputError: an item not of that form (named ``--bound``).
    """
    out = {}
    for item in items:
        name, sep, rng = item.partition("=")
        lo, sep2, hi = rng.partition(":")
        try:
            if not (sep and sep2):
                raise ValueError
            out[name.strip()] = (float(lo), float(hi))
        except ValueError:
            raise InputError("--bound", item, "expected NAME=LOWER:UPPER in SI units, e.g. fn_x=850:950") from None
    return out


def sensitivity(method: str, cfg: Config, rpm: np.ndarray, *, n: int | None = None, t: float | None = None,
                eps: float | Sequence[float] | None = None, seed: int = 0, engine: str = "zoa",
                preset: str | None = None,
                bounds: Mapping[str, tuple[float, float]] | None = None, levels: int = 4, client=None,
                progress: Progress | None = None) -> Study:
    """Run one sensitivity study of the SLD of ``cfg`` at ``rpm`` [rev/min].

    Args:
        method: ``oat``, ``mc``, ``sobol`` or ``morris``.
        n: MC paths, Sobol base sample (a power of 2) or Morris trajectories (:data:`DEFAULT_N`).
        t: neighbourhood half-width (each parameter within [(1−t)p, (1+t)p]); default 0.1.
        eps: OAT's relative changes (a sequence; the paper's grid with ``preset="paper"``) or MC's one
            relative change (0.01).
        preset: ``"paper"``: centre on the paper's predicted parameters when ``cfg`` is its Ex.1, 2 or 3,
            and the paper's OAT grid.
        bounds: {name: (lower, upper)} [SI] replacing the ±t range (sobol, morris).
        client: a ``distributed.Client`` to run MC, Sobol and Morris on (same numbers as locally).
        progress: ``progress(stage, done, total)`` in structures evaluated; cancel by raising.
    Raises:
        InputError: unknown method or preset, bad settings (named).
    """
    from millstab import sensitivity as sa

    if method not in METHODS:
        raise InputError("METHOD", method, f"must be one of {', '.join(METHODS)}")
    if preset is not None and preset not in PRESETS:
        raise InputError("--preset", preset, f"must be one of {', '.join(PRESETS)}")
    from millstab.stability import check_rpm

    rpm = check_rpm(rpm)  # ["5000", "x"], NaN, 0: an InputError naming rpm before any work
    cfg, _ = modal(cfg)
    _warn_time_averaged(cfg, engine)
    example = sa.match_example(cfg.cutting, cfg.structure)
    theta, centre = None, "the config's modal parameters"
    if preset == "paper":
        if example:
            theta = sa.predicted_theta(example)
            centre = f"the paper's {example} predicted values (its Table 3)"
        else:
            centre += " (not a paper example: --preset paper sets only the paper's settings)"
    t_val = DEFAULT_T if t is None else t
    n_val = DEFAULT_N.get(method) if n is None else n
    common = dict(theta=theta, engine=engine)
    context = dict(config=cfg, rpm=rpm, engine=engine, preset=preset, centre_source=centre,
                   paper_example=example)
    if method == "oat":
        grid = sa.PAPER_EPS_GRID if (preset == "paper" and eps is None) else eps
        res = sa.oat(cfg.structure, cfg.cutting, rpm, grid, **common)
        return Study("oat", res, **context)
    cb = count_progress(progress, f"{method}: structures")
    if method == "mc":
        eps_val = DEFAULT_EPS if eps is None else float(eps)
        res = sa.monte_carlo(cfg.structure, cfg.cutting, rpm, n=n_val, t=t_val, eps=eps_val, seed=seed, progress=cb,
                             client=client, **common)
        paper = sa.table6() if set(res.names) == set(sa.table6()) else None
        comparable = (example == "ex1" and preset == "paper" and abs(t_val - DEFAULT_T) < 1e-12
                      and abs(eps_val - DEFAULT_EPS) < 1e-12)
        return Study("mc", res, paper=paper, paper_comparable=comparable, **context)
    if method == "sobol":
        res = sa.sobol(cfg.structure, cfg.cutting, rpm, n=n_val, t=t_val, bounds=bounds or {}, seed=seed, progress=cb,
                       client=client, **common)
    else:
        res = sa.morris(cfg.structure, cfg.cutting, rpm, trajectories=n_val, levels=levels, t=t_val,
                        bounds=bounds or {}, seed=seed, progress=cb, client=client, **common)
    return Study(method, res, **context)


def _warn_time_averaged(cfg: Config, engine: str) -> None:
    """Warn, as ``lobes`` does, when the engine averages the cutting force and less than one tooth cuts on average:
    the sensitivities are then those of a model whose SLD is off by a factor at single speeds there."""
    from warnings import warn

    from millstab.api.lobes import config_time_averaged_note

    note = config_time_averaged_note(cfg, engine)
    if note:
        warn(f"{note}; these are that model's sensitivities: --engine spectral (or sdm) for the time-domain model's",
             UserWarning, stacklevel=3)


def _table_text(study: Study) -> str:
    """The study's table as text (the lines ``millstab sensitivity`` prints after the header): its result's
    ``summary()``, Monte Carlo's beside the paper's Table 6."""
    if study.method == "mc":
        return study.result.summary(study.paper, study.paper_comparable)
    return study.result.summary()
