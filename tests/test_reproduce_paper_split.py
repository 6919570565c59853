"""The paper's Table 1 step computes apart from its prose and check (issue 26: ``table1`` computed, wrote and
checked in one body): ``compute_table1`` returns a frozen :class:`Table1`; ``table1_checks`` and ``render_table1``
read only that. The result is written by hand here, and rendered with every engine made unreachable."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from millstab.reproduce import paper
from millstab.reproduce.report import ReportWriter


class _NoEngine:
    """An engine, or an engine factory, that fails when used."""

    def __getattr__(self, name):
        raise AssertionError("render computed")

    def __call__(self, *a, **k):
        raise AssertionError("render computed")


def _table1(mismatches: int = 0, sdm: bool = True) -> paper.Table1:
    """Two examples on 12 speeds: ex1's ZOA limit 2 mm with a 1 mm notch at 4000 rpm (chatter 900 Hz), SDM 10 %
    deeper on every 6th speed except 20 % at the first; ex2 flat 0.5 mm, no SDM."""
    rpm = np.linspace(3000.0, 14000.0, 12)
    d1 = np.full(12, 2e-3)
    d1[1] = 1e-3
    s1 = d1[::paper.SDM_EVERY] * np.array([1.2, 1.1])
    slds = (paper.ExampleSLD("ex1", "ex1: 2 teeth", rpm, d1, np.linspace(800, 1900, 12), (rpm[::6], s1) if sdm
                             else None),
            paper.ExampleSLD("ex2", "ex2: 4 teeth", rpm, np.full(12, 0.5e-3), np.full(12, 500.0), None))
    inputs = (("fn_x [Hz]", 903.0, 903.0, 500.0, 500.0, 950.0, 950.0),)
    return paper.Table1(inputs, mismatches, slds)


def test_table1_check_by_hand():
    """0 mismatches holds; 2 fail."""
    (row,) = paper.table1_checks(_table1())
    assert (row.ok, row.measured) == (True, "0 mismatching values")
    (row,) = paper.table1_checks(_table1(2))
    assert (row.ok, row.measured) == (False, "2 mismatching values")


def test_render_table1_without_computing(tmp_path, monkeypatch):
    """The section from a hand-made result, no engine reachable (fails on the old code: there was no result to
    render). The summary by hand: ex1's minimum 1 mm at 4000 rpm, 900 Hz; SDM vs ZOA median 15 %, max 20 %."""
    from millstab import stability

    monkeypatch.setattr(paper, "zoa", _NoEngine())
    for mod, name in ((paper, "engine_with"), (stability, "engine_with"), (stability, "get_engine")):
        monkeypatch.setattr(mod, name, _NoEngine())
    t = _table1()
    w = ReportWriter(tmp_path, "t")
    paper.render_table1(w, t)
    rep = w.write()
    assert rep.checks == tuple(paper.table1_checks(t))
    assert {p.name for p in rep.files} == {"table1_inputs.csv", "fig_sld_examples.png", "sld_examples_summary.csv"}
    rows = (tmp_path / "sld_examples_summary.csv").read_text().splitlines()
    assert rows[1] == "ex1,3000.0,14000.0,1.0,4000.0,900.0,15.0 % / 20.0 %"
    assert rows[2].endswith(",not run (--quick)")
    assert (tmp_path / "table1_inputs.csv").read_text().splitlines()[1] == "fn_x [Hz],903.0,903.0,500.0,500.0,950.0,950.0"
    with pytest.raises(dataclasses.FrozenInstanceError):
        t.mismatches = 1
