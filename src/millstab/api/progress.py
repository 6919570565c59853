"""The one progress protocol of the service layer (:data:`millstab.progress.Progress`), and cancellation.

Every long service function takes ``progress``: a callable ``progress(stage, done, total)`` with
``stage`` a short text ("identify: lsq", "sdm: limiting depths"), ``done`` a count and ``total`` the count
at the end, or ``None`` where it is not known in advance (an iterative solver). A caller cancels by
raising :class:`Cancelled` from the callback (a :class:`CancelToken` does it for a web page's cancel
button): the exception propagates out of the numerical code, which calls the callback only between
compiled chunks, so nothing is left half-written.
"""

from __future__ import annotations

import threading

from millstab.progress import Progress  # noqa: F401 (the one protocol; re-exported by millstab.api)
from millstab.progress import cancel_checked
#: ``with collect_warnings() as caught:`` millstab's warnings issued by this thread only (a web job's own)
from millstab.warnlog import collect as collect_warnings  # noqa: F401 (re-exported by millstab.api)


class Cancelled(Exception):
    """Raised through a running service function when its caller cancels it."""


class CancelToken:
    """A cancel flag that one thread sets (a button) and the worker's progress callback checks.

    ``token.watch(progress)`` wraps a progress callback (or none) into one that raises
    :class:`Cancelled` once :meth:`cancel` has been called.
    """

    def __init__(self) -> None:
        self._event = threading.Event()

    def cancel(self) -> None:
        """Ask the running work to stop at its next progress report."""
        self._event.set()

    @property
    def cancelled(self) -> bool:
        return self._event.is_set()

    def check(self) -> None:
        """Raise :class:`Cancelled` when cancelled."""
        if self._event.is_set():
            raise Cancelled("cancelled by the user")

    def checked(self):
        """``with token.checked():`` the work run in the block on this thread stops at its next cancel point
        (:func:`millstab.progress.cancel_point`: before every engine call, between an engine's compiled chunks) once
        :meth:`cancel` is called, as well as at its progress reports: work that reports nothing for minutes (an
        update's first stage, a map or recommendation from an sdm posterior) stops within one engine chunk."""
        return cancel_checked(self.check)

    def watch(self, progress: Progress | None = None) -> Progress:
        """A progress callback that reports to ``progress`` and then raises if cancelled."""

        def report(stage: str, done: int, total: int | None) -> None:
            if progress is not None:
                progress(stage, done, total)
            self.check()

        return report
