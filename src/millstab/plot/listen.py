"""Figure of a listened recording: the spectrum with its noise floor, the masked synchronous and mains
lines and the chatter line; below, the chatter amplitude in time (onset marked). Draws
:class:`millstab.listen.Listening`; computes nothing."""

from __future__ import annotations

import math

import numpy as np

from millstab.plot._layout import finish, panels
from millstab.plot.simulate import LABEL_COLOUR


def plot_listening(res, title: str = "", ax=None):
    """The spectrum over the chatter amplitude in time, in a new figure or in ``ax``'s place."""
    fig, (ax_f, ax_t) = panels(ax, 2, 1, figsize=(8, 6), gridspec_kw={"height_ratios": [2, 1]})
    f, p = res.freq_hz, res.psd
    keep = f <= min(8000.0, f[-1])
    db = 10 * np.log10(np.maximum(p[keep], 1e-300))
    ax_f.plot(f[keep], db, lw=0.6, color="0.3", label="spectrum")
    ax_f.plot(f[keep], 10 * np.log10(np.maximum(res.floor[keep], 1e-300)), lw=1.0, color="tab:blue", label="floor")
    m = res.synchronous[keep]
    ax_f.plot(f[keep][m], db[m], ".", ms=1.5, color="tab:gray", label="masked (spindle, mains)")
    colour = LABEL_COLOUR.get(res.label, "black")
    if math.isfinite(res.chatter_hz):
        ax_f.axvline(res.chatter_hz, color=colour, lw=1.0, ls="--", label=f"{res.chatter_hz:.1f} Hz")
    ax_f.set_xlabel("frequency [Hz]")
    ax_f.set_ylabel("PSD [dB]")
    ax_f.legend(fontsize=8, loc="upper right")
    ax_f.set_title(title + (": " if title else "") + f"{res.label}, score {res.score:.3g}", color=colour)
    if res.times_s.size:
        ax_t.plot(res.times_s, res.chatter_amp, "o-", ms=3, color=colour)
        if math.isfinite(res.onset_s):
            ax_t.axvline(res.onset_s, color="k", lw=0.8, ls=":", label=f"onset {res.onset_s:.2f} s")
            ax_t.legend(fontsize=8)
    ax_t.set_xlabel("time [s]")
    ax_t.set_ylabel("chatter amplitude")
    finish(fig, ax)
    return fig
