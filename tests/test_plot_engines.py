"""plot.engines: one panel per cut, every engine's curve drawn with its data, flip speeds marked."""

from __future__ import annotations

import numpy as np

from millstab.plot.engines import STYLE_CYCLE, plot_engine_panels
from millstab.reproduce.low_immersion import ENGINE_STYLE


def test_panels_draw_each_engine_and_the_flip_markers():
    rpm = np.linspace(5000, 25000, 11)
    zoa = 1 + (rpm - 15000) ** 2 / 1e8  # lowest 1 mm, highest 2 mm
    spec = zoa * 0.8
    flip = spec < 0.9
    fig = plot_engine_panels([
        {"title": "a", "curves": {"zoa": (rpm, zoa), "sdm": (rpm[::2], zoa[::2]), "spectral": (rpm, spec)},
         "flip": (rpm[flip], spec[flip])},
        {"title": "b", "curves": {"zoa": (rpm, 10 * zoa)}, "ylim_mm": 7.0},
    ], ENGINE_STYLE)
    ax0, ax1 = fig.axes
    lines = {ln.get_label(): ln for ln in ax0.get_lines()}
    assert np.array_equal(lines["zero-order (ZOA)"].get_ydata(), zoa)
    assert np.array_equal(lines["semi-discretization (SDM)"].get_xdata(), rpm[::2])
    assert np.array_equal(lines["spectral"].get_ydata(), spec)
    assert lines["flip (period-doubling) boundary"].get_xdata().size == flip.sum() > 0
    # default top: 1.1 × min(highest, 4 × lowest) over the panel's curves; a given ylim is kept
    assert ax0.get_ylim() == (0, 1.1 * min(zoa.max(), 4 * spec.min()))
    assert ax1.get_ylim() == (0, 7.0) and ax0.get_title() == "a"
    assert "flip (period-doubling) boundary" not in [ln.get_label() for ln in ax1.get_lines()]


def test_curves_without_a_given_style_take_the_cycle_and_their_names():
    """The plot knows no engine names: unstyled curves get the cycle's styles in order, labelled by name."""
    rpm = np.linspace(5000, 25000, 5)
    fig = plot_engine_panels([{"title": "c", "curves": {"mine": (rpm, rpm / 1e4), "other": (rpm, rpm / 2e4)}}])
    (ax,) = fig.axes
    first, second = ax.get_lines()
    assert (first.get_label(), second.get_label()) == ("mine", "other")
    assert first.get_linestyle() == STYLE_CYCLE[0]["ls"] and second.get_color() == STYLE_CYCLE[1]["color"]
