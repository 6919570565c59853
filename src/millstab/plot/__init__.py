"""Figures. Functions take result objects and return matplotlib figures; nothing is computed here.

* :mod:`millstab.plot.sld` -- stability lobe diagrams (envelope, raw lobes, measured points, panels, families).
* :mod:`millstab.plot.identify`, :mod:`millstab.plot.sensitivity` -- identification and sensitivity figures.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; never needs a display

from millstab.errors import InputError  # noqa: E402

FORMATS = (".png", ".svg", ".pdf")


def save_figure(fig, path: str | Path, protect=()) -> Path:
    """Save a figure as PNG, SVG or PDF (by extension) through a temporary file, then close it."""
    import os
    import tempfile

    from millstab.io.results import check_not_protected

    p = Path(path)
    if p.suffix.lower() not in FORMATS:
        raise InputError("plot file", str(path), f"extension must be one of {', '.join(FORMATS)}")
    check_not_protected(p, protect)
    p.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=p.parent, suffix=p.suffix)
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=150, bbox_inches="tight", format=p.suffix[1:].lower())
        os.replace(tmp, p)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
        import matplotlib.pyplot as plt

        plt.close(fig)
    return p
