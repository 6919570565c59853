"""Every `millstab COMMAND ... --option` the README and docs/*.md show names a command and options that the
command's --help lists: a renamed or removed option cannot stay in the documentation (a newcomer who copies
the line gets "No such option")."""

from __future__ import annotations

import re
from pathlib import Path

import typer.main

from millstab.cli import app

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def _options(command) -> set[str]:
    return {o for p in command.params for o in (*p.opts, *p.secondary_opts) if o.startswith("--")} | {"--help"}


def stale_options(text: str, name: str = "doc") -> list[str]:
    """'FILE:LINE: millstab CMD --opt' for each option a `millstab CMD` of ``text`` names that CMD does not take.
    A command line ends at a comment, a closing backtick or a shell separator (&&, |, ;)."""
    root = typer.main.get_command(app)
    found = []
    for n, line in enumerate(text.splitlines(), 1):
        for m in re.finditer(r"millstab ([a-z]+)((?: [^`#&|;\n]*)?)", line):
            command = root.commands.get(m.group(1))
            if command is None:
                continue  # prose: "millstab warns", "millstab loses"
            rest = m.group(2)
            if hasattr(command, "commands"):  # a group: `millstab campaign export ...`
                words = rest.split()
                if not words or words[0] not in command.commands:
                    continue
                command = command.commands[words[0]]
            rest = rest.split(" millstab ")[0]
            for option in re.findall(r"(?<![\w-])(--[a-z][\w-]*)", rest):
                if option not in _options(command):
                    found.append(f"{name}:{n}: millstab {m.group(1)} {option}")
    return found


def test_documented_options_exist():
    stale = [s for f in DOCS for s in stale_options(f.read_text(encoding="utf-8"), f.name)]
    assert not stale, "options the docs name that the command does not take:\n" + "\n".join(stale)


def test_a_stale_option_is_found():
    """The check is not vacuous: a misspelt option, a subcommand's option and a second command on one line are
    read; prose and comments are not."""
    text = ("millstab lobes example:ex1 --rpm 2000:12000:10 --out sld.csv --plott sld.png   # --not-an-option\n"
            "millstab campaign export --db shop.db --campaign c --out d --bogus\n"
            "millstab update a.toml c.csv --out p.json && millstab map p.json --stickout 60 --plot m.png\n"
            "millstab warns when --nothing\n")
    assert stale_options(text) == ["doc:1: millstab lobes --plott", "doc:2: millstab campaign --bogus"]
