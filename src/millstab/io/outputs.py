"""A run's output paths, checked before the work starts.

Every command calls :func:`check_outputs` right after reading its inputs and before computing, so a
bad output path costs nothing (not a finished Monte Carlo) and can never destroy an input: the
config, the measured FRF files the config names (:func:`config_inputs`), points, speed lists, fit
files. The writers in :mod:`millstab.io.results` repeat the input check at write time.

Rules, each an :class:`InputError` naming the option, the path as the user wrote it and what is
allowed:

* an output is not one of the run's input files (same file also through links: ``os.path.samefile``);
* no two outputs of a run are the same file (``--out a.png --plot a.png``);
* a file output is not an existing folder; a folder output (``reproduce --out``) is not a file, and
  holds no input file of a kind the run writes there;
* a figure output has a known extension (:data:`FIGURE_FORMATS`);
* the folder an output goes into exists or can be created (its nearest existing ancestor is a folder,
  not a file) and is writable (a probe file is created and removed: ``os.access`` is wrong for
  root, read-only mounts and ACLs).
"""

from __future__ import annotations

import os
import secrets
import tomllib
from pathlib import Path
from typing import Iterable, Mapping

from millstab.errors import InputError
from millstab.io.figures import FIGURE_FORMATS  # noqa: F401  (re-exported: it was defined here)
from millstab.io.results import PathLike, _same_file


def config_inputs(cfg) -> dict[str, Path]:
    """The files a loaded :class:`~millstab.config.Config` reads, by label: the config file itself
    and, for a measured-FRF structure, each FRF file it names (``"structure.frf.xx"``, ...).

    The FRF paths are resolved exactly as the loader does (relative to the config's folder).
    """
    path = getattr(cfg, "path", None)
    if path is None:
        return {}
    files = {"config": Path(path)}
    if cfg.structure.is_modal:
        return files
    from millstab.io.frf_files import _source

    # the config loaded a moment ago, so it reads again; utf-8-sig also accepts a byte-order mark
    data = tomllib.loads(Path(path).read_text(encoding="utf-8-sig"))
    terms = (data.get("structure") or {}).get("frf") or {}
    for term, src in terms.items():
        field = f"structure.frf.{term}"
        files[field] = _source(src, field, Path(path).parent)[0]
    holder = data.get("holder") or {}  # a [tool]'s holder measured in files (docs/tooltip.md)
    for prefix, h in (("holder", holder), ("holder.x", holder.get("x") or {}), ("holder.y", holder.get("y") or {})):
        for table, keys in (("frf", ("h", "l", "n", "p", "H", "L", "N", "P")),
                            ("artifact", ("tip", "cross", "offset_direct")),
                            ("finite_differences", ("h00", "h01", "h11", "h02", "h12", "h22"))):
            for key in keys:
                src = (h.get(table) or {}).get(key)
                if src is not None:
                    field = f"{prefix}.{table}.{key}"
                    files[field] = _source(src, field, Path(path).parent)[0]
    return files


def _labelled(paths: Mapping[str, PathLike | None] | Iterable[PathLike | None]) -> dict[str, Path]:
    """{label: Path} from a mapping, or from a plain list (each path is its own label); None dropped."""
    items = paths.items() if isinstance(paths, Mapping) else ((str(p), p) for p in paths)
    return {label: Path(p) for label, p in items if p is not None}


def _nearest_existing(path: Path) -> Path:
    """``path`` or its nearest ancestor that exists (the current directory for a bare relative name)."""
    p = path.absolute()
    while not p.exists() and p != p.parent:
        p = p.parent
    return p


def _check_writable_folder(field: str, written: str, folder: Path) -> None:
    """``folder`` (which will hold an output) exists or can be created, and is writable."""
    base = _nearest_existing(folder)
    if not base.is_dir():
        raise InputError(field, written, f"{base} is a file, not a folder: the output cannot go below it")
    probe = base / f".millstab-probe-{secrets.token_hex(4)}"
    try:
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except OSError as exc:
        where = "the folder" if base == folder.absolute() else f"{base}, the nearest existing folder of"
        raise InputError(field, written, f"cannot write in {where} {folder} ({exc.strerror})") from None
    os.close(fd)
    os.unlink(probe)


def check_outputs(inputs: Mapping[str, PathLike | None] | Iterable[PathLike | None],
                  outputs: Mapping[str, PathLike | None], *, figures: Iterable[str] = (),
                  folders: Mapping[str, Iterable[str]] | None = None) -> dict[str, Path]:
    """Check a run's output paths against its input files, each other and the file system.

    Call it before the work. Nothing is created (apart from a probe file, removed at once).

    Args:
        inputs: the files the run reads, ``{label: path}`` (e.g. ``{"config": .., "--points": ..}``,
            see :func:`config_inputs`) or a plain list; ``None`` entries are skipped.
        outputs: ``{option: path}`` as given on the command line (e.g. ``{"--out": .., "--plot": ..}``);
            ``None`` entries (option not given) are skipped.
        figures: the options in ``outputs`` that are figures (extension checked).
        folders: the options in ``outputs`` that are folders, each with the file extensions the run
            writes into it (e.g. ``{"--out": (".csv", ".png", ".md", ".html")}``); an input file of
            such a kind directly in the folder is refused.

    Returns:
        ``{option: Path}`` of the outputs given.

    Raises:
        InputError: naming the option, the path as written and what is wrong (see the module docstring).
    """
    ins = _labelled(inputs)
    outs = {k: Path(v) for k, v in outputs.items() if v is not None}
    folders = dict(folders or {})
    figures = set(figures)
    seen: dict[str, Path] = {}
    for field, path in outs.items():
        written = str(outputs[field])
        if field in figures and path.suffix.lower() not in FIGURE_FORMATS:
            raise InputError(field, written, f"a plot file's extension must be one of {', '.join(FIGURE_FORMATS)}")
        for label, src in ins.items():
            if _same_file(path, src):
                what = f"the input file {src}" if label == str(src) else f"{label} {src}, an input of this run"
                raise InputError(field, written, f"would overwrite {what}; choose another output path")
        for other, opath in seen.items():
            if _same_file(path, opath):
                raise InputError(field, written, f"is the same file as {other}; give each output its own path")
        seen[field] = path
        if field in folders:
            if path.exists() and not path.is_dir():
                raise InputError(field, written, "is a file; give a folder (it is created if missing)")
            kinds = {k.lower() for k in folders[field]}
            for label, src in ins.items():
                if src.resolve().parent == path.resolve() and src.suffix.lower() in kinds:
                    raise InputError(field, written, f"the folder holds the input file {src}, and the run writes "
                                     f"{', '.join(sorted(kinds))} files there; choose another folder or move the "
                                     "input out of it")
            _check_writable_folder(field, written, path)
        else:
            if path.is_dir():
                raise InputError(field, written, "is a folder; give a file name")
            _check_writable_folder(field, written, path.parent)
    return outs


__all__ = ["FIGURE_FORMATS", "check_outputs", "config_inputs"]
