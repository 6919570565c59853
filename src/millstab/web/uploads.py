"""Uploads: a drop zone that refuses files above a size limit in the browser (before any byte is sent) and
again on the server (before anything parses them), and the per-session folder for FRF files.

The file type is checked on the server, by extension: the drop widget (FilePond) checks MIME types, and
browsers give none for ``.toml``, ``.frf``, ``.uff`` or ``.unv`` (chromium refused every config with
"File is of invalid type. Expects  or .toml"), so the widget is given no type filter at all."""

from __future__ import annotations

import re
from pathlib import Path

import panel as pn

from millstab import api
from millstab.api.inputs import MAX_FRF_BYTES, MAX_TEXT_BYTES
from millstab.errors import InputError
from millstab.io.frf_files import FORMATS

__all__ = ["CONFIG_TYPES", "FRF_TYPES", "MAX_FRF_BYTES", "MAX_TEXT_BYTES", "POINTS_TYPES", "check_type", "dropper",
           "latest", "save_in"]

#: the extensions each drop zone takes; FRF files: the reader's own (a .txt FRF has no reader: refused here
#: with the list rather than by the reader after the upload is saved)
CONFIG_TYPES = (".toml",)
FRF_TYPES = tuple(FORMATS)
POINTS_TYPES = (".csv", ".txt")


def _mb(limit: int) -> str:
    return f"{limit / 1e6:g}MB"


def dropper(name: str, accept: tuple[str, ...], limit: int = MAX_TEXT_BYTES, css: str = "") -> pn.widgets.FileDropper:
    """A single-file drop zone named ``name`` for files ending in ``accept`` (shown in the label, checked by
    :func:`latest`) and at most ``limit`` bytes (checked in the browser too)."""
    return pn.widgets.FileDropper(label=f"{name}: {', '.join(accept)} (≤ {limit / 1e6:g} MB)", accepted_filetypes=[],
                                  max_file_size=_mb(limit), multiple=False, layout="compact",
                                  css_classes=[css] if css else [], width=300)


def check_type(name: str, accept: tuple[str, ...], what: str) -> None:
    """Refuse an upload whose name does not end in one of ``accept`` (lower-case extensions)."""
    ext = Path(name).suffix.lower()
    if ext not in accept:
        raise InputError(name, ext or "no extension", f"{what} files must end in {', '.join(accept)}")


def latest(widget: pn.widgets.FileDropper, limit: int = MAX_TEXT_BYTES, accept: tuple[str, ...] | None = None,
           what: str = "") -> tuple[str, bytes | str] | None:
    """(file name, content) of the file in ``widget``, or None; refuses one whose name does not end in
    ``accept`` (:func:`check_type`) or above ``limit`` bytes (:func:`millstab.api.check_size`) before the
    content is used."""
    if not widget.value:
        return None
    name, content = list(widget.value.items())[-1]
    if accept is not None:
        check_type(name, accept, what)
    size = len(content.encode("utf-8")) if isinstance(content, str) else len(content)
    api.check_size(size, name, limit)
    return name, content


_SAFE = re.compile(r"[^A-Za-z0-9._-]+")


def save_in(folder: Path, role: str, name: str, content: bytes | str) -> Path:
    """Write an uploaded file into the session ``folder`` as ``ROLE_NAME`` (name reduced to safe
    characters, never a path: the file cannot land outside the folder)."""
    safe = _SAFE.sub("_", Path(name).name).lstrip(".") or "upload"
    path = folder / f"{role}_{safe}"
    from millstab.io.results import atomic_write_bytes

    return atomic_write_bytes(path, content.encode("utf-8") if isinstance(content, str) else content)
