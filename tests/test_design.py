"""Test planning (millstab.identify.design, millstab design): optimal-design algebra against closed forms,
the sensitivities against the SLD's exact scaling laws, and the planned speeds against an independent
re-computation of their information."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from millstab.cli import main
from millstab.datasets import load_example
from millstab.errors import InputError
from millstab.frf import ModalBatch
from millstab.identify import fit_lsq, make_problem
from millstab.identify.design import (design_after_fit, design_speeds, log_jacobians, optimal_weights, relative_sigma,
                                      round_design)
from millstab.identify.synthetic import boundary_points
from millstab.io.points import write_points
from millstab.params import Parameterization
from millstab.stability import zoa


# --- the optimal-design algebra --------------------------------------------------------------------------
def _regression(x: np.ndarray, degree: int) -> np.ndarray:
    return np.vander(x, degree + 1, increasing=True)[None]  # (1, m, P)


@pytest.mark.slow
def test_a_optimal_quadratic_regression_is_quarter_half_quarter():
    """A-optimal design of y = a + bx + cx² on [-1, 1]: weight 1/4 at ±1 and 1/2 at 0 (closed form:
    tr M⁻¹ = (2w+1)/(2w(1−2w)) + 1/(2w) for weight w at each end, minimal at w = 1/4)."""
    x = np.linspace(-1, 1, 201)
    w, eff, _ = optimal_weights(_regression(x, 2), 1, iterations=20000, tol=1e-5)
    # the algorithm converges to point masses only slowly: count the mass within 0.05 of each support point
    near = lambda x0: w[np.abs(x - x0) <= 0.05 + 1e-12].sum()  # noqa: E731
    assert [near(-1), near(0), near(1)] == pytest.approx([0.25, 0.5, 0.25], abs=5e-3)
    assert eff > 0.99  # the equivalence-theorem bound: within 1 % of the optimum
    # brute force over the symmetric three-point designs agrees on the optimum
    grid = np.linspace(0.01, 0.49, 4801)
    crit = (2 * grid + 1) / (2 * grid * (1 - 2 * grid)) + 1 / (2 * grid)
    assert grid[np.argmin(crit)] == pytest.approx(0.25, abs=1e-3)


def test_c_optimal_slope_puts_half_at_each_end():
    """Pinning only the slope of a straight line: all weight at the ends, half each."""
    x = np.linspace(-1, 1, 101)
    w, eff, _ = optimal_weights(_regression(x, 1), 1, target=np.array([1]), iterations=20000, tol=1e-6)
    assert w[0] == pytest.approx(0.5, abs=5e-3) and w[-1] == pytest.approx(0.5, abs=5e-3)
    assert eff > 0.95  # a singular optimum (the intercept is not estimable from it): slower to certify


def test_existing_information_is_completed_not_repeated():
    """With the intercept already known exactly from earlier points (huge M₀ on it), the best new
    points for the line y = a + bx serve the slope alone: the ends."""
    x = np.linspace(0, 1, 51)
    info0 = np.array([[[1e9, 0.0], [0.0, 0.0]]])
    w, _, _ = optimal_weights(_regression(x, 1), 10, info0=info0, iterations=20000, tol=1e-6)
    assert w[-1] > 0.99  # the point farthest from 0 carries all the slope information


def test_round_design_keeps_the_total_and_each_count_within_one():
    rng = np.random.default_rng(3)
    w = rng.dirichlet(np.ones(40))
    for n in (1, 7, 40, 113):
        c = round_design(w, n)
        assert c.sum() == n and np.all(np.abs(c - n * w) < 1)


def test_relative_sigma_inverts_and_flags_singular():
    rng = np.random.default_rng(0)
    a = rng.standard_normal((8, 4))
    m = a.T @ a
    assert relative_sigma(m) == pytest.approx(np.sqrt(np.diag(np.linalg.inv(m))), rel=1e-10)
    sing = m.copy()
    sing[:, 3] = sing[3, :] = 0.0
    assert np.isinf(relative_sigma(sing)).any()


# --- sensitivities: exact scaling laws of the SLD --------------------------------------------------------
def test_log_jacobians_obey_the_scaling_laws():
    """b ∝ k (all stiffnesses × c ⇒ depth × c), and b depends on Ω and every fn only through Ω/fn:
    ∂ln b/∂ln k_x + ∂ln b/∂ln k_y = 1 and ∂ln b/∂ln Ω = −(∂ln b/∂ln fn_x + ∂ln b/∂ln fn_y)."""
    cfg = load_example("ex3")
    par = Parameterization(cfg.structure)
    rpm = np.linspace(4000, 20000, 57)
    jac, slope = log_jacobians(par, cfg.cutting, par.theta0[None], rpm)
    names = list(par.free)
    kx, ky, fx, fy = (names.index(n) for n in ("k_x", "k_y", "fn_x", "fn_y"))
    assert jac[0, :, kx] + jac[0, :, ky] == pytest.approx(np.ones(rpm.size), abs=1e-6)
    # central differences across a cusp
    np.testing.assert_allclose(slope[0], -(jac[0, :, fx] + jac[0, :, fy]), rtol=1e-3, atol=1e-3)


# --- planning on a real SLD ------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def ex3():
    cfg = load_example("ex3")
    return cfg, Parameterization(cfg.structure), np.linspace(3000, 21000, 400)


def test_plan_information_matches_an_independent_recomputation(ex3):
    """The planned tests' reported standard errors equal √diag((JᵀV⁻¹J)⁻¹) rebuilt from the engine
    directly at the planned speeds (forward differences, another step), and beat n evenly spaced
    speeds at the point the plan was made for."""
    cfg, par, cand = ex3
    plan = design_speeds(par, cfg.cutting, cand, 60, samples=1, noise=0.02, speed_noise=0.0)
    assert plan.rpm.size == 60 and np.all(np.isin(plan.rpm, cand))
    theta = par.theta0
    h = 1e-5
    rows = np.vstack([theta, theta * np.exp(h * np.eye(par.size))])
    d = np.log(zoa.envelope_batch(par.batch(rows), cfg.cutting, plan.rpm))
    jac = ((d[1:] - d[0]) / h).T / 0.02
    sigma = np.sqrt(np.diag(np.linalg.inv(jac.T @ jac)))
    assert plan.sigma_design == pytest.approx(sigma, rel=2e-2)
    assert np.sum(plan.sigma_design ** 2) < 0.8 * np.sum(plan.sigma_uniform ** 2)
    assert plan.efficiency > 0.99
    assert plan.predicted_depth_mm == pytest.approx(
        zoa.envelope_batch(ModalBatch.from_structures([cfg.structure]), cfg.cutting, plan.rpm)[0] * 1e3, rel=1e-9)


def test_plan_is_reproducible_and_seeded(ex3):
    cfg, par, cand = ex3
    a = design_speeds(par, cfg.cutting, cand, 20, seed=4)
    b = design_speeds(par, cfg.cutting, cand, 20, seed=4)
    c = design_speeds(par, cfg.cutting, cand, 20, seed=5)
    assert np.array_equal(a.rpm, b.rpm) and np.array_equal(a.weights, b.weights)
    assert not np.array_equal(a.weights, c.weights)


def test_target_fn_pins_fn_better_than_the_all_parameter_plan(ex3):
    cfg, par, cand = ex3
    # many tests, so rounding the continuous designs to whole tests hardly matters
    all_ = design_speeds(par, cfg.cutting, cand, 400, samples=1, speed_noise=0.0)
    fn = design_speeds(par, cfg.cutting, cand, 400, samples=1, speed_noise=0.0, target=["fn_x", "fn_y"])
    idx = [par.free.index("fn_x"), par.free.index("fn_y")]
    assert np.sum(fn.sigma_design[idx] ** 2) < np.sum(all_.sigma_design[idx] ** 2)
    assert fn.target == ("fn_x", "fn_y")


def test_speed_noise_keeps_tests_off_near_vertical_flanks(ex3):
    """Without speed uncertainty the plan puts tests on the steepest flanks; with it, the steepest
    planned speed is far less steep."""
    cfg, par, cand = ex3
    steep = design_speeds(par, cfg.cutting, cand, 40, samples=1, speed_noise=0.0)
    calm = design_speeds(par, cfg.cutting, cand, 40, samples=1, speed_noise=0.01)
    _, s_steep = log_jacobians(par, cfg.cutting, par.theta0[None], steep.rpm)
    _, s_calm = log_jacobians(par, cfg.cutting, par.theta0[None], calm.rpm)
    assert np.abs(s_calm).max() < 0.5 * np.abs(s_steep).max()


def test_plan_after_a_fit_completes_the_first_points():
    """Sequential use: fit 20 evenly spaced noisy points, plan 20 more around that fit; the plan's
    predicted errors (first points + plan) are smaller than with 20 more evenly spaced ones."""
    cfg = load_example("ex1")
    rpm1 = np.linspace(3000, 12000, 20)
    pts = boundary_points(cfg.structure, cfg.cutting, rpm1, noise=0.02, seed=7)
    fit = fit_lsq(make_problem(cfg.structure, cfg.cutting, pts), seed=0)
    plan = design_after_fit(fit, cfg.cutting, np.linspace(2000, 15000, 600), 20, existing_rpm=rpm1, seed=1)
    assert plan.sigma_existing is not None
    assert np.all(plan.sigma_design <= plan.sigma_existing)
    assert np.sum(plan.sigma_design ** 2) < np.sum(plan.sigma_uniform ** 2)


@pytest.mark.parametrize("kwargs, field", [
    ({"n": 0}, "n"),
    ({"noise": -0.01}, "noise"),
    ({"noise": 0.0}, "noise"),
    ({"speed_noise": float("nan")}, "speed_noise"),
    ({"samples": 0}, "samples"),
    ({"target": ["fn_z"]}, "fn_z"),
])
def test_bad_plan_input_names_the_field(ex3, kwargs, field):
    cfg, par, cand = ex3
    with pytest.raises(InputError, match=field):
        design_speeds(par, cfg.cutting, cand, **{"n": 5, **kwargs})


def test_fewer_tests_than_parameters_are_refused(ex3):
    cfg, par, cand = ex3
    with pytest.raises(InputError, match="cannot determine 6 free parameters: plan at least 4"):
        design_speeds(par, cfg.cutting, cand, 3, existing_rpm=[5000.0, 6000.0])


def test_candidates_that_cannot_determine_a_parameter_are_refused(ex3):
    """Three speeds cannot determine six parameters, however the tests are spread over them."""
    cfg, par, _ = ex3
    with pytest.raises(InputError, match="cannot determine"):
        design_speeds(par, cfg.cutting, [5000.0, 6000.0, 7000.0], 10)


# --- the command ----------------------------------------------------------------------------------------
def test_cli_design_writes_the_plan(tmp_path, capsys):
    out, fig = tmp_path / "plan.csv", tmp_path / "plan.png"
    assert main(["design", "example:ex1", "--n", "12", "--out", str(out), "--plot", str(fig)]) == 0
    rows = list(csv.DictReader(out.open()))
    assert sum(int(r["tests"]) for r in rows) == 12
    assert all(float(r["predicted_depth_mm"]) > 0 for r in rows)
    assert fig.stat().st_size > 0
    text = " ".join(capsys.readouterr().out.split())
    # Ex1: identical x and y modes in slotting, so six parameters cannot be told apart at these values
    assert "not determined" in text and "--axisymmetric" in text


def test_cli_design_after_identify(tmp_path, capsys):
    cfg = load_example("ex1")
    pts = boundary_points(cfg.structure, cfg.cutting, np.linspace(3000, 12000, 25), noise=0.02, seed=2)
    csv_path = write_points(tmp_path / "pts.csv", pts)
    fit = tmp_path / "fit.json"
    assert main(["identify", "example:ex1", str(csv_path), "--quiet", "--out", str(fit)]) == 0
    tip = " ".join(capsys.readouterr().out.split())  # rich wraps long lines
    assert "tip: `millstab design example:ex1 --fit" in tip  # 25 noisy points leave ζ loose
    fit_bytes, pts_bytes = fit.read_bytes(), csv_path.read_bytes()
    out = tmp_path / "next.csv"
    assert main(["design", "example:ex1", "--fit", str(fit), "--points", str(csv_path), "--n", "10",
                 "--rpm", "2000:15000:20", "--out", str(out)]) == 0
    assert "measured points" in capsys.readouterr().out  # the table compares with the points so far
    assert sum(int(r["tests"]) for r in csv.DictReader(out.open())) == 10
    # planning reads the fit and the points, never writes them
    assert fit.read_bytes() == fit_bytes and csv_path.read_bytes() == pts_bytes
    assert json.loads(fit_bytes)["parameters"]


def test_cli_design_axisymmetric_determines_the_tied_parameters(capsys):
    assert main(["design", "example:ex1", "--n", "10", "--axisymmetric"]) == 0
    text = capsys.readouterr().out
    assert "not determined" not in text and "fn *" in text


@pytest.mark.parametrize("args, field", [
    (["--target", "zeta_q"], "zeta_q"),
    (["--n", "0"], "n"),
    (["--rpm", "9000:100:5"], "--rpm"),
])
def test_cli_design_bad_input_one_line_exit_2(capsys, args, field):
    assert main(["design", "example:ex1", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("millstab: error:") and field in err


# --- the plan against even spacing, by its own criterion ---------------------------------------------------
def _criterion_at(par, cutting, plan, speeds, samples, noise=0.02, speed_noise=0.005):
    """The plan's criterion rebuilt independently: the same θ samples (centre, then seeded draws from the
    prior), information JᵀV⁻¹J from the engine at ``speeds`` (one row per test) plus the documented ridge
    (1e-9 × mean over samples of Σ_candidates ‖j‖²), mean over the samples of the summed squared relative
    standard errors of the target parameters (np.linalg.inv)."""
    from millstab.identify.design import _samples, prior_covariance

    u = _samples(np.log(par.theta0)[None], prior_covariance(par), samples, np.log(par.lower), np.log(par.upper), 0)

    def rows(r):
        jac, slope = log_jacobians(par, cutting, np.exp(u), np.asarray(r, float))
        return jac / np.sqrt(noise ** 2 + (speed_noise * slope) ** 2)[..., None]

    jc = rows(plan.candidates)
    ridge = 1e-9 * np.mean((jc ** 2).sum(axis=(1, 2))) * np.eye(par.size)
    jac = rows(speeds)
    t = [par.free.index(n) for n in plan.target]
    inv = np.linalg.inv(np.einsum("smi,smj->sij", jac, jac) + ridge)
    return float(np.mean(inv[:, t, t].sum(axis=1)))


@pytest.mark.parametrize("case, n", [("ex3", 6), ("ex3", 10), ("ex2", 6), ("random", 6)])
def test_plan_is_never_worse_than_even_spacing_for_its_criterion(case, n):
    """The rounded plan's criterion (recomputed independently) is at most that of n tests evenly spaced over
    the candidates. (The Bayesian continuous design spreads its weight over ~50 speeds; rounding it to 6–10
    tests used to drop most of them: on Example 3 the old plan was 1.4× worse than even spacing while its
    continuous design printed efficiency ≥ 0.999.) The printed efficiency bounds the rounded plan."""
    from millstab.identify.synthetic import random_case

    if case == "random":
        c = random_case(np.random.default_rng(5))
        par, cut, cand = Parameterization(c.structure), c.cutting, np.linspace(c.rpm[0], c.rpm[-1], 200)
    else:
        cfg = load_example(case)
        par = Parameterization(cfg.structure, (), case == "ex2")  # ex2: x = y, planned tied
        cut, cand = cfg.cutting, np.linspace(cfg.rpm.min(), cfg.rpm.max(), 200)
    plan = design_speeds(par, cut, cand, n, samples=8, seed=0)
    even = cand[np.abs(cand[:, None] - np.linspace(cand[0], cand[-1], n)[None]).argmin(axis=0)]
    assert plan.samples == 8  # every sample determinable: the criterion averages over all of them
    phi_plan = _criterion_at(par, cut, plan, plan.rpm, 8)
    phi_even = _criterion_at(par, cut, plan, even, 8)
    assert phi_plan <= phi_even * (1 + 1e-6), (phi_plan, phi_even)
    assert plan.criterion_design == pytest.approx(phi_plan, rel=1e-3)
    assert plan.criterion_uniform == pytest.approx(phi_even, rel=1e-3)
    assert 0 < plan.efficiency <= plan.efficiency_continuous <= 1
    # the columns the command prints (RMS over the samples) add up to the criterion
    t = [par.free.index(nm) for nm in plan.target]
    assert np.sum(plan.sigma_design_mean[t] ** 2) == pytest.approx(plan.criterion_design, rel=1e-6)
    assert np.sum(plan.sigma_uniform_mean[t] ** 2) == pytest.approx(plan.criterion_uniform, rel=1e-6)


def test_exchange_reaches_the_best_integer_design():
    """Quadratic regression on 9 points of [-1, 1], 4 tests: the exchange from the rounded uniform design
    reaches the brute-force best of all 495 integer designs (A-optimal: 1, 2, 1 tests at −1, 0, 1)."""
    from itertools import combinations_with_replacement

    from millstab.identify.design import criterion, improve_counts

    x = np.linspace(-1, 1, 9)
    jac = _regression(x, 2)
    target = np.arange(3)
    best = np.inf
    for combo in combinations_with_replacement(range(9), 4):
        c = np.bincount(combo, minlength=9)
        with np.errstate(all="ignore"):
            info = jac[0].T @ (c[:, None] * jac[0])
        if np.linalg.matrix_rank(info) == 3:
            best = min(best, float(np.trace(np.linalg.inv(info))))
    start = round_design(np.full(9, 1 / 9), 4)
    c = improve_counts(jac, start, None, target)
    assert c.sum() == 4
    assert float(criterion(jac, c, None, target)) == pytest.approx(best, rel=1e-9)
    assert list(c) == [1, 0, 0, 0, 2, 0, 0, 0, 1]


# --- a fit file must come from the same config ----------------------------------------------------------
@pytest.fixture(scope="module")
def ex3_fit(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("fit")
    cfg = load_example("ex3")
    pts = boundary_points(cfg.structure, cfg.cutting, np.linspace(3000, 21000, 14), noise=0.02, seed=1)
    csv_path = write_points(tmp / "pts.csv", pts)
    fit = tmp / "fit.json"
    assert main(["identify", "example:ex3", str(csv_path), "--quiet", "--out", str(fit)]) == 0
    return fit, csv_path


def _config_like_ex3(path, **cutting):
    """ex3.toml with some cutting entries replaced (and optionally a second x mode)."""
    from importlib import resources

    text = resources.files("millstab.datasets").joinpath("ex3.toml").read_text()
    for key, value in cutting.items():
        if key == "second_x_mode":
            text = text.replace("[[structure.y]]",
                                '[[structure.x]]\nfn = "2000 Hz"\nk = "40 N/um"\nzeta = 0.03\n\n[[structure.y]]')
            continue
        lines = text.splitlines()
        text = "\n".join(f"{key} = {value}" if ln.startswith(f"{key} =") else ln for ln in lines) + "\n"
    path.write_text(text)
    return path


@pytest.mark.parametrize("change, words", [
    ({"teeth": 4}, "teeth"),
    ({"kt": '"2000 N/mm^2"'}, "kt"),
    ({"entry": '"90 deg"'}, "entry"),
    ({"second_x_mode": True}, "mode"),
])
def test_cli_design_refuses_a_fit_from_another_config(tmp_path, capsys, ex3_fit, change, words):
    fit, _ = ex3_fit
    cfg = _config_like_ex3(tmp_path / "other.toml", **change)
    assert main(["design", str(cfg), "--fit", str(fit), "--n", "8"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("millstab: error:") and "--fit" in err and words in err


@pytest.mark.slow
def test_cli_design_with_the_fits_config_and_old_fit_files(tmp_path, capsys, ex3_fit):
    """The same config (another file with the same contents) is accepted; a fit file from before the
    cutting record warns that it cannot be checked, and still plans. Stiffness is printed in N/µm."""
    fit, pts = ex3_fit
    same = _config_like_ex3(tmp_path / "same.toml")
    assert main(["design", str(same), "--fit", str(fit), "--points", str(pts), "--n", "8"]) == 0
    out = capsys.readouterr().out
    assert "N/µm" in out and "e+06" not in out and "e+07" not in out
    assert "evenly spaced" in " ".join(out.split())
    doc = json.loads(fit.read_text())
    del doc["cutting"]
    old = tmp_path / "old.json"
    old.write_text(json.dumps(doc))
    assert main(["design", "example:ex3", "--fit", str(old), "--n", "8"]) == 0
    assert "does not record the cutting conditions" in " ".join(capsys.readouterr().err.split())
    renamed = tmp_path / "renamed.toml"
    renamed.write_text(same.read_text().replace('name = "ex3"', 'name = "shop"'))
    assert main(["design", str(renamed), "--fit", str(fit), "--n", "8"]) == 0
    assert "made from config 'ex3', this is 'shop'" in " ".join(capsys.readouterr().err.split())


def test_design_after_fit_refuses_other_cutting_conditions():
    cfg = load_example("ex1")
    pts = boundary_points(cfg.structure, cfg.cutting, np.linspace(3000, 12000, 20), noise=0.02, seed=7)
    fit = fit_lsq(make_problem(cfg.structure, cfg.cutting, pts), seed=0, n_candidates=16, rounds=0, n_local=0)
    other = load_example("ex2").cutting
    with pytest.raises(InputError, match="cutting"):
        design_after_fit(fit, other, np.linspace(2000, 15000, 100), 10)


def test_cli_design_help_is_readable(capsys, monkeypatch):
    """Rich read the old help's square brackets ([speeds], [rev/min]) as markup and dropped them, and kept
    the docstring's line breaks inside sentences. The help now keeps every word and each paragraph whole."""
    monkeypatch.setenv("COLUMNS", "250")
    assert main(["design", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())  # the help is wrapped to the terminal's width
    assert "(fn 5 %, k and ζ 30 %)" in text
    assert "speeds table" in text and "START:STOP:STEP in rev/min" in text


def test_design_options_object_and_keywords_are_one_call():
    """Issue 26: design_speeds' settings are DesignOptions (checked when built); keyword calls still work and
    give the same plan; a misspelt keyword is a TypeError naming it."""
    from millstab.identify.design import DesignOptions

    cfg = load_example("ex3")
    par = Parameterization(cfg.structure, ("fn_x", "fn_y"))
    cand = np.linspace(5000, 15000, 21)
    a = design_speeds(par, cfg.cutting, cand, 4, samples=2, noise=0.03, iterations=50, seed=1)
    b = design_speeds(par, cfg.cutting, cand, 4, options=DesignOptions(samples=2, noise=0.03, iterations=50), seed=1)
    np.testing.assert_array_equal(a.rpm, b.rpm)
    assert a.noise == b.noise == 0.03 and a.criterion_design == b.criterion_design
    with pytest.raises(InputError, match="noise"):
        DesignOptions(noise=0.0)
    with pytest.raises(InputError, match="samples"):
        design_speeds(par, cfg.cutting, cand, 4, samples=0)
    with pytest.raises(TypeError, match="'sample'"):
        design_speeds(par, cfg.cutting, cand, 4, sample=3)


def test_a_plan_uses_the_fits_engine_and_says_so():
    """A fit made with the spectral engine (at low immersion the zero-order one is off) is planned on the spectral
    engine: its predicted depths are the spectral limits of the plan's centre, recomputed here (an exploratory test:
    `design --fit` of a spectral fit predicted zero-order depths up to 2.8× the true limit; fails on the old code).
    `engine=` overrides it; the plan's JSON and summary name it."""
    import dataclasses

    from millstab import api
    from millstab.identify.design import SpeedDesign
    from millstab.stability import spectral

    cfg = load_example("ex3")
    pts = boundary_points(cfg.structure, cfg.cutting, np.linspace(3000, 12000, 12), noise=0.02, seed=7)
    fit = fit_lsq(make_problem(cfg.structure, cfg.cutting, pts), seed=0, n_candidates=16, rounds=0, n_local=0)
    fit = dataclasses.replace(fit, settings={**fit.settings, "engine": "spectral"})
    rpm = np.linspace(5000, 11000, 7)
    plan = api.design(cfg, n=6, fit=fit, rpm=rpm, samples=2, seed=1)
    assert plan.engine == "spectral" and "(limits from the spectral engine)" in plan.summary()
    par = Parameterization(fit.structure, fit.names, fit.par.axisymmetric)
    want = spectral.envelope(par.structure(plan.theta), cfg.cutting, plan.rpm).depth_mm
    np.testing.assert_allclose(plan.predicted_depth_mm, want, rtol=1e-3)
    assert SpeedDesign.from_json(json.loads(json.dumps(plan.to_json()))).engine == "spectral"
    zoa_plan = api.design(cfg, n=6, fit=fit, rpm=rpm, samples=2, seed=1, engine="zoa")
    assert zoa_plan.engine == "zoa"
    np.testing.assert_allclose(zoa_plan.predicted_depth_mm,
                               zoa.envelope(par.structure(zoa_plan.theta), cfg.cutting, zoa_plan.rpm).depth_mm,
                               rtol=1e-9)
    with pytest.raises(InputError, match="--engine"):
        api.design(cfg, n=6, fit=fit, rpm=rpm, samples=2, engine="fast")
