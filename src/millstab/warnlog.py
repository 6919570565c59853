"""millstab's own warnings, per thread: issue (:func:`warn`), collect (:func:`collect`), silence (:func:`quiet`).

Why not :class:`warnings.catch_warnings`: it swaps process-wide state (``warnings.showwarning`` and the
filter list), and the standard library documents it as unsafe with threads. The web app runs several
sessions' jobs in threads at once; with ``catch_warnings(record=True)`` in each, a job that leaves after
another one entered puts back a hook that points at the other job's list (later warnings then land in
the wrong session or nowhere), and one job's ``simplefilter("ignore")`` silences every other job.

Here the state is a stack per thread. Every warning millstab issues goes through :func:`warn` (or
:func:`emit` for a recorded one); walking this thread's stack from the innermost entry, a :func:`quiet`
entry of a matching category drops it and a :func:`collect` entry keeps it (unfiltered, like
``catch_warnings(record=True)`` with ``simplefilter("always")``). With neither, it is an ordinary
:func:`warnings.warn`: the process's filters, ``pytest.warns`` and the CLI's one-line printing apply as
before. Warnings of other libraries (numpy, SALib) take the standard route only.
"""

from __future__ import annotations

import sys
import threading
import warnings
from collections.abc import Iterator
from contextlib import contextmanager

_local = threading.local()


def _stack() -> list[tuple[str, object]]:
    """This thread's entries, innermost last: ("collect", list) or ("quiet", categories)."""
    if not hasattr(_local, "stack"):
        _local.stack = []
    return _local.stack


def _leave(entry: tuple[str, object]) -> None:
    """Remove ``entry`` itself (by identity: two collectors' empty lists are equal) from this thread's stack."""
    stack = _stack()
    for i in range(len(stack) - 1, -1, -1):
        if stack[i] is entry:
            del stack[i]
            return


#: :func:`_handler`'s answer for a warning that a :func:`quiet` drops
_DROP = object()


def _handler(category: type[Warning]):
    """Where a warning of ``category`` goes in this thread: the innermost collector's list, :data:`_DROP`
    when a :func:`quiet` inside it matches, or ``None`` (no entry takes it: the standard route)."""
    for kind, what in reversed(_stack()):
        if kind == "quiet":
            if issubclass(category, what):
                return _DROP
        else:
            return what
    return None


def emit(record: warnings.WarningMessage) -> None:
    """Pass a recorded warning on: to this thread's innermost collector, dropped by a :func:`quiet`
    inside it, or else re-issued with :func:`warnings.warn_explicit` at its recorded place."""
    to = _handler(record.category)
    if to is None:
        warnings.warn_explicit(record.message, record.category, record.filename, record.lineno)
    elif to is not _DROP:
        to.append(record)


def warn(message: str, category: type[Warning] = UserWarning, stacklevel: int = 1) -> None:
    """Issue a millstab warning (``stacklevel`` as for :func:`warnings.warn`, counted from the caller)."""
    to = _handler(category)
    if to is None:  # exactly warnings.warn: the process's filters and its once-per-place registry
        warnings.warn(message, category, stacklevel=stacklevel + 1)
        return
    if to is _DROP:
        return
    try:
        frame = sys._getframe(stacklevel)
        where = (frame.f_code.co_filename, frame.f_lineno)
    except ValueError:  # fewer frames than stacklevel
        where = ("sys", 1)
    to.append(warnings.WarningMessage(category(message), category, *where))


@contextmanager
def collect() -> Iterator[list[warnings.WarningMessage]]:
    """Collect the millstab warnings this thread issues inside the block (a list of
    :class:`warnings.WarningMessage`; ``str(w.message)`` is the text). Other threads are unaffected."""
    caught: list[warnings.WarningMessage] = []
    entry = ("collect", caught)
    _stack().append(entry)
    try:
        yield caught
    finally:
        _leave(entry)


@contextmanager
def quiet(*categories: type[Warning]) -> Iterator[None]:
    """Drop the millstab warnings of ``categories`` (default: all) this thread issues inside the block."""
    entry = ("quiet", tuple(categories) or (Warning,))
    _stack().append(entry)
    try:
        yield
    finally:
        _leave(entry)


__all__ = ["collect", "emit", "quiet", "warn"]
