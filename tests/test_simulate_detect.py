"""The detector's label rests on the multiplier's trend and on a level relative to the feed (issue 29),
a diverging run is reported without NaN, and ``simulate``'s door checks its outputs before the work and
blames the right option (issue 25).

Reference: the semi-discretization engine's boundary (an independent method) of the 1-DOF benchmark
(Insperger & Stépán: 2 teeth, Kt = 6e8 N/m², Kr = 1/3, fn = 922 Hz, ζ = 0.011, m = 0.03993 kg).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from millstab.model import Cutting, Mode, Structure
from millstab.simulate import CutResult, detect, label_cuts, simulate_cut

FN, ZETA, MASS = 922.0, 0.011, 0.03993
K = MASS * (2 * math.pi * FN) ** 2
BENCH = Structure(x=(Mode(FN, K, ZETA),))
LOW = Cutting.from_immersion(2, 6e8, 1 / 3, 0.05, "down")
SLOT = Cutting(2, 6e8, 1 / 3, 0.0, math.pi)
FEED = 1e-4


@pytest.mark.slow
def test_low_immersion_cuts_at_085_and_115_of_the_sdm_limit_are_stable_and_chatter():
    """14 speeds, default 200 tooth periods: every cut at 0.85 × the limit is stable, at 1.15 × chatter.
    The old detector called 10 000 rpm chatter (growth 2.04 of a vibration of 8e-15 f_t)."""
    from millstab.stability import sdm

    rpm = np.linspace(5000.0, 25000.0, 14)
    rpm[6] = 10000.0
    b = sdm.envelope(BENCH, LOW, rpm).depth
    lab = label_cuts(BENCH, LOW, np.r_[rpm, rpm], np.r_[0.85 * b, 1.15 * b], FEED)
    assert list(lab.label[:14]) == ["stable"] * 14, lab.label[:14]
    assert list(lab.label[14:]) == ["chatter"] * 14, lab.label[14:]
    assert np.all(np.isfinite(lab.chatter_hz[14:])) and np.all(np.isnan(lab.chatter_hz[:14]))
    assert np.all((lab.multiplier[:14] < 1.0) | (lab.level[:14] < 1e-4))  # decaying, or no vibration at all


def _cut(x: np.ndarray, m: int, rpm: float = 10000.0) -> CutResult:
    T = 60.0 / (2 * rpm)
    t = np.arange(x.size) * T / m
    z = np.zeros_like(x)
    return CutResult(rpm, 1e-3, FEED, 2, m, t, x, z, z, z, False, FN, (True, False))


def test_a_vibration_at_round_off_level_is_stable_whatever_its_growth():
    """Forced T-periodic motion plus a non-synchronous wiggle growing 2x over the run but of 1e-15 f_t:
    no chatter (the old rule tested the growth first and called it chatter)."""
    m, C = 64, 200
    n = C * m + 1
    t = np.arange(n) / m  # in tooth periods
    forced = 2e-6 * np.sin(2 * math.pi * t)
    wiggle = 1e-19 * 2.0 ** (t / C * 4) * np.sin(2 * math.pi * 0.37 * t)
    d = detect(_cut(forced + wiggle, m))
    assert d.label == "stable" and d.level < 1e-12 and d.growth > 1.5
    # the same wiggle at 1 % of the feed per tooth is chatter, at the right frequency
    d = detect(_cut(forced + 1e16 * wiggle, m))
    f_t = 2 * 10000.0 / 60
    assert d.label == "chatter" and abs(d.chatter_hz % f_t - 0.37 * f_t) < 0.01 * f_t


def test_trend_is_the_fitted_multiplier_of_a_clean_exponential():
    """d_c grows as |μ|^c exactly: the fitted multiplier is |μ| (closed form), growth = |μ|^W."""
    m, C = 32, 400
    t = np.arange(C * m + 1) / m
    mu = 1.006  # growth 1.006^100 = 1.82 over W = 100 periods: above GROWTH = 1.5
    x = 1e-6 * mu**t * np.sin(2 * math.pi * 0.29 * t)
    d = detect(_cut(x, m))
    assert d.multiplier == pytest.approx(mu, rel=2e-4)
    assert d.growth == pytest.approx(mu ** (C // 4), rel=0.03)
    assert d.label == "chatter"
    d = detect(_cut(1e-6 * 0.994**t * np.sin(2 * math.pi * 0.29 * t), m))
    assert d.multiplier == pytest.approx(0.994, rel=2e-4) and d.label == "stable"


def test_a_run_that_diverges_within_two_periods_reports_chatter_without_nan(capsys):
    """Far beyond the limit the run stops within two tooth periods: before, 'chatter at nan Hz (); growth nan'."""
    res = simulate_cut(BENCH, SLOT, 9000.0, 0.2, FEED, revs=5)
    assert res.diverged and res.periods < 2
    d = detect(res)
    assert d.label == "chatter"
    assert math.isfinite(d.chatter_hz) and 0 < d.chatter_hz < 2 * FN + res.tooth_hz * 2
    assert math.isfinite(d.growth) and d.growth > 1 and math.isfinite(d.level) and d.level > 1
    json.dumps(d.to_dict(), allow_nan=False)
    from millstab.cli import main

    assert main(["simulate", "example:ex1", "--rpm", "9000", "--depth", "200", "--revs", "5"]) == 0
    out = capsys.readouterr().out
    assert "nan" not in out.lower() and "chatter at" in out and "diverged" in out


def test_simulate_cuts_checks_the_output_before_the_work_and_prints_without_out(tmp_path, capsys, monkeypatch):
    from millstab import api
    from millstab.cli import main

    cuts = tmp_path / "cuts.csv"
    cuts.write_text("rpm,depth_mm\n9000,1\n9000,8\n")
    calls = []
    real = api.label_cuts
    monkeypatch.setattr(api, "label_cuts", lambda *a, **k: calls.append(1) or real(*a, **k))
    assert main(["simulate", "example:ex1", "--cuts", str(cuts), "--out", str(cuts)]) == 2
    assert calls == [] and cuts.read_text() == "rpm,depth_mm\n9000,1\n9000,8\n"  # refused before any cut
    capsys.readouterr()
    assert main(["simulate", "example:ex1", "--cuts", str(cuts), "--revs", "40"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1] == "rpm,depth_mm,label,chatter_hz"
    assert lines[2].startswith("9000.0,1.0,stable,") and lines[3].split(",")[2] == "chatter"


@pytest.mark.parametrize("args,field", [
    (["--rpm", "0.01", "--depth", "1"], "--rpm"),
    (["--rpm", "9000", "--depth", "1", "--marginal", "weird"], "--marginal"),
    (["--rpm", "9000", "--depth", "1", "--marginal", "random"], "--marginal"),
    (["--rpm", "9000", "--depth", "1", "--label-noise", "0.1"], "--label-noise"),
    (["--rpm", "9000", "--depth", "1", "--record", "cut.mp3"], "--record"),
])
def test_simulate_messages_blame_the_right_option(args, field, capsys, tmp_path, monkeypatch):
    from millstab.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(["simulate", "example:ex1", *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"millstab: error: {field} ")


def test_a_cut_too_long_to_store_blames_the_speed_or_the_revolutions():
    """At 0.01 rpm one revolution alone exceeds the storage (the speed is wrong, not the revs); at 10 rpm
    100 revolutions do (fewer revolutions fit: the revs are named, with how many fit)."""
    from millstab.errors import InputError

    with pytest.raises(InputError) as e:
        simulate_cut(BENCH, SLOT, 0.01, 1e-3, FEED)
    assert e.value.field == "rpm" and "rev/min" in str(e.value)
    with pytest.raises(InputError) as e:
        simulate_cut(BENCH, SLOT, 10.0, 1e-3, FEED)
    assert e.value.field == "revs" and "revolutions at this speed" in str(e.value)



# Two flip islands (SDM radius ρ > 1 on a band of depths, < 1 just above it): a 2-mode structure at a/D = 0.25 up
# milling, 12 450 rpm (3 teeth, Kt 600 MPa, Kr 0.4; ρ > 1 on 14.08..15.11 mm, < 1 on the pocket 15.11..16.87 mm,
# 0.932 at 16.47 mm, > 1 above: Hopf), and the packaged ex1 (2 teeth, 903 Hz) at a/D = 0.05 down milling,
# 12 500 rpm (ρ > 1 from 120.8 mm to ~140 mm, 0.953 at 145 mm; 400 steps, the spectral engine at 10..30 nodes
# agrees to 1e-4, while the default extrapolated SDM radius there is 0.912: the pocket's ρ is taken at 400 steps)
ISLAND = Structure(x=(Mode(665.0, 4.2e6, 0.03),), y=(Mode(1045.0, 39.9e6, 0.03),))
UP25 = Cutting.from_immersion(3, 6e8, 0.4, 0.25, "up")
EX1 = Structure.symmetric(903.0, 12.53e6, 0.03)
EX1_LOW = Cutting.from_immersion(2, 556.31e6, 0.404, 0.05, "down")


@pytest.mark.parametrize("structure,cutting,rpm,pocket,above,rest_stable", [
    (ISLAND, UP25, 12450.0, 16.47e-3, 17.0e-3, True), (EX1, EX1_LOW, 12500.0, 145e-3, None, False)])
def test_labels_follow_the_sdm_radius_across_a_flip_island_and_its_stable_pocket(structure, cutting, rpm, pocket,
                                                                                  above, rest_stable):
    """A report called 16.47 mm at 12 450 rpm (the first case) weakly unstable and its "stable" label a detector
    miss: the depth is in the stable pocket above the island (SDM ρ 0.932 at 400 steps, 0.933 by default; spectral
    0.932), and the simulation decays with |μ| 0.930 from a steady or a rest start, so "stable" is right. Around
    the island's lower edge b0 the labels change where ρ does: 0.95 b0 stable, 1.05 b0 chatter (ρ 1.008, 1.017);
    a depth above the pocket (17 mm, ρ 1.018) is not stable. In ex1's pocket the entry transient of a rest start
    sustains a small flip vibration (marginal, level 0.01 f_t: a nonlinear response, as in real cuts), so only the
    steady start is checked there. (These passed before the report: a guard, not a fix.)"""
    from millstab.stability import sdm

    b0 = sdm.envelope(structure, cutting, [rpm]).depth[0]
    depth = np.array([0.95 * b0, 1.05 * b0, pocket] + ([above] if above else []))
    rho = sdm.rho_map(structure, cutting, [rpm], depth, steps=400)[0]
    assert rho[0] < 1.0 < rho[1] and rho[2] < 0.96 and np.all(rho[3:] > 1.0)  # the case is what the docstring says
    lab = label_cuts(structure, cutting, np.full(depth.size, rpm), depth, FEED)
    assert list(lab.label[:3]) == ["stable", "chatter", "stable"], lab.label
    assert np.all(lab.label[3:] != "stable"), lab.label
    assert lab.multiplier[2] == pytest.approx(rho[2], abs=5e-3)  # a linear decay, not a missed growth
    if rest_stable:
        rest = detect(simulate_cut(structure, cutting, rpm, pocket, FEED, start="rest"))
        assert rest.label == "stable" and rest.multiplier == pytest.approx(rho[2], abs=5e-3)
