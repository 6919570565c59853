"""Packaged datasets: the seed paper's example configs and the numbers its report compares against.

* ``ex1``, ``ex2``, ``ex3`` -- the paper's synthetic examples (tab:Input_values).
* ``fourflute`` -- the four-flute tool's static modal parameters (tab:modal), slotting.
* ``ex3_points`` (``ex3_points.csv``) -- an example points file: 40 boundary points of Example 3 with
  2 % depth noise, so that ``millstab identify example:ex3 example:ex3_points`` runs at once (the
  command that generated it is in its first lines).

Use :func:`load_example` (or ``load_config("example:ex1")``) for a :class:`~millstab.io.config.Config`,
:func:`points_path` (or ``read_points("example:ex3_points")``) for an example points file, and
:func:`paper_values` for the paper's published numbers (SI units, see ``paper_values.toml``).
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from millstab.errors import InputError

_DIR = Path(__file__).resolve().parent
#: files in this folder that are data, not example configs
_NOT_EXAMPLES = {"paper_values"}


def list_examples() -> list[str]:
    """Names of the packaged example configs, sorted (e.g. ``["ex1", "ex2", "ex3", "fourflute"]``)."""
    return sorted(p.stem for p in _DIR.glob("*.toml") if p.stem not in _NOT_EXAMPLES)


def example_path(name: str) -> Path:
    """The file of a packaged example config.

    Raises:
        InputError: unknown name (the message lists the available examples).
    """
    names = list_examples()
    key = str(name).strip().lower()
    if key.endswith(".toml"):
        key = key[:-5]
    if key not in names:
        hint = (f" ({key} is an example points file: give it where points are read, e.g. "
                f"`millstab identify example:ex3 example:{key}`)" if key in list_example_points() else "")
        raise InputError("example", name, f"unknown example; available: {', '.join(names)}{hint}")
    return _DIR / f"{key}.toml"


def list_example_points() -> list[str]:
    """Names of the packaged example points files, sorted (e.g. ``["ex3_points"]``)."""
    return sorted(p.stem for p in _DIR.glob("*.csv"))


def points_path(name: str) -> Path:
    """The file of a packaged example points file (``"ex3_points"`` or ``"ex3_points.csv"``).

    Raises:
        InputError: unknown name (the message lists the available points files).
    """
    names = list_example_points()
    key = str(name).strip().lower()
    if key.endswith(".csv"):
        key = key[:-4]
    if key not in names:
        raise InputError("example points", name, f"unknown example points file; available: {', '.join(names)}")
    return _DIR / f"{key}.csv"


def load_example(name: str):
    """A packaged example as a :class:`~millstab.io.config.Config`."""
    from millstab.io.config import load_config

    return load_config(example_path(name))


def paper_values() -> dict[str, Any]:
    """The seed paper's published numbers as a nested dict (a fresh copy on every call).

    Groups (each with a ``cite`` string naming its table): ``input_values`` (ex1..ex3),
    ``results_fourier`` (ex*.target / ex*.predicted), ``modal``, ``experimental_results``
    (newton_raphson, method1_two_point, method2_regression), ``experiment``, ``sensitivity_oat``,
    ``mc`` (mean, sd per parameter in ``params``). Units: fn [Hz], k [N/m], zeta [-], kt [N/m²],
    angles in keys ending ``_deg``, speeds in keys ending ``_rpm``/``rpm_min``/``rpm_max`` [rev/min].
    """
    with open(_DIR / "paper_values.toml", "rb") as fh:
        return tomllib.load(fh)


__all__ = ["example_path", "list_example_points", "list_examples", "load_example", "paper_values", "points_path"]
