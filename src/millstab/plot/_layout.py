"""Where a figure's panels go: a new figure, or the place of an Axes the caller gives (``ax=``), so that
every result's ``figure(ax=None)`` can draw into a figure of the caller's (a notebook's grid, a report page).

A one-panel figure draws into ``ax`` itself; a figure of several panels takes ``ax``'s place in its figure
(``ax`` is removed and its slot split into the panels, :meth:`matplotlib.gridspec.SubplotSpec.subgridspec`).
Only a figure made here is laid out (``tight_layout``): a caller's figure is the caller's to lay out."""

from __future__ import annotations

import numpy as np


def panels(ax, nrows: int = 1, ncols: int = 1, *, figsize=None, squeeze: bool = True, gridspec_kw=None, layout=None,
           **kw):
    """``(figure, axes)`` as :func:`matplotlib.pyplot.subplots` returns them; with ``ax`` the panels fill its
    place (``figsize`` and ``layout`` then belong to the caller's figure and are ignored)."""
    import matplotlib.pyplot as plt

    if ax is None:
        return plt.subplots(nrows, ncols, figsize=figsize, squeeze=squeeze, gridspec_kw=gridspec_kw, layout=layout,
                            **kw)
    fig = ax.figure
    if nrows == ncols == 1:
        return fig, (ax if squeeze else np.array([[ax]]))
    spec = ax.get_subplotspec()
    ax.remove()
    return fig, spec.subgridspec(nrows, ncols, **(gridspec_kw or {})).subplots(squeeze=squeeze, **kw)


def grid(ax, nrows: int, ncols: int, *, figsize=None, **gridspec_kw):
    """``(figure, gridspec)`` for panels placed by hand (``fig.add_subplot(gs[...])``): a new figure's grid,
    or ``ax``'s place split into ``nrows`` × ``ncols``."""
    import matplotlib.pyplot as plt

    if ax is None:
        fig = plt.figure(figsize=figsize)
        return fig, fig.add_gridspec(nrows, ncols, **gridspec_kw)
    fig, spec = ax.figure, ax.get_subplotspec()
    ax.remove()
    return fig, spec.subgridspec(nrows, ncols, **gridspec_kw)


def finish(fig, ax) -> None:
    """Lay out a figure made here (``ax`` None); leave a caller's alone."""
    if ax is None:
        fig.tight_layout()


def suptitle(fig, ax, text: str) -> None:
    """The figure's title on a figure made here; a caller's figure keeps its own (its title is the caller's)."""
    if ax is None:
        fig.suptitle(text)
