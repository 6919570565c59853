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

Cancel points: a stretch of work that reports no progress for long (the first tempering stage of an update, a map
or a recommendation from an sdm posterior: minutes of engine calls without a report) still stops when asked.
:func:`cancel_checked` names a check for the current thread; :func:`cancel_point`, called before every engine call of
the forward model and between the compiled chunks of an engine that chunks its work, runs it (the check raises to
stop). A thread without one (the command line, a notebook) pays one attribute lookup per call.
"""

from __future__ import annotations

import threading
from contextlib import contextmanager
from typing import Callable, Iterator, Optional

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


_HERE = threading.local()


@contextmanager
def cancel_checked(check: Callable[[], None]) -> Iterator[None]:
    """Within the block, on this thread only, every :func:`cancel_point` calls ``check()``, which raises to stop
    the work (``millstab.api.CancelToken.checked``: a web job's Cancel button). Why per thread: the app's jobs of
    several sessions share one process, and one session's cancel must not stop another's job."""
    before = getattr(_HERE, "check", None)
    _HERE.check = check
    try:
        yield
    finally:
        _HERE.check = before


def cancel_point() -> None:
    """Run this thread's cancel check (:func:`cancel_checked`), if any: a place where the work may stop (between
    engine calls or compiled chunks, never inside one: nothing is left half-written)."""
    check = getattr(_HERE, "check", None)
    if check is not None:
        check()


__all__ = ["CountProgress", "Progress", "SolverProgress", "cancel_checked", "cancel_point", "count_progress",
           "solver_progress"]
