"""The service layer: one function per user task, taking validated inputs and returning result objects.

The command line parses its options, calls these and prints or saves what they return; the web app
(``millstab app``) and notebooks call the same functions, so every door gives the same numbers and the
same error messages. Long tasks take ``progress(stage, done, total)`` (:mod:`millstab.api.progress`);
raising :class:`Cancelled` from it (or using a :class:`CancelToken`) stops the work.

Inputs (:mod:`~millstab.api.inputs`): :func:`config`, :func:`config_from_text`, :func:`points`,
:func:`points_from_text`, :func:`config_from_fields` / :func:`config_fields` (a form's fields),
:func:`check_size` (an upload's size, before reading it), :func:`speeds`, :func:`modal` (a measured FRF → its fitted modes).

Tasks: :func:`lobes` (SLD, any registered engine), :func:`identify`, :func:`design` (next test speeds),
:func:`update` / :func:`p_stable` / :func:`recommend` (Bayesian updating and decisions),
:func:`predict` (per-cut P(stable) and P(label chatter)), :func:`validate` (cross-validated scores beside baselines),
:func:`sensitivity` (oat, mc, sobol, morris; locally or on Dask), :func:`tip_frf` / :func:`stickout_sweep` (the tool
tip of a [tool] in its [holder] by receptance coupling, "which stickout?"), :func:`simulate_cut` / :func:`label_cuts`
(virtual cuts), :func:`listen_file` / :func:`listen_signal` (a recorded cut: chatter and a speed),
:func:`record_cut` (a virtual recording), :func:`label_from_recordings` (cuts labelled by ear), :func:`modal_fit`
(tap test), :func:`reproduce`.
Figures: ``*_figure`` functions return matplotlib figures; tables: ``*_table`` functions return
``(header, columns)`` for :func:`millstab.io.results.csv_text` / ``write_csv``.

Units as everywhere in millstab: speeds rev/min, depths mm where a name says ``_mm`` (else m),
frequencies Hz, stiffness N/m.
"""

from millstab.api.identify import (check_fit_matches, design, design_figure, fit_curves, fit_figure, fit_rpm,
                                   history_figure, identify)
from millstab.api.inputs import (check_size, config, config_fields, config_from_fields, config_from_text, config_toml,
                                 modal, points, points_from_text, speeds)
from millstab.api.listen import Heard, label_from_recordings, listen_figure, listen_file, listen_signal, record_cut
from millstab.api.lobes import Lobes, envelope, lobes, lobes_figure, raw_lobes
from millstab.api.progress import CancelToken, Cancelled, Progress
from millstab.api.sensitivity import DEFAULT_N as SENSITIVITY_DEFAULT_N
from millstab.api.sensitivity import PRESETS as SENSITIVITY_PRESETS
from millstab.api.sensitivity import Study, sensitivity
from millstab.api.tooltip import FALLBACK_RPM as TOOLTIP_FALLBACK_RPM
from millstab.api.tooltip import StickoutSweep, TipFRF, stickout_sweep, stickouts_mm, tip_figure, tip_frf, tool_config
from millstab.api.studies import label_cuts, labels_table, modal_fit, reproduce, simulate_cut
from millstab.api.update import (condition_line, corner_figure, depth_grid, for_condition, map_figure, map_table,
                                 p_stable, posterior_from_json, recommend, update)
from millstab.api.predict import Prediction, predict
from millstab.api.validate import validate

__all__ = ["SENSITIVITY_DEFAULT_N", "SENSITIVITY_PRESETS", "TOOLTIP_FALLBACK_RPM", "StickoutSweep", "TipFRF",
           "stickout_sweep", "stickouts_mm", "tip_figure", "tip_frf", "tool_config", "CancelToken", "Cancelled",
           "Heard", "Lobes", "Prediction", "Progress", "Study", "predict", "validate",
           "check_fit_matches", "check_size", "condition_line", "config", "config_fields", "config_from_fields", "config_from_text",
           "config_toml", "corner_figure", "depth_grid", "design", "design_figure", "envelope", "fit_curves",
           "fit_figure", "fit_rpm", "for_condition", "history_figure", "identify", "label_cuts", "label_from_recordings",
           "listen_figure", "listen_file", "listen_signal", "labels_table", "lobes", "lobes_figure",
           "map_figure", "map_table", "modal", "modal_fit", "p_stable", "points", "points_from_text", "posterior_from_json",
           "raw_lobes", "recommend", "record_cut", "reproduce", "sensitivity", "simulate_cut", "speeds", "update"]
