"""Validated inputs of the service layer: configs and point sets from files, packaged examples or text
(an upload), speed grids, and a measured-FRF structure replaced by its fitted modes where a task needs
modes. Every problem is an :class:`~millstab.errors.InputError` naming the field, the value and what is
allowed, the same message whichever door (command line, Python, web page) the input came through.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Mapping

import numpy as np

from millstab.bounds import check_speeds
from millstab.bounds import samples as check_samples  # noqa: F401 (re-exported by millstab.api for the doors)
from millstab.bounds import seed as check_seed  # noqa: F401 (re-exported)
from millstab.datasets import list_example_points, list_examples  # noqa: F401 (re-exported)
from millstab.errors import InputError
from millstab.io.config import config_from_dict, config_to_toml, load_config, parse_config
from millstab.config import Config
from millstab.io.points import parse_points, read_points
from millstab.points import PointSet
from millstab.io.text import decode_text
from millstab.params import shown_value  # noqa: F401 (re-exported: a parameter value as printed)
from millstab.parsing import parse_grid, parse_interval, parse_rpm_range  # noqa: F401 (re-exported)
from millstab.units import SHOWN as SHOWN_UNITS  # noqa: F401 (re-exported: how a parameter is printed)
from millstab.units import is_quantity, quantity_values

#: speeds when neither the caller nor the config gives any [rpm]: START, STOP, STEP
FALLBACK_RPM = (2000.0, 12000.0, 20.0)
#: the largest text (an upload) parsed as a config or a point set [bytes]
MAX_TEXT_BYTES = 5_000_000
#: the largest measured-FRF file accepted as an upload [bytes] (a UFF file holds many records)
MAX_FRF_BYTES = 20_000_000


def config(source: Config | str | os.PathLike | Mapping) -> Config:
    """A config: itself, a TOML file, a packaged example ``"example:NAME"`` (ex1, ex2, ex3, fourflute), or its
    tables as a dict (``{"cutting": {...}, "structure": {...}}``, :func:`config_from_fields`).

    Raises:
        InputError: as the file's reader, and for ``[speeds]`` outside :func:`millstab.bounds.check_speeds`'s
            bounds (naming the file and ``[speeds]``); ``config`` for a source that is none of these.
    """
    if isinstance(source, Config):
        return _bounded(source)
    if isinstance(source, Mapping):
        return config_from_fields(source)
    if not isinstance(source, (str, os.PathLike)):
        raise InputError("config", f"a {type(source).__name__}", "a Config, a TOML file (path), \"example:NAME\" or "
                                                                  "the config's tables as a dict")
    return _bounded(load_config(source))


def _bounded(cfg: Config) -> Config:
    """``cfg`` when its ``[speeds]`` lie within :func:`millstab.bounds.check_speeds`'s bounds (a config's own
    speeds drive every command that is given no --rpm)."""
    if cfg.rpm is not None:
        check_speeds(cfg.rpm, f"{cfg.path.name if cfg.path else cfg.name} [speeds]")
    return cfg


def config_from_text(text: str | bytes, name: str = "config", files: Mapping[str, str | os.PathLike] | None = None
                     ) -> Config:
    """A config parsed from TOML text (an upload); ``name`` names it in messages.

    Text has no folder, and an upload must not make the server read its files: a ``[structure.frf]``
    file name is looked up only in ``files`` ({file name as uploaded: path}, the files uploaded in the
    same browser session) and any other name or path is refused before a file is opened. Without
    ``files`` every FRF file reference is refused.

    Raises:
        InputError: as for a config file; ``structure.frf.xx`` for a file not in ``files``.
    """
    return _bounded(parse_config(_text(text, name), name=Path(name).stem or name, files=dict(files or {}),
                                 source=name))


def points(source, name: str = "table") -> PointSet:
    """A point set: itself, a CSV file, a packaged example ``"example:NAME"`` (ex3_points), CSV text of more than one
    line (as :func:`points_from_text`), or a table of cuts in
    a notebook: a pandas DataFrame, a mapping {column: values} or a list of row mappings, with the columns of a
    points file (``rpm``, ``depth_mm``, ``label``, ``chatter_hz``, the condition columns, …; see
    :mod:`millstab.io.points`). A table is read by the file reader, so it gets the same checks and messages; they
    name it ``name`` and count its header as line 1 (row 0 is line 2). Empty cells (None, NaN) are empty.

    Raises:
        InputError: as the file's reader; ``points`` for a source that is none of these.
    """
    if isinstance(source, PointSet):
        return source
    if isinstance(source, str) and "\n" in source.strip():  # CSV text itself (no file name holds a line break)
        return points_from_text(source, name)
    if isinstance(source, (str, os.PathLike)):
        return read_points(source)
    return parse_points(_table_csv(source, name), name)


def _table_csv(table, name: str) -> str:
    """The CSV text of a table of cuts (a DataFrame, {column: values} or [{column: value}, …]) as the command line's
    files are written (:func:`millstab.io.results.csv_text`: numbers exactly, None/NaN/NA as empty cells)."""
    from millstab.io.results import csv_text

    if hasattr(table, "columns") and hasattr(table, "to_dict"):  # a pandas DataFrame, without importing pandas
        table = {str(c): list(table[c]) for c in table.columns}
    if isinstance(table, Mapping):
        cols = {str(c): list(np.atleast_1d(np.asarray(v, dtype=object))) for c, v in table.items()}
        if len({len(v) for v in cols.values()}) > 1:
            raise InputError(name, {c: len(v) for c, v in cols.items()}, "every column needs the same number of rows")
        return csv_text(list(cols), list(cols.values()))
    if isinstance(table, (list, tuple)) and all(isinstance(r, Mapping) for r in table):
        rows = [{str(c): v for c, v in r.items()} for r in table]
        header = list(dict.fromkeys(c for r in rows for c in r))
        return csv_text(header, [[r.get(c) for r in rows] for c in header])
    raise InputError("points", f"a {type(table).__name__}", "a PointSet, a CSV file (path), \"example:NAME\", a "
                                                              "DataFrame, {column: values} or a list of row dicts")


def overlay_points(*sets: PointSet | None) -> PointSet | None:
    """The given point sets (boundary points, labelled cuts; ``None`` skipped) as one set of their speeds
    [rpm], depths [mm] and labels, to draw on an SLD; ``None`` when there are none."""
    sets = [p for p in sets if p is not None]
    if not sets:
        return None
    return PointSet(np.concatenate([p.rpm for p in sets]), np.concatenate([p.depth_mm for p in sets]),
                    np.concatenate([p.label for p in sets]))


def in_config_condition(points: PointSet | None, cfg: Config | None, target=None) -> PointSet | None:
    """The points cut in the config's own condition, or in ``target`` (a :class:`~millstab.model.Cutting`; empty
    condition cells are the config's either way), to draw on that condition's SLD: a point cut in another condition
    belongs to another boundary. ``None`` stays ``None``."""
    if points is None or cfg is None or (not points.has_conditions and target is None):
        return points
    from millstab.points import in_condition

    return points.subset(in_condition(points, cfg.cutting, cfg.cutting if target is None else target,
                                      getattr(cfg, "diameter_mm", None)))


def config_in_condition(cfg: Config, **target) -> tuple[Config, str | None]:
    """(``cfg`` in the target condition the doors' options name, one line saying so), or (``cfg``, None) when none is
    given: the same tool and structure, ``cutting`` replaced (:func:`millstab.api.target_condition`; ``target``: its
    keywords ``radial_immersion``, ``milling``, ``entry_deg``, ``exit_deg``, ``teeth``)."""
    import dataclasses

    from millstab.api.update import condition_text, target_condition

    c = target_condition(cfg.cutting, cfg.diameter_mm, **target)
    if c is None:
        return cfg, None
    return (dataclasses.replace(cfg, cutting=c),
            f"computed for {condition_text(c)} (the config's: {condition_text(cfg.cutting)})")


def points_drawn(points: PointSet | None, cfg: Config, target=None) -> tuple[PointSet | None, str | None]:
    """(the points cut in the config's condition or in ``target``, :func:`in_config_condition`; a line counting the
    others and naming their conditions, or None when every point is drawn)."""
    drawn = in_config_condition(points, cfg, target)
    if points is None or len(drawn) == len(points):
        return drawn, None
    from millstab.points import condition_text, cut_conditions, same_condition

    # named: a reader who edited the form's condition sees where the points went, not only that they went
    conds, _ = cut_conditions(points, cfg.cutting, getattr(cfg, "diameter_mm", None))
    shown = cfg.cutting if target is None else target
    others = "; ".join(dict.fromkeys(condition_text(c) for c in conds if not same_condition(c, shown)))
    return drawn, (f"{len(points) - len(drawn)} of the {len(points)} points were cut in other conditions than the "
                   f"{'config' if target is None else 'target'}'s: not drawn (they were cut in {others})")


def points_from_text(text: str | bytes, name: str = "points.csv") -> PointSet:
    """A point set parsed from CSV text ``rpm,depth_mm[,label][,weight][,chatter_hz]`` (an upload), with the
    same checks as a file; ``name`` names it in messages."""
    return parse_points(_text(text, name), name)


def config_from_fields(fields, name: str = "config", base_dir: str | os.PathLike | None = None,
                       files: Mapping[str, str | os.PathLike] | None = None) -> Config:
    """A config from the parsed-TOML form of its tables (``{"cutting": {...}, "structure": {...}}``, values
    numbers or strings with units exactly as in a TOML file): a form's fields go through the validators of
    a file. ``base_dir`` resolves the file names of a ``[structure.frf]`` table (the web app's per-session
    folder of uploaded FRF files); ``files`` instead confines them as in :func:`config_from_text`.

    Raises:
        InputError: as for a config file, naming the field (``cutting.kt``, ``structure.x[0].fn``).
    """
    return _bounded(config_from_dict(fields, name, None, Path(base_dir) if base_dir is not None else None, files))


def config_fields(cfg: Config) -> dict:
    """The tables of ``cfg`` as :func:`config_from_fields` takes them (values with units as
    :func:`config_toml` writes them): ``config_from_fields(config_fields(cfg))`` gives the same config.
    A measured-FRF config has no ``structure`` table here (its FRF files are named by the caller: the web
    form's uploads); every other table is the config writer's, ``[prior]`` included."""
    import dataclasses
    import tomllib

    from millstab.model import Mode, Structure

    if cfg.structure.is_modal:
        return tomllib.loads(config_to_toml(cfg))
    # the io writer writes modal structures only: write the rest with a placeholder and leave it out
    out = tomllib.loads(config_to_toml(dataclasses.replace(cfg, structure=Structure(x=(Mode(1000.0, 1e7, 0.03),)))))
    out.pop("structure", None)
    return out


def check_size(nbytes: int, name: str, limit: int | None = None) -> None:
    """Refuse an upload of ``nbytes`` bytes larger than ``limit`` (default :data:`MAX_TEXT_BYTES`, read at
    the call) before anything reads it.

    Raises:
        InputError: naming the file, its size and the limit.
    """
    limit = MAX_TEXT_BYTES if limit is None else limit
    if nbytes > limit:
        raise InputError(name, f"{nbytes / 1e6:.1f} MB", f"is too large (at most {limit / 1e6:g} MB)")


def config_toml(cfg: Config) -> str:
    """The TOML text that reproduces ``cfg`` (the web app's config download; ``millstab lobes FILE``)."""
    return config_to_toml(cfg)


def speeds(spec=None, cfg: Config | None = None, fallback: tuple[float, float, float] = FALLBACK_RPM,
           field: str = "--rpm", rpm_file: str | os.PathLike | None = None) -> np.ndarray:
    """Spindle speeds [rpm]: ``spec`` as ``START:STOP:STEP`` text (START = STOP: that one speed, as a file of one
    line), a sequence of numbers or a pint Quantity (converted from its unit: 100 Hz = 6000 rpm), else a speeds
    file ``rpm_file`` (:func:`millstab.io.speeds.read_rpm_file`), else the config's ``[speeds]``, else the
    ``fallback`` grid.

    Raises:
        InputError: bad range text, both ``spec`` and ``rpm_file``, or a speed outside
            :func:`millstab.bounds.check_speeds`'s bounds (10..500 000 rev/min) or not finite.
    """
    if isinstance(spec, str) and not spec:  # an empty --rpm is no --rpm
        spec = None
    if rpm_file:
        if spec is not None:
            raise InputError(field, spec, "give either --rpm or --rpm-file, not both")
        from millstab.io.speeds import read_rpm_file

        return check_speeds(read_rpm_file(Path(rpm_file)), f"--rpm-file {Path(rpm_file).name}")
    if spec is None:
        if cfg is not None and cfg.rpm is not None:
            return check_speeds(cfg.rpm, f"{cfg.name} [speeds]")
        return np.arange(fallback[0], fallback[1] + fallback[2] / 2, fallback[2])
    if isinstance(spec, str):
        return parse_rpm_range(spec, field, single=True)
    if is_quantity(spec):  # 100 Hz is 6000 rpm: numpy alone would strip the unit and read 100 rpm
        spec = quantity_values(spec, field, "frequency") * 60.0
    try:
        r = np.asarray(spec, dtype=float).ravel()
    except (TypeError, ValueError):  # ["5000", "abc"], a dict: numpy's own message names no field
        raise InputError(field, spec, "speeds must be START:STOP:STEP text or a sequence of numbers in "
                                      "rev/min") from None
    if r.size == 0 or not np.all(np.isfinite(r)) or np.any(r <= 0):
        raise InputError(field, spec if r.size < 6 else f"{r.size} speeds", "speeds must be finite numbers > 0 rev/min")
    return check_speeds(r, field)


def modal(cfg: Config, modes: int | str = "auto") -> tuple[Config, str | None]:
    """``cfg`` itself when its structure is modal; else ``cfg`` with the modes fitted to its measured FRF
    (identification, planning, updating and sensitivity need modes) and a one-line note saying so. ``cfg``: what
    :func:`config` takes (a Config, a file, ``"example:NAME"``, its tables)."""
    cfg = config(cfg)
    if cfg.structure.is_modal:
        return cfg, None
    from millstab.modal.run import fitted_config

    return fitted_config(cfg, modes)


def _text(text: str | bytes, name: str) -> str:
    check_size(len(text), name)
    if isinstance(text, bytes):
        text = decode_text(text, name, name, "text file (CSV or TOML)")
    return text.lstrip("\ufeff")
