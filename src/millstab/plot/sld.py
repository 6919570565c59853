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
        points: a :class:`millstab.points.PointSet` marked by label.
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


def plot_sld_panels(panels: Sequence[tuple[str, Sequence[tuple[str, np.ndarray, np.ndarray]]]]):
    """Side-by-side SLDs: ``panels`` = [(title, [(label, rpm, depth_mm), ...]), ...]; the first curve of
    each panel is drawn solid with its stable region shaded, the others dashed."""
    fig, axes = plt.subplots(1, len(panels), figsize=(5 * len(panels), 4.2), squeeze=False)
    for ax, (title, curves) in zip(axes[0], panels):
        for i, (label, rpm, d) in enumerate(curves):
            if i == 0:
                ax.plot(rpm, d, color="tab:blue", lw=1.6, label=label)
                ax.fill_between(rpm, 0, np.where(np.isfinite(d), d, np.nan), color="tab:blue", alpha=0.1, lw=0)
            else:
                ax.plot(rpm, d, ls="--", color=("tab:orange", "tab:purple", "tab:brown")[(i - 1) % 3], lw=1.3,
                        label=label)
        ax.set_ylim(0, 1.1 * _finite_top(*[c[2] for c in curves]))
        ax.set_title(title)
        ax.set_xlabel("spindle speed [rev/min]")
        ax.set_ylabel("axial depth [mm]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    return fig


def plot_sld_family(rpm: np.ndarray, curves: dict[str, np.ndarray], points=None,
                    fitted: tuple[str, np.ndarray] | None = None, title: str | None = None):
    """Several SLDs on common speeds (e.g. the paper's Fig. fourSLD): the first curve dashed black (the
    static SLD), the others coloured, an optional fitted curve in bold orange and points in red.

    Args:
        rpm: speeds (S,) [rev/min]; curves: {label: depth (S,) [mm]}; fitted: (label, depth (S,) [mm]).
        points: a PointSet drawn as red dots, labelled with its ``source``.

    The legend sits below the axes: inside, with five or six long labels, it covers lobe peaks.
    """
    fig, ax = plt.subplots(figsize=(9, 5.8), layout="constrained")
    styles = [dict(color="black", ls="--"), dict(color="tab:blue"), dict(color="tab:green", ls="-."),
              dict(color="tab:purple", ls=":")]
    for i, (label, d) in enumerate(curves.items()):
        ax.plot(rpm, d, lw=1.6, label=label, **styles[i % len(styles)])
    if fitted is not None:
        ax.plot(rpm, fitted[1], color="tab:orange", lw=2.0, label=fitted[0])
    if points is not None:
        ax.scatter(points.rpm, points.depth_mm, color="tab:red", s=22, zorder=5, label=points.source or "points")
    lows = min(float(np.nanmin(d)) for d in curves.values())
    ax.set_ylim(0, min(_finite_top(*curves.values()), 4 * lows) * 1.05)
    ax.set_xlim(rpm.min(), rpm.max())
    ax.set_xlabel("spindle speed [rev/min]")
    ax.set_ylabel("axial depth of cut [mm]")
    ax.grid(alpha=0.3)
    fig.legend(*ax.get_legend_handles_labels(), loc="outside lower center", ncol=2, fontsize=8, frameon=False)
    if title:
        ax.set_title(title)
    return fig
