"""The progress callbacks, in one place: the one public protocol and the two shapes that truly differ from it.

* :data:`Progress` -- ``progress(stage, done, total)``: ``stage`` a short text, ``done`` a count and ``total``
  the count at the end, or ``None`` where it is not known in advance. The service layer's protocol
  (``millstab.api.Progress``) and the engines' (the SDM engine always knows its total).
* :data:`CountProgress` -- ``progress(done, total)``: a counter with no stage, as ``forward``'s
  ``Pinned.map``, ``cluster`` and the sensitivity studies report rows or paths; the stage is the caller's.
* :data:`SolverProgress` -- ``progress(stage, iteration, best)``: an identification solver's, whose third
  argument is the best objective value so far, not a total (an iterative solver has none).

:func:`count_progress` and :func:`solver_progress` turn the last two into :data:`Progress`. Cancellation
(raising from the callback) is :mod:`millstab.api.progress`'s.
"""

from __future__ import annotations

from typing import Callable, Optional

#: progress(stage, done, total); total None = unknown
Progress = Callable[[str, int, Optional[int]], None]
#: progress(done, total): a counter without a stage
CountProgress = Callable[[int, int], None]
#: progress(stage, iteration, best objective so far)
SolverProgress = Callable[[str, int, float], None]


def solver_progress(progress: Progress | None, label: str) -> SolverProgress | None:
    """Adapt a solver's ``progress(stage, iteration, best)`` to :data:`Progress` (total unknown; the best
    objective value goes into the stage text)."""
    if progress is None:
        return None

    def report(stage: str, iteration: int, best: float) -> None:
        progress(f"{label}: {stage}, best {best:.4g}", int(iteration), None)

    return report


def count_progress(progress: Progress | None, stage: str) -> CountProgress | None:
    """Adapt a ``progress(done, total)`` counter (sensitivity studies) to :data:`Progress`."""
    if progress is None:
        return None
    return lambda done, total: progress(stage, int(done), int(total))


__all__ = ["CountProgress", "Progress", "SolverProgress", "count_progress", "solver_progress"]
