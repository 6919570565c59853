"""Report figures read well: the Fig. fourSLD legend covers no curve, the Newton convergence plot shows a
zig-zag history as dots under a best-so-far line, and the report's figures carry their title once."""

from __future__ import annotations

from types import SimpleNamespace

import matplotlib.pyplot as plt
import numpy as np
import pytest

from millstab.plot.identify import plot_convergence
from millstab.plot.sld import plot_sld_family


def _fake_fit(mlae, rss=None):
    n = len(mlae)
    return SimpleNamespace(history_mlae=np.asarray(mlae, float),
                           history_rss=np.full(n, np.nan) if rss is None else np.asarray(rss, float),
                           method="newton", iterations=n, evaluations=10 * n)


def _zigzag(n):
    """A paper-like history: a decreasing trend, every other iterate a trial jump 10x worse."""
    i = np.arange(n)
    return 10.0 ** (-3 * i / n) * np.where(i % 2, 10.0, 1.0)


def test_family_legend_is_outside_the_axes():
    rpm = np.linspace(5000, 7000, 201)
    # six curves whose peaks reach the top of the plot everywhere, the upper left included
    curves = {f"curve {i} with a long label": 0.3 + 0.3 * np.abs(np.sin((rpm - 5000) / 150 + i)) for i in range(5)}
    fig = plot_sld_family(rpm, curves, fitted=("fitted", curves["curve 0 with a long label"] * 1.01))
    fig.canvas.draw()
    (ax,) = fig.axes
    legends = list(fig.legends) + ([ax.get_legend()] if ax.get_legend() is not None else [])
    assert len(legends) == 1
    assert len(legends[0].get_texts()) == 6
    assert not legends[0].get_window_extent().overlaps(ax.get_window_extent())
    plt.close(fig)


def test_long_zigzag_history_is_dots_under_a_best_so_far_line():
    h = _zigzag(600)  # the paper's scheme runs 600 iterations from Table 3's start
    fig = plot_convergence(_fake_fit(h))
    (ax,) = fig.axes
    assert ax.get_yscale() == "log"
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    dots = lines["MLAE (eq. 4), each iterate"]
    assert dots.get_linestyle() == "None" and dots.get_marker() == "." and np.array_equal(dots.get_ydata(), h)
    best = lines["MLAE (eq. 4), best so far"]
    assert best.get_linestyle() == "-" and best.get_linewidth() > dots.get_markersize() / 2
    # best so far, recomputed by brute force
    assert np.array_equal(best.get_ydata(), [h[: k + 1].min() for k in range(h.size)])
    plt.close(fig)


def test_short_history_is_joined_and_monotone_history_has_one_line():
    h = _zigzag(20)
    fig = plot_convergence(_fake_fit(h))
    lines = {ln.get_label(): ln for ln in fig.axes[0].get_lines()}
    assert lines["MLAE (eq. 4), each iterate"].get_linestyle() == "-"
    assert "MLAE (eq. 4), best so far" in lines
    plt.close(fig)
    mono = np.geomspace(1, 1e-4, 200)  # least squares records the best after each iteration: nothing to add
    fig = plot_convergence(_fake_fit(mono, rss=mono ** 2))
    labels = [ln.get_label() for ln in fig.axes[0].get_lines()]
    assert labels == ["MLAE (eq. 4)", "RSS (fitted residuals)"]
    plt.close(fig)


def test_report_figure_keeps_its_title_once(tmp_path):
    from millstab.reproduce.report import ReportWriter

    rep = ReportWriter(tmp_path, "t")
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    ax.set_title("Fig. X: a title")
    rep.figure("one", fig, "Fig. X: a title")
    assert ax.get_title() == ""  # the caption is the title
    fig, axes = plt.subplots(1, 2)
    fig.suptitle("Fig. Y: panels")
    for a, t in zip(axes, ("left", "right")):
        a.set_title(t)
    rep.figure("two", fig, "Fig. Y: panels")
    assert fig.get_suptitle() == "" and [a.get_title() for a in axes] == ["left", "right"]  # panel titles stay
    rep.write()
    md = (tmp_path / "report.md").read_text()
    assert md.count("Fig. X: a title") == 1 and md.count("Fig. Y: panels") == 1


@pytest.mark.parametrize("value,shown", [(np.bool_(True), "yes"), (np.bool_(False), "no"), (True, "yes"),
                                         (np.float64(1.0), "1"), (np.int64(3), "3")])
def test_report_numbers_show_booleans_as_words(value, shown):
    from millstab.reproduce.report import fmt

    assert fmt(value) == shown


def test_comparison_rows_read_compared_with_the_ratio(tmp_path):
    from millstab.reproduce.report import ReportWriter

    rep = ReportWriter(tmp_path, "t")
    c = rep.compare("mean fn/k beside the paper's", 138.0, 83.0)
    assert c.verdict == "compared" and "ours/paper = 1.66" in c.measured and "138" in c.measured
    assert rep.check("a claim", "x", False).verdict == "DOES NOT HOLD"
    rep.write()
    md = (tmp_path / "report.md").read_text()
    assert "| mean fn/k beside the paper's | ours 138, paper 83: ours/paper = 1.66 | compared |" in md
    assert "| a claim | x | DOES NOT HOLD |" in md


def test_a_finished_report_is_frozen(tmp_path):
    """ReportWriter builds, Report is what a run returns: frozen, its checks and files tuples (issue 26: Report
    was a mutable writer whose lists a caller could change after the run; fails on the old code)."""
    import dataclasses

    from millstab.reproduce.report import Check, Report, ReportWriter

    w = ReportWriter(tmp_path, "t")
    w.heading("h")
    w.check("a claim", "x", True)
    rep = w.write()
    assert isinstance(rep, Report) and rep.checks == (Check("a claim", "x", True),)
    with pytest.raises(dataclasses.FrozenInstanceError):
        rep.title = "other"
    with pytest.raises(AttributeError):
        rep.checks.append(Check("added later", "y", False))
    w.check("after the report", "z", False)  # the writer goes on; the report it gave does not change
    assert len(rep.checks) == 1
    assert rep.markdown() == Report(tmp_path, "t", rep.blocks, rep.checks, rep.files).markdown()
