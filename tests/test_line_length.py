"""Every line of the project's Python within the configured length (pyproject's [tool.ruff] line-length).

Issue 26 found 232 (later 475) lines over it; they were wrapped by hand, and this keeps it so. Counted in
characters (a ³ is one), stricter than ruff's E501, which lets a line of one long token pass."""

from __future__ import annotations

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PLACES = ("src", "tests", "benchmarks", "docs")


def test_no_python_line_is_longer_than_the_configured_length():
    limit = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["ruff"]["line-length"]
    over = [f"{path.relative_to(ROOT)}:{number}: {len(line)} characters"
            for place in PLACES for path in sorted((ROOT / place).rglob("*.py"))
            for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1)
            if len(line) > limit]
    assert not over, f"{len(over)} lines over {limit} characters:\n" + "\n".join(over[:40])
