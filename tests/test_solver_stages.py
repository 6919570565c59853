"""The solvers' stages, each tested on its own (identify.search, identify.lsq, identify.newton) and the
shared option parsers (millstab.parsing): shapes, bounds, seeds, and each stage's defining property
checked against an independent computation here."""

from __future__ import annotations

import numpy as np
import pytest

from millstab.errors import InputError
from millstab.forward import log_jacobian
from millstab.identify import lsq, newton
from millstab.identify.objective import make_problem
from millstab.identify.search import pick_distinct, search_box, sobol
from millstab.identify.synthetic import example_points
from millstab.parsing import parse_assignments, parse_grid, parse_interval, parse_rpm_range


@pytest.fixture(scope="module")
def ex3():
    """Example 3 (900/950 Hz, 20 % down milling), 24 noise-free boundary points."""
    cfg, pts = example_points("ex3", n=24)
    prob = make_problem(cfg.structure, cfg.cutting, pts)
    return prob, np.log(prob.par.theta0)


# --- shared search tools --------------------------------------------------------------------------------

def test_search_box_is_the_start_times_or_over_the_factors_inside_the_bounds(ex3):
    prob, u_true = ex3
    blo, bhi = search_box(prob, u_true, {"k": 1.2})
    factors = np.array([{"fn": 1.5, "k": 1.2, "zeta": 2.5}[prob.par.kind(n)] for n in prob.par.free])
    lo, hi = np.log(prob.par.lower), np.log(prob.par.upper)
    np.testing.assert_allclose(blo, np.maximum(lo, u_true - np.log(factors)), rtol=1e-15)
    np.testing.assert_allclose(bhi, np.minimum(hi, u_true + np.log(factors)), rtol=1e-15)
    edge = np.log(prob.par.upper) - 0.1  # a start near the upper bound: the box stops at it
    assert np.array_equal(search_box(prob, edge)[1], hi)


def test_sobol_points_are_seeded_prefixes_of_one_sequence():
    a = sobol(3, 5, seed=4)
    assert a.shape == (5, 3) and np.all((a >= 0) & (a < 1))
    np.testing.assert_array_equal(a, sobol(3, 8, seed=4)[:5])  # more points extend, never change, the design
    assert not np.array_equal(a, sobol(3, 5, seed=5))
    assert sobol(2, 1, seed=0).shape == (1, 2)


def test_pick_distinct_takes_the_cheapest_far_enough_apart():
    u = np.array([[0.0, 0.0], [0.01, 0.0], [1.0, 0.0], [0.0, 1.0], [2.0, 2.0]])
    cost = np.array([1.0, 0.5, 3.0, 2.0, np.inf])
    assert pick_distinct(u, cost, 3, 0.1).tolist() == [1, 3, 2]  # row 0 is within 0.1 of row 1; inf never
    # up to the swap of the two columns, (1, 0) and (0, 1) are the same point
    assert pick_distinct(u, cost, 3, 0.1, perm=np.array([1, 0])).tolist() == [1, 3]


# --- least squares ---------------------------------------------------------------------------------------

def test_lsq_check_options():
    with pytest.raises(InputError, match="loss"):
        lsq.check_options("l2", 10, ((2, 3),))
    with pytest.raises(InputError, match="schedule"):
        lsq.check_options("linear", 10, ((0, 3),))
    lsq.check_options("huber", 1, ((1, 1),))


def test_history_keeps_the_best_so_far_and_reports_progress():
    seen = []
    h = lsq.History(lambda stage, i, best: seen.append((stage, i, best)))
    h(np.array([[1.0], [2.0]]), np.array([5.0, 3.0]))
    h(np.array([[7.0]]), np.array([4.0]))  # worse: the best so far is repeated
    h(np.array([[8.0]]), np.array([1.0]))
    assert h.rss == [3.0, 3.0, 1.0] and [u[0] for u in h.u] == [2.0, 2.0, 8.0]
    assert seen == [("lsq", 1, 3.0), ("lsq", 2, 3.0), ("lsq", 3, 1.0)]


def test_starts_add_keeps_every_stage_and_a_better_best():
    s = lsq.Starts(np.zeros(2), 1.0)
    assert not s.add(np.ones((2, 2)), np.array([0.9995, 2.0]), 3, margin=1e-3)  # not 0.1 % better
    assert s.best_rss == 1.0 and s.lm_iterations == 3 and len(s.u) == 1
    assert s.add(np.array([[1.0, 2.0], [3.0, 4.0]]), np.array([0.5, 0.2]), 2)
    assert s.best_rss == 0.2 and s.best_u.tolist() == [3.0, 4.0] and s.lm_iterations == 5


def test_multistart_improves_on_the_start_and_keeps_the_last_halving_stage(ex3):
    prob, u_true = ex3
    u0 = u_true + np.log([1.1, 0.8, 1.2, 0.95, 1.2, 0.85])
    rss0 = prob.rss(prob.predict_u(u0[None]))[0]
    s = lsq.multistart(prob, u0, n_candidates=64, schedule=((8, 2), (2, 4)), seed=0, search=None, perm=None,
                       record=lsq.History(), central=False)
    assert s.u[0].shape == (2, prob.p) and s.best_rss == s.rss[0].min() < 0.1 * rss0
    np.testing.assert_allclose(prob.rss(prob.predict_u(s.best_u[None]))[0], s.best_rss, rtol=1e-9)


def test_reseed_candidates_resample_one_mode_at_a_time(ex3):
    prob, u_true = ex3
    blo, bhi = search_box(prob, u_true)
    uu = lsq.reseed_candidates(prob, u_true, blo, bhi, seed=1, round_no=0)
    blocks = lsq.mode_blocks(prob)
    assert uu.shape == (1 + 128 * len(blocks) + 256, prob.p) and np.array_equal(uu[0], u_true)
    for b, cols in enumerate(blocks):
        part = uu[1 + 128 * b: 1 + 128 * (b + 1)]
        others = [j for j in range(prob.p) if j not in cols]
        assert np.all(part[:, others] == u_true[others])  # the other modes held at the best
        assert np.all((part[:, cols] >= blo[cols]) & (part[:, cols] <= bhi[cols]))
    np.testing.assert_array_equal(uu, lsq.reseed_candidates(prob, u_true, blo, bhi, seed=1, round_no=0))


def test_reseed_runs_only_while_the_fit_is_poor(ex3):
    prob, u_true = ex3
    s = lsq.Starts(u_true.copy(), 1e-30)
    lsq.reseed(prob, s, u_true, rounds=3, good_rms=0.01, seed=0, search=None, perm=None, record=lsq.History(),
               central=False)
    assert s.rounds == 0 and s.u == []
    u_off = u_true + 0.3
    s = lsq.Starts(u_off, float(prob.rss(prob.predict_u(u_off[None]))[0]))
    lsq.reseed(prob, s, u_off, rounds=1, good_rms=0.0, seed=0, search=None, perm=None, record=lsq.History(),
               central=False)
    assert s.rounds == 1 and len(s.u) == 1


def test_confidence_cloud_stays_near_the_best_point(ex3):
    prob, u_true = ex3
    uu = lsq.confidence_cloud(prob, u_true, 20, seed=2, central=False)
    assert uu.shape == (21, prob.p) and np.array_equal(uu[0], u_true)
    assert np.abs(uu - u_true).max() <= 0.15 + 1e-12
    assert np.all((uu >= np.log(prob.par.lower)) & (uu <= np.log(prob.par.upper)))
    s = lsq.Starts(u_true.copy(), 0.0)
    lsq.local_search(prob, s, n_local=0, seed=0, perm=None, record=lsq.History(), central=False)
    assert s.u == []  # n_local = 0: the stage is skipped


def test_polish_reaches_the_truth_and_its_jacobian_is_the_log_jacobian(ex3):
    """Noise-free points and a start 2 % off: the polish returns the truth; its J (log residuals) equals
    ∂ ln b/∂ ln θ from millstab.forward.log_jacobian (another code path: depths, not residuals)."""
    prob, u_true = ex3
    sol, r, j = lsq.polish(prob, u_true + 0.02, loss="linear", f_scale=0.05, max_nfev=50, central=False)
    np.testing.assert_allclose(sol.x, u_true, atol=1e-6)
    assert r @ r < 1e-12 and j.shape == (prob.n, prob.p)
    # the same forward differences (h = 1e-4, backwards at an upper bound) taken on ln b by forward.py
    ref = log_jacobian(prob._forward, np.exp(sol.x)[None], np.unique(prob.rpm), central=False,
                       bounds=(prob.par.lower, prob.par.upper))[0]
    np.testing.assert_allclose(j, ref[np.unique(prob.rpm, return_inverse=True)[1]], rtol=1e-6, atol=1e-9)


def test_uncertainty_is_sigma2_inverse_jtj(ex3):
    prob, _ = ex3
    j = np.random.default_rng(0).standard_normal((prob.n, prob.p))
    rss = 0.04 * (prob.n - prob.p)  # σ² = RSS/(n − p) = 0.04 from the residuals
    sd, corr, cond = lsq.uncertainty(prob, j, rss, None)
    cov = 0.04 * np.linalg.inv(j.T @ j)
    np.testing.assert_allclose(sd, np.sqrt(np.diag(cov)), rtol=1e-10)
    np.testing.assert_allclose(corr, cov / np.outer(sd, sd), atol=1e-12)
    assert cond == pytest.approx(np.linalg.cond(j.T @ j), rel=1e-9)
    sd2, _, _ = lsq.uncertainty(prob, j, 1e-10, 0.01)  # a stated 1 % noise floors a tiny scatter
    np.testing.assert_allclose(sd2, 0.01 * np.sqrt(np.diag(np.linalg.inv(j.T @ j))), rtol=1e-10)


def test_identifiability_warnings():
    corr = np.eye(3)
    assert lsq.identifiability_warnings(["a", "b", "c"], corr, 10.0) == []
    corr[0, 2] = corr[2, 0] = -0.995
    out = lsq.identifiability_warnings(["a", "b", "c"], corr, 1e9)
    assert [c for c, _ in out] == ["near_singular", "correlated"] and "a/c (-0.995)" in out[1][1]


def test_alternative_solutions_inside_the_confidence_region_only(ex3):
    prob, u_true = ex3
    theta = np.exp(u_true)
    far = u_true + np.array([0.3, 0, 0, 0, 0, 0])
    near = u_true + 0.001
    starts = lsq.Starts(u_true, 1.0, [np.vstack([near, far, far + 0.5])], [np.array([1.0, 1.01, 100.0])])
    alts = lsq.alternative_solutions(prob, theta, 1.0, np.full(prob.p, 1e-3), starts, None, None)
    # `near` is the estimate itself, `far + 0.5` lies outside RSS ≤ RSS_min (1 + p/(n−p) F): only `far`
    assert len(alts) == 1 and alts[0]["rss"] == 1.01
    np.testing.assert_allclose(list(alts[0]["estimate"].values()), np.exp(far), rtol=1e-12)


def test_cut_warning():
    assert lsq.cut_warning(None) is None
    ok = {"stable_cuts": 3, "stable_predicted_chatter": 0, "chatter_cuts": 2, "chatter_predicted_stable": 0}
    assert lsq.cut_warning(ok) is None
    assert "1 of 3 stable cuts" in lsq.cut_warning({**ok, "stable_predicted_chatter": 1})


# --- Newton–Raphson ----------------------------------------------------------------------------------------

@pytest.mark.parametrize("name, value", [("alpha", 0.0), ("alpha", 1.5), ("max_iter", 0), ("n_guesses", 0),
                                         ("jump", 1.0), ("critical_weight", 0.5), ("fd_step", 0.2)])
def test_newton_check_options(name, value):
    good = dict(alpha=1.0, max_iter=10, n_guesses=2, jump=0.05, min_jump=0.01, critical_weight=10.0, fd_step=1e-4)
    newton.check_options(**good)
    with pytest.raises(InputError, match=name):
        newton.check_options(**{**good, name: value})
    with pytest.raises(InputError, match="min_jump"):
        newton.check_options(**{**good, "min_jump": 0.1})


def test_screen_design_adds_a_grid_over_the_fn_columns(ex3):
    prob, u_true = ex3
    blo, bhi = search_box(prob, u_true)
    cand = newton.screen_design(prob.par, u_true, blo, bhi, 16, 25, seed=0)
    assert cand.shape == (1 + 16 + 25, prob.p) and np.array_equal(cand[0], u_true)
    grid = cand[17:]
    fn = [0, 3]
    other = [1, 2, 4, 5]
    assert np.all(grid[:, other] == u_true[other])
    assert sorted(set(grid[:, 0])) == pytest.approx(np.linspace(blo[0], bhi[0], 5))
    assert newton.screen_design(prob.par, u_true, blo, bhi, 16, 0, seed=0).shape == (17, prob.p)
    assert np.all((cand[:, fn] >= blo[fn]) & (cand[:, fn] <= bhi[fn]))


def test_refine_design_and_initial_guesses(ex3):
    prob, u_true = ex3
    refine = {"fn": 1.02, "k": 1.15, "zeta": 1.15}
    centres = np.vstack([u_true, u_true + 0.1])
    local = newton.refine_design(prob.par, centres, 8, refine, seed=1)
    half = np.log([refine[prob.par.kind(n)] for n in prob.par.free])
    assert local.shape == (16, prob.p)
    assert np.all(np.abs(local[:8] - u_true) <= half) and np.all(np.abs(local[8:] - centres[1]) <= half)
    one = newton.initial_guesses(prob, u_true, n_guesses=1, n_screen=64, n_fn_grid=16, n_centres=2, n_refine=8,
                                 refine=refine, min_distance=0.05, seed=0, search=None, perm=None)
    assert np.array_equal(one, u_true[None])
    g = newton.initial_guesses(prob, u_true + 0.1, n_guesses=4, n_screen=64, n_fn_grid=16, n_centres=2, n_refine=8,
                               refine=refine, min_distance=0.05, seed=0, search=None, perm=None)
    assert g.shape == (4, prob.p)
    assert min(np.abs(g[i] - g[j]).max() for i in range(4) for j in range(i)) >= 0.05


def test_difference_rows_scaled_and_literal():
    theta = np.array([[900.0, 1e7], [950.0, 2e7]])
    r = newton.difference_rows(theta, 1e-3, scaled=True)
    assert r.shape == (2, 3, 2) and np.array_equal(r[:, 0], theta)
    np.testing.assert_allclose(r[:, 1, 0], theta[:, 0] * np.exp(1e-3), rtol=1e-15)
    np.testing.assert_array_equal(r[:, 1, 1], theta[:, 1])
    lit = newton.difference_rows(theta, 1e-3, scaled=False)
    np.testing.assert_allclose(lit[:, 2, 1], theta[:, 1] * 1.001, rtol=1e-15)


def test_trial_jumps_structured_and_pattern():
    lo, hi = np.full(2, -10.0), np.full(2, 10.0)
    best = np.array([1.0, 2.0])
    signs = np.array([[1, 0], [-1, 1]])
    j = newton.trial_jumps(best, [], signs, 0.05, lo, hi)
    np.testing.assert_allclose(np.exp(j - best), [[1.05, 1.0], [1 / 1.05, 1.05]], rtol=1e-12)
    path = [best - 0.1, best]  # progress +0.1 per iteration: pattern jumps continue along it
    jp = newton.trial_jumps(best, path, signs, 0.05, lo, hi)
    # a two-point path: every lag reaches back to its first point, so each lag repeats the same multiples
    m = len(newton.PATTERN_MULTIPLES)
    assert jp.shape == (2 + len(newton.PATTERN_LAGS) * m, 2)
    np.testing.assert_allclose(jp[2:2 + m], best + newton.PATTERN_MULTIPLES[:, None] * 0.1, rtol=1e-12)
    assert np.all(newton.trial_jumps(best, [], signs, 0.05, lo, np.array([1.0, 2.0])) <= [1.0, 2.0])


def test_weighted_mlae_is_the_plain_one_with_unit_weight(ex3):
    prob, u_true = ex3
    pred = prob.predict_u(np.vstack([u_true, u_true + 0.05, u_true - 0.05]))  # (3, n)
    pg = np.stack([pred, pred[::-1]])  # (G=2, P+1=3, n)
    plain, fw = newton.weighted_mlae(prob, pg, 1.0, 0.02)
    np.testing.assert_allclose(plain, prob.mlae(pg[:, 0]), rtol=1e-15)
    np.testing.assert_allclose(fw, prob.mlae(pg.reshape(6, -1)).reshape(2, 3), rtol=1e-12)
    _, fw10 = newton.weighted_mlae(prob, pg, 10.0, 0.02)
    assert not np.allclose(fw10, fw)  # the critical points weigh more


def test_newton_step_is_the_papers_update(ex3):
    prob, u_true = ex3
    par = prob.par
    s = np.linspace(0.1, 0.6, prob.p)  # ∂MLAE/∂u
    f0, h = 0.2, 1e-4
    f_w = np.concatenate([[f0], f0 + h * s])[None]
    u_new = newton.newton_step(u_true[None], np.exp(u_true)[None], f_w, fd_step=h, scaled=True, alpha=0.5,
                               max_step=10.0, par=par)
    np.testing.assert_allclose(u_new[0], u_true - 0.5 * f0 * s / (s @ s), rtol=1e-9)
    capped = newton.newton_step(u_true[None], np.exp(u_true)[None], f_w, fd_step=h, scaled=True, alpha=1.0,
                                max_step=1e-3, par=par)
    assert np.abs(capped - u_true).max() == pytest.approx(1e-3)


# --- option parsing ------------------------------------------------------------------------------------------

def test_parsers():
    np.testing.assert_array_equal(parse_rpm_range("2000:2100:50"), [2000.0, 2050.0, 2100.0])
    np.testing.assert_array_equal(parse_grid("0:6:0.5", "--depth", "mm"), np.arange(13) * 0.5)
    assert parse_interval("5000:9000", "--rpm", "rpm") == (5000.0, 9000.0)
    assert parse_assignments("fn_x=900, k_x=1.2e7") == {"fn_x": 900.0, "k_x": 1.2e7}
    for call, field in ((lambda: parse_rpm_range("9000:2000:5"), "--rpm"), (lambda: parse_rpm_range("a:b:c"), "--rpm"),
                        (lambda: parse_interval("1:2:3", "--rpm", "rpm"), "--rpm"),
                        (lambda: parse_assignments("fn_x=-1"), "--initial fn_x")):
        with pytest.raises(InputError) as err:
            call()
        assert err.value.field == field
