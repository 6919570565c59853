"""Uploads: a drop zone that refuses files above a size limit in the browser (before any byte is sent) and
again on the server (before anything parses them), and the per-session folder for FRF files."""

from __future__ import annotations

import re
from pathlib import Path

import panel as pn

from millstab import api
from millstab.api.inputs import MAX_FRF_BYTES, MAX_TEXT_BYTES

__all__ = ["MAX_FRF_BYTES", "MAX_TEXT_BYTES", "dropper", "latest", "save_in"]


def _mb(limit: int) -> str:
    return f"{limit / 1e6:g}MB"


def dropper(name: str, accept: list[str], limit: int = MAX_TEXT_BYTES, css: str = "") -> pn.widgets.FileDropper:
    """A single-file drop zone named ``name`` for files ending in ``accept`` and at most ``limit`` bytes."""
    return pn.widgets.FileDropper(label=f"{name} (≤ {limit / 1e6:g} MB)", accepted_filetypes=accept,
                                  max_file_size=_mb(limit), multiple=False, layout="compact",
                                  css_classes=[css] if css else [], width=300)


def latest(widget: pn.widgets.FileDropper, limit: int = MAX_TEXT_BYTES) -> tuple[str, bytes | str] | None:
    """(file name, content) of the file in ``widget``, or None; refuses one above ``limit`` bytes
    (:func:`millstab.api.check_size`) before the content is used."""
    if not widget.value:
        return None
    name, content = list(widget.value.items())[-1]
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
