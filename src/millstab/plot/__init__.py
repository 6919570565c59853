"""Figures. Functions take result objects and return matplotlib figures; nothing is computed here, and
no file is written (save a figure with :func:`millstab.io.save_figure`).

* :mod:`millstab.plot.sld` -- stability lobe diagrams (envelope, raw lobes, measured points, panels, families).
* :mod:`millstab.plot.identify`, :mod:`millstab.plot.sensitivity` -- identification and sensitivity figures.

Importing this package leaves matplotlib's backend alone (a notebook keeps its inline or widget
backend); saving needs no display, since each format renders with its own canvas.
"""
