"""Stability engines side by side: the limits of several engines on one speed grid per panel, with the
speeds where an engine finds a period-doubling (flip) boundary marked. Draws arrays; computes nothing.
"""

from __future__ import annotations

from typing import Mapping, Sequence

import matplotlib.pyplot as plt
import numpy as np

#: line styles given to the curves of a panel in order when the caller gives none
STYLE_CYCLE = (
    dict(color="tab:blue", lw=1.6, ls="-"),
    dict(color="black", lw=1.2, ls="-."),
    dict(color="tab:red", lw=1.3, ls="--"),
    dict(color="tab:green", lw=1.2, ls=":"),
)


def plot_engine_panels(panels: Sequence[dict], styles: Mapping[str, dict] | None = None):
    """One panel per cut: the limiting depth [mm] against spindle speed [rev/min] of each engine.

    Args:
        panels: dicts with ``title``; ``curves`` = {engine name: (rpm, depth_mm)}; optional ``flip`` =
            (rpm, depth_mm) of the speeds where the boundary is a flip (period-doubling) one, drawn as
            red triangles; optional ``ylim_mm`` (default: 1.1 × the highest finite depth, at most 4 × the
            lowest, so the lobe bottoms stay readable).
        styles: optional matplotlib line keywords per curve name (``label`` included); a curve without
            one is drawn in the next style of :data:`STYLE_CYCLE`, labelled with its name.
    Returns:
        The matplotlib Figure.
    """
    fig, axes = plt.subplots(1, len(panels), figsize=(6.5 * len(panels), 4.4), squeeze=False)
    for ax, panel in zip(axes[0], panels):
        lows, highs = [], []
        for i, (name, (rpm, d)) in enumerate(panel["curves"].items()):
            style = (styles or {}).get(name) or dict(STYLE_CYCLE[i % len(STYLE_CYCLE)], label=name)
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
