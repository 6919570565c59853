"""Stability lobe diagrams: spindle speed [rpm] against limiting axial depth [mm]."""

from __future__ import annotations

from typing import Sequence

import matplotlib.pyplot as plt
import numpy as np

#: colours of measured points by label
POINT_STYLE = {
    "stable": dict(marker="o", color="tab:green", label="stable cut"),
    "chatter": dict(marker="x", color="tab:red", label="chatter cut"),
    "": dict(marker=".", color="black", label="boundary point"),
}


def _finite_top(*depth_mm: np.ndarray) -> float:
    vals = np.concatenate([np.asarray(d)[np.isfinite(d)] for d in depth_mm if d is not None])
    return float(vals.max()) if vals.size else 1.0


def plot_sld(rpm: np.ndarray, depth_mm: np.ndarray, *, label: str = "stability limit", lobes=None, points=None,
             others: Sequence[tuple[str, np.ndarray, np.ndarray]] = (), title: str | None = None,
             ylim_mm: float | None = None, ax=None):
    """One SLD: the limit with the stable region shaded, optional raw lobes, other curves and points.

    Args:
        rpm, depth_mm: the envelope (speeds [rev/min], depths [mm]; ``inf`` = no limit there).
        lobes: raw lobes (:class:`millstab.stability.zoa.Lobe`, depth in m) drawn thin and grey.
        points: a :class:`millstab.io.points.PointSet` marked by label.
        others: extra curves ``(label, rpm, depth_mm)`` (e.g. another engine, a target SLD).
        ylim_mm: top of the depth axis; default a little above the highest finite value shown.
    Returns:
        The matplotlib Figure.
    """
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(8, 4.8))
    rpm = np.asarray(rpm, float)
    d = np.asarray(depth_mm, float)
    top = ylim_mm or 1.15 * max(_finite_top(d, *[o[2] for o in others]),
                                float(points.depth_mm.max()) if points is not None and len(points) else 0.0)
    shade = np.where(np.isfinite(d), d, top)
    ax.fill_between(rpm, 0, shade, color="tab:blue", alpha=0.12, lw=0, label="stable (predicted)")
    if lobes:
        for i, lb in enumerate(lobes):
            ax.plot(lb.rpm, lb.depth * 1e3, color="0.6", lw=0.6, label="raw lobes" if i == 0 else None)
    ax.plot(rpm, d, color="tab:blue", lw=1.8, label=label)
    styles = ["--", "-.", ":", (0, (5, 1))]
    colours = ["tab:orange", "tab:purple", "tab:brown", "tab:gray"]
    for i, (lab, r, dd) in enumerate(others):
        ax.plot(r, dd, ls=styles[i % 4], color=colours[i % 4], lw=1.6, label=lab)
    if points is not None and len(points):
        for lab, style in POINT_STYLE.items():
            m = points.label == lab
            if m.any():
                ax.scatter(points.rpm[m], points.depth_mm[m], s=28, zorder=5, **style)
    ax.set_xlim(rpm.min(), rpm.max())
    ax.set_ylim(0, top)
    ax.set_xlabel("spindle speed [rev/min]")
    ax.set_ylabel("axial depth of cut [mm]")
    if title:
        ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", fontsize=8, framealpha=0.9)
    return fig
