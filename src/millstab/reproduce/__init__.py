"""Reproduce the seed paper end to end: :func:`run` writes report.md, report.html, figures and CSVs.

The paper's tables and figures come from :mod:`millstab.reproduce.paper`; two further steps from
:mod:`millstab.reproduce.low_immersion` go beyond it (simulated test cuts; the zero-order, SDM and
spectral engines at low radial immersion and the zero-order identification's model error there), and
:mod:`millstab.reproduce.campaign` plays a virtual test campaign of Bayesian updating.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Callable

from millstab.reproduce.paper import Context
from millstab.reproduce.report import Report, ReportWriter

TITLE = ("millstab reproduces: Sensitivity Analysis and Monte Carlo Based Uncertainty Quantification of the "
         "In-process Modal Parameters in Milling")


def steps() -> list[tuple[str, Callable[[Context], None]]]:
    """The steps in report order (name, function)."""
    from millstab.reproduce import campaign, low_immersion, paper

    return [
        ("Table 1 and the synthetic SLDs", paper.table1),
        ("Table 3: identification of Examples 1-3", paper.table3),
        ("Table 4, Fig. fourSLD, experimental identification", paper.four_flute),
        ("Fig. SENS and Table 6: sensitivity", paper.sensitivity),
        ("Beyond the paper: simulated cuts", low_immersion.simulated_cuts),
        ("Beyond the paper: engines at low immersion, identification", low_immersion.engines),
        ("Beyond the paper: a virtual test campaign (Bayesian updating)", campaign.virtual_campaign),
    ]


def run(out: Path, quick: bool = False, seed: int = 0, points: Path | None = None,
        progress: Callable[[str], None] | None = None) -> Report:
    """Run every step into ``out``; returns the report (frozen, already written)."""
    t0 = time.perf_counter()
    rep = ReportWriter(Path(out), TITLE)
    ctx = Context(rep, quick=quick, seed=seed, points=points, progress=progress)
    rep.paragraph(
        "Every number below was computed in this run by millstab; the paper's numbers come from "
        "millstab/datasets/paper_values.toml, each cited to its table. "
        + ("This is the --quick run (smaller Monte Carlo, fewer identification starts, no SDM check of "
           "Table 1's SLDs, SDM on a coarser grid in the low-immersion section). "
           if quick else "")
        + f"Seed {seed}.")
    for name, fn in steps():
        with ctx.step(name):
            fn(ctx)
    rep.heading("Run time")
    total = time.perf_counter() - t0
    rep.table("run_time", ["step", "seconds"], [[k, v] for k, v in ctx.timings.items()] + [["total", total]],
              "Wall-clock time of each step on this machine")
    return rep.write()
