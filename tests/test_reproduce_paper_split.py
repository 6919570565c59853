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
    assert ((tmp_path / "table1_inputs.csv").read_text().splitlines()[1]
            == "fn_x [Hz],903.0,903.0,500.0,500.0,950.0,950.0")
    with pytest.raises(dataclasses.FrozenInstanceError):
        t.mismatches = 1


NAMES = ("fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y")


def _sensitivity() -> paper.Sensitivity:
    """By hand: ex1's one-at-a-time MSE at +20 % is fn 4 and 3 mm² above k, ζ ≤ 0.2; ex2's k_x (5) beats fn.
    Monte Carlo set A: means fn 2, 3; k 0.1, 0.15; ζ 0.01, 0.02 (fn_x/k_x = 20); set B the same but fn_y 1."""
    from millstab.sensitivity.results import MCResult, OATResult

    eps = np.array([-0.2, 0.0, 0.2])
    theta = np.array([900.0, 1e7, 0.03, 900.0, 1e7, 0.03])

    def one(at20):
        return OATResult(NAMES, theta, eps, np.outer(at20, [1.0, 0.0, 1.0]), np.linspace(3e3, 15e3, 4), np.ones(4))

    def mc(mean):
        spread = np.array([0.9, 1.1, 0.95, 1.05])[:, None]  # mean 1: the means stay those given
        return MCResult(NAMES, theta, 0.1, 0.01, 0, 4, np.linspace(3e3, 15e3, 4), spread * np.array(mean))

    oats = (("ex1", one([4.0, 0.1, 0.01, 3.0, 0.2, 0.02])), ("ex2", one([4.0, 5.0, 0.01, 3.0, 0.2, 0.02])))
    mcs = {"A: set a": mc([2.0, 0.1, 0.01, 3.0, 0.15, 0.02]), "B: set b": mc([2.0, 0.1, 0.01, 1.0, 0.15, 0.02])}
    table6 = {n: {"mean": m, "sd": m / 2} for n, m in zip(NAMES, (5.0, 0.5, 0.05, 5.0, 0.5, 0.05))}
    return paper.Sensitivity(oats, mcs, table6)


def test_sensitivity_checks_by_hand():
    """ex1 most sensitive to fn: holds; ex2 (k_x 5 > fn_y 3) fails. Set A: min fn 2 > 10 × max k 1.5 and min k 0.1
    > max ζ 0.02: holds; set B: min fn 1 < 1.5 fails. Both compare fn_x/k_x = 20 with the paper's 5/0.5 = 10."""
    rows = paper.sensitivity_checks(_sensitivity())
    assert [(c.kind, c.ok) for c in rows] == [("claim", True), ("claim", False), ("claim", True),
                                               ("comparison", True), ("claim", False), ("comparison", True)]
    assert rows[0].measured == "MSE at +20 %: fn_x 4, k_x 0.1, zeta_x 0.01, fn_y 3, k_y 0.2, zeta_y 0.02"
    assert rows[2].measured == "fn_x 2, k_x 0.1, zeta_x 0.01, fn_y 3, k_y 0.15, zeta_y 0.02"
    assert rows[3].measured == "ours 20, paper 10: ours/paper = 2.00" and rows[3].verdict == "compared"


def test_render_sensitivity_without_computing(tmp_path, monkeypatch):
    """The section from a hand-made result, no study or engine reachable (fails on the old code: no result)."""
    from millstab import sensitivity, stability

    monkeypatch.setattr(paper, "zoa", _NoEngine())
    for mod, name in ((stability, "engine_with"), (stability, "get_engine"), (sensitivity, "oat"),
                      (sensitivity, "monte_carlo")):
        monkeypatch.setattr(mod, name, _NoEngine())
    r = dataclasses.replace(_sensitivity(), oat=_sensitivity().oat[:1])  # one Fig. SENS panel set is enough here
    w = ReportWriter(tmp_path, "t")
    paper.render_sensitivity(w, r)
    rep = w.write()
    assert rep.checks == tuple(paper.sensitivity_checks(r))
    assert {p.name for p in rep.files} == {"fig_sens_ex1.png", "fig_sens_mse_at_plus20.csv",
                                           "table6_monte_carlo.csv", "fig_mc_convergence.png"}
    t6 = (tmp_path / "table6_monte_carlo.csv").read_text().splitlines()
    assert len(t6) == 13 and t6[1].startswith("A,fn_x,5.0,2.0") and t6[7].startswith("B,fn_x,")
    assert "N = 4 paths" in (tmp_path / "report.md").read_text()
