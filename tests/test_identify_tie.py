"""The x = y test of the default solver (millstab.identify.tie): in an x/y-symmetric cut the tied model
is reported when the points do not reject it, and only then."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from millstab.datasets import load_example
from millstab.identify import fit_lsq, make_problem
from millstab.identify.synthetic import boundary_points, default_speeds
from millstab.identify.tie import f_test, is_tied, tied_problem
from millstab.model import Mode, Structure
from millstab.params import Parameterization


def _fit(structure, cfg, noise, seed, **kw):
    pts = boundary_points(structure, cfg.cutting, default_speeds(cfg), noise=noise, seed=seed)
    prob = make_problem(cfg.structure, cfg.cutting, pts)
    return prob, fit_lsq(prob, seed=seed, **kw)


@pytest.mark.parametrize("ex", ["ex1", "ex2"])
@pytest.mark.slow
def test_alike_x_and_y_are_reported_tied_with_honest_errors(ex):
    """The paper's Examples 1–2 (x = y, slotting) at 2 % noise: the tied estimate, within 0.1 % in fn,
    both directions equal; the ±2σ intervals cover the truth in most parameters (a free fit covered
    80 % and split fn_x from fn_y by up to 0.7 %)."""
    cfg = load_example(ex)
    truth = Parameterization(cfg.structure).theta0
    covered = total = 0
    for seed in range(4):
        prob, fit = _fit(cfg.structure, cfg, 0.02, seed)
        assert is_tied(fit) and fit.settings["xy_tie_test"]["p_value"] >= 0.05
        assert np.array_equal(fit.estimate[:3], fit.estimate[3:])
        assert np.abs(fit.estimate[[0, 3]] / truth[[0, 3]] - 1).max() < 1e-3
        assert any("x and y tied" in w for w in fit.warnings)
        free = fit.alternatives[0]
        assert "x and y free" in free["why"] and free["rss"] <= fit.rss  # the free fit is never worse in RSS
        covered += int((np.abs(fit.estimate - truth) <= 2 * fit.std_errors).sum())
        total += truth.size
    assert covered / total >= 0.9


@pytest.mark.slow
def test_noise_free_alike_structure_is_tied_and_exact():
    cfg = load_example("ex1")
    _, fit = _fit(cfg.structure, cfg, 0.0, 0)
    assert is_tied(fit)
    assert fit.estimate == pytest.approx(Parameterization(cfg.structure).theta0, rel=1e-6)


@pytest.mark.parametrize("noise", [0.0, 0.02])
@pytest.mark.slow
def test_different_x_and_y_are_not_tied(noise):
    """Slotting with x and y modes 10 % apart in fn: the points reject x = y (noise-free and at 2 %)."""
    cfg = load_example("ex1")
    truth = Structure(x=(Mode(903.0, 12.53e6, 0.03),), y=(Mode(990.0, 16e6, 0.02),))
    prob, fit = _fit(truth, cfg, noise, 1)
    assert not is_tied(fit)
    assert fit.settings["xy_tie_test"]["p_value"] < 0.05
    est = np.sort(fit.estimate[[0, 3]])
    assert est == pytest.approx([903.0, 990.0], rel=5e-3)


@pytest.mark.slow
def test_tie_xy_false_keeps_the_free_fit():
    cfg = load_example("ex1")
    _, fit = _fit(cfg.structure, cfg, 0.02, 0, tie_xy=False)
    assert "xy_tie_test" not in fit.settings


def test_no_tie_without_x_y_symmetry():
    """Example 3 (20 % immersion, α_xx ≠ α_yy): no swap symmetry, so nothing to tie."""
    cfg = load_example("ex3")
    prob = make_problem(cfg.structure, cfg.cutting, boundary_points(cfg.structure, cfg.cutting, default_speeds(cfg)))
    assert tied_problem(prob) is None


def test_tied_problem_maps_pairs():
    cfg = load_example("ex1")
    prob = make_problem(cfg.structure, cfg.cutting, boundary_points(cfg.structure, cfg.cutting, default_speeds(cfg)),
                        free="fn_x,zeta_x,fn_y,zeta_y")
    tprob, index = tied_problem(prob)
    assert tprob.par.free == ("fn", "zeta") and list(index) == [0, 1, 0, 1]


def test_f_test_matches_the_f_distribution_and_the_exact_floor():
    f, p = f_test(rss_tied=1.3, rss_free=1.0, n=100, p=6, q=3, floor=0.0)
    assert f == pytest.approx((0.3 / 3) / (1.0 / 94))
    assert p == pytest.approx(stats.f.sf(f, 3, 94))
    # two exact fits (residuals at the engine's round-off) are indistinguishable: p = 1, not F = 0/0
    assert f_test(1e-21, 1e-22, 100, 6, 3, floor=1e-10)[1] == pytest.approx(1.0)
    assert f_test(1e-21, 1e-22, 100, 6, 3, floor=0.0)[1] < 1e-6  # without the floor: "significant"
