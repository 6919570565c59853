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

__all__ = ["CONFIG_TYPES", "FRF_TYPES", "LimitedDropper", "MAX_FRF_BYTES", "MAX_TEXT_BYTES", "POINTS_TYPES",
           "check_type", "dropper",
           "latest", "save_in"]

#: the extensions each drop zone takes; FRF files: the reader's own (a .txt FRF has no reader: refused here
#: with the list rather than by the reader after the upload is saved)
CONFIG_TYPES = (".toml",)
FRF_TYPES = tuple(FORMATS)
POINTS_TYPES = (".csv", ".txt")


def _mb(limit: int) -> str:
    return f"{limit / 1e6:g}MB"


class LimitedDropper(pn.widgets.FileDropper):
    """A drop zone that counts, on the server, each file's bytes as its chunks arrive: a file above ``limit``
    bytes, or one that would make the zone hold more than ``total`` bytes with its other files (default
    ``limit``), is dropped at the chunk that passes the limit; a single-file zone holds one file (a new one
    replaces it). Why: the browser's ``max_file_size`` binds only the page's own script, and Panel keeps every
    chunk of a file until its last one and every file ever sent (the size check of :func:`latest` comes after), so a
    crafted client announcing a 1 000-chunk file, or sending file after file, filled the server's memory. The
    browser refuses such files before sending them (``max_total_file_size`` too), so a dropped file is a crafted
    client's: its name is kept in ``dropped``, nothing else."""

    def __init__(self, limit: int, total: int | None = None, **params):
        super().__init__(**params)
        self._limit, self._total = limit, limit if total is None else total
        self.dropped: list[str] = []

    def _held(self, name: str) -> int:
        """Bytes this zone holds besides file ``name``'s kept copy (the one it would replace)."""
        kept = sum(len(v) for k, v in (self.value or {}).items() if k != name)
        return kept + sum(len(c) for chunks in self._file_buffer.values() for c in chunks)

    def _process_event(self, event):
        data = event.data
        if event.event_name == "upload_event":
            name = data["name"]
            if data["chunk"] == 1:
                self._file_buffer.pop(name, None)  # a file sent again starts afresh (Panel's own rule)
                if not self.multiple:  # the zone shows one file: the one it replaces is not kept besides it
                    for other in [k for k in (self.value or {}) if k != name]:
                        del self.value[other]
            elif name not in self._file_buffer:
                return  # the rest of a dropped file (or chunks without a first one)
            size = sum(len(c) for c in self._file_buffer.get(name, ())) + len(data["data"])
            if size > self._limit or self._held(name) + len(data["data"]) > self._total:
                self._file_buffer.pop(name, None)
                self.dropped.append(name)
                return
        super()._process_event(event)


def dropper(name: str, accept: tuple[str, ...], limit: int = MAX_TEXT_BYTES, css: str = "") -> LimitedDropper:
    """A single-file drop zone named ``name`` for files ending in ``accept`` (shown in the label, checked by
    :func:`latest`) and at most ``limit`` bytes (checked in the browser, as the file arrives and in :func:`latest`)."""
    return LimitedDropper(limit, label=f"{name}: {', '.join(accept)} (≤ {limit / 1e6:g} MB)", accepted_filetypes=[],
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
