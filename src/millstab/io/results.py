"""Writing results (JSON, CSV; figures in :mod:`millstab.io.figures`) without ever losing a user's file.

Every writer here goes through one atomic writer: the data are written to a temporary file in the
target's directory and then moved over the target with :func:`os.replace`, so a crash or a full
disk leaves either the old file or the new one, never half of either. Writers take ``protect``, the
input files of the run; writing over one of them is refused with :class:`InputError`, because
``millstab identify cuts.csv -o cuts.csv`` would otherwise silently destroy the measurements.

JSON conventions (:func:`to_jsonable`): numpy arrays become (nested) lists, numpy scalars plain
numbers, dataclasses dicts, paths strings, complex numbers ``{"real": .., "imag": ..}``. Strict JSON
has no NaN or Infinity, so non-finite floats are written as ``null`` (``np.asarray(x, float)`` reads
them back as NaN).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
import os
import secrets
from pathlib import Path
from typing import Any, BinaryIO, Callable, Iterable, Sequence

import numpy as np

from millstab.errors import InputError
from millstab.io.text import looks_like, read_text

PathLike = str | os.PathLike[str]


def _same_file(a: Path, b: Path) -> bool:
    """True when ``a`` and ``b`` name the same file (also through symlinks and hard links)."""
    try:
        if a.exists() and b.exists():
            return os.path.samefile(a, b)
    except OSError:
        pass
    return a.resolve() == b.resolve()


def check_not_protected(path: PathLike, protect: Iterable[PathLike] = ()) -> Path:
    """Return ``path`` as a Path; raise InputError when it is one of the ``protect`` files."""
    target = Path(path)
    for p in protect:
        if p is None:
            continue
        if _same_file(target, Path(p)):
            raise InputError("output", str(target),
                             f"would overwrite the input file {p}; choose a different output path")
    return target


def _atomic_write(path: PathLike, write: Callable[[BinaryIO], None], protect: Iterable[PathLike] = (),
                  mode: int | None = None) -> Path:
    """Write a file atomically: ``write(fh)`` fills a temporary file in the target's directory, which
    then replaces the target with :func:`os.replace`.

    ``mode`` (e.g. 0o600 for a private file): the new file's exact permissions, set before anything is
    written, whatever the umask or the mode of the file it replaces. Otherwise:
    the temporary file is created with ``os.open(..., 0o666)`` so the umask applies, as for any file
    a program creates (``tempfile.mkstemp`` would give 0600, and an os.replace keeps that mode: a
    report served from a shared folder then cannot be read). A file that is replaced keeps its mode.

    Raises:
        InputError: ``path`` is one of ``protect``, is a directory, or cannot be written.
    """
    target = check_not_protected(path, protect)
    if target.is_dir():
        raise InputError("output", str(target), "is a directory; give a file name")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError("output", str(target),
                         f"cannot create the directory {target.parent}: {exc.strerror}") from None
    tmp = target.parent / f".{target.name}.{secrets.token_hex(4)}.tmp"
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666 if mode is None else mode)
    except OSError as exc:
        raise InputError("output", str(target), f"cannot write in {target.parent}: {exc.strerror}") from None
    try:
        with os.fdopen(fd, "wb") as fh:
            if mode is not None:
                os.fchmod(fh.fileno(), mode)
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        if mode is None and target.exists():
            try:
                os.chmod(tmp, target.stat().st_mode & 0o7777)
            except OSError:
                pass
        os.replace(tmp, target)
    except BaseException:
        try:
            tmp.unlink()
        except OSError:
            pass
        raise
    return target


def atomic_write_text(path: PathLike, text: str, protect: Iterable[PathLike] = (), encoding: str = "utf-8",
                      mode: int | None = None) -> Path:
    """Write ``text`` to ``path`` atomically (temp file in the same directory, then os.replace).

    Parent directories are created. The new file gets the usual permissions (0666 minus umask), or
    the permissions of the file it replaces, or exactly ``mode`` if given (0o600: readable by its owner only).

    Raises:
        InputError: ``path`` is one of ``protect``, is a directory, or cannot be written.
    """
    data = text.encode(encoding)
    return _atomic_write(path, lambda fh: fh.write(data), protect, mode)


def atomic_write_bytes(path: PathLike, data: bytes, protect: Iterable[PathLike] = ()) -> Path:
    """Write ``data`` to ``path`` atomically (as :func:`atomic_write_text`)."""
    return _atomic_write(path, lambda fh: fh.write(data), protect)


def ensure_folder(path: PathLike) -> Path:
    """Create the folder ``path`` (and its parents) if it does not exist; return it as a Path."""
    p = Path(path)
    p.mkdir(parents=True, exist_ok=True)
    return p


def to_jsonable(obj: Any) -> Any:
    """Convert ``obj`` to plain JSON types (see the module docstring for the conventions).

    Raises:
        TypeError: an object of a type with no JSON form (names the type).
    """
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, (int, np.integer)) and not isinstance(obj, np.bool_):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, (float, np.floating)):
        x = float(obj)
        return x if math.isfinite(x) else None
    if isinstance(obj, (complex, np.complexfloating)):
        return {"real": to_jsonable(obj.real), "imag": to_jsonable(obj.imag)}
    if isinstance(obj, np.ndarray):
        return [to_jsonable(v) for v in obj.tolist()] if obj.ndim else to_jsonable(obj.item())
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: to_jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, (set, frozenset)):
        return [to_jsonable(v) for v in sorted(obj, key=repr)]
    raise TypeError(f"cannot write an object of type {type(obj).__name__} to JSON")


def write_json(path: PathLike, obj: Any, protect: Iterable[PathLike] = (), indent: int | None = 2) -> Path:
    """Write ``obj`` as JSON (UTF-8) to ``path`` atomically; returns the path.

    Raises:
        InputError: ``path`` is a protected input file or cannot be written.
    """
    text = json.dumps(to_jsonable(obj), indent=indent, ensure_ascii=False, allow_nan=False) + "\n"
    return atomic_write_text(path, text, protect)


def read_json(path: PathLike) -> Any:
    """Read a JSON file.

    Raises:
        InputError: the file does not exist or is not valid JSON (with the line number).
    """
    p = Path(path)
    if not p.is_file():
        raise InputError("json file", str(p), "file does not exist")
    text = read_text(p, "json file", "JSON text file")  # a BOM from a Windows editor is fine
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        kind = looks_like(text)
        seems = f"; the file looks like {kind}, not JSON: is it in the JSON file's place?" if kind else ""
        raise InputError(str(p), f"line {exc.lineno}, column {exc.colno}",
                         f"not valid JSON: {exc.msg}{seems}") from None


def _cell(v: Any) -> str:
    """One CSV cell: floats with the shortest repr that reads back exactly, NaN, None and pandas' NA as empty."""
    if v is None or type(v).__name__ in ("NAType", "NaTType"):  # pandas' missing values, without importing pandas
        return ""
    if isinstance(v, (bool, np.bool_)):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        x = float(v)
        if math.isnan(x):
            return ""
        return repr(x)  # 'inf' / '-inf' read back with float()
    return str(v)


def csv_text(header: Sequence[str], columns: Sequence[Sequence[Any]]) -> str:
    """Columns (equal lengths) under ``header`` as CSV text: what :func:`write_csv` writes (the web app's
    downloads use it, so a download and the command line's file are the same bytes).

    Floats are written with Python's shortest round-trip repr (no precision lost); NaN as an empty
    cell.

    Raises:
        InputError: header and columns disagree in count, or columns differ in length.
    """
    header = [str(h) for h in header]
    cols = [np.asarray(c).ravel() if not isinstance(c, (list, tuple)) else list(c) for c in columns]
    if len(header) != len(cols):
        raise InputError("csv header", header, f"needs one name per column ({len(cols)} columns)")
    lengths = {len(c) for c in cols}
    if len(lengths) > 1:
        raise InputError("csv columns", sorted(lengths), "all columns must have the same length")
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for row in zip(*cols):
        w.writerow([_cell(v) for v in row])
    return buf.getvalue()


def write_csv(path: PathLike, header: Sequence[str], columns: Sequence[Sequence[Any]],
              protect: Iterable[PathLike] = ()) -> Path:
    """Write columns (equal lengths) under ``header`` as CSV atomically (:func:`csv_text`); returns the path.

    Raises:
        InputError: see :func:`csv_text`, or the path is a protected input file.
    """
    return atomic_write_text(path, csv_text(header, columns), protect)


__all__ = ["atomic_write_bytes", "atomic_write_text", "check_not_protected", "csv_text", "ensure_folder", "read_json",
           "to_jsonable", "write_csv", "write_json"]
