"""Packaged datasets: the seed paper's example configs and the numbers its report compares against.

* ``ex1``, ``ex2``, ``ex3`` -- the paper's synthetic examples (tab:Input_values).
* ``fourflute`` -- the four-flute tool's static modal parameters (tab:modal), slotting.
* ``ex3_points`` (``ex3_points.csv``) -- an example points file: 40 boundary points of Example 3 with
  2 % depth noise, so that ``millstab identify example:ex3 example:ex3_points`` runs at once (the
  command that generated it is in its first lines).

Use :func:`load_example` (or ``load_config("example:ex1")``) for a :class:`~millstab.config.Config`,
:func:`points_path` (or ``read_points("example:ex3_points")``) for an example points file, and
:func:`paper_values` for the paper's published numbers (SI units, see ``paper_values.toml``).
"""

from __future__ import annotations

import tomllib
from typing import Any

from millstab.config import Config
from millstab.io.config import load_config

# the files are located by the io layer, which resolves "example:NAME" (datasets sits above io)
from millstab.io.examples import _DIR, example_path, list_example_points, list_examples, points_path  # noqa: F401


def load_example(name: str) -> Config:
    """A packaged example as a :class:`~millstab.config.Config`."""
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
