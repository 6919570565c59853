"""The ``millstab`` command. Thin: parse, call the library, print and save.

Every input problem ends as one line on stderr (``millstab: error: ...``) and exit status 2.
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
from millstab.cli import webapp  # noqa: E402,F401
from millstab.cli import listen  # noqa: E402,F401


def _one_line_warning(message, category, filename, lineno, file=None, line=None):
    print(f"millstab: warning: {message}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script. With ``argv`` given (tests), returns the exit status
    instead of exiting.

    Typer runs in standalone mode, so its own usage errors print usage and exit 2; millstab's
    InputError propagates to here and becomes one line on stderr with exit status 2.
    """
    warnings.showwarning = _one_line_warning
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
    if argv is None:
        sys.exit(code)
    return code
