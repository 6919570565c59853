"""Figures of simulated cuts: the time trace with the once-per-tooth samples, the once-per-tooth
samples in the x-y plane, and the spectrum with the tooth-passing harmonics marked, titled by the
detector's label. Draws :class:`millstab.simulate.CutResult` and :class:`millstab.simulate.Detection`;
computes nothing.
"""

from __future__ import annotations

from typing import Sequence

import matplotlib.pyplot as plt
import numpy as np

LABEL_COLOUR = {"stable": "tab:green", "marginal": "tab:orange", "chatter": "tab:red"}


def _title(result, detection) -> str:
    text = f"{result.rpm:.0f} rpm, {result.depth_m * 1e3:.3g} mm: {detection.label}"
    if detection.label != "stable" and np.isfinite(detection.chatter_hz):
        text += f" at {detection.chatter_hz:.0f} Hz ({detection.lobe})"
    return text


def draw_cut(result, detection, axes) -> None:
    """Draw one cut on three axes: time trace, once-per-tooth samples (x-y), spectrum."""
    ax_t, ax_p, ax_f = axes
    colour = LABEL_COLOUR.get(detection.label, "black")
    ax_t.plot(result.t * 1e3, result.x * 1e6, lw=0.6, color="tab:blue", label="x")
    if result.active[1]:
        ax_t.plot(result.t * 1e3, result.y * 1e6, lw=0.6, color="tab:purple", alpha=0.7, label="y")
    ax_t.plot(result.once_t * 1e3, result.once_x * 1e6, ".", ms=3, color=colour, label="once per tooth (x)")
    ax_t.set_xlabel("time [ms]")
    ax_t.set_ylabel("displacement [µm]")
    ax_t.set_title(_title(result, detection), color=colour, fontsize=10)
    ax_t.legend(fontsize=7, loc="upper right")
    n = result.once_x.size
    late = slice(n // 2, n)
    if result.active[1]:  # the samples in the x-y plane
        u, v, lu, lv = result.once_x, result.once_y, "x", "y"
    else:  # one direction: the return map x_c -> x_{c+1}
        u, v = result.once_x[:-1], result.once_x[1:]
        lu, lv = "$x_c$", "$x_{c+1}$"
        n, late = n - 1, slice((n - 1) // 2, n - 1)
    ax_p.plot(u[: n // 2] * 1e6, v[: n // 2] * 1e6, ".", ms=2, color="0.7", label="first half")
    ax_p.plot(u[late] * 1e6, v[late] * 1e6, ".", ms=3, color=colour, label="second half")
    ax_p.set_xlabel(f"{lu} once per tooth [µm]")
    ax_p.set_ylabel(f"{lv} once per tooth [µm]")
    ax_p.set_title(f"growth {detection.growth:.3g}, level {detection.level:.2g}", fontsize=9)
    ax_p.legend(fontsize=7)
    draw_spectrum(detection, ax_f, result.fn_max_hz)


def draw_spectrum(detection, ax, fn_max_hz: float | None = None) -> None:
    """The detector's spectrum [µm] on a log scale with the tooth-passing harmonics dotted and the chatter line
    in the label's colour, up to 3 × ``fn_max_hz`` (the structure's highest mode [Hz]) or 4 tooth passings."""
    colour = LABEL_COLOUR.get(detection.label, "black")
    f, a = detection.freq_hz, detection.amplitude_m
    if f.size:
        top_amp = float(a.max()) * 1e6 if a.size and a.max() > 0 else 1.0
        ax.semilogy(f, np.maximum(a * 1e6, 1e-7 * top_amp), lw=0.7, color="black")
        ax.set_ylim(1e-6 * top_amp, 3 * top_amp)  # six decades: the harmonics and the chatter peak
        top = f[-1]
        for k in range(1, int(top / detection.tooth_hz) + 1):
            ax.axvline(k * detection.tooth_hz, color="tab:gray", lw=0.6, ls=":", zorder=0)
        if np.isfinite(detection.chatter_hz):
            ax.axvline(detection.chatter_hz, color=colour, lw=1.0, label=f"chatter {detection.chatter_hz:.0f} Hz")
            ax.legend(fontsize=7)
        ax.set_xlim(0, min(top, max(3 * (fn_max_hz or 0.0), 4 * detection.tooth_hz)))
    ax.set_xlabel(f"frequency [Hz] (dotted: tooth passing {detection.tooth_hz:.0f} Hz and harmonics)")
    ax.set_ylabel("amplitude [µm]")


def plot_spectrum(detection, title: str | None = None, ax=None):
    """One detection's spectrum (:func:`draw_spectrum`), titled by its verdict; into ``ax`` or a new figure.
    Returns the Figure."""
    from millstab.plot._layout import finish, panels

    fig, ax_ = panels(ax, figsize=(8, 3.6))
    draw_spectrum(detection, ax_)
    ax_.set_title(title or detection.summary(), color=LABEL_COLOUR.get(detection.label, "black"), fontsize=10)
    finish(fig, ax)
    return fig


def plot_cut(result, detection, title: str | None = None):
    """One cut: time trace, once-per-tooth samples and spectrum in a row. Returns the Figure."""
    fig, axes = plt.subplots(1, 3, figsize=(14, 3.8), gridspec_kw={"width_ratios": [2.2, 1, 1.6]})
    draw_cut(result, detection, axes)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_cuts(cuts: Sequence[tuple], title: str | None = None):
    """Several cuts (pairs of result, detection), one row each (e.g. a stable and a chattering cut)."""
    fig, axes = plt.subplots(len(cuts), 3, figsize=(14, 3.6 * len(cuts)), squeeze=False,
                             gridspec_kw={"width_ratios": [2.2, 1, 1.6]})
    for row, (res, det) in zip(axes, cuts):
        draw_cut(res, det, row)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_trace(result, title: str | None = None, ax=None):
    """One cut's time trace (x, y [µm] over t [ms]) with its once-per-tooth samples, without a detector's
    verdict (with one, :func:`draw_cut` draws three panels); into ``ax`` or a new figure. Returns the Figure."""
    from millstab.plot._layout import finish, panels

    fig, ax_ = panels(ax, figsize=(9, 3.6))
    ax_.plot(result.t * 1e3, result.x * 1e6, lw=0.6, color="tab:blue", label="x")
    if result.active[1]:
        ax_.plot(result.t * 1e3, result.y * 1e6, lw=0.6, color="tab:purple", alpha=0.7, label="y")
    ax_.plot(result.once_t * 1e3, result.once_x * 1e6, ".", ms=3, color="black", label="once per tooth (x)")
    ax_.set_xlabel("time [ms]")
    ax_.set_ylabel("displacement [µm]")
    ax_.set_title(title or f"{result.rpm:.0f} rpm, {result.depth_m * 1e3:.3g} mm" + (" (diverged)" if result.diverged
                                                                                    else ""), fontsize=10)
    ax_.legend(fontsize=7, loc="upper right")
    finish(fig, ax)
    return fig


def plot_labels(labels, title: str | None = None, ax=None):
    """Labelled cuts (:class:`millstab.simulate.Labels`) on speed [rev/min] and depth [mm], one colour per
    label (the label written, after any label noise); into ``ax`` or a new figure. Returns the Figure."""
    from millstab.plot._layout import finish, panels

    fig, ax_ = panels(ax, figsize=(8, 4.8))
    marker = {"stable": "o", "marginal": "^", "chatter": "x"}
    label = np.asarray(labels.label).astype(str)
    for name in ("stable", "marginal", "chatter"):
        m = label == name
        if m.any():
            ax_.scatter(labels.rpm[m], labels.depth_mm[m], s=28, marker=marker[name], color=LABEL_COLOUR[name],
                        zorder=5, label=f"{name} ({int(m.sum())})")
    ax_.set_xlabel("spindle speed [rev/min]")
    ax_.set_ylabel("axial depth of cut [mm]")
    ax_.set_ylim(bottom=0)
    ax_.grid(alpha=0.3)
    ax_.legend(fontsize=8, loc="upper left")
    ax_.set_title(title or f"{label.size} simulated cuts", fontsize=10)
    finish(fig, ax)
    return fig
