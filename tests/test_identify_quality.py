"""How far an identification can be trusted (millstab.identify.quality): degrees of freedom, the noise
behind the standard errors, poor and systematic residuals, the zero-order model's weak cuts, and point
sets that cannot determine the parameters at all.

Synthetic points: the paper's Example 3 (two modes 900/950 Hz, 3 teeth, a/D 0.2 down milling) at
evenly spaced speeds with seeded relative Gaussian noise."""

from __future__ import annotations

import itertools
import json
import math

import numpy as np
import pytest

from millstab.cli import main
from millstab.datasets import load_example
from millstab.errors import InputError
from millstab.identify import fit_lsq, identify, make_problem
from millstab.identify.quality import (ASSUMED_NOISE, FEW_DOF, accurate_engine, error_sigma, outliers,
                                       radial_immersion, runs_test, zoa_model_poor)
from millstab.identify.synthetic import boundary_points
from millstab.config import Config
from millstab.io.points import write_points
from millstab.points import PointSet
from millstab.model import Cutting, Structure

SPEEDS = (3000.0, 21000.0)
#: a short search: every fit here starts at the truth (the config's structure), and these tests are about
#: the diagnostics at the optimum, not about finding it
FAST = dict(n_candidates=32, schedule=((4, 5), (1, 30)), rounds=0, n_local=0)


@pytest.fixture(scope="module")
def ex3():
    return load_example("ex3")


def _points(cfg, n: int, noise: float, seed: int) -> PointSet:
    return boundary_points(cfg.structure, cfg.cutting, np.linspace(*SPEEDS, n), noise=noise, seed=seed)


def _z(fit) -> np.ndarray:
    """|estimate − truth| / standard error per parameter (the truth is the config's structure)."""
    return np.abs(fit.estimate - fit.par.theta0) / fit.std_errors


# --- degrees of freedom -------------------------------------------------------------------------------
@pytest.mark.parametrize("seed", [0, 1])
def test_as_many_points_as_parameters_has_no_dof_and_honest_errors(ex3, seed):
    """n = p: the fit interpolates the six noisy points (RSS ≈ 0), so the residual scatter is 0 and the
    old standard errors were ~1e-12 with the truth 1e11 σ away. Now: dof = 0 is reported (Fit, JSON),
    the errors use the assumed 2 % noise — the points' real noise here — so they cover the truth."""
    fit = identify(ex3, _points(ex3, 6, 0.02, seed), seed=0, **FAST)
    assert fit.dof == 0 and fit.n_points == 6
    assert "no_dof" in fit.codes and any("no degrees of freedom" in w for w in fit.warnings)
    assert fit.noise["source"] == "assumed" and fit.noise["sigma"] == ASSUMED_NOISE
    assert np.all(fit.std_errors / fit.estimate > 1e-4)
    assert _z(fit).max() < 3, _z(fit)
    doc = fit.to_json()
    assert doc["dof"] == 0 and "no_dof" in doc["warning_codes"] and doc["noise"]["source"] == "assumed"
    json.dumps(doc, default=lambda a: np.asarray(a).tolist())  # serialisable


@pytest.mark.parametrize("seed", [5, 7, 8])
def test_one_spare_point_errors_cover_the_truth(ex3, seed):
    """n = p + 1: σ̂² from one residual degree of freedom is χ²₁-distributed, below 1/100 of σ² one time in
    twelve; with it the truth was 7–40 σ away for these draws. With the assumed-noise floor the truth is
    within 3 σ, and the fit says that few degrees of freedom are left."""
    fit = identify(ex3, _points(ex3, 7, 0.02, seed), seed=0, **FAST)
    assert fit.dof == 1 and "few_dof" in fit.codes
    assert fit.noise["sigma"] >= ASSUMED_NOISE
    assert _z(fit).max() < 3, _z(fit)


def test_stated_noise_sets_the_errors_exactly(ex3):
    """Noise-free points (σ̂ ~ 1e-7): the standard errors are σ·√diag((JᵀJ)⁻¹), so stating 4 % instead of
    2 % doubles every one exactly; the record says where σ came from."""
    pts = _points(ex3, 30, 0.0, 0)
    a = identify(ex3, pts, seed=0, noise=0.02, **FAST)
    b = identify(ex3, pts, seed=0, noise=0.04, **FAST)
    np.testing.assert_allclose(a.estimate, b.estimate, rtol=1e-9)
    np.testing.assert_allclose(b.std_errors, 2 * a.std_errors, rtol=1e-6)
    assert a.noise["source"] == "stated" and a.noise["stated"] == 0.02 and a.dof == 24
    assert "poor_fit" not in a.codes and "few_dof" not in a.codes


def test_error_sigma_rules():
    """The σ choice (module docstring of quality), by hand: residual scatter with enough dof, the larger
    of stated (or assumed) and scatter otherwise; mm residuals scale the relative noise by the depth."""
    n, p = 40, 6
    dof = n - p
    rss = dof * 0.01 ** 2  # σ̂ = 1 %
    assert error_sigma(rss, n, p, 1.0, None)["sigma"] == pytest.approx(0.01)
    assert error_sigma(rss, n, p, 1.0, 0.03)["sigma"] == pytest.approx(0.03)
    hi = error_sigma(rss, n, p, 1.0, 0.005)
    assert hi["sigma"] == pytest.approx(0.01) and hi["source"] == "residuals"
    few = error_sigma((FEW_DOF - 1) * 0.001 ** 2, p + FEW_DOF - 1, p, 1.0, None)
    assert few["sigma"] == ASSUMED_NOISE and few["source"] == "assumed"
    none = error_sigma(0.0, p, p, 2.5, None)  # mm residuals, median depth 2.5 mm
    assert none["dof"] == 0 and none["estimated"] is None and none["sigma"] == pytest.approx(ASSUMED_NOISE * 2.5)


# --- poor and systematic fits ---------------------------------------------------------------------------
def test_residuals_well_above_the_stated_noise_are_a_poor_fit(ex3):
    """Points with 6 % noise fitted with 1 % stated: χ² says the residuals are far above the stated noise.
    The same points with 6 % stated: no poor fit."""
    pts = _points(ex3, 40, 0.06, 3)
    bad = identify(ex3, pts, seed=0, noise=0.01, **FAST)
    assert "poor_fit" in bad.codes and bad.checks["chi2_p_value"] < 1e-6
    assert bad.noise["source"] == "residuals"  # the errors widen with the scatter
    ok = identify(ex3, pts, seed=0, noise=0.06, **FAST)
    assert "poor_fit" not in ok.codes and ok.checks["chi2_p_value"] > 0.01


def test_runs_test_matches_its_exact_distribution():
    """The runs test's mean number of runs, 2 n₁n₂/n + 1, against all C(10, 5) sign arrangements; a
    clustered arrangement (two runs) is significant, an alternating one is not."""
    runs = []
    for pos in itertools.combinations(range(10), 5):
        s = -np.ones(10)
        s[list(pos)] = 1
        runs.append(1 + np.count_nonzero(s[1:] != s[:-1]))
    assert np.mean(runs) == pytest.approx(2 * 5 * 5 / 10 + 1)
    rpm = np.arange(20.0)
    clustered = runs_test(np.where(rpm < 10, 1.0, -1.0), rpm)
    alternating = runs_test(np.where(rpm % 2 == 0, 1.0, -1.0), rpm)
    assert clustered["runs"] == 2 and clustered["p_value"] < 1e-3
    assert alternating["runs"] == 20 and alternating["p_value"] > 0.99
    # speed order, not row order: the same residuals shuffled give the same runs
    perm = np.random.default_rng(1).permutation(20)
    assert runs_test(np.where(rpm < 10, 1.0, -1.0)[perm], rpm[perm])["runs"] == 2


def test_systematic_misfit_is_flagged_and_points_to_the_model(ex3):
    """Boundary points the model cannot follow (the true boundary × a slow 8 % swell along the speed
    axis, noise-free): the residual signs cluster along the speed, the runs test flags it, and — the
    cut being a/D 0.2 — the warning points to the accurate engine (spectral; it said sdm, against the README
    and docs/identification.md). The same structure's exact points raise no such warning."""
    rpm = np.linspace(*SPEEDS, 40)
    exact = boundary_points(ex3.structure, ex3.cutting, rpm)
    swell = PointSet(rpm, exact.depth_mm * np.exp(0.08 * np.sin(2 * math.pi * (rpm - rpm[0]) / (rpm[-1] - rpm[0]))))
    fit = identify(ex3, swell, seed=0, **FAST)
    assert "residual_structure" in fit.codes, (fit.codes, fit.checks)
    assert any("refit with --engine spectral" in w for w in fit.warnings if "systematic" in w)
    clean = identify(ex3, exact, seed=0, **FAST)
    assert "residual_structure" not in clean.codes and "poor_fit" not in clean.codes


def test_zero_order_model_hint_only_on_its_weak_cuts():
    """a/D = (cos φst − cos φex)/2; the hint for a/D < 0.3 or two teeth, not for 4-tooth slotting (where the
    zero-order solution is exact)."""
    low = Cutting.from_immersion(3, 2000e6, 0.3, 0.25, "up")
    assert radial_immersion(low) == pytest.approx(0.25)
    assert zoa_model_poor(low) and zoa_model_poor(Cutting(2, 2000e6, 0.3))
    assert zoa_model_poor(Cutting(4, 2000e6, 0.3)) is None
    assert zoa_model_poor(Cutting.from_immersion(4, 2000e6, 0.3, 0.5, "down")) is None
    # a/D 0.3 through its angles is 0.29999999999999993: not "a/D = 0.3 < 0.3" (as it said until 2026-11-29); with
    # three teeth less than one cuts on average (0.55), the decisions' rule, and that is what is said
    at = Cutting.from_immersion(3, 2000e6, 0.3, 0.3, "up")
    assert radial_immersion(at) < 0.3 and "0.3 < 0.3" not in zoa_model_poor(at)
    assert "0.55 teeth in the cut" in zoa_model_poor(at)
    assert zoa_model_poor(Cutting.from_immersion(6, 2000e6, 0.3, 0.3, "up")) is None  # 1.1 teeth in the cut
    truth = Structure.symmetric(500.0, 8e6, 0.02)
    slot = Cutting(4, 695e6, 0.404)
    pts = boundary_points(truth, slot, np.linspace(3000, 9000, 30))
    fit = identify(Config(cutting=slot, structure=truth, name="slot"), pts, axisymmetric=True, seed=0, **FAST)
    assert "zoa_model" not in fit.codes
    fit2 = identify(Config(cutting=low, structure=truth, name="low"),
                    boundary_points(truth, low, np.linspace(3000, 9000, 30)), axisymmetric=True, seed=0, **FAST)
    zoa = fit2.warnings[fit2.codes.index("zoa_model")]
    assert "check with --engine spectral" in zoa and "process damping" in zoa
    # the engine to refit with is chosen by capability: spectral, or sdm for a cut with process damping
    assert accurate_engine(low) == "spectral"
    assert accurate_engine(Cutting(3, 2000e6, 0.3, process_damping=1e5, diameter=0.012)) == "sdm"


def test_outliers_are_points_beyond_four_robust_sigma():
    """The rule behind the ``outliers`` warning: |r| > 4 × 1.4826 median|r| √(n/(n − p)); a 3.5σ noise point is
    not one, a ×1.2 depth among 2 % noise is; nothing with fewer than FEW_DOF spare points (a near-interpolating
    fit's residuals say nothing of the noise) or at an exact fit's round-off."""
    cfg = load_example("ex3")
    prob = make_problem(cfg.structure, cfg.cutting, _points(cfg, 40, 0.02, 0))
    r = 0.02 * np.random.default_rng(5).standard_normal(prob.n)
    r[3], r[17] = 0.07, np.log(1.2)  # 3.5σ of 2 % noise; a depth 20 % off
    assert list(np.flatnonzero(outliers(r, prob, prob.p))) == [17]
    assert not outliers(r[: prob.p + FEW_DOF - 1], make_problem(
        cfg.structure, cfg.cutting, _points(cfg, prob.p + FEW_DOF - 1, 0.02, 0)), prob.p).any()
    assert not outliers(1e-9 * r, prob, prob.p).any()


# --- point sets that cannot determine the parameters ------------------------------------------------------
def test_points_at_one_speed_are_refused_clearly(ex3):
    """All boundary points at one speed (the kernel used to fail with SystemError/ZeroDivisionError):
    a clear InputError; with one free parameter one speed is enough and the fit runs."""
    one = PointSet(np.full(8, 9000.0), np.linspace(1.0, 2.0, 8))
    with pytest.raises(InputError, match="different spindle speeds"):
        identify(ex3, one)
    two = PointSet(np.repeat([9000.0, 12000.0], 4), np.linspace(1.0, 2.0, 8))
    with pytest.raises(InputError, match="2 distinct speeds"):
        identify(ex3, two)
    depth = boundary_points(ex3.structure, ex3.cutting, [9000.0]).depth_mm[0]
    prob = make_problem(ex3.structure, ex3.cutting, PointSet(np.full(3, 9000.0), depth * np.array([0.98, 1.0, 1.02])),
                        free="k_x", initial={"k_x": 12e6})
    fit = fit_lsq(prob, seed=0, **FAST)
    assert fit.dof == 2 and np.isfinite(fit.estimate).all()


def test_equal_depths_are_flagged(ex3):
    """A constant depth column (no lobes): the fit runs but says the points cannot locate fn."""
    flat = PointSet(np.linspace(*SPEEDS, 12), np.full(12, 1.5))
    fit = identify(ex3, flat, seed=0, **FAST)
    assert "flat_points" in fit.codes and any("1.5 mm" in w for w in fit.warnings)
    assert "flat_points" not in identify(ex3, _points(ex3, 12, 0.0, 0), seed=0, **FAST).codes


def test_test_cuts_at_one_speed_are_reported(ex3):
    """Labelled test cuts all at one speed (three or more at one speed also crashed the kernel)."""
    pts = _points(ex3, 20, 0.0, 0)
    lim = boundary_points(ex3.structure, ex3.cutting, [9000.0]).depth_mm[0]
    allp = PointSet(np.concatenate([pts.rpm, np.full(3, 9000.0)]),
                    np.concatenate([pts.depth_mm, lim * np.array([0.5, 0.8, 1.5])]),
                    np.array([""] * len(pts) + ["stable", "stable", "chatter"], dtype=object))
    fit = fit_lsq(make_problem(ex3.structure, ex3.cutting, allp), seed=0, **FAST)
    assert fit.test_cuts == {"stable_cuts": 2, "stable_predicted_chatter": 0, "chatter_cuts": 1,
                             "chatter_predicted_stable": 0}


def test_cli_one_speed_is_one_line_exit_2(tmp_path, capsys):
    csv = tmp_path / "one.csv"
    csv.write_text("rpm,depth_mm\n" + "".join(f"9000,{1 + 0.1 * i}\n" for i in range(8)))
    assert main(["identify", "example:ex3", str(csv), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("millstab: error:") and "9000 rpm" in err


def test_cli_prints_dof_noise_and_stiffness_in_n_per_um(tmp_path, capsys):
    """The CLI states the degrees of freedom and where the errors' σ comes from; every printed stiffness
    (table and the alternatives line) is in N/µm while the JSON stays SI. Example 1 (x = y, slotting)
    with noise: the tied fit is reported and the free one listed as an alternative."""
    ex1 = load_example("ex1")
    csv = write_points(tmp_path / "pts.csv", boundary_points(ex1.structure, ex1.cutting, np.linspace(3000, 12000, 16),
                                                             noise=0.02, seed=2))
    out = tmp_path / "fit.json"
    assert main(["identify", "example:ex1", str(csv), "--quiet", "--noise", "0.03", "--out", str(out)]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "degrees of freedom: 16 boundary points − 3 parameters = 13" in text  # x = y tied: 3 parameters
    assert "standard errors from the stated depth noise (3 %)" in text
    doc = json.loads(out.read_text())
    assert doc["dof"] == 13 and doc["noise"]["stated"] == 0.03 and doc["parameters"]["k_x"] > 1e6  # SI
    assert doc["cutting"]["teeth"] == ex1.cutting.teeth
    alts = text.split("alternative:")[1:]
    assert alts and all("k_x=" in a and "N/µm" in a.split("k_x=")[1][:20] for a in alts)
    assert main(["identify", "example:ex1", str(csv), "--quiet", "--noise", "-1"]) == 2
    assert "--noise" in capsys.readouterr().err
