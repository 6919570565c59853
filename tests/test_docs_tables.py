"""docs/architecture.md's engine contract and results tables are generated from the code (docs/tables.py):
this fails when the doc and the code differ (issue 26: the hand-kept contract table had lost two contract
attributes, ``time_averaged`` and ``depth_accuracy``, and the results table four result types)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

DOCS = Path(__file__).resolve().parents[1] / "docs"


def _tables():
    spec = importlib.util.spec_from_file_location("doc_tables", DOCS / "tables.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_architecture_tables_are_the_codes():
    tables = _tables()
    text = tables.DOC.read_text(encoding="utf-8")
    assert tables.render(text) == text, "docs/architecture.md differs from the code: run python docs/tables.py"


def test_a_stale_table_is_found_and_every_contract_attribute_is_listed():
    """The check is not vacuous: a table row removed by hand is put back by the generator; every
    annotated attribute of the Engine protocol has a documented row."""
    from millstab.stability.base import Engine

    tables = _tables()
    text = tables.DOC.read_text(encoding="utf-8")
    stale = text.replace("| `depth_accuracy` |", "| `depth_accuracy_old` |")
    assert stale != text and tables.render(stale) == text
    contract = tables.contract_table()
    for name in Engine.__annotations__:
        assert f"| `{name}` |" in contract and "(undocumented)" not in contract
