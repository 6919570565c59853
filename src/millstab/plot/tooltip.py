"""The tool-tip figure: the coupled tip FRF (magnitude, real and imaginary parts) and, over a stickout
range, the minimum limiting depth and the first natural frequency per stickout ("which stickout?")."""

from __future__ import annotations

import numpy as np


def plot_tooltip(freq_hz, g, sweep=None, stickout: float | None = None, title: str = "", ax=None):
    """Figure of a tip FRF (``freq_hz`` [Hz], ``g`` [m/N]) and an optional sweep
    (:class:`millstab.api.tooltip.StickoutSweep`); ``stickout`` [m] marks the config's own; into ``ax``'s
    place or a new figure."""
    from millstab.plot._layout import panels

    cols = 2 if sweep is not None else 1
    fig, axes = panels(ax, 1, cols, figsize=(6.2 * cols, 4.4), squeeze=False, layout="constrained")
    ax = axes[0, 0]
    ax.plot(freq_hz, g.real * 1e6, color="tab:blue", lw=1.1, label="real")
    ax.plot(freq_hz, g.imag * 1e6, color="tab:red", lw=1.1, label="imaginary")
    ax.plot(freq_hz, np.abs(g) * 1e6, color="0.3", lw=0.8, ls="--", label="|G|")
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("tool-tip receptance [um/N]")
    ax.set_title(title or "tool-tip FRF (receptance coupling)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    if sweep is not None:
        ax = axes[0, 1]
        mm = sweep.stickout * 1e3
        ax.plot(mm, sweep.min_depth_mm, "o-", color="tab:blue", ms=3, lw=1.2, label=f"minimum limit ({sweep.engine})")
        b = sweep.best()
        ax.plot(mm[b], sweep.min_depth_mm[b], "*", color="tab:green", ms=12, label=f"best: {mm[b]:g} mm")
        if stickout is not None:
            ax.axvline(stickout * 1e3, color="0.5", lw=0.8, ls=":", label=f"config: {stickout * 1e3:g} mm")
        ax.set_xlabel("stickout [mm]")
        ax.set_ylabel("minimum b_lim over the speeds [mm]")
        ax.set_title(f"which stickout? ({sweep.rpm.min():g}..{sweep.rpm.max():g} rpm)")
        ax.grid(alpha=0.3)
        ax2 = ax.twinx()
        ax2.plot(mm, sweep.fn_hz[:, 0], color="tab:orange", lw=1.0, ls="--", label="first mode")
        ax2.set_ylabel("first tip mode [Hz]", color="tab:orange")
        h1, l1 = ax.get_legend_handles_labels()
        h2, l2 = ax2.get_legend_handles_labels()
        ax.legend(h1 + h2, l1 + l2, fontsize=8, loc="upper right")
    return fig
