"""The file layer: configs, point sets, FRF files and results. The only part of millstab that touches files.

* :mod:`millstab.io.config` -- TOML configs with explicit units → :class:`millstab.config.Config`.
* :mod:`millstab.io.points` -- boundary points / labelled test cuts CSV → :class:`millstab.points.PointSet`.

The types they read live below io (``Config`` in :mod:`millstab.config`, ``PointSet`` in :mod:`millstab.points`)
and are imported from there only.
* :mod:`millstab.io.frf_files` -- measured FRFs from CSV, CutPro ``.frf`` and UFF58 files.
* :mod:`millstab.io.results` -- atomic JSON/CSV writers that refuse to overwrite input files.
* :mod:`millstab.io.figures` -- figures (the plots' return values) saved through the same writer.
* :mod:`millstab.io.examples` -- the packaged example files behind ``"example:NAME"``.
* :mod:`millstab.io.outputs` -- a run's output paths checked before the work (inputs, duplicates, folders).
"""

from millstab.io.config import config_from_dict, config_to_toml, load_config, parse_config, write_config
from millstab.io.frf_files import (list_uff_records, load_measured_frf, read_frf, read_frf_csv, read_frf_cutpro,
                                   read_frf_uff, write_frf_csv)
from millstab.io.points import check_enough, read_points, write_points
from millstab.io.outputs import check_outputs, config_inputs
from millstab.io.figures import save_figure, write_figure
from millstab.io.results import atomic_write_text, ensure_folder, read_json, to_jsonable, write_csv, write_json

__all__ = ["atomic_write_text", "check_enough", "check_outputs", "config_from_dict", "config_inputs", "config_to_toml",
           "ensure_folder", "list_uff_records", "load_config", "load_measured_frf", "parse_config", "read_frf",
           "read_frf_csv", "read_frf_cutpro", "read_frf_uff", "read_json", "read_points", "save_figure", "to_jsonable",
           "write_config", "write_csv", "write_figure", "write_frf_csv", "write_json", "write_points"]
