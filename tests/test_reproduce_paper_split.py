"""Each of the paper's steps computes apart from its prose and checks (issue 26: each computed, wrote and checked
in one body): ``compute_table1``/``compute_table3``/``compute_four_flute``/``compute_sensitivity`` return a frozen
result; its ``*_checks`` and ``render_*`` read only that. Each result is written by hand here, its checks worked out
by hand, and rendered with every engine, solver and study it would compute with made unreachable."""

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


def _render_alone(tmp_path, monkeypatch, render, result, checks, unreachable):
    """``render(writer, result)`` with the report's engine and every (module, name) of ``unreachable`` (and the
    stability registry) failing when used; the report written, its headline rows those of ``checks(result)``."""
    from millstab import stability

    monkeypatch.setattr(paper, "zoa", _NoEngine())
    for mod, name in ((stability, "engine_with"), (stability, "get_engine"), *unreachable):
        monkeypatch.setattr(mod, name, _NoEngine())
    w = ReportWriter(tmp_path, "t")
    render(w, result)
    rep = w.write()
    assert rep.checks == tuple(checks(result))
    return rep


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
    t = _table1()
    rep = _render_alone(tmp_path, monkeypatch, paper.render_table1, t, paper.table1_checks, [(paper, "engine_with")])
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
    from millstab import sensitivity

    r = dataclasses.replace(_sensitivity(), oat=_sensitivity().oat[:1])  # one Fig. SENS panel set is enough here
    rep = _render_alone(tmp_path, monkeypatch, paper.render_sensitivity, r, paper.sensitivity_checks,
                        [(sensitivity, "oat"), (sensitivity, "monte_carlo")])
    assert {p.name for p in rep.files} == {"fig_sens_ex1.png", "fig_sens_mse_at_plus20.csv",
                                           "table6_monte_carlo.csv", "fig_mc_convergence.png"}
    t6 = (tmp_path / "table6_monte_carlo.csv").read_text(encoding="utf-8").splitlines()
    assert len(t6) == 13 and t6[1].startswith("A,fn_x,5.0,2.0") and t6[7].startswith("B,fn_x,")
    # the CSVs name their unit, as the report's other tables do (they said "paper mean", "fn_x": no unit)
    assert t6[0] == ("speed set,parameter,paper mean [mm²],ours mean [mm²],paper SD [mm²],ours SD [mm²],"
                     "ours SEM [mm²]")
    sens = (tmp_path / "fig_sens_mse_at_plus20.csv").read_text(encoding="utf-8").splitlines()
    assert sens[0] == "example,fn_x [mm²],k_x [mm²],zeta_x [mm²],fn_y [mm²],k_y [mm²],zeta_y [mm²]"
    assert "N = 4 paths" in (tmp_path / "report.md").read_text()


def _fit(estimate, iterations=7, mlae=(0.5, 0.1, 0.01), names=NAMES, std_errors=None, warnings=()):
    """A stand-in for an identification's fit: what the Table 3 and four-flute sections read of one."""
    from types import SimpleNamespace

    mlae = np.array(mlae)
    return SimpleNamespace(estimate=np.array(estimate, float), iterations=iterations, time_s=1.25, method="newton",
                           evaluations=9, history_mlae=mlae, history_rss=mlae / 2, names=names,
                           std_errors=std_errors, warnings=list(warnings))


def _table3(newton_off: float = 0.001, lsq_off: float = 0.0005) -> paper.Table3:
    """Three examples with truth θ0; the paper's Predicted row 1 % off everywhere; our Newton fit ``newton_off``
    off in every parameter, our lsq fit ``lsq_off`` off; SLDs flat 1 mm (target) and 1.1 mm (Newton)."""
    truth = np.array([900.0, 1e7, 0.03, 950.0, 1.2e7, 0.02])
    rpm = np.linspace(3000.0, 15000.0, 5)
    exs = tuple(paper.ExampleFit(ex, truth, truth * paper.START_FACTORS, truth * 1.01,
                                 _fit(truth * (1 + newton_off)), _fit(truth * (1 + lsq_off), iterations=3),
                                 np.full(6, newton_off), np.full(6, lsq_off), rpm, np.ones(5), np.full(5, 1.1))
                for ex in paper.EXAMPLES)
    return paper.Table3(exs, 60, np.array([0, 2]), np.array([np.full(5, 2.0), np.full(5, 1.2)]))


def test_table3_checks_by_hand():
    """Newton 0.1 % off against the paper's 1 %: holds; lsq 0.05 % ≤ 0.1 %: holds. Newton 2 % off fails,
    lsq 0.2 % fails; two rows per example in Table 3's order."""
    rows = paper.table3_checks(_table3())
    assert [c.ok for c in rows] == [True] * 6
    assert rows[0].claim.startswith("ex1: the paper's method") and rows[5].claim.startswith("ex3: default solver")
    assert rows[0].measured.startswith("fn_x 0.10 % (paper 1.00 %), k_x 0.10 % (paper 1.00 %)")
    assert rows[1].measured == "worst error 0.0500 %"
    assert [c.ok for c in paper.table3_checks(_table3(0.02, 0.002))] == [False] * 6


def test_render_table3_without_computing(tmp_path, monkeypatch):
    """The section from a hand-made result, no engine, forward model or solver reachable (fails on the old code:
    ``table3`` identified and drew in one body)."""
    from millstab import forward, identify

    rep = _render_alone(tmp_path, monkeypatch, paper.render_table3, _table3(), paper.table3_checks,
                        [(forward, "forward"), (identify, "identify")])
    assert {p.name for p in rep.files} == {"table3_identification.csv", "fig_conv.png", "fig_iter.png",
                                           "fig_eggs.png"}
    rows = (tmp_path / "table3_identification.csv").read_text().splitlines()
    assert len(rows) == 1 + 3 * 7
    assert rows[1].startswith("ex1,fn_x [Hz],900.0,1170.0,909.0,1.0")
    assert rows[7] == "ex1,iterations / time [s],,,60,,7 / 1.2,,3 / 1.2,"


def _four_flute(user_points=None) -> paper.FourFlute:
    """By hand: a 5-speed fourSLD with a static SLD whose minimum 0.5 mm sits at 6000 rpm and an in-process one
    flat at 2 mm; an axisymmetric lsq fit 0.5 % off the stand-in's fn (4103.4 Hz)."""
    from types import SimpleNamespace

    from millstab.model import Mode
    from millstab.points import PointSet

    rpm = np.linspace(5000.0, 7000.0, 5)
    curves = {"static": np.array([1.0, 0.8, 0.5, 0.9, 1.2]), "in-process": np.full(5, 2.0)}
    truth = {"fn": 4103.4, "k": 11.65e6, "zeta": 0.0269}
    names = ("fn", "k", "zeta")
    lsq = _fit([4103.4 * 1.005, 11.7e6, 0.027], names=names, std_errors=np.array([10.0, 0.1e6, 0.001]))
    newton = _fit([4100.0, 11.6e6, 0.0268], names=names)
    pts = PointSet(np.array([5600.0, 6000.0]), np.array([1.5, 1.6]), source="points by hand")
    plan = SimpleNamespace(names=names, sigma_existing=np.array([0.01, 0.1, 0.2]),
                           sigma_uniform=np.array([0.008, 0.08, 0.15]), sigma_design=np.array([0.005, 0.05, 0.1]),
                           rpm=np.array([5800.0, 5800.0, 6200.0]),
                           tests=lambda: [(5800.0, 2, 1.4), (6200.0, 1, 1.7)])
    table4 = (("fn_x [Hz]", 1000.0, 1000.0, 4000.0, 4000.0),)
    return paper.FourFlute(table4, rpm, curves, pts, user_points, Mode(4000.0, 2e7, 0.02), newton, lsq,
                           None if user_points else truth, np.full(5, 1.7), plan, pts, rpm, np.full(5, 1.7))


def test_four_flute_checks_by_hand():
    """fn 0.5 % off the stand-in's truth: holds (< 1 %); the user's own points: no check (no truth)."""
    (row,) = paper.four_flute_checks(_four_flute())
    assert (row.ok, row.measured) == (True, "0.50 % off")
    assert paper.four_flute_checks(_four_flute(user_points="tests.csv")) == []


def test_render_four_flute_without_computing(tmp_path, monkeypatch):
    """The section from a hand-made result, no engine, solver or design reachable (fails on the old code:
    ``four_flute`` computed, identified, planned and wrote in one body). The fourSLD summary by hand."""
    from millstab import identify
    from millstab.identify import design

    f = _four_flute()
    rep = _render_alone(tmp_path, monkeypatch, paper.render_four_flute, f, paper.four_flute_checks,
                        [(identify, "identify"), (design, "design_after_fit")])
    assert [p.name for p in rep.files] == ["table4_static_modal.csv", "fourSLD_summary.csv",
                                           "experimental_identification.csv", "test_plan.csv", "fig_plan.png",
                                           "fig_fourSLD.png"]
    summary = (tmp_path / "fourSLD_summary.csv").read_text().splitlines()
    assert summary[1] == "static,0.5,6000.0,0.5,6000.0" and summary[2] == "in-process,2.0,5000.0,2.0,5500.0"
    ident = (tmp_path / "experimental_identification.csv").read_text().splitlines()
    fn_row = ident[1].split(",")
    assert fn_row[:4] == ["fn [Hz]", "4000.0", "4103.4", "4100.0"] and fn_row[5] == "20.0"
    assert float(fn_row[6]) == pytest.approx(0.5) and fn_row[7] == "false"  # 20.5 Hz off against ±2σ = 20 Hz
    assert "5800 (2), 6200" in (tmp_path / "report.md").read_text()
    with pytest.raises(dataclasses.FrozenInstanceError):
        f.lsq = None
