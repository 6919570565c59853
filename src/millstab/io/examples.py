"""The packaged example files (configs ``*.toml`` and points ``*.csv`` in :mod:`millstab.datasets`'s
folder): their names and paths, so that the readers can resolve ``"example:NAME"``. Locating only;
:mod:`millstab.datasets` re-exports these and loads the examples through the readers.
"""

from __future__ import annotations

from pathlib import Path

from millstab.errors import InputError

#: the package-data folder of millstab.datasets (located by path: importing that package would import io)
DATA_DIR = _DIR = Path(__file__).resolve().parent.parent / "datasets"
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


__all__ = ["DATA_DIR", "example_path", "list_example_points", "list_examples", "points_path"]
