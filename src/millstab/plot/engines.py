"""Stability engines side by side: the limits of several engines on one speed grid per panel, with the
speeds where an engine finds a period-doubling (flip) boundary marked. Draws arrays; computes nothing.
"""

from __future__ import annotations

from typing import Sequence

import matplotlib.pyplot as plt
import numpy as np

#: line style per engine name (others fall back to grey dotted)
ENGINE_STYLE = {
    "zoa": dict(color="tab:blue", lw=1.6, ls="-", label="zero-order (ZOA)"),
    "sdm": dict(color="black", lw=0, marker="o", ms=3.5, mfc="none", label="semi-discretization (SDM)"),
    "spectral": dict(color="tab:red", lw=1.3, ls="--", label="spectral"),
}


def plot_engine_panels(panels: Sequence[dict]):
    """One panel per cut: the limiting depth [mm] against spindle speed [rev/min] of each engine.

    Args:
        panels: dicts with ``title``; ``curves`` = {engine name: (rpm, depth_mm)}; optional ``flip`` =
            (rpm, depth_mm) of the speeds where the boundary is a flip (period-doubling) one, drawn as
            red triangles; optional ``ylim_mm`` (default: 1.1 × the highest finite depth, at most 4 × the
            lowest, so the lobe bottoms stay readable).
    Returns:
        The matplotlib Figure.
    """
    fig, axes = plt.subplots(1, len(panels), figsize=(6.5 * len(panels), 4.4), squeeze=False)
    for ax, panel in zip(axes[0], panels):
        lows, highs = [], []
        for name, (rpm, d) in panel["curves"].items():
            style = ENGINE_STYLE.get(name, dict(color="0.5", ls=":", lw=1.2, label=name))
            ax.plot(rpm, d, **style)
            fin = np.asarray(d)[np.isfinite(d)]
            if fin.size:
                lows.append(fin.min())
                highs.append(fin.max())
        if panel.get("flip") is not None and len(panel["flip"][0]):
            ax.plot(*panel["flip"], "v", color="tab:red", ms=4, label="flip (period-doubling) boundary")
        top = panel.get("ylim_mm") or 1.1 * min(max(highs, default=1.0), 4 * min(lows, default=1.0))
        ax.set_ylim(0, top)
        ax.set_xlim(min(np.min(c[0]) for c in panel["curves"].values()),
                    max(np.max(c[0]) for c in panel["curves"].values()))
        ax.set_title(panel["title"], fontsize=10)
        ax.set_xlabel("spindle speed [rev/min]")
        ax.set_ylabel("limiting axial depth [mm]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="upper left", framealpha=0.9)
    fig.tight_layout()
    return fig
