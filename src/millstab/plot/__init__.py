"""Figures. Functions take result objects and return matplotlib figures; nothing is computed here.

* :mod:`millstab.plot.sld` -- stability lobe diagrams (envelope, raw lobes, measured points, panels, families).
* :mod:`millstab.plot.identify`, :mod:`millstab.plot.sensitivity` -- identification and sensitivity figures.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; never needs a display

from millstab.io.outputs import FIGURE_FORMATS as FORMATS  # noqa: E402


def save_figure(fig, path: str | Path, protect=()) -> Path:
    """Save a figure as PNG, SVG or PDF (by extension) through the io layer's atomic writer, then close it.

    Raises:
        InputError: unknown extension, ``path`` is one of ``protect``, or it cannot be written.
    """
    import matplotlib.pyplot as plt

    from millstab.io.results import write_figure

    try:
        return write_figure(fig, path, protect=protect)
    finally:
        plt.close(fig)
