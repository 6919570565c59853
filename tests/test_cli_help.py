"""Help texts are plain text: brackets (units, TOML tables) are shown, not eaten as rich markup."""

from __future__ import annotations

import pytest

from millstab.cli import main


@pytest.mark.parametrize("argv,shown", [
    (["recommend", "--help"], "Deepest allowed cut [mm]"),
    (["update", "--help"], "optional [prior]"),
    (["map", "--help"], "START:STOP:STEP [mm]"),
    (["modal", "--help"], "the fitted [structure] section"),
    (["sensitivity", "oat", "--help"], "(rev/min)"),
])
def test_help_keeps_brackets(capsys, argv, shown):
    assert main(argv) == 0
    out = " ".join(capsys.readouterr().out.split())  # the help is wrapped to the terminal width
    assert shown in out
