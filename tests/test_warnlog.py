"""millstab.warnlog: per-thread collection and silencing of millstab's warnings (the web app's sessions)."""

from __future__ import annotations

import threading
import warnings

import pytest

from millstab.errors import UnitWarning
from millstab.model import Mode
from millstab.warnlog import collect, emit, quiet, warn


def test_interleaved_threads_keep_their_own_warnings():
    """A enters, B enters, A leaves, B warns, B leaves: the order that left catch_warnings(record=True)'s
    hook pointing at A's list (B's warning lost to B, A's list growing after A left)."""
    step = [threading.Event() for _ in range(3)]
    got: dict[str, list[str]] = {}

    def a():
        with collect() as caught:
            warn("a1")
            step[0].set()
            step[1].wait(5)
        warn("a-after")  # outside its collector: an ordinary warning
        got["a"] = [str(w.message) for w in caught]
        step[2].set()

    def b():
        step[0].wait(5)
        with collect() as caught:
            step[1].set()
            step[2].wait(5)
            warn("b1")
            Mode(500.0, 12.53, 0.02, "structure.x[0]")  # millstab's own unit warning, from deep inside
        got["b"] = [str(w.message) for w in caught]

    with warnings.catch_warnings(record=True) as outside:
        warnings.simplefilter("always")
        threads = [threading.Thread(target=a), threading.Thread(target=b)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(10)
    assert got["a"] == ["a1"]
    assert got["b"][0] == "b1" and len(got["b"]) == 2 and "N/um" in got["b"][1]
    assert [str(w.message) for w in outside] == ["a-after"]


def test_quiet_and_collect_nest_like_filters():
    with collect() as outer:
        with quiet(UnitWarning):
            warn("dropped", UnitWarning)
            warn("kept: another category", UserWarning)
            with collect() as inner:  # an inner collector records what an outer quiet would drop
                warn("inner", UnitWarning)
        for w in inner:
            emit(w)  # passed on: the outer collector has it
        with quiet():
            emit(inner[0])  # dropped
    assert [str(w.message) for w in outer] == ["kept: another category", "inner"]
    assert outer[1].category is UnitWarning


def test_outside_any_collector_it_is_an_ordinary_warning_at_the_callers_line():
    def caller():
        warn("from the caller's caller", UnitWarning, stacklevel=2)

    with pytest.warns(UnitWarning, match="caller's caller") as rec:
        caller()
    assert rec[0].filename == __file__
    with collect() as caught:
        caller()
    assert caught[0].filename == __file__ and caught[0].lineno == rec[0].lineno + 3
    with pytest.warns(UnitWarning, match="caller's caller"):
        emit(caught[0])


def test_quiet_silences_only_this_thread():
    ready, done = threading.Event(), threading.Event()
    caught_in_other: list[str] = []

    def other():
        ready.wait(5)
        with collect() as caught:
            warn("other thread")
        caught_in_other.extend(str(w.message) for w in caught)
        done.set()

    t = threading.Thread(target=other)
    t.start()
    with quiet():
        ready.set()
        done.wait(5)
    t.join(5)
    assert caught_in_other == ["other thread"]
