"""Every `millstab COMMAND ... --option` the README and docs/*.md show names a command and options that the
command's --help lists: a renamed or removed option cannot stay in the documentation (a newcomer who copies
the line gets "No such option"); and a whole `millstab update` or `map` line names what it writes (without --out,
--db or --plot it stops with "--out = None is invalid")."""

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


#: commands that stop unless one of these options says where their result goes
WRITES = {"update": ("--out", "--db"), "map": ("--out", "--plot", "--db")}


def unwritten(text: str, name: str = "doc") -> list[str]:
    """'FILE:LINE: millstab CMD' for each whole command line (its first argument a file, not an option or '...')
    of ``text`` that names none of :data:`WRITES`' options for its command."""
    found = []
    for n, line in enumerate(text.splitlines(), 1):
        for m in re.finditer(r"millstab (update|map)((?: [^`#&|;\n]*)?)", line):
            words = m.group(2).split()
            if not words or words[0].startswith("-") or "..." in words or "…" in words:
                continue  # prose: "`millstab update --engine spectral`", "millstab update ... --batch-effect 3%"
            if not set(words) & set(WRITES[m.group(1)]):
                found.append(f"{name}:{n}: millstab {m.group(1)}")
    return found


def test_documented_updates_and_maps_say_where_they_write():
    missing = [s for f in DOCS if f.name != "updating-measured.md"  # the notebook quotes commands as timed
               for s in unwritten(f.read_text(encoding="utf-8"), f.name)]
    assert not missing, "command lines that stop for want of --out:\n" + "\n".join(missing)
    text = ("millstab update my_tool.toml cuts.csv --batch-effect 3%   # each day\n"
            "millstab map post.json --rpm 3000:15000:40 --plot m.png\n"
            "`millstab update --engine spectral` and `millstab update ... --start`\n")
    assert unwritten(text) == ["doc:1: millstab update"]


def test_the_quoted_engine_option_error_is_the_commands(tmp_path, capsys):
    """docs/updating.md quotes the error of a wrong --engine-option value word for word (it said ">= 1" after the
    bound became 1..2,000)."""
    from millstab.cli import main

    text = " ".join((ROOT / "docs" / "updating.md").read_text(encoding="utf-8").split())
    quoted = re.search(r"`(millstab: error: --engine-option steps = 0 [^`]*)`", text).group(1)
    cuts = tmp_path / "cuts.csv"
    cuts.write_text("rpm,depth_mm,label\n9000,1.0,stable\n9000,4.0,chatter\n", encoding="utf-8")
    argv = ["update", "example:ex1", str(cuts), "--engine", "sdm", "--engine-option", "steps=0", "--out",
            str(tmp_path / "post.json")]
    assert main(argv) == 2
    assert capsys.readouterr().err.strip() == quoted


def unresolved_names(text: str) -> list[str]:
    """The dotted Python names of ``text`` (`millstab.update.sampler`, `api.update`, `Posterior.engine_options` is
    not one: only names from millstab or api) that neither import nor resolve as attributes. Schema names
    (`millstab.posterior/3`) and file names (`millstab.yaml`) are not Python names; a module needing an optional
    package that is not installed is not checked."""
    import importlib

    bad = []
    for m in re.finditer(r"(?<![\w./-])((?:millstab|api)(?:\.\w+)+)(?![\w/]|\.\w)", text):
        dotted = m.group(1)
        parts = ("millstab." + dotted if dotted.startswith("api.") else dotted).split(".")
        if parts[-1] in {"yaml", "toml", "json", "csv"}:
            continue
        obj, i = None, len(parts)
        while i and obj is None:
            try:
                obj = importlib.import_module(".".join(parts[:i]))
            except ModuleNotFoundError as e:
                if e.name and not e.name.startswith("millstab"):
                    obj = ...  # an optional dependency is missing here: not checked
                    break
                i -= 1
        if obj is ...:
            continue
        for a in parts[i:]:
            if not hasattr(obj, a):
                try:
                    obj = importlib.import_module(f"{obj.__name__}.{a}")
                    continue
                except (ModuleNotFoundError, AttributeError):
                    bad.append(dotted)
                    break
            obj = getattr(obj, a)
    return bad


def test_documented_python_names_exist():
    """`millstab.x.y` and `api.f` in the README and docs name modules, functions and constants that exist (a rename
    leaves no stale name behind); the check finds a missing one."""
    stale = [f"{f.name}: {n}" for f in DOCS for n in unresolved_names(f.read_text(encoding="utf-8"))]
    assert not stale, "names the docs use that the code has not:\n" + "\n".join(stale)
    text = "`millstab.update.sampler.ACCEPT_TARGET`, `api.update`, `millstab.posterior/3`, `api.no_such_function`"
    assert unresolved_names(text) == ["api.no_such_function"]
