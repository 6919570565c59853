"""The internal-error log: the command line's last-resort handler writes the traceback of an unexpected
exception here and prints one line with the path (``millstab: internal error: ... (traceback in PATH)``)."""

from __future__ import annotations

import datetime
import os
import sys
import tempfile
import traceback
from pathlib import Path


def log_dir() -> Path:
    """Where internal-error logs go: ``$MILLSTAB_LOG_DIR``, else ``$XDG_CACHE_HOME/millstab/logs`` (default
    ``~/.cache/millstab/logs``), else the temporary folder when that cannot be written."""
    env = os.environ.get("MILLSTAB_LOG_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "millstab" / "logs"


def write_error_log(exc: BaseException, argv: list[str] | None) -> Path | None:
    """Write the traceback of ``exc`` with the command line and versions to a new log file; its path, or None
    when no folder could be written."""
    from millstab import __version__

    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    text = (f"millstab {__version__}, Python {sys.version.split()[0]}, {sys.platform}\n"
            f"command: millstab {' '.join(sys.argv[1:] if argv is None else argv)}\n\n"
            + "".join(traceback.format_exception(type(exc), exc, exc.__traceback__)))
    for folder in (log_dir(), Path(tempfile.gettempdir()) / "millstab-logs"):
        try:
            folder.mkdir(parents=True, exist_ok=True)
            path = folder / f"error-{stamp}-{os.getpid()}.log"
            path.write_text(text, encoding="utf-8")
            return path
        except OSError:
            continue
    return None
