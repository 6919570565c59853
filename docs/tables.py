"""Generate the tables of docs/architecture.md that the code can state itself, and check them.

``python docs/tables.py`` rewrites each generated table in place (between its ``<!-- generated: NAME -->``
and ``<!-- end: NAME -->`` lines); ``python docs/tables.py --check`` exits 1 when the doc differs from the
code (tests/test_docs_tables.py runs the check). Tables:

* ``results``: every result that round-trips through JSON (``millstab.jsondoc.RESULTS``: class, schema,
  home) and the documents written only (``millstab.jsondoc.WRITTEN``);
* ``contract``: the engine contract, from the ``Engine`` protocol of ``millstab.stability.base`` (its
  attributes with their docstring text, its methods with their signatures, its optional methods).
"""

from __future__ import annotations

import re
import sys
from importlib.util import find_spec
from pathlib import Path

DOC = Path(__file__).resolve().parent / "architecture.md"
SRC = Path(__file__).resolve().parents[1] / "src"


def _home(module: str) -> str:
    """``millstab.identify.result`` → ``identify/result.py`` (a package: its ``__init__.py``)."""
    rel = Path(*module.split(".")[1:])
    return f"{rel}/__init__.py" if (SRC / "millstab" / rel).is_dir() else f"{rel}.py"


def results_table() -> str:
    from millstab.jsondoc import RESULTS, WRITTEN

    rows = ["| result | schema | home | read back |", "| --- | --- | --- | --- |"]
    rows += [f"| `{cls}` | `{schema}` | `{_home(mod)}` | `{cls}.from_json(doc, source)` |"
             for mod, cls, schema in RESULTS]
    rows += [f"| `{name}` | `{schema}` | `{_home(mod)}` | written only (a report of a run) |"
             for mod, name, schema in WRITTEN]
    return "\n".join(rows)


def _entries(block: list[str]) -> dict[str, str]:
    """``name: text`` entries of a Google-style docstring block (continuation lines indented deeper)."""
    out: dict[str, str] = {}
    indent, key = None, None
    for line in block:
        if not line.strip():
            continue
        depth = len(line) - len(line.lstrip())
        if indent is None:
            indent = depth
        if depth == indent:
            head, _, text = line.strip().partition(": ")
            key = head
            out[key] = text
        elif key is not None:
            out[key] += " " + line.strip()
    return out


def _sections(doc: str) -> dict[str, list[str]]:
    """The top-level paragraphs of a docstring by their head (``Attributes:``, ``Conditions: ...``,
    ``per_set_kr (...): ...``, ``Optional (...):``): {head: the paragraph's lines, the head line's text first}."""
    out: dict[str, list[str]] = {}
    key = None
    for line in doc.splitlines():
        if line and not line[0].isspace():
            head, _, text = line.partition(": ") if ": " in line else (line.rstrip(":"), "", "")
            key = head
            out[key] = [text] if text else []
        elif key is not None:
            out[key].append(line)
    return out


def contract_table() -> str:
    import inspect

    from millstab.stability.base import Engine

    sections = _sections(inspect.getdoc(Engine) or "")
    sections.pop(next(iter(sections)))  # the summary line
    attrs = _entries(sections.pop("Attributes"))
    optional_head = next(h for h in sections if h.startswith("Optional"))
    optional = _entries(sections.pop(optional_head))
    rows = ["| attribute | meaning |", "| --- | --- |"]
    for name in Engine.__annotations__:
        rows.append(f"| `{name}` | {attrs.get(name, '(undocumented)')} |")
    for name in ("envelope", "envelope_batch", "chunk_rows"):
        fn = getattr(Engine, name)
        sig = re.sub(r": '[^']*'", "", str(inspect.signature(fn)).replace("(self, ", "(").split(" ->")[0])
        rows.append(f"| `{name}{sig}` | {(inspect.getdoc(fn) or '').splitlines()[0]} |")
    for head, lines in sections.items():  # further paragraphs: Conditions, optional capabilities
        name, _, note = head.partition(" (")
        shown = f"`{name}`" + (f" ({note.rstrip(')')})" if note else "")
        rows.append(f"| {shown} | {' '.join(x.strip() for x in lines).strip()} |")
    for head, text in optional.items():
        rows.append(f"| `{head.split(' ->')[0]}` (optional) | {text} |")
    return "\n".join(rows)


def _md(text: str) -> str:
    """Docstring markup as Markdown: ``code`` → `code`, :func:`a.b` → `a.b`."""
    text = re.sub(r":\w+:`~?([^`]+)`", r"`\1`", text)
    return text.replace("``", "`")


TABLES = {"contract": lambda: _md(contract_table()), "results": results_table}


def render(text: str) -> str:
    """``text`` with every generated table replaced by the code's."""
    for name, make in TABLES.items():
        pattern = re.compile(rf"(<!-- generated: {name} [^\n]*-->\n)(?:.*?\n)?(<!-- end: {name} -->)", re.DOTALL)
        if not pattern.search(text):
            raise SystemExit(f"{DOC.name}: no generated table {name!r} (<!-- generated: {name} ... --> ... "
                             f"<!-- end: {name} -->)")
        text = pattern.sub(lambda m, make=make: m.group(1) + make() + "\n" + m.group(2), text)
    return text


def main(argv: list[str]) -> int:
    sys.path.insert(0, str(SRC))
    assert find_spec("millstab") is not None
    text = DOC.read_text(encoding="utf-8")
    new = render(text)
    if "--check" in argv:
        if new != text:
            print(f"{DOC} differs from the code: run python docs/tables.py", file=sys.stderr)
            return 1
        return 0
    if new != text:
        DOC.write_text(new, encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
