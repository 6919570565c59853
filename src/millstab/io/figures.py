"""Writing figures: the plots (:mod:`millstab.plot`) return matplotlib figures and never touch files;
this module saves them (PNG, SVG or PDF, by extension) through the atomic writer of
:mod:`millstab.io.results`, so a figure output has the same guarantees as every other output.
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterable

from millstab.errors import InputError
from millstab.io.results import PathLike, _atomic_write

#: figure formats every ``--plot``-like option accepts (by extension)
FIGURE_FORMATS = (".png", ".svg", ".pdf")


def write_figure(fig, path: PathLike, protect: Iterable[PathLike] = (), dpi: int = 150) -> Path:
    """Save a matplotlib figure as PNG, SVG or PDF (by the extension of ``path``) atomically, with
    the same permissions as every other output (0666 minus umask); the figure is not closed.

    Raises:
        InputError: unknown extension, a protected input file, or a path that cannot be written.
    """
    p = Path(path)
    fmt = p.suffix.lower()
    if fmt not in FIGURE_FORMATS:
        raise InputError("plot file", str(path), f"extension must be one of {', '.join(FIGURE_FORMATS)}")
    # savefig renders with the format's own (non-interactive) canvas, whatever the session's backend
    return _atomic_write(p, lambda fh: fig.savefig(fh, dpi=dpi, bbox_inches="tight", format=fmt[1:]), protect)


def save_figure(fig, path: PathLike, protect: Iterable[PathLike] = ()) -> Path:
    """:func:`write_figure`, then close the figure (a command or a report makes many; pyplot keeps each
    open figure alive until it is closed).

    Raises:
        InputError: unknown extension, ``path`` is one of ``protect``, or it cannot be written.
    """
    try:
        return write_figure(fig, path, protect=protect)
    finally:
        import matplotlib.pyplot as plt  # importing pyplot selects no backend; closing needs none

        plt.close(fig)




def figure_bytes(fig, fmt: str, dpi: int = 150) -> bytes:
    """A figure as PNG, SVG or PDF bytes (a download), rendered as :func:`write_figure` renders files;
    the figure is closed.

    Raises:
        InputError: unknown format.
    """
    import io

    import matplotlib.pyplot as plt

    ext = "." + fmt.lower().lstrip(".")
    if ext not in FIGURE_FORMATS:
        raise InputError("figure format", fmt, f"must be one of {', '.join(FIGURE_FORMATS)}")
    buf = io.BytesIO()
    try:
        fig.savefig(buf, format=ext[1:], dpi=dpi, bbox_inches="tight")
    finally:
        plt.close(fig)
    return buf.getvalue()


__all__ = ["FIGURE_FORMATS", "figure_bytes", "save_figure", "write_figure"]
