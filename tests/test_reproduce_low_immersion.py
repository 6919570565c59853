"""The report's low-immersion sections compute apart from their prose and checks (issue 26: ``simulated_cuts``
and ``engines`` computed, wrote and checked in one body): ``compute_cuts``, ``compute_engines`` and
``compute_identification`` return frozen results; the ``*_checks`` and ``render_*`` functions read only those.
Here the results are written by hand, the checks worked out by hand, and the sections rendered with every
engine, the simulation and the identification made unreachable."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from millstab.reproduce import low_immersion as li
from millstab.reproduce.report import ReportWriter
from millstab.simulate import CutResult
from millstab.simulate.detect import Detection


@pytest.fixture
def no_compute(monkeypatch):
    """Every way the sections could compute, made to fail."""
    from millstab import identify, simulate, stability

    def no(*a, **k):
        raise AssertionError("render computed")

    for mod, names in ((stability, ("get_engine", "engine_with")), (simulate, ("simulate_cut", "detect")),
                       (identify, ("fit_lsq", "make_problem"))):
        for n in names:
            monkeypatch.setattr(mod, n, no)


def _cut(depth_mm: float) -> CutResult:
    t = np.arange(40) * 1e-4
    x = 1e-6 * np.sin(2 * np.pi * 900 * t)
    return CutResult(li.CUT_RPM, depth_mm * 1e-3, li.FEED_M, 2, 4, t, x, 0 * x, 0 * x, 0 * x, False, 922.0,
                     (True, False))


def _det(label: str, hz: float, lobe: str) -> Detection:
    f = np.linspace(0, 3000, 50)
    return Detection(label, hz, lobe, 0.01, 1.5, 20, 606.7, f, 1e-7 * (1 + f / 3000))


def _cuts(chatter_hz: float = 1010.0, lobe: str = "flip") -> li.SimulatedCuts:
    """SDM limit 0.5 mm at 1000 Hz (flip), ZOA 1.0 mm; cuts at 0.4 mm (stable) and 0.65 mm (chatter)."""
    return li.SimulatedCuts(0.5e-3, 1000.0, "flip", 1.0e-3,
                            (("stable", 0.8, _cut(0.4), _det("stable", float("nan"), "")),
                             ("chatter", 1.3, _cut(0.65), _det("chatter", chatter_hz, lobe))))


def test_cut_checks_by_hand():
    """0.4 mm stable: holds. 0.65 mm chatter at 1010 Hz (1.0 % off SDM's 1000 Hz, so not within 1 %) fails;
    at 1009 Hz, flip, it holds; a Hopf lobe against SDM's flip fails."""
    rows = li.cuts_checks(_cuts(1009.0))
    assert [c.ok for c in rows] == [True, True]
    assert rows[0].measured == f"0.400 mm at {li.CUT_RPM:.0f} rpm: stable"
    assert rows[1].measured == "0.650 mm: chatter at 1009.0 Hz (flip); SDM 1000.0 Hz (flip)"
    assert [c.ok for c in li.cuts_checks(_cuts(1010.5))] == [True, False]
    assert [c.ok for c in li.cuts_checks(_cuts(1009.0, "hopf"))] == [True, False]


def _engines(sdm_off: float = 0.005) -> li.EngineComparison:
    """Five speeds, SDM on every 2nd (3 speeds). a/D 0.05: ZOA 2.0 mm flat, spectral minimum 1.5 mm (ZOA/spectral
    = 1.33), SDM = spectral × (1 + sdm_off); a/D 1: ZOA 0.2 mm, spectral 0.2 mm, SDM equal."""
    rpm = np.linspace(5000.0, 25000.0, 5)
    spec = np.array([1.8, 1.5, 1.6, 1.7, 1.9]) * 1e-3
    curves = {0.05: {"zoa": (rpm, np.full(5, 2.0e-3), 0.1), "sdm": (rpm[::2], spec[::2] * (1 + sdm_off), 0.2),
                     "spectral": (rpm, spec, 0.3)},
              1.0: {"zoa": (rpm, np.full(5, 0.2e-3), 0.1), "sdm": (rpm[::2], np.full(3, 0.2e-3), 0.2),
                    "spectral": (rpm, np.full(5, 0.2e-3), 0.3)}}
    flip = {0.05: np.array([False, True, True, False, False]), 1.0: np.zeros(5, bool)}
    return li.EngineComparison(True, 2, curves, flip)


def test_engine_checks_by_hand():
    """ZOA 2.000 / spectral 1.500 = 1.33 > 1.3; spectral vs SDM: 1/1.005 − 1 = −0.50 % at a/D 0.05, 0 at 1.
    SDM 2 % off fails the second check."""
    rows = li.engines_checks(_engines())
    assert [c.ok for c in rows] == [True, True]
    assert rows[0].measured == "ZOA 2.000 mm / spectral 1.500 mm = 1.33"
    assert rows[1].measured == "a/D 0.05: 0.50 %, a/D 1: 0.00 %"
    assert [c.ok for c in li.engines_checks(_engines(0.02))] == [True, False]


def _ident(spread: float = 0.08) -> li.LowImmersionIdentification:
    """Truth 903 Hz, 12.53e6 N/m, 0.03; the estimate's k_y `spread` off (the worst); spectral within 0.4 %."""
    th = np.array([903.0, 12.53e6, 0.03, 903.0, 12.53e6, 0.03])
    est = th * np.array([1.01, 0.98, 1.02, 1.0, 1 + spread, 0.99])
    dev = {"ZOA at the truth": np.array([0.1, 0.3]), "spectral at the truth": np.array([0.002, 0.004]),
           "ZOA at its estimate": np.array([0.05, 0.02]), "spectral at the ZOA estimate": np.array([0.2, 0.1])}
    return li.LowImmersionIdentification(0, th, th * 1.2, est, np.abs(est / th - 1), 3.25, dev)


def test_identification_checks_by_hand():
    """Spectral max 0.4 % < 1 %: holds; worst 8.0 % (k_y) > 5 %: holds, ZOA at the truth up to 30 %; an
    estimate 4 % off at worst fails the second."""
    rows = li.identification_checks(_ident())
    assert [c.ok for c in rows] == [True, True]
    assert rows[0].measured == "max deviation 0.40 %"
    assert rows[1].measured == "worst 8.0 % (k_y); ZOA at the truth off by up to 30 %"
    assert [c.ok for c in li.identification_checks(_ident(0.04))] == [True, False]


def test_render_writes_the_sections_without_computing(tmp_path, no_compute):
    """The three sections from hand-made results: their tables, figures and the same checks, with nothing
    computed (fails on the old code: there was no result to render)."""
    w = ReportWriter(tmp_path, "t")
    cuts, eng, ident = _cuts(1009.0), _engines(), _ident()
    li.render_cuts(w, cuts)
    li.render_engines(w, eng)
    li.render_identification(w, ident)
    rep = w.write()
    assert rep.checks == tuple(li.cuts_checks(cuts) + li.engines_checks(eng) + li.identification_checks(ident))
    assert {p.name for p in rep.files} == {"simulated_cuts.csv", "fig_simulated_cuts.png", "fig_engines.png",
                                           "engines_summary.csv", "low_immersion_identification.csv",
                                           "low_immersion_residuals.csv"}
    md = (tmp_path / "report.md").read_text()
    assert "zero-order limit at this speed is 1.000 mm, so the zero-order model calls both cuts stable" in md
    assert "one in 2 of them (101 speeds) for SDM (--quick; the full run: one in 2)." in md
    assert "it took 3.2 s" in md and "worst parameter error is 8.0 % (k_y)" in md
    # the engines table by hand: a/D 0.05 spectral minimum 1.5 mm at 10000 rpm, 0.50 % from SDM, 2 flip speeds
    summary = (tmp_path / "engines_summary.csv").read_text().splitlines()
    spec = next(r.split(",") for r in summary if r.startswith("0.05,spectral"))
    assert [float(spec[2]), float(spec[3]), round(float(spec[4]), 6), int(spec[7])] == [1.5, 10000.0, 0.497512, 2]
    for r in (cuts, eng, ident):
        with pytest.raises(dataclasses.FrozenInstanceError):
            r.quick = False
