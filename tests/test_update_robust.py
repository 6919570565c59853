"""Robust updating (issue 24, model side): graded labels, heavy-tailed prior, learned noise levels, the
prior's support, the prior–data conflict warning, honest label predictions, the posterior file layout."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import log_ndtr, ndtr
from scipy.stats import t as student_t

from millstab.errors import InputError
from millstab.io.config import parse_config
from millstab.points import PointSet
from millstab.update import Posterior, make_prior, update
from millstab.update.conflict import check
from millstab.update.likelihood import Evidence, Likelihood, cut_loglik, limits
from millstab.update.predict import predict_cuts
from configs import TWO_MODE_TOML

TOML = TWO_MODE_TOML
ONLY_KX = '[prior]\nfixed = ["fn_x", "zeta_x", "fn_y", "k_y", "zeta_y", "label_error", "sigma_depth"]\n'


def _prior(extra: str = ""):
    cfg = parse_config(TOML + extra)
    return cfg, make_prior(cfg.structure, cfg.cutting, cfg.prior)


# --- graded labels --------------------------------------------------------------------------------------
@pytest.mark.parametrize("eps", [0.0, 0.02])
def test_graded_likelihood_is_the_kinds_bit_for_bit_and_the_power_form_between(eps):
    z = np.linspace(-45, 45, 181)[None, :].repeat(3, 0)
    kind = np.array([[0], [1], [2]]).repeat(181, 1)
    grade = np.array([[0.0], [1.0], [0.5]]).repeat(181, 1)
    by_kind, by_grade = cut_loglik(z, kind, eps), cut_loglik(z, None, eps, grade)
    np.testing.assert_array_equal(by_kind, by_grade)
    # the closed forms: Φ(±z) mixed with ε, the marginal half/half
    up, down = log_ndtr(z[0]), log_ndtr(-z[0])
    if eps:
        up, down = (np.logaddexp(math.log1p(-eps) + up, math.log(eps) + down),
                    np.logaddexp(math.log1p(-eps) + down, math.log(eps) + up))
    np.testing.assert_array_equal(by_grade[0], down)
    np.testing.assert_array_equal(by_grade[1], up)
    np.testing.assert_array_equal(by_grade[2], 0.5 * (up + down))
    g = 0.3  # a written probability: the power form P(chatter)^g P(stable)^(1−g)
    np.testing.assert_allclose(cut_loglik(z[0], None, eps, np.full(181, g)), g * up + (1 - g) * down, rtol=1e-13)
    # a per-sample ε (B, 1) broadcasts and equals the scalar form row by row
    e2 = np.array([[0.01], [0.1]])
    got = cut_loglik(z[:2], None, e2, grade[:2])
    for r in range(2):
        np.testing.assert_allclose(got[r], cut_loglik(z[r], None, float(e2[r, 0]), grade[r]), rtol=1e-14)


def test_graded_cuts_reach_the_evidence_and_the_likelihood():
    cfg, prior = _prior(ONLY_KX)
    rpm = np.array([6000.0, 7000.0, 8000.0])
    ps = PointSet(rpm, [1.0, 2.0, 3.0], ["stable", "marginal", "chatter"], grade=[0.0, 0.3, 0.9])
    ev = Evidence.from_points(ps)
    np.testing.assert_array_equal(ev.cut_grade, [0.0, 0.3, 0.9])
    u = prior.mean_u[None]
    b = limits(prior, u, rpm)[0][0]
    z = (np.array([1.0, 2.0, 3.0]) - b) / 0.05
    want = cut_loglik(z, None, prior.label_error, np.array([0.0, 0.3, 0.9])).sum()
    assert Likelihood(prior, ev)(u)[0] == pytest.approx(want, rel=1e-12)


# --- the prior -------------------------------------------------------------------------------------------
def test_student_prior_density_and_draws_are_the_t():
    assert _prior()[1].tails == "multivariate_t_shift"  # the default since 2026-11-28 (tests/test_update_shift.py)
    cfg, prior = _prior('[prior]\ntails = "student"\n')
    assert prior.tails == "student" and prior.nu == 4.0
    rng = np.random.default_rng(0)
    u = prior.sample(40000, rng)
    z = (u - prior.mean_u) / prior.spread
    for j in range(prior.size):  # draws: the t's quantiles (within the Monte Carlo error)
        for q in (0.05, 0.25, 0.5, 0.75, 0.95):
            assert abs(np.quantile(z[:, j], q) - student_t.ppf(q, 4)) < 0.04
    zz = rng.standard_normal((5, prior.size))
    want = student_t.logpdf(zz, 4).sum(1) - np.log(prior.spread).sum()
    np.testing.assert_allclose(prior.logpdf(prior.mean_u + zz * prior.spread), want, rtol=1e-12)
    # the Gaussian is the old prior; the mixture integrates to one
    from scipy.stats import norm

    gp = _prior('[prior]\ntails = "normal"\n')[1]
    np.testing.assert_allclose(gp.logpdf(gp.mean_u + zz * gp.spread), norm.logpdf(zz).sum(1) - np.log(gp.spread).sum(),
                               rtol=1e-12)
    from millstab.update.prior import _log_density

    x = np.linspace(-60, 60, 240001)
    assert np.trapezoid(np.exp(_log_density(x, "mixture", 4.0)), x) == pytest.approx(1.0, abs=1e-9)
    assert np.trapezoid(np.exp(_log_density(x, "student", 4.0)), x) == pytest.approx(1.0, abs=2e-5)


def test_heavy_tails_write_off_one_contradiction_and_follow_two():
    """k_x alone free (grid posterior, one engine call): a tool truly 3× softer than its tap test (k_x
    −3.7σ), each cut chattering just above the TRUE limit, where the hammer test says stable by a factor
    2.9. With a Gaussian prior one such label is written off (a factor ε) and two still mostly are, since
    moving 3.7σ costs 6.8 nats; the Student-t writes off most of one and follows two (its penalty grows
    only logarithmically); with eight labels both follow."""
    rpm = np.linspace(5200, 11800, 8)
    med = {}
    for tails in ("normal", "student"):
        cfg, prior = _prior(ONLY_KX + f'tails = "{tails}"\n')
        truth = prior.mean_u - math.log(3.0)
        depth = 1.05 * limits(prior, truth[None], rpm)[0][0]
        g = prior.mean_u[0] + np.linspace(-12, 6, 1801) * prior.spread[0]
        for n in (1, 2, 8):
            with pytest.warns(UserWarning, match="every cut is chatter"):
                ev = Evidence.from_points(PointSet(rpm[:n], depth[:n], ["chatter"] * n))
            logp = prior.logpdf(g[:, None]) + Likelihood(prior, ev)(g[:, None])
            w = np.exp(logp - logp.max())
            med[tails, n] = float(np.interp(0.5, np.cumsum(w) / w.sum(), g) - prior.mean_u[0]) / prior.spread[0]
    assert med["normal", 1] > -0.5 and med["student", 1] > -2.0  # one label: written off (mostly, with the t)
    assert med["normal", 2] > -1.5 and med["student", 2] < -3.5  # two: the t follows them, the Gaussian does not
    assert med["normal", 8] < -3.5 and med["student", 8] < -3.5


def test_support_rejects_zeta_above_one_before_the_engine_and_a_wide_spread_updates():
    cfg, prior = _prior('[prior]\nzeta = "60 %"\n')
    u = np.tile(prior.mean_u, (3, 1))
    u[1, 2] = math.log(1.2)  # ζ_x = 1.2: outside the support
    u[2, 5] = 0.0  # ζ_y = 1
    lik = Likelihood(prior, Evidence.from_points(PointSet([6000.0, 8000.0], [1.0, 3.0], ["stable", "chatter"])))
    ll = lik(u)
    assert np.isfinite(ll[0]) and ll[1] == -np.inf and ll[2] == -np.inf
    assert lik.n_sets == 1  # only the row inside the support reached the engine
    assert prior.logpdf(u)[1] == -np.inf
    rng = np.random.default_rng(1)
    assert (prior.sample(20000, rng)[:, [2, 5]] < 0).all()  # draws inside (0, 1)
    cuts = PointSet([5500.0, 6500.0, 8000.0, 9000.0], [1.0, 3.0, 2.0, 6.0], ["stable", "chatter", "stable", "chatter"])
    post = update(cfg, cuts, samples=300, seed=0)  # used to abort with a validation error blaming the config
    assert (post.samples[:, [2, 5]] < 1).all()


@pytest.mark.parametrize("table, field", [('k = "5000 %"', "prior.k"), ("fn_x = 1.5", "prior.fn_x"),
                                          ('tails = "cauchy"', "prior.tails"),
                                          ('fixed = ["label_eror"]', "prior.fixed")])
def test_implausible_prior_tables_are_named(table, field):
    with pytest.raises(InputError) as info:
        _prior("[prior]\n" + table + "\n")
    assert info.value.field == field


def test_noise_levels_are_learned_unless_held():
    _, p = _prior()
    assert p.noise_names == ("label_error", "sigma_depth") and p.dim == p.size + 2
    w = p.sample_noise(20000, np.random.default_rng(0))
    eps, fac = p.noise(w, w.shape[0])
    assert np.median(eps) == pytest.approx(0.02, rel=0.05) and (eps < 0.5).all() and (eps > 0).all()
    assert np.median(fac) == pytest.approx(1.0, abs=0.02)
    np.testing.assert_allclose(p.noise_coordinates(eps, fac), w, rtol=1e-9, atol=1e-12)
    _, held = _prior('[prior]\nfixed = ["label_error", "sigma_depth"]\n')
    assert held.noise_names == () and held.dim == held.size
    _, zero = _prior("[prior]\nlabel_error = 0\n")
    assert zero.noise_names == ("sigma_depth",)  # ε = 0 cannot be learned in logit coordinates: held


@pytest.mark.slow
def test_learned_label_error_matches_a_brute_force_grid_posterior():
    """k_x and the label error ε free (σ_b held): SMC marginals against a 2-D grid of (ln k_x, logit 2ε) with
    the same prior and likelihood; 16 cuts, three of them swapped, so the data move ε up from 2 %."""
    cfg, prior = _prior('[prior]\nfixed = ["fn_x", "zeta_x", "fn_y", "k_y", "zeta_y", "sigma_depth"]\n'
                        'sigma_depth = "15 %"\n')
    assert prior.noise_names == ("label_error",)
    rng = np.random.default_rng(4)
    rpm = np.linspace(5200, 11800, 16)
    truth = prior.mean_u * 1.0
    truth[0] += math.log(0.8)
    b = limits(prior, truth[None], rpm)[0][0]
    depth = b * rng.uniform(0.6, 1.4, rpm.size)
    lab = np.where(depth > b, "chatter", "stable")
    lab[[2, 7, 11]] = np.where(lab[[2, 7, 11]] == "chatter", "stable", "chatter")
    cuts = PointSet(rpm, depth, lab)
    post = update(cfg, cuts, samples=2000, seed=3)
    lik = Likelihood(prior, Evidence.from_points(cuts))
    mu, sd = prior._noise_prior()
    g1 = prior.mean_u[0] + np.linspace(-6, 4, 100) * prior.spread[0]
    g2 = mu[0] + np.linspace(-4, 5, 90) * sd[0]
    vv = np.stack(np.meshgrid(g1, g2, indexing="ij"), -1).reshape(-1, 2)
    logp = prior.logpdf_full(vv) + lik(vv)
    w = np.exp(logp - logp.max()).reshape(100, 90)
    w /= w.sum()
    smc = np.c_[post.u[:, 0], prior.noise_coordinates(post.label_error, post.sigma_depth_factor)[:, 0]]
    for j, (grid, marg) in enumerate(((g1, w.sum(1)), (g2, w.sum(0)))):
        mean = (grid * marg).sum()
        s = math.sqrt(((grid - mean) ** 2 * marg).sum())
        assert abs(smc[:, j].mean() - mean) < 0.15 * s, (j, smc[:, j].mean(), mean, s)
        assert abs(smc[:, j].std() - s) < 0.15 * s
        for q in (0.05, 0.5, 0.95):
            assert abs(np.quantile(smc[:, j], q) - np.interp(q, np.cumsum(marg), grid)) < 0.25 * s
    assert np.median(post.label_error) > 0.026  # three swaps in sixteen: the label error learned upwards (prior 0.02)


# --- conflict, predictions, the file ----------------------------------------------------------------------
def test_conflict_check_names_the_parameter_and_its_distance():
    _, prior = _prior('[prior]\ntails = "student"\n')  # one parameter far off: the independent t's case
    rng = np.random.default_rng(0)
    u = prior.mean_u + 0.2 * prior.spread * rng.standard_normal((2000, prior.size))
    msg, info = check(prior, u)
    assert msg is None and not info["conflict"] and info["log_bayes_factor"] < 1.0
    u[:, 1] += math.log(1 / 3)  # k_x 3× softer: −3.7σ of the 30 % spread
    msg, info = check(prior, u)
    assert info["conflict"] and msg.startswith("the cuts contradict the hammer test: k_x is 0.33× the tap test's "
                                               "(-3.7σ)")
    # the Bayes factor is the importance-sampling identity Z_t/Z_r = E_post,r[p_t/p_r], checked by hand
    d = prior.logpdf(u, "normal") - prior.logpdf(u)
    assert info["log_bayes_factor"] == pytest.approx(-math.log(np.exp(d).mean()), rel=1e-9)


@pytest.mark.slow
def test_update_names_a_wrong_hammer_test_and_api_results_carry_it():
    """Cuts from a tool 3× stiffer (k) with 20 % higher fn and 3× the damping than its tap test: the
    posterior moves there and the result's warnings (Python and JSON, with its code) name the conflict;
    cuts from the tap test's own structure do not."""
    from millstab import api

    cfg, prior = _prior()
    rng = np.random.default_rng(2)
    rpm = np.linspace(5000, 12000, 14)
    f = np.array([1.2, 3.0, 3.0, 1.2, 3.0, 3.0])
    res = {}
    for name, theta in (("off", prior.median * f), ("same", prior.median)):
        b = limits(prior, np.log(theta)[None], rpm)[0][0]
        depth = b * rng.uniform(0.6, 1.4, rpm.size)
        cuts = PointSet(rpm, depth, np.where(depth > b, "chatter", "stable"))
        res[name] = api.update(cfg, cuts, samples=1000, seed=1)
    off = res["off"]
    assert any(w.startswith("the cuts contradict the hammer test") for w in off.warnings)
    doc = off.to_json()
    assert "prior-data-conflict" in doc["warning_codes"]
    assert not any(w.startswith("the cuts contradict") for w in res["same"].warnings)


def test_predict_cuts_is_the_posterior_predictive_of_the_learned_label_model():
    cfg, prior = _prior()
    rng = np.random.default_rng(0)
    n = 50
    u = prior.sample(n, rng)
    noise = np.c_[rng.uniform(0.01, 0.2, n), rng.uniform(0.5, 2.0, n)]
    post = Posterior(prior, np.exp(u), "zoa", noise=noise)
    rpm, depth = np.array([6000.0, 9000.0, 6000.0]), np.array([0.5, 4.0, 30.0])
    ps, pl = predict_cuts(post, rpm, depth)
    b = limits(prior, u, rpm)[0]
    np.testing.assert_allclose(ps, (b > depth).mean(0), rtol=0, atol=0)
    want = (noise[:, :1] + (1 - 2 * noise[:, :1]) * ndtr((depth - b) / (0.05 * noise[:, 1:]))).mean(0)
    np.testing.assert_allclose(pl, want, rtol=1e-12)
    assert ((pl > 0) & (pl < 1)).all()  # a written label is never certain
    # held noise: ε + (1 − 2ε)·mean Φ with the prior's ε and σ_b
    held = Posterior(prior, np.exp(u), "zoa")
    _, pl0 = predict_cuts(held, rpm, depth)
    np.testing.assert_allclose(pl0, 0.02 + 0.96 * ndtr((depth - b) / 0.05).mean(0), rtol=1e-12)


def test_posterior_file_keeps_the_noise_and_an_old_file_still_loads():
    cfg, prior = _prior()
    cuts = PointSet([5500.0, 6500.0, 8000.0, 9000.0], [1.0, 3.0, 2.0, 6.0], ["stable", "chatter", "stable", "chatter"])
    post = update(cfg, cuts, samples=200, seed=0)
    doc = post.to_json()
    assert doc["schema"] == "millstab.posterior/3" and doc["noise"]["names"] == ["label_error", "sigma_depth"]
    back = Posterior.from_json(doc)
    np.testing.assert_array_equal(back.noise, post.noise)
    assert back.prior.tails == prior.tails == "multivariate_t_shift" and back.prior.noise_names == prior.noise_names
    # sequential reuse from the file: the learned noise levels carry over
    more = PointSet(np.r_[cuts.rpm, 7000.0], np.r_[cuts.depth_mm, 2.5], list(cuts.label) + ["chatter"])
    assert update(cfg, more, samples=200, seed=1, start=back).noise.shape == (200, 2)
    # a millstab.posterior/1 file (Gaussian prior, held noise) loads as it was written
    old = dict(doc, schema="millstab.posterior/1")
    old.pop("noise")
    old["prior"] = {k: v for k, v in doc["prior"].items()
                    if k not in ("tails", "nu", "label_error_spread", "sigma_depth_spread")}
    was = Posterior.from_json(old)
    assert was.prior.tails == "normal" and was.noise is None and was.prior.noise_names == ()
    np.testing.assert_array_equal(was.label_error, np.full(200, 0.02))
    with pytest.raises(InputError):
        Posterior.from_json(dict(doc, noise={"names": ["label_error"], "samples": [[0.1]]}))


def test_tails_and_held_noise_survive_a_config_round_trip(tmp_path):
    from millstab.io.config import load_config, write_config

    cfg = parse_config(TOML + '[prior]\ntails = "mixture"\nfixed = ["zeta_y", "label_error"]\n')
    back = load_config(write_config(tmp_path / "c.toml", cfg)).prior
    assert back.tails == "mixture" and back.fixed == ("zeta_y", "label_error")
    p = make_prior(cfg.structure, cfg.cutting, back)
    assert p.tails == "mixture" and p.noise_names == ("sigma_depth",) and "zeta_y" not in p.names


def test_labels_written_off_as_errors_are_named():
    """Six cuts chattering at 0.05 mm under a ≈ 3 mm hammer-test limit: no structure within the prior
    explains them, so the learned label error rises far above the config's 2 % — and the update says so,
    naming the cuts (before: P(stable) = 1 there and not a word). Under ``multivariate_t``: the default
    ``multivariate_t_shift`` has a structure that explains them (every stiffness and damping far lower together, its
    rival component), so it names the conflict with the hammer test instead (checked at the end)."""
    cfg, prior = _prior('[prior]\ntails = "multivariate_t"\n')
    rpm = np.linspace(5500, 11500, 6)
    with pytest.warns(UserWarning, match="the cuts contradict the hammer test or each other: 6 of 6 labels"):
        post = update(cfg, PointSet(rpm, np.full(6, 0.05), ["chatter"] * 6), samples=500, seed=1)
    assert np.median(post.label_error) > 0.058  # above the prior's 95 % quantile of ε
    assert "prior-data-conflict" in post.to_json()["warning_codes"]
    _, pl = predict_cuts(post, rpm, np.full(6, 0.05))
    assert (pl > 0.06).all()  # the written label's probability follows the learned label error, not the 2 %
    # the default prior moves the structure instead (its label error stays low) and names the conflict all the same
    cfg, _ = _prior()
    with pytest.warns(UserWarning, match="the cuts contradict the hammer test: k_"):
        post = update(cfg, PointSet(rpm, np.full(6, 0.05), ["chatter"] * 6), samples=500, seed=1)
    assert "prior-data-conflict" in post.to_json()["warning_codes"] and np.median(post.label_error) < 0.058
    ps, _ = predict_cuts(post, rpm, np.full(6, 0.05))
    assert (ps < 0.5).all()  # and it believes the cuts chatter
