"""Bokeh figures of the page: the SLD with hover readout and overlaid points, and the P(stable) map.
They draw what the service layer computed; nothing here computes a limit."""

from __future__ import annotations

import numpy as np
from bokeh.models import ColumnDataSource, HoverTool
from bokeh.plotting import figure

#: point labels and how they are drawn (boundary points have label "")
MARKERS = {"": ("boundary", "black", "circle"), "stable": ("stable", "#2e7d32", "circle"),
           "chatter": ("chatter", "#c62828", "x"), "marginal": ("marginal", "#ef6c00", "triangle")}


def update(source: ColumnDataSource, data: dict) -> None:
    """Replace a source's data from any callback of the session. Panel runs some widget callbacks
    without the Bokeh document lock; ``pn.io.unlocked`` holds the change and sends it itself."""
    import panel as pn

    with pn.io.unlocked():
        source.data = data


def _finite(a: np.ndarray) -> np.ndarray:
    """NaN instead of ±inf (JSON cannot carry inf; Bokeh leaves a gap at NaN)."""
    a = np.asarray(a, float).copy()
    a[~np.isfinite(a)] = np.nan
    return a


def sld_figure(title: str = "", name: str = "sld", limit: str = "limit", second: str = "second curve",
               raw: bool = True) -> tuple:
    """(figure, sources): the limit line (legend ``limit``) with hover, a second line (legend ``second``: the
    fit's start), the raw lobes (with ``raw``) and one scatter per point label; ``sources["legend"]`` holds the
    point layers' legend entries (:func:`set_scatter` shows each while its layer holds points)."""
    fig = figure(height=430, sizing_mode="stretch_width", title=title, x_axis_label="spindle speed [rpm]",
                 y_axis_label="axial depth limit [mm]", tools="pan,box_zoom,wheel_zoom,reset,save", name=f"{name}_fig")
    src = {"env": ColumnDataSource(dict(rpm=[], blim_mm=[], lobe=[], chatter_hz=[]), name=f"{name}_source"),
           "other": ColumnDataSource(dict(rpm=[], blim_mm=[]), name=f"{name}_other"),
           "raw": ColumnDataSource(dict(xs=[], ys=[]), name=f"{name}_raw"),
           "plan": ColumnDataSource(dict(rpm=[], depth_mm=[]), name=f"{name}_plan")}
    if raw:
        fig.multi_line("xs", "ys", source=src["raw"], color="#9e9e9e", line_width=0.8, alpha=0.7,
                       legend_label="raw lobes")
    line = fig.line("rpm", "blim_mm", source=src["env"], color="#1565c0", line_width=2, legend_label=limit)
    if second:
        fig.line("rpm", "blim_mm", source=src["other"], color="#6a1b9a", line_width=1.5, line_dash="dotted",
                 legend_label=second)
    layers = {}  # the point layers' renderers, by source key
    for label, (text, color, marker) in MARKERS.items():
        key = f"pts_{text}"
        src[key] = ColumnDataSource(dict(rpm=[], depth_mm=[]), name=f"{name}_{key}")
        layers[key] = fig.scatter("rpm", "depth_mm", source=src[key], color=color, marker=marker, size=7,
                                  legend_label=text)
    layers["plan"] = fig.scatter("rpm", "depth_mm", source=src["plan"], color="#00838f", marker="inverted_triangle",
                                 size=10, legend_label="planned tests")
    fig.add_tools(HoverTool(renderers=[line], mode="vline", tooltips=[
        ("speed", "@rpm{0,0} rpm"), ("depth limit", "@blim_mm{0.000} mm"), ("chatter", "@chatter_hz{0,0.0} Hz"),
        ("lobe", "@lobe")]))
    fig.add_layout(fig.legend[0], "right")
    # the point layers' legend entries, shown only while their layer holds points (set_scatter): an empty
    # layer's entry is a name without a marker, and "stable" listed over a plot without one misleads
    src["legend"] = {key: item for item in fig.legend[0].items for key, r in layers.items() if r in item.renderers}
    for item in src["legend"].values():
        item.visible = False
    fig.legend.click_policy = "hide"
    fig.legend.label_text_font_size = "9pt"
    fig.y_range.start = 0
    return fig, src


def set_points(src: dict, points) -> None:
    """Overlay a PointSet by label (or clear with None)."""
    for label, (text, _, _) in MARKERS.items():
        if points is None:
            set_scatter(src, f"pts_{text}", [], [])
        else:
            m = points.label == label
            set_scatter(src, f"pts_{text}", points.rpm[m], points.depth_mm[m])


def set_scatter(src: dict, key: str, rpm, depth_mm) -> None:
    """Put points [rev/min, mm] in the SLD's layer ``key`` (``pts_<label>``, ``plan``); its legend entry is
    shown while it holds any."""
    import panel as pn

    update(src[key], dict(rpm=rpm, depth_mm=depth_mm))
    with pn.io.unlocked():
        src["legend"][key].visible = len(rpm) > 0


def set_line(source: ColumnDataSource, rpm, depth_mm, **extra) -> None:
    update(source, dict(rpm=np.asarray(rpm, float), blim_mm=_finite(depth_mm), **extra))


def set_raw(source: ColumnDataSource, lobes, rpm=None, depth_mm=None) -> None:
    """The raw zero-order lobes (millstab.stability.zoa.Lobe: rpm, depth [m]), cut to the speeds ``rpm``
    [rev/min] and to twice the largest finite limit ``depth_mm`` (a lobe's branches run far outside the
    diagram and would set its axes)."""
    if not lobes:
        update(source, dict(xs=[], ys=[]))
        return
    lo, hi = (float(np.min(rpm)), float(np.max(rpm))) if rpm is not None else (-np.inf, np.inf)
    d = np.asarray(depth_mm, float) if depth_mm is not None else np.array([np.inf])
    top = 2.0 * float(np.max(d[np.isfinite(d)])) if np.isfinite(d).any() else np.inf
    xs, ys = [], []
    for lb in lobes:
        x = np.asarray(lb.rpm, float)
        y = _finite(np.asarray(lb.depth) * 1e3)
        y[(x < lo) | (x > hi) | (y > top)] = np.nan
        if np.isfinite(y).any():
            xs.append(x)
            ys.append(y)
    update(source, dict(xs=xs, ys=ys))


def map_figure(rpm, depth_mm, pm, cuts=None, name: str = "pmap", marks=()):
    """P(stable) over rpm × depth with the 5/50/95 % contours, the cuts, and ``marks``: (rpm, depth [mm],
    legend label) of the recommended cut and the next test. The axes span the map and every mark (one outside the
    map was drawn off the axes: the caller makes the map reach them, this keeps them in sight regardless)."""
    x = [float(rpm[0]), float(rpm[-1])] + [float(r) for r, _, _ in marks]
    y = [float(depth_mm[0]), float(depth_mm[-1])] + [float(d) for _, d, _ in marks]
    fig = figure(height=430, sizing_mode="stretch_width",
                 title="P(stable), with its 5 % (dashed), 50 % (solid) and 95 % (dotted) boundaries",
                 x_axis_label="spindle speed [rpm]", y_axis_label="axial depth [mm]",
                 x_range=(min(x), max(x)), y_range=(min(y), max(y)),
                 tools="pan,box_zoom,wheel_zoom,reset,save,hover", name=f"{name}_fig",
                 tooltips=[("speed", "$x{0,0} rpm"), ("depth", "$y{0.00} mm"), ("P(stable)", "@image{0.00}")])
    from bokeh.models import ColorBar, LinearColorMapper
    from bokeh.palettes import RdYlGn11

    colors = LinearColorMapper(palette=list(reversed(RdYlGn11)), low=0.0, high=1.0)  # red: chatter, green: stable
    fig.image(image=[np.asarray(pm, float).T], x=float(rpm[0]), y=float(depth_mm[0]), dw=float(rpm[-1] - rpm[0]),
              dh=float(depth_mm[-1] - depth_mm[0]), color_mapper=colors, name=f"{name}_image")
    fig.add_layout(ColorBar(color_mapper=colors, title="P(stable)", width=12), "right")
    if np.nanmin(pm) < 0.95 and np.nanmax(pm) > 0.05:
        # black lines read on both ends of the red-green map: 5 % dashed, 50 % solid, 95 % dotted
        fig.contour(np.asarray(rpm, float), np.asarray(depth_mm, float), np.asarray(pm, float).T,
                    levels=[0.05, 0.5, 0.95],
                    line_color="black", line_width=[1.5, 2.5, 1.5], line_dash=["dashed", "solid", "dotted"])
    if cuts is not None:
        styles = {"stable": dict(marker="circle", fill_color="white", line_color="black", size=9),
                  "chatter": dict(marker="x", line_color="black", line_width=2.5, size=11),
                  "marginal": dict(marker="triangle", fill_color="#ef6c00", line_color="black", size=10),
                  "": dict(marker="diamond", fill_color="#1565c0", line_color="white", size=9)}
        for label, style in styles.items():
            m = cuts.label == label
            if m.any():
                fig.scatter(cuts.rpm[m], cuts.depth_mm[m], legend_label=MARKERS[label][0], **style)
    drawn = [fig.scatter([r], [d], marker=marker, size=18, fill_color=color, line_color="white", legend_label=text)
             for (r, d, text), (marker, color) in zip(marks, (("star", "#1565c0"), ("square_pin", "#6a1b9a")))]
    if drawn:  # the recommendation on top: the next test is often the recommended cut itself and hid its star
        fig.renderers = [g for g in fig.renderers if g is not drawn[0]] + [drawn[0]]
    if cuts is not None or marks:
        fig.legend.location = "top_right"
    return fig


def preview_figure(src: dict):
    """A small SLD beside the form; its source ``src["preview"]`` gets the same data as the Lobes tab's
    (a Bokeh model cannot be shared by two panes)."""
    src["preview"] = ColumnDataSource(dict(rpm=[], blim_mm=[], lobe=[], chatter_hz=[]), name="preview_source")
    fig = figure(height=320, width=460, title="SLD preview (details in Lobes)", x_axis_label="spindle speed [rpm]",
                 y_axis_label="depth limit [mm]", tools="pan,box_zoom,wheel_zoom,reset", name="preview_fig")
    line = fig.line("rpm", "blim_mm", source=src["preview"], color="#1565c0", line_width=2)
    fig.add_tools(HoverTool(renderers=[line], mode="vline", tooltips=[
        ("speed", "@rpm{0,0} rpm"), ("depth limit", "@blim_mm{0.000} mm"), ("chatter", "@chatter_hz{0,0.0} Hz"),
        ("lobe", "@lobe")]))
    fig.y_range.start = 0
    return fig
