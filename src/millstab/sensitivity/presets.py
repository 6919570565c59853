"""The ``--preset paper`` of the sensitivity studies: which packaged example a config is, the predicted
parameter sets the seed paper's Section 3.2 centres its studies on, and its Table 6 (tab:MC). (Named apart
from :mod:`millstab.reproduce.paper`, the report's steps that reproduce the paper; this was
``sensitivity/paper.py``.)"""

from __future__ import annotations

import math

import numpy as np

from millstab.datasets import paper_values
from millstab.model import Cutting, Structure

_PARAMS = ("fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y")


def _close(a: float, b: float) -> bool:
    return math.isclose(a, b, rel_tol=1e-6, abs_tol=1e-9)


def match_example(cutting: Cutting, structure: Structure) -> str | None:
    """``ex1``/``ex2``/``ex3`` when the cutting conditions and the structure are those of the paper's
    Table 1 (tab:Input_values) example, by value (not by name); else None."""
    if not structure.is_modal or len(structure.x) != 1 or len(structure.y) != 1:
        return None
    pv = paper_values()["input_values"]
    for name in ("ex1", "ex2", "ex3"):
        v = pv[name]
        cut_ok = (cutting.teeth == v["teeth"] and _close(cutting.kt, v["kt"]) and _close(cutting.kr, v["kr"])
                  and _close(math.degrees(cutting.entry), v["entry_deg"])
                  and _close(math.degrees(cutting.exit), v["exit_deg"]))
        if not cut_ok:
            continue
        vals = (structure.x[0].fn, structure.x[0].k, structure.x[0].zeta, structure.y[0].fn, structure.y[0].k,
                structure.y[0].zeta)
        if all(_close(a, v[p]) for a, p in zip(vals, _PARAMS)):
            return name
    return None


def predicted_theta(example: str) -> np.ndarray:
    """The paper's predicted (Newton-Raphson) parameters of an example, tab:results_fourier, in the
    order fn_x, k_x, zeta_x, fn_y, k_y, zeta_y [Hz, N/m, -] (Ex.1: 910.4 Hz, 13.44 N/µm, 0.0287 / 0.0286)."""
    p = paper_values()["results_fourier"][example]["predicted"]
    return np.array([p[n] for n in _PARAMS], dtype=float)


def table6() -> dict[str, dict[str, float]]:
    """The paper's Table 6 (tab:MC): {name: {mean, sd}} in mm² (N = 10 000, t = 0.1, ε = 1 %, around
    Ex.1 predicted values; the paper's speed set is not given)."""
    mc = paper_values()["mc"]
    return {n: {"mean": float(m), "sd": float(s)} for n, m, s in zip(mc["params"], mc["mean"], mc["sd"])}
