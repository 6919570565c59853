"""The paper's Newton–Raphson scheme (millstab.identify.newton) at the paper's own accuracy.

Start: every parameter 30 % off its target, alternating direction (as ``millstab reproduce``'s Table 3:
START_FACTORS in millstab.reproduce.paper); 100 noise-free boundary points of Example 2.
"""

from __future__ import annotations

import numpy as np
import pytest

from millstab.datasets import paper_values
from millstab.identify import fit_newton, make_problem
from millstab.identify.newton import jump_directions
from millstab.identify.objective import rel_error, swap_permutation
from millstab.identify.synthetic import example_points

NAMES = ["fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y"]
START_FACTORS = np.array([1.3, 0.7, 1.3, 0.7, 1.3, 0.7])


@pytest.mark.slow
def test_newton_reaches_paper_accuracy_on_ex2_from_30_percent_off():
    """Every parameter at least as close as the paper's Predicted row (Table 3: fn 0.7 %, k 8.3 %, ζ 2 %)."""
    cfg, pts = example_points("ex2")
    prob = make_problem(cfg.structure, cfg.cutting, pts)
    truth = prob.par.theta0
    pv = paper_values()["results_fourier"]["ex2"]["predicted"]
    paper_err = rel_error(np.array([pv[n] for n in NAMES]), truth)
    fit = fit_newton(prob, truth * START_FACTORS, seed=0)
    err = rel_error(fit.estimate, truth, swap_permutation(prob.par, prob.cutting))
    assert (err <= paper_err).all(), (err, paper_err)
    assert fit.mlae < 1e-3
    assert fit.settings["jumps_kept"] > 0
    # one engine call per iteration, plus the two screening calls and the final evaluation
    assert fit.engine_calls == fit.iterations + 3


def test_jump_directions_include_valley_moves():
    cfg, pts = example_points("ex2")
    par = make_problem(cfg.structure, cfg.cutting, pts).par
    d = jump_directions(par)
    assert set(np.unique(d)) <= {-1.0, 0.0, 1.0}
    assert len(np.unique(d, axis=0)) == len(d)
    # k_x up with ζ_x down, alone and together with the y mode's valley move
    assert any((row == [0, 1, -1, 0, 0, 0]).all() for row in d)
    assert any((row == [0, 1, -1, 0, -1, 1]).all() for row in d)


@pytest.mark.slow
def test_newton_ex3_from_10_percent_off_finds_the_fn_basin():
    """Example 3 (modes 900/950 Hz) from bench_identify's ±10 % start 1 (fn_x −10 %, fn_y +10 %): before the
    regular fn grid among the initial-guess candidates every guess sat in a wrong fn_x basin (fn_x 11 % off,
    MLAE 0.15); now every parameter is at least as close as the paper's Predicted row."""
    cfg, pts = example_points("ex3")
    prob = make_problem(cfg.structure, cfg.cutting, pts)
    truth = prob.par.theta0
    pv = paper_values()["results_fourier"]["ex3"]["predicted"]
    paper_err = rel_error(np.array([pv[n] for n in NAMES]), truth)
    factors = np.random.default_rng(1).choice([0.9, 1.1], truth.size)  # bench_identify.start(truth, 1, 0.1)
    fit = fit_newton(prob, truth * factors, seed=1)
    err = rel_error(fit.estimate, truth)
    assert (err <= paper_err).all(), (err, paper_err)
    assert fit.mlae < 0.01
