"""The ``millstab`` command. Thin: parse, call the library, print and save.

Every input problem ends as one line on stderr (``millstab: error: ...``) and exit status 2. Anything
else that goes wrong ends as one line too (``millstab: internal error: TYPE: MESSAGE (traceback in LOG)``,
exit status 1), with the traceback in a log file (:mod:`millstab.io.errorlog`) for a bug report;
running out of memory says so. A cold numba cache is announced once (:mod:`millstab.cli.notices`).
"""

from __future__ import annotations

import sys
import warnings

from millstab.cli.app import app
from millstab.errors import InputError

# subcommands register themselves on `app` when imported
from millstab.cli import lobes  # noqa: E402,F401
from millstab.cli import identify  # noqa: E402,F401
from millstab.cli import design  # noqa: E402,F401
from millstab.cli import reproduce  # noqa: E402,F401
from millstab.cli import sensitivity  # noqa: E402,F401
from millstab.cli import simulate  # noqa: E402,F401
from millstab.cli import modal  # noqa: E402,F401
from millstab.cli import update  # noqa: E402,F401
from millstab.cli import recommend  # noqa: E402,F401
from millstab.cli import predict  # noqa: E402,F401
from millstab.cli import validate  # noqa: E402,F401
from millstab.cli import webapp  # noqa: E402,F401
from millstab.cli import history  # noqa: E402,F401
from millstab.cli import campaign  # noqa: E402,F401
from millstab.cli import warmup  # noqa: E402,F401
from millstab.cli import tooltip  # noqa: E402,F401
from millstab.cli import listen  # noqa: E402,F401


def _one_line_warning(message, category, filename, lineno, file=None, line=None):
    from millstab.cli.emit import SHOWN

    SHOWN.add(str(message))
    print(f"millstab: warning: {message}", file=sys.stderr)


def _one_line_warnings() -> None:
    """Warnings print as one line each from here on; none counts as shown yet (tests run several commands in one
    process: :data:`millstab.cli.emit.SHOWN`)."""
    from millstab.cli.emit import SHOWN

    SHOWN.clear()
    warnings.showwarning = _one_line_warning


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script. With ``argv`` given (tests), returns the exit status
    instead of exiting.

    Typer runs in standalone mode, so its own usage errors print usage and exit 2 (and Ctrl-C prints
    "Aborted!", exit 1); millstab's InputError propagates to here and becomes one line on stderr with exit
    status 2; any other exception becomes one line with the path of its traceback's log, exit status 1.
    """
    from millstab.cli.notices import install_compile_notice

    _one_line_warnings()
    install_compile_notice()
    code = 0
    try:
        app(args=argv, prog_name="millstab")
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    except InputError as exc:
        print(f"millstab: error: {exc}", file=sys.stderr)
        code = 2
    except (FileNotFoundError, IsADirectoryError, PermissionError) as exc:
        print(f"millstab: error: {exc}", file=sys.stderr)
        code = 2
    except KeyboardInterrupt:  # outside typer's own handling (it prints "Aborted!"): as before
        raise
    except MemoryError as exc:
        log = _log(exc, argv)
        print(f"millstab: error: out of memory{': ' + str(exc) if str(exc) else ''}; ask for less (fewer "
              f"--samples, speeds or depths){log}", file=sys.stderr)
        code = 1
    except Exception as exc:  # the last resort: one line, the traceback in a file for the bug report
        text = " ".join(str(exc).split())
        print(f"millstab: internal error: {type(exc).__name__}: {text[:300]}{_log(exc, argv)}", file=sys.stderr)
        code = 1
    if argv is None:
        sys.exit(code)
    return code


def _log(exc: BaseException, argv: list[str] | None) -> str:
    """`` (traceback in PATH)`` after the log of ``exc`` is written, or a hint when none could be."""
    from millstab.io.errorlog import write_error_log

    path = write_error_log(exc, argv)
    return f" (traceback in {path})" if path is not None else " (no log folder could be written)"
