"""The modal fit figure: measured vs fitted magnitude and phase per direction, the stabilisation
diagram, and (when a config gave the cutting conditions) the SLD from the fit beside the measured one."""

from __future__ import annotations

import numpy as np

#: stabilisation-diagram markers: (marker, colour, label) by stability class 0/1/2
_STAB = {0: ("o", "0.7", "new pole"), 1: ("v", "tab:orange", "stable fn"), 2: ("+", "tab:green", "stable fn and ζ")}


def plot_modal_fit(result, check=None, ax=None):
    """Figure of a :class:`~millstab.modal.run.ModalResult` (and an optional :class:`SLDCheck`), in a new figure
    or in ``ax``'s place."""
    from millstab.plot._layout import finish, panels

    dirs = list(result.fits)
    rows = 3 if check is None else 4
    fig, axes = panels(ax, rows, len(dirs), figsize=(6.0 * len(dirs), 2.6 * rows), squeeze=False,
                             gridspec_kw={"height_ratios": [2, 1, 2] + ([2] if check is not None else [])})
    for j, d in enumerate(dirs):
        fit = result.fits[d]
        f = fit.freq_hz
        ax_m, ax_p, ax_s = axes[0, j], axes[1, j], axes[2, j]
        ax_m.semilogy(f, np.abs(fit.h), color="0.55", lw=1, label=f"measured ({fit.source})")
        ax_m.semilogy(f, np.abs(fit.h_fit), color="tab:blue", lw=1.3, label=f"fit, {len(fit.modes)} mode(s)")
        for m in fit.modes:
            ax_m.axvline(m.fn, color="tab:red", lw=0.6, alpha=0.6)
        ax_m.set_ylabel("|H| [m/N]")
        ax_m.set_title(f"{d}: RMS misfit {100 * fit.nrmse:.2f} % of max |H|")
        ax_m.legend(fontsize=8)
        ax_p.plot(f, np.degrees(np.angle(fit.h)), color="0.55", lw=1)
        ax_p.plot(f, np.degrees(np.angle(fit.h_fit)), color="tab:blue", lw=1.3)
        ax_p.set_ylabel("phase [deg]")
        ax_p.set_ylim(-185, 185)
        st = fit.stabilisation
        for cls, (marker, colour, label) in _STAB.items():
            xs = np.concatenate([fn[s == cls] for fn, s in zip(st.fn, st.stable)])
            ys = np.concatenate([np.full(int(np.sum(s == cls)), o) for o, s in zip(st.orders, st.stable)])
            ax_s.plot(xs, ys, marker, color=colour, ms=4, ls="none", label=label)
        for m in fit.modes:
            ax_s.axvline(m.fn, color="tab:red", lw=0.6, alpha=0.6)
        ax_s.set_xlim(f[0], f[-1])
        ax_s.set_xlabel("frequency [Hz]")
        ax_s.set_ylabel("model order")
        ax_s.legend(fontsize=7, loc="upper right")
    if check is not None:
        gs = axes[3, 0].get_gridspec()
        for a in axes[3, :]:
            a.remove()
        a = fig.add_subplot(gs[3, :])
        a.plot(check.rpm, check.measured_mm, color="0.4", lw=1.2,
               label=f"measured FRF (min {check.min_measured_mm:.4g} mm)")
        a.plot(check.rpm, check.fitted_mm, color="tab:blue", lw=1.2, ls="--",
               label=f"fitted modes (min {check.min_fitted_mm:.4g} mm)")
        a.set_xlabel("spindle speed [rev/min]")
        a.set_ylabel("b_lim [mm]")
        finite = np.concatenate([check.measured_mm[np.isfinite(check.measured_mm)],
                                 check.fitted_mm[np.isfinite(check.fitted_mm)]])
        if finite.size:
            a.set_ylim(0, min(float(finite.max()), 6 * float(finite.min())) * 1.05)
        a.set_title(f"SLD check: minimum depth {100 * check.min_difference:+.2f} %, worst difference "
                     f"{100 * check.worst_difference:.1f} % at {check.worst_rpm:.6g} rpm")
        a.legend(fontsize=8)
    finish(fig, ax)
    return fig


__all__ = ["plot_modal_fit"]
