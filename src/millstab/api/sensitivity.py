"""Sensitivity studies as a service: one-at-a-time, Monte Carlo (the paper's Table 6), Sobol' and Morris,
around a config's structure or the paper's predicted values, locally or on a Dask cluster."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from millstab.api.inputs import modal
from millstab.api.progress import Progress, count_progress
from millstab.errors import InputError
from millstab.io.config import Config

METHODS = ("oat", "mc", "sobol", "morris")
PRESETS = ("paper",)
#: defaults of n per method: MC paths, Sobol base sample (power of 2), Morris trajectories
DEFAULT_N = {"mc": 10_000, "sobol": 1024, "morris": 50}
#: default neighbourhood half-width t and MC's relative change eps
DEFAULT_T, DEFAULT_EPS = 0.1, 0.01


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

    def to_json(self, paths: bool = True) -> dict:
        """The result's JSON (with its ``"schema"``) and the run's context (config, preset, centre); Monte
        Carlo without ``paths``: the statistics only (the command line's file)."""
        doc = self.result.to_json(paper=self.paper, paths=paths) if self.method == "mc" else self.result.to_json()
        if self.method == "mc":
            doc["paper_comparable"] = self.paper_comparable
        doc.update({"config": self.config.name, "preset": self.preset, "centre_source": self.centre_source,
                    "paper_example": self.paper_example})
        return doc

    def header(self) -> str:
        r = self.rpm
        return (f"{self.config.name}: {r.size} speeds {r.min():g}..{r.max():g} rpm ({self.engine}); "
                f"centre: {self.centre_source}")

    def figure(self):
        """The study's figure (``millstab sensitivity ... --plot``)."""
        from millstab.plot import sensitivity as ps

        if self.method == "oat":
            return ps.plot_oat(self.result, title=f"{self.config.name}: one-at-a-time sensitivity ({self.rpm.size} speeds)")
        if self.method == "mc":
            return ps.plot_mc_convergence(self.result, paper=self.paper if self.paper_comparable else None)
        return ps.plot_sobol_speed(self.result) if self.method == "sobol" else ps.plot_morris(self.result)


def sensitivity(method: str, cfg: Config, rpm: np.ndarray, *, n: int | None = None, t: float | None = None,
                eps: float | Sequence[float] | None = None, seed: int = 0, engine: str = "zoa", preset: str | None = None,
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
    cfg, _ = modal(cfg)
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
    context = dict(config=cfg, rpm=np.asarray(rpm, float), engine=engine, preset=preset, centre_source=centre,
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
        res = sa.morris(cfg.structure, cfg.cutting, rpm, trajectories=n_val, levels=levels, t=t_val, bounds=bounds or {},
                        seed=seed, progress=cb, client=client, **common)
    return Study(method, res, **context)
