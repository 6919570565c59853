"""pyproject.toml: the package metadata installs without setuptools deprecation warnings."""

from __future__ import annotations

import tomllib
from pathlib import Path

from packaging.requirements import Requirement  # a dependency of pytest itself

PYPROJECT = Path(__file__).resolve().parents[1] / "pyproject.toml"


def _pyproject() -> dict:
    with open(PYPROJECT, "rb") as fh:
        return tomllib.load(fh)


def test_license_is_an_spdx_expression():
    # the table form (license = { text = "MIT" }) makes setuptools >= 77 print a deprecation warning on
    # every install; PEP 639 wants an SPDX expression string
    lic = _pyproject()["project"]["license"]
    assert isinstance(lic, str) and lic == "MIT"


def test_build_requires_a_setuptools_that_reads_spdx_licenses():
    # setuptools < 77 rejects a string license: the build requirement must exclude those versions
    reqs = {r.name: r for r in map(Requirement, _pyproject()["build-system"]["requires"])}
    spec = reqs["setuptools"].specifier
    assert "77.0" in spec and "84.2.1" in spec
    assert not any(v in spec for v in ("68.0", "76.1", "76.9.9"))
