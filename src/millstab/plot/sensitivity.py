"""Sensitivity figures: Fig. SENS panels (one-at-a-time), Monte Carlo convergence, Sobol indices
against spindle speed, Morris μ*/σ. Each takes a result from :mod:`millstab.sensitivity` and returns
a matplotlib Figure; nothing is computed here beyond reshaping. MSE axes are in mm².
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from millstab.plot._layout import finish, grid, panels, suptitle

_LABEL = {"fn": "f_n", "k": "k", "zeta": "\\zeta"}


def _tex(name: str) -> str:
    """fn_x → $f_{n,x}$, zeta_y2 → $\\zeta_{y2}$."""
    kind, _, rest = name.partition("_")
    base = _LABEL.get(kind, kind)
    if kind == "fn":
        return f"$f_{{n{',' + rest if rest else ''}}}$"
    return f"${base}_{{{rest}}}$" if rest else f"${base}$"


def _grid(names):
    """Panel layout: rows = directions (x, y) when the names carry them, columns = fn, k, ζ."""
    n = len(names)
    cols = 3 if n % 3 == 0 else min(n, 4)
    rows = int(np.ceil(n / cols))
    return rows, cols


def plot_oat(result, title: str | None = None, ax=None):
    """The paper's Fig. SENS: MSE [mm²] against ε, one panel per parameter. Natural-frequency panels
    share their own vertical scale; all other panels share a common (smaller) one."""
    names = result.names
    rows, cols = _grid(names)
    fig, axes = panels(ax, rows, cols, figsize=(3.6 * cols, 2.9 * rows), squeeze=False)
    eps = 100 * np.asarray(result.eps)
    is_fn = np.array([n.startswith("fn") for n in names])
    top_fn = 1.05 * float(result.mse_mm2[is_fn].max()) if is_fn.any() else None
    top_other = 1.05 * float(result.mse_mm2[~is_fn].max()) if (~is_fn).any() else None
    for j, name in enumerate(names):
        a = axes.flat[j]
        a.plot(eps, result.mse_mm2[j], "o-", color="tab:red" if is_fn[j] else "tab:blue", ms=3)
        a.set_title(_tex(name))
        a.set_xlabel("change ε [%]")
        a.set_ylabel("MSE [mm²]")
        top = top_fn if is_fn[j] else top_other
        if top and top > 0:
            a.set_ylim(0, top)
        a.grid(alpha=0.3)
    for a in axes.flat[len(names):]:
        a.set_visible(False)
    if top_fn and top_other and ax is None:
        fig.text(0.5, -0.01, f"natural-frequency panels on their own scale ({top_fn / top_other:.0f}x the others)",
                 ha="center", fontsize=8)
    suptitle(fig, ax, title or f"One-at-a-time sensitivity of the SLD ({result.rpm.size} speeds, "
                               f"{result.rpm.min():g}-{result.rpm.max():g} rpm, {result.engine})")
    finish(fig, ax)
    return fig


def plot_mc_convergence(result, paper: dict | None = None, title: str | None = None, ax=None):
    """Running mean of each parameter's MSE [mm²] against the number of paths (log axis), with a
    ±1.96·SEM band; the paper's Table 6 mean as a dashed line when ``paper`` is given."""
    names = result.names
    rows, cols = _grid(names)
    fig, axes = panels(ax, rows, cols, figsize=(3.6 * cols, 2.9 * rows), squeeze=False)
    k, mean, sem = result.running(300)
    for j, name in enumerate(names):
        a = axes.flat[j]
        a.plot(k, mean[:, j], color="tab:blue", lw=1.2, label="running mean")
        ok = np.isfinite(sem[:, j])
        a.fill_between(k[ok], (mean - 1.96 * sem)[ok, j], (mean + 1.96 * sem)[ok, j], color="tab:blue", alpha=0.2,
                        label="±1.96 SEM")
        if paper and name in paper:
            a.axhline(paper[name]["mean"], color="k", ls="--", lw=1, label="paper Table 6")
        a.set_xscale("log")
        a.set_title(f"{_tex(name)}: {result.mean[j]:.3g} ± {result.sem[j]:.1g} mm²", fontsize=9)
        a.set_xlabel("paths")
        a.set_ylabel("mean MSE [mm²]")
        a.grid(alpha=0.3)
    for a in axes.flat[len(names):]:
        a.set_visible(False)
    axes.flat[0].legend(fontsize=7)
    suptitle(fig, ax, title or f"Monte Carlo sensitivity: N = {result.n}, t = {result.t:g}, ε = {result.eps:g}, "
                               f"seed {result.seed}")
    finish(fig, ax)
    return fig


def plot_sobol_speed(result, title: str | None = None, ax=None):
    """Sobol indices of b_lim against spindle speed: the nominal SLD on top, total-order indices
    (solid, with confidence band) and first-order indices (dashed) per parameter below; a bar chart
    of the indices of the MSE and the envelope minimum on the right."""
    fig, gs = grid(ax, 2, 2, figsize=(12, 6.5), width_ratios=(3, 1), height_ratios=(1, 2))
    ax0 = fig.add_subplot(gs[0, 0])
    ax1 = fig.add_subplot(gs[1, 0], sharex=ax0)
    axb = fig.add_subplot(gs[:, 1])
    rpm = result.rpm
    ax0.plot(rpm, result.depth_nominal_mm, color="k", lw=1)
    ax0.set_ylabel("nominal b_lim [mm]")
    ax0.grid(alpha=0.3)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    b = result.blim
    for j, name in enumerate(result.names):
        c = colors[j % len(colors)]
        ax1.plot(rpm, b["ST"][:, j], color=c, lw=1.2, label=f"{_tex(name)} total")
        ax1.fill_between(rpm, b["ST"][:, j] - b["ST_conf"][:, j], b["ST"][:, j] + b["ST_conf"][:, j], color=c,
                         alpha=0.15)
        ax1.plot(rpm, b["S1"][:, j], color=c, lw=0.9, ls="--")
    ax1.set_xlabel("spindle speed [rpm]")
    ax1.set_ylabel("Sobol index of b_lim")
    # first-order estimates go negative where interactions dominate (fn_x with fn_y): keep them visible
    ax1.set_ylim(max(-1.0, min(-0.05, float(np.nanmin(b["S1"])) - 0.05)), 1.05)
    ax1.grid(alpha=0.3)
    ax1.legend(fontsize=7, ncol=6, loc="upper center", bbox_to_anchor=(0.5, -0.15),
               title="solid: total order (band: CI), dashed: first order", title_fontsize=7)
    x = np.arange(len(result.names))
    w = 0.2
    for i, (label, d) in enumerate((("MSE S1", result.mse), ("MSE ST", result.mse), ("min S1", result.minimum),
                                    ("min ST", result.minimum))):
        key = label.split()[1]
        axb.bar(x + (i - 1.5) * w, d[key], w, yerr=d[key + "_conf"], capsize=2, label=label)
    axb.set_xticks(x, [_tex(n) for n in result.names])
    axb.set_ylabel("Sobol index")
    axb.set_title("SLD MSE and envelope minimum", fontsize=9)
    axb.legend(fontsize=7)
    axb.grid(alpha=0.3, axis="y")
    suptitle(fig, ax, title or f"Sobol indices (N = {result.n}, {result.n * (len(result.names) + 2)} structures, "
                               f"{100 * result.conf_level:g} % CI, {result.engine})")
    finish(fig, ax)
    return fig


def plot_morris(result, title: str | None = None, ax=None):
    """Morris screening: σ against μ* (with μ*'s confidence half-width) for the MSE [mm²] and the
    envelope minimum [mm], each parameter labelled."""
    outs = list(result.outputs)
    fig, axes = panels(ax, 1, len(outs), figsize=(5.5 * len(outs), 4.5), squeeze=False)
    units = {"mse": "mm²", "minimum": "mm"}
    for a, o in zip(axes.flat, outs):
        d = result.outputs[o]
        a.errorbar(d["mu_star"], d["sigma"], xerr=d["mu_star_conf"], fmt="o", capsize=3)
        for j, name in enumerate(result.names):
            a.annotate(_tex(name), (d["mu_star"][j], d["sigma"][j]), textcoords="offset points", xytext=(4, 4))
        a.set_xlabel(f"μ* [{units.get(o, '')}]")
        a.set_ylabel(f"σ [{units.get(o, '')}]")
        a.set_title("SLD MSE vs nominal" if o == "mse" else "envelope minimum")
        a.grid(alpha=0.3)
    suptitle(fig, ax, title or f"Morris screening: {result.trajectories} trajectories, {result.levels} levels")
    finish(fig, ax)
    return fig


__all__ = ["plot_mc_convergence", "plot_morris", "plot_oat", "plot_sobol_speed"]
