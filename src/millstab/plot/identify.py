"""Identification figures, as in the seed paper: convergence (Fig. conv), iteration snapshots (Fig. iter)
and the final SLD against the target or the measured points (Fig. eggs).

Nothing is computed here: the SLD curves arrive as arrays (callers evaluate them with the forward
model, :func:`millstab.forward.forward`).
Speeds in rev/min, depths in mm.
"""

from __future__ import annotations

from typing import Sequence

import matplotlib.pyplot as plt
import numpy as np


def snapshot_indices(n_iter: int, n_panels: int = 6) -> np.ndarray:
    """Iterations to show in :func:`plot_iterations`: the first, the last and evenly spaced ones between."""
    return np.unique(np.linspace(0, max(n_iter - 1, 0), n_panels).round().astype(int))


#: above this many iterations the iterates are drawn as dots without a joining line: a line through a
#: zig-zagging history (the paper's scheme alternates between trial jumps and steps) fills a solid band
DENSE_ITERATIONS = 60


def plot_convergence(fit, *, ax=None, title: str | None = None):
    """Objective against iteration (paper Fig. conv) on a log axis: the MLAE (eq. 4) of every iterate and,
    when the history is not monotone, the best so far as a bold line; RSS too for least squares.

    Long histories (more than :data:`DENSE_ITERATIONS`) show each iterate as a small faint dot without a
    joining line, so a zig-zag reads as a cloud under which the best-so-far line descends.
    """
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(6.4, 4))
    it = np.arange(len(fit.history_mlae))
    dense = it.size > DENSE_ITERATIONS
    for values, colour, name, marker in ((fit.history_mlae, "tab:blue", "MLAE (eq. 4)", "o"),
                                         (fit.history_rss, "tab:orange", "RSS (fitted residuals)", "s")):
        y = np.maximum(np.asarray(values, float), 1e-300)
        if not np.isfinite(y).any():
            continue
        best = np.fmin.accumulate(y)
        monotone = np.array_equal(best, y, equal_nan=True)
        label = name if monotone else f"{name}, each iterate"
        if dense:
            ax.semilogy(it, y, ls="none", marker=".", ms=2.5, alpha=0.35, color=colour, label=label)
        else:
            ax.semilogy(it, y, ls="-", marker=marker, ms=3, lw=0.8, color=colour, label=label)
        if not monotone:
            ax.semilogy(it, best, ls="-", lw=2.0, color=colour, label=f"{name}, best so far")
    ax.set_xlabel("iteration")
    ax.set_ylabel("objective")
    ax.set_title(title or f"{fit.method}: convergence ({fit.iterations} iterations, {fit.evaluations} SLD evaluations)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, markerscale=2)
    return fig


def plot_iterations(fit, rpm: np.ndarray, target_mm: np.ndarray, guesses_mm: np.ndarray, iterations: Sequence[int], *,
                    points=None, ncols: int = 3, title: str | None = None):
    """A grid of panels (paper Fig. iter): the target SLD (blue) and the guessed SLD (orange) at chosen iterations.

    Args:
        rpm: speeds of the curves (S,) [rev/min]; target_mm: the target SLD (S,) [mm] or ``None``.
        guesses_mm: (len(iterations), S) guessed SLDs [mm]; iterations: their iteration numbers.
        points: measured points (PointSet) drawn in every panel, optional.
    """
    n = len(iterations)
    nrows = int(np.ceil(n / ncols))
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.2 * ncols, 3.0 * nrows), squeeze=False, sharex=True, sharey=True)
    top = np.nanmax([np.nanmax(np.where(np.isfinite(g), g, np.nan)) for g in guesses_mm])
    if target_mm is not None:
        top = max(top, np.nanmax(target_mm))
    if points is not None:
        top = max(top, float(points.depth_mm.max()))
    for a, it, g in zip(axes.flat, iterations, guesses_mm):
        if target_mm is not None:
            a.plot(rpm, target_mm, color="tab:blue", lw=1.5, label="target")
        if points is not None:
            a.scatter(points.rpm, points.depth_mm, s=6, color="k", zorder=4, label="points")
        a.plot(rpm, g, color="tab:orange", lw=1.3, label="guess")
        a.set_title(f"iteration {it}: MLAE {fit.history_mlae[it]:.3g}", fontsize=9)
        a.set_ylim(0, 1.1 * top)
        a.grid(alpha=0.3)
    for a in axes.flat[n:]:
        a.axis("off")
    for a in axes[-1]:
        a.set_xlabel("spindle speed [rev/min]")
    for a in axes[:, 0]:
        a.set_ylabel("depth [mm]")
    axes.flat[0].legend(fontsize=7)
    fig.suptitle(title or f"{fit.method}: guessed SLD through the iterations")
    fig.tight_layout()
    return fig


def plot_final(fits_or_panels: Sequence[tuple[str, np.ndarray, np.ndarray | None, np.ndarray, object]], *,
               title: str | None = None):
    """Final SLDs (paper Fig. eggs): one panel per case, target (blue) and identified (orange) SLD, points.

    Args:
        fits_or_panels: tuples ``(label, rpm (S,), target_mm (S,) or None, fitted_mm (S,), points or None)``.
    """
    n = len(fits_or_panels)
    fig, axes = plt.subplots(1, n, figsize=(5.0 * n, 3.6), squeeze=False)
    for a, (label, rpm, target, fitted, points) in zip(axes[0], fits_or_panels):
        if target is not None:
            a.plot(rpm, target, color="tab:blue", lw=1.6, label="target")
        a.plot(rpm, fitted, color="tab:orange", lw=1.4, ls="--" if target is not None else "-", label="identified")
        if points is not None and len(points):
            style = {"": ("k", ".", "boundary point"), "stable": ("tab:green", "o", "stable cut"),
                     "chatter": ("tab:red", "x", "chatter cut")}
            for lab, (c, m, name) in style.items():
                sel = points.label == lab
                if sel.any():
                    a.scatter(points.rpm[sel], points.depth_mm[sel], s=14, color=c, marker=m, zorder=5, label=name)
        a.set_title(label, fontsize=10)
        a.set_xlabel("spindle speed [rev/min]")
        a.set_ylabel("depth [mm]")
        a.set_ylim(0, None)
        a.grid(alpha=0.3)
        a.legend(fontsize=7)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_design(plan, rpm: np.ndarray | None = None, sld_mm: np.ndarray | None = None, measured=None, *,
                title: str | None = None, ax=None):
    """A test plan (:class:`~millstab.identify.design.SpeedDesign`) on the SLD it was planned around.

    Args:
        rpm, sld_mm: the SLD at the plan's centre [rev/min], [mm], or None (the plan alone: what the plan
            holds is its depths at the planned speeds, not the SLD between them); measured: points already
            measured, or None; ax: draw into this Axes (else a new figure).
    Planned tests are triangles at their predicted depth, larger for more repeats at one speed.
    """
    from millstab.plot._layout import finish, panels

    fig, ax_ = panels(ax, figsize=(7.5, 3.8))
    if sld_mm is not None:
        ax_.plot(rpm, sld_mm, color="tab:blue", lw=1.4, label="SLD at the current estimate")
    if measured is not None and len(measured):
        ax_.scatter(measured.rpm, measured.depth_mm, s=10, color="k", zorder=4, label="measured")
    tests = plan.tests()
    r = np.array([t[0] for t in tests])
    c = np.array([t[1] for t in tests])
    d = np.array([t[2] for t in tests])
    ax_.scatter(r, d, s=18 + 14 * (c - 1), marker="v", color="tab:red", zorder=5,
                label=f"planned ({len(plan.rpm)} tests)")
    ax_.set_xlabel("spindle speed [rev/min]")
    ax_.set_ylabel("depth [mm]")
    finite = [] if sld_mm is None else np.asarray(sld_mm, float)[np.isfinite(sld_mm)]
    tops = [float(v) for v in (np.max(finite) if len(finite) else np.nan, d.max() if d.size else np.nan)
            if np.isfinite(v)]
    if tops:
        ax_.set_ylim(0, 1.1 * max(tops))
    ax_.grid(alpha=0.3)
    ax_.legend(fontsize=7)
    ax_.set_title(title or "planned boundary-point tests", fontsize=10)
    finish(fig, ax)
    return fig


__all__ = ["plot_convergence", "plot_design", "plot_final", "plot_iterations", "snapshot_indices"]
