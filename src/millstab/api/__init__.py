"""The service layer: one function per user task, taking validated inputs and returning result objects.

The command line parses its options, calls these and prints or saves what they return; the web app
(``millstab app``) and notebooks call the same functions, so every door gives the same numbers and the
same error messages. Long tasks take ``progress(stage, done, total)`` (:mod:`millstab.api.progress`);
raising :class:`Cancelled` from it (or using a :class:`CancelToken`) stops the work.

Inputs (:mod:`~millstab.api.inputs`): :func:`config`, :func:`config_from_text`, :func:`points`,
:func:`points_from_text`, :func:`config_from_fields` / :func:`config_fields` (a form's fields),
:func:`check_size` (an upload's size, before reading it), :func:`speeds`, :func:`modal` (a measured FRF → its fitted
modes).

Tasks: :func:`lobes` (SLD, any registered engine), :func:`identify`, :func:`design` (next test speeds),
:func:`update` / :func:`p_stable` / :func:`recommend` (Bayesian updating and decisions),
:func:`predict` (per-cut P(stable) and P(label chatter)), :func:`validate` (cross-validated scores beside baselines),
:func:`sensitivity` (oat, mc, sobol, morris; locally or on Dask), :func:`tip_frf` / :func:`stickout_sweep` (the tool
tip of a [tool] in its [holder] by receptance coupling, "which stickout?"), :func:`simulate_cut` / :func:`label_cuts`
(virtual cuts), :func:`listen_file` / :func:`listen_signal` (a recorded cut: chatter and a speed),
:func:`record_cut` / :func:`record_tap` (virtual recordings of a cut and of a tap), :func:`tap_path` (a tap
recording → the sensor path ``listen --tap`` divides out), :func:`label_from_recordings` (cuts labelled by ear),
:func:`modal_fit` (tap test), :func:`reproduce`.
Beside the tasks, what the doors need so that they import nothing else (issue 26): option parsers and
checks (:func:`parse_rpm_range`, :func:`parse_interval`, :func:`parse_grid`, :func:`parse_eps`,
:func:`parse_bounds`, :func:`check_speeds`, :func:`check_seed`, :func:`check_samples`, :func:`check_frf_type`),
the registered engines (:data:`ENGINES`) and identification methods, the packaged examples, a job's own
warnings (:func:`collect_warnings`) and a Dask client (:func:`open_client`).
Figures: ``*_figure`` functions return matplotlib figures; tables: ``*_table`` functions return
``(header, columns)`` for :func:`millstab.io.results.csv_text` / ``write_csv``.

Units as everywhere in millstab: speeds rev/min, depths mm where a name says ``_mm`` (else m),
frequencies Hz, stiffness N/m.
"""

import importlib
import sys
import types

#: {submodule: the names it gives the service layer}; ``NAME=ATTR`` where the submodule calls it otherwise
_HOMES = {
    "inputs": ("check_samples", "check_seed", "check_size", "check_speeds", "config", "config_fields",
              "config_from_fields", "config_from_text", "config_toml", "list_example_points", "list_examples",
              "config_in_condition", "in_config_condition", "overlay_points", "points_drawn",
              "modal", "parse_grid", "parse_interval", "parse_rpm_range", "points", "points_from_text", "speeds",
              "SHOWN_UNITS", "shown_value"),
    "lobes": ("ENGINES", "Lobes", "cheapest_engine", "check_engine_name", "envelope", "lobes", "lobes_figure",
              "raw_lobes", "sld_title"),
    "identify": ("IDENTIFY_METHODS", "check_fit_matches", "design", "design_figure", "fit_curves", "fit_figure",
                "fit_rpm", "history_figure", "identify"),
    "update": ("ENGINE_OPTION_FORM", "at_stickout", "check_engine_options", "check_risk", "condition_line",
               "condition_text", "corner_figure",
               "cuts_in_condition",
               "decision_rule", "depth_grid", "engine_keywords", "engine_option_pairs", "engine_options_from_text",
               "engine_update_note", "for_condition", "limit_memo",
               "map_figure", "map_samples", "map_samples_text", "map_table", "next_test_elsewhere", "p_stable",
               "over_holder", "posterior_from_json", "recommend", "target_condition", "update",
               "UpdateSettings", "with_batch_effect", "with_engine_options"),
    "predict": ("Prediction", "predict"),
    "validate": ("validate",),
    "sensitivity": ("SENSITIVITY_DEFAULT_N=DEFAULT_N", "SENSITIVITY_PRESETS=PRESETS", "Study", "parse_bounds",
                   "parse_eps", "sensitivity"),
    "tooltip": ("StickoutSweep", "TOOLTIP_FALLBACK_RPM=FALLBACK_RPM", "TipFRF", "stickout_sweep", "stickouts_mm",
               "tip_figure", "tip_frf", "tool_config"),
    "studies": ("check_frf_type", "label_cuts", "labels_table", "modal_check", "modal_figure", "modal_fit",
               "modal_quality", "modal_toml", "reproduce", "reproduce_steps", "simulate_cut", "simulate_figure",
               "simulate_mode"),
    "listen": ("Heard", "label_from_recordings", "listen_figure", "listen_file", "listen_signal", "read_cuts",
               "record_cut", "record_tap", "tap_path"),
    "progress": ("CancelToken", "Cancelled", "Progress", "collect_warnings"),
    "cluster": ("CONNECT_SECONDS", "open_client"),
}
#: {public name: (submodule, its name there)}
_WHERE = {n.partition("=")[0]: (mod, n.partition("=")[2] or n) for mod, names in _HOMES.items() for n in names}


def __getattr__(name: str):
    """Import a name's submodule on its first use: ``from millstab import api`` (every command line door
    does it at module level) stays as cheap as numpy, and a task pays for what it uses (measured, CPU time
    on the loaded 2-core build machine: ``import millstab.api`` 0.10 s; every name resolved 0.7 s more, as
    ``IDENTIFY_METHODS`` and the solvers bring scipy; ``import millstab.cli`` 0.19 s against 0.16 s before
    the doors imported api)."""
    if name not in _WHERE:  # a submodule by its name (``api.inputs.MAX_TEXT_BYTES``, ``api.shop``)
        try:
            return importlib.import_module(f"{__name__}.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}":
                raise
            raise AttributeError(f"module 'millstab.api' has no attribute {name!r}") from None
    mod, attr = _WHERE[name]
    value = getattr(importlib.import_module(f"millstab.api.{mod}"), attr)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


class _Api(types.ModuleType):
    """A submodule that shares its name with a task (``identify``, ``lobes``, ``update``, ``predict``,
    ``validate``, ``sensitivity``) must not replace the task's function when it is first imported: the
    import system sets ``millstab.api.<submodule>`` after loading it, and this refuses that one case."""

    def __setattr__(self, name: str, value) -> None:
        if name in _WHERE and isinstance(value, types.ModuleType):
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Api

__all__ = sorted(_WHERE)  # noqa: PLE0605 (every name of _HOMES, nothing else)
