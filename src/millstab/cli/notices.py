"""What the command line says on stderr when a run would otherwise be silent for long: the one-time
compilation of the engines (numba) in a fresh cache.

The compile notice listens to numba's own ``numba:compile`` event, which numba raises only after its
on-disk cache missed (``Dispatcher.compile``: ``load_overload`` first, the event on a miss), so a warm
cache prints nothing and costs nothing; nor does an in-memory stderr (:func:`_real_stream`). The listener
is registered when numba is first imported (an import hook), so commands that never touch an engine
(``--help``, input errors) do not pay numba's ~0.5 s import for it.
"""

from __future__ import annotations

import importlib.abc
import sys

#: printed once per process when an engine kernel compiles (a cold numba cache)
COMPILE_NOTICE = ("millstab: compiling the engines (first run only: ~1 min for zoa, ~4 min for spectral; "
                  "later runs load them from the cache; `millstab warmup` compiles them all ahead)…")

_said = [False]


def _on_compile(event) -> None:
    if _said[0]:
        return
    disp = (event.data or {}).get("dispatcher")
    module = getattr(getattr(disp, "py_func", None), "__module__", "") or ""
    if module.startswith("millstab"):
        _said[0] = True
        if _real_stream(sys.stderr):
            print(COMPILE_NOTICE, file=sys.stderr, flush=True)


def _real_stream(stream) -> bool:
    """Whether ``stream`` is a terminal, pipe or file (has a file descriptor). An in-memory stream (a test's
    capture of ``main()``, a program embedding the CLI) gets no notice: such callers read stderr as the
    command's errors and warnings, one per line, and a cold cache there is no newcomer's first run."""
    try:
        stream.fileno()
        return True
    except (AttributeError, OSError, ValueError):  # io.UnsupportedOperation is both OSError and ValueError
        return False


def _register() -> None:
    from numba.core import event

    class _Notice(event.Listener):
        def on_start(self, ev):
            _on_compile(ev)

        def on_end(self, ev):
            pass

    event.register("numba:compile", _Notice())


class _NumbaHook(importlib.abc.MetaPathFinder):
    """Registers the compile listener right after ``numba`` is imported, wherever that happens."""

    def find_spec(self, name, path=None, target=None):
        if name != "numba":
            return None
        sys.meta_path.remove(self)
        import importlib.util

        spec = importlib.util.find_spec(name)
        if spec is None or spec.loader is None:
            return spec
        loader = spec.loader
        exec_module = loader.exec_module

        def exec_and_register(module):
            exec_module(module)
            try:
                _register()
            except Exception:  # pragma: no cover (an older numba without the event API: no notice)
                pass

        loader.exec_module = exec_and_register
        return spec


def install_compile_notice() -> None:
    """Say :data:`COMPILE_NOTICE` once on stderr when an engine kernel compiles (idempotent)."""
    if getattr(install_compile_notice, "_done", False):
        return
    install_compile_notice._done = True
    if "numba" in sys.modules:
        _register()
    else:
        sys.meta_path.insert(0, _NumbaHook())
