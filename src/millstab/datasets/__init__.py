"""Packaged datasets: the seed paper's example configs and the numbers its report compares against.

* ``ex1``, ``ex2``, ``ex3`` -- the paper's synthetic examples (tab:Input_values).
* ``fourflute`` -- the four-flute tool's static modal parameters (tab:modal), slotting.

Use :func:`load_example` (or ``load_config("example:ex1")``) for a :class:`~millstab.io.config.Config`
and :func:`paper_values` for the paper's published numbers (SI units, see ``paper_values.toml``).
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
        raise InputError("example", name, f"unknown example; available: {', '.join(names)}")
    return _DIR / f"{key}.toml"


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


__all__ = ["example_path", "list_examples", "load_example", "paper_values"]
