"""Figures of Bayesian updating: the posterior's pair plot and the P(stable) map (drawing only)."""

from __future__ import annotations

import numpy as np

from millstab.units import SHOWN as _SHOW  # the one table of shown units

_MARKERS = {"stable": ("o", "tab:green"), "chatter": ("x", "tab:red"), "marginal": ("^", "tab:orange"),
            "": ("s", "k")}


def plot_corner(samples: np.ndarray, names, units, truth: np.ndarray | None = None, max_points: int = 2000, ax=None):
    """Pair plot of posterior samples (N, P): histograms on the diagonal, scatter below it (in a new figure or
    in ``ax``'s place)."""
    from millstab.plot._layout import finish, panels

    p = samples.shape[1]
    scale = np.array([_SHOW.get(u, (1.0, u))[0] for u in units])
    s = samples * scale
    sub = s[:: max(1, s.shape[0] // max_points)]
    fig, axes = panels(ax, p, p, figsize=(1.9 * p + 1, 1.9 * p + 1), squeeze=False)
    for i in range(p):
        for j in range(p):
            a = axes[i, j]
            if j > i:
                a.set_visible(False)
                continue
            if i == j:
                a.hist(s[:, i], bins=40, color="0.4")
                a.set_yticks([])
            else:
                a.plot(sub[:, j], sub[:, i], ".", ms=1.5, alpha=0.4, color="tab:blue")
                if truth is not None:
                    a.plot(truth[j] * scale[j], truth[i] * scale[i], "r+", ms=10)
            if truth is not None and i == j:
                a.axvline(truth[i] * scale[i], color="r", lw=1)
            if i == p - 1:
                a.set_xlabel(f"{names[j]} [{_SHOW.get(units[j], (1, units[j]))[1]}]".replace(" []", ""), fontsize=8)
            if j == 0 and i > 0:
                a.set_ylabel(f"{names[i]} [{_SHOW.get(units[i], (1, units[i]))[1]}]".replace(" []", ""), fontsize=8)
            a.tick_params(labelsize=6)
    finish(fig, ax)
    return fig


def plot_pmap(rpm: np.ndarray, depth_mm: np.ndarray, p_stable: np.ndarray, prior_rpm=None, prior_depth_mm=None,
              cuts: dict | None = None, recommended: dict | None = None, title: str = "", elsewhere: int = 0):
    """P(stable) (S, D) as colour with its 5/50/95 % contours, the prior's SLD and the labelled cuts (those made
    in the map's condition); ``elsewhere``: how many cuts were made in other conditions, named in the legend
    and not drawn (their depths belong to other limits)."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 5))
    mesh = ax.pcolormesh(rpm, depth_mm, p_stable.T, cmap="RdYlGn", vmin=0, vmax=1, shading="auto")
    fig.colorbar(mesh, ax=ax, label="P(stable)")
    cs = ax.contour(rpm, depth_mm, p_stable.T, levels=[0.05, 0.5, 0.95], colors="k", linewidths=[0.8, 1.4, 0.8],
                    linestyles=["--", "-", "--"])
    ax.clabel(cs, fmt={0.05: "5 %", 0.5: "50 %", 0.95: "95 %"}, fontsize=7)
    if prior_rpm is not None:
        ax.plot(prior_rpm, prior_depth_mm, color="tab:blue", lw=1.2, ls=":", label="prior SLD (hammer test)")
    if cuts and cuts.get("rpm"):
        lab = np.asarray(cuts.get("label", [""] * len(cuts["rpm"])))
        r, d = np.asarray(cuts["rpm"], float), np.asarray(cuts["depth_mm"], float)
        for name, (m, c) in _MARKERS.items():
            sel = lab == name
            if sel.any():
                ax.plot(r[sel], d[sel], m, color=c, mec="k" if m != "x" else c, ms=6, label=name or "boundary point")
    if recommended:
        ax.plot(recommended["rpm"], recommended["depth_mm"], "*", color="gold", mec="k", ms=14, label="recommended")
    if elsewhere:
        ax.plot([], [], " ", label=f"{elsewhere} cut{'s' if elsewhere > 1 else ''} in other conditions: not drawn")
    ax.set_xlim(rpm.min(), rpm.max())
    ax.set_ylim(depth_mm.min(), depth_mm.max())
    ax.set_xlabel("spindle speed [rpm]")
    ax.set_ylabel("axial depth [mm]")
    ax.set_title(title)
    ax.legend(fontsize=7, loc="upper left")
    return fig


def plot_recommendation(rec, title: str = "", ax=None):
    """A recommendation (:class:`millstab.update.decide.Recommendation`) on speed [rpm] and depth [mm]: the
    recommended cut (gold star) with its speed tolerance as a bar, the next test, and the data guard's chatter
    cuts with the depth cap each sets over its speed band (drawing only: the P(stable) map behind them is a new
    computation, ``api.update.map_figure``); into ``ax`` or a new figure. Returns the Figure."""
    from millstab.plot._layout import finish, panels

    fig, ax_ = panels(ax, figsize=(8, 5))
    tol = rec.speed_tolerance * rec.rpm
    ax_.errorbar([rec.rpm], [rec.depth_mm], xerr=[[tol], [tol]] if tol > 0 else None, fmt="*", color="gold",
                 mec="k", ms=14, ecolor="k", capsize=3, zorder=6,
                 label=f"recommended: P(chatter) {rec.p_chatter:.3f} ≤ {rec.risk:g}")
    nt = rec.next_test
    ax_.plot([nt["rpm"]], [nt["depth_mm"]], "D", color="tab:blue", mec="k", ms=8, zorder=5,
             label="next test" + (f": P(chatter) {nt['p_chatter']:.2f}" if "p_chatter" in nt else ""))
    for i, g in enumerate(rec.guard):
        ax_.plot([g["rpm"]], [g["depth_mm"]], "x", color="tab:red", ms=8, label="chatter cut (data guard)" if i == 0
                 else None)
        if "cap_mm" in g and "half_width_rpm" in g:
            ax_.hlines(g["cap_mm"], g["rpm"] - g["half_width_rpm"], g["rpm"] + g["half_width_rpm"],
                       color="tab:red", lw=1.0, ls="-" if g.get("binding") else ":",
                       label="guard cap" if i == 0 else None)
    ax_.set_ylim(bottom=0)
    ax_.set_xlabel("spindle speed [rpm]")
    ax_.set_ylabel("axial depth [mm]")
    ax_.set_title(title or f"recommended cut (limited by {rec.limited_by})", fontsize=10)
    ax_.grid(alpha=0.3)
    ax_.legend(fontsize=7, loc="upper left")
    finish(fig, ax)
    return fig


def plot_prediction(rpm: np.ndarray, depth_mm: np.ndarray, p_stable: np.ndarray, labels=None, title: str = "",
                    ax=None):
    """Cuts at speed [rpm] and depth [mm] coloured by their P(stable) (0 red … 1 green), the written labels
    marked around them where given; into ``ax`` or a new figure. Returns the Figure."""
    from millstab.plot._layout import finish, panels

    fig, ax_ = panels(ax, figsize=(8, 5))
    sc = ax_.scatter(rpm, depth_mm, c=p_stable, cmap="RdYlGn", vmin=0, vmax=1, s=40, edgecolors="k", zorder=5)
    fig.colorbar(sc, ax=ax_, label="P(stable)")
    if labels is not None:
        lab = np.asarray(labels).astype(str)
        for name in ("stable", "chatter", "marginal"):
            sel = lab == name
            if sel.any():
                m, c = _MARKERS[name]
                ax_.scatter(np.asarray(rpm)[sel], np.asarray(depth_mm)[sel], s=120, marker=m if m != "x" else "s",
                            facecolors="none", edgecolors=c, lw=1.2, zorder=4, label=f"labelled {name}")
        if ax_.get_legend_handles_labels()[0]:
            ax_.legend(fontsize=7, loc="upper left")
    ax_.set_ylim(bottom=0)
    ax_.set_xlabel("spindle speed [rpm]")
    ax_.set_ylabel("axial depth [mm]")
    ax_.set_title(title or f"P(stable) of {np.size(rpm)} cuts", fontsize=10)
    ax_.grid(alpha=0.3)
    finish(fig, ax)
    return fig


def plot_campaign(rpm: np.ndarray, depth_mm: np.ndarray, maps: dict, truth_depth_mm: np.ndarray, cuts: dict,
                  recs: dict, productivity: np.ndarray, stable: np.ndarray, prior_depth_mm: np.ndarray | None = None):
    """A virtual campaign: P(stable) maps after some numbers of cuts, and productivity / best vs cuts.

    Args:
        rpm (S,), depth_mm (D,): the maps' grid [rpm], [mm].
        maps: {number of cuts k: P(stable) (S, D)} (up to three panels).
        truth_depth_mm: the true limit at ``rpm`` [mm]; prior_depth_mm: the prior's SLD [mm] or ``None``.
        cuts: {"rpm", "depth_mm", "label"} lists of the campaign's cuts in order (panel k shows the first k).
        recs: {k: (rpm, depth_mm)} the recommendation after k cuts.
        productivity, stable: after 0, 1, … cuts, the recommendation's productivity over the best truly
            stable cut's, and whether it is truly stable.
    """
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(11, 7.5))
    lab = np.asarray(cuts["label"])
    cr, cd = np.asarray(cuts["rpm"], float), np.asarray(cuts["depth_mm"], float)
    for ax, (k, pm) in zip(axes.ravel(), maps.items()):
        mesh = ax.pcolormesh(rpm, depth_mm, pm.T, cmap="RdYlGn", vmin=0, vmax=1, shading="auto", rasterized=True)
        ax.contour(rpm, depth_mm, pm.T, levels=[0.05, 0.5, 0.95], colors="k", linewidths=[0.6, 1.2, 0.6],
                   linestyles=["--", "-", "--"])
        ax.plot(rpm, truth_depth_mm, color="tab:blue", lw=1.4, label="true limit")
        if prior_depth_mm is not None:
            ax.plot(rpm, prior_depth_mm, color="tab:blue", lw=1, ls=":", label="hammer-test SLD")
        for name, (m, c) in _MARKERS.items():
            sel = (lab == name) & (np.arange(lab.size) < k)
            if sel.any():
                ax.plot(cr[sel], cd[sel], "X" if m == "x" else m, color=c, mec="k", ms=7, label=name)
        if k in recs:
            ax.plot(*recs[k], "*", color="gold", mec="k", ms=14, label="recommended (risk 5 %)")
        ax.set_xlim(rpm.min(), rpm.max())
        ax.set_ylim(depth_mm.min(), depth_mm.max())
        ax.set_title(f"after {k} cut{'s' if k != 1 else ''}", fontsize=10)
        ax.set_xlabel("spindle speed [rpm]")
        ax.set_ylabel("axial depth [mm]")
        fig.colorbar(mesh, ax=ax, label="P(stable)")
    axes.ravel()[len(maps) - 1].legend(fontsize=7, loc="upper left")  # the panel with the most cuts
    ax = axes[1, 1]
    k = np.arange(len(productivity))
    p, ok = np.asarray(productivity, float), np.asarray(stable, bool)
    ax.plot(k, p, "-", color="0.5")
    ax.plot(k[ok], p[ok], "o", color="tab:green", label="truly stable")
    ax.plot(k[~ok], p[~ok], "x", color="tab:red", ms=8, label="chatters")
    ax.axhline(0.85, color="k", ls="--", lw=0.8, label="85 % of the best")
    ax.set_ylim(0, max(1.05, float(p.max()) + 0.05))
    ax.set_xlabel("test cuts")
    ax.set_ylabel("productivity / best truly stable")
    ax.set_title("cuts to the optimum", fontsize=10)
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    return fig


__all__ = ["plot_campaign", "plot_corner", "plot_pmap", "plot_prediction", "plot_recommendation"]
