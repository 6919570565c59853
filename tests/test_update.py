"""Bayesian updating: likelihood closed forms, the sampler against exact answers, a brute-force grid
posterior, maps, recommendations, the prior table and the cuts reader."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy.stats import norm

from millstab.errors import InputError
from millstab.io.config import parse_config
from millstab.io.points import read_points, write_points
from millstab.points import PointSet
from millstab.model import Cutting, Mode, Structure
from millstab.stability import zoa
from millstab.update import Posterior, make_prior, update
from millstab.update.decide import p_stable_from_limits, p_stable_map, recommend, safe_depth
from millstab.update.likelihood import Evidence, Likelihood, cut_loglik, frequency_distance, limits
from millstab.update.posterior import split_modes
from millstab.update.sampler import ess_of, systematic_resample, tempered_smc
from configs import TWO_MODE_TOML

CUT = Cutting(2, 556.31e6, 0.404, 0.0, math.pi)
STRUCT = Structure(x=(Mode(903.0, 12.53e6, 0.03),), y=(Mode(1050.0, 15e6, 0.04),))
TOML = TWO_MODE_TOML


# --- likelihood closed forms ------------------------------------------------------------------------
def test_cut_loglik_is_probit_and_marginal_is_half_each():
    z = np.array([-2.0, -0.3, 0.0, 0.7, 3.0])
    np.testing.assert_allclose(cut_loglik(z, np.ones(5, int)), norm.logcdf(z), rtol=1e-12)
    np.testing.assert_allclose(cut_loglik(z, np.zeros(5, int)), norm.logcdf(-z), rtol=1e-12)
    m = cut_loglik(z, np.full(5, 2))
    np.testing.assert_allclose(m, 0.5 * (norm.logcdf(z) + norm.logcdf(-z)), rtol=1e-12)
    assert np.argmax(m) == 2  # a marginal cut is most likely right on the limit


def test_label_error_is_the_swap_mixture_and_bounds_a_contradiction():
    z = np.array([-40.0, -3.0, -0.5, 0.0, 0.5, 3.0, 40.0])
    for eps in (0.0, 0.02, 0.3):
        up, down = cut_loglik(z, np.ones(7, int), eps), cut_loglik(z, np.zeros(7, int), eps)
        np.testing.assert_allclose(np.exp(up), (1 - eps) * norm.cdf(z) + eps * norm.cdf(-z), rtol=1e-12, atol=1e-300)
        np.testing.assert_allclose(np.exp(up) + np.exp(down), 1.0, rtol=1e-12)  # the two labels are all there is
    # a label 40 σ on the wrong side costs log ε, not −∞ (nor the ≈ −800 of the plain probit)
    assert cut_loglik(np.array([-40.0]), np.ones(1, int), 0.02)[0] == pytest.approx(math.log(0.02), rel=1e-9)
    assert cut_loglik(np.array([-40.0]), np.ones(1, int), 0.0)[0] < -700


def test_a_swapped_label_leaves_the_truth_inside_with_label_error_but_not_without():
    """Twelve cuts bracketing the true limit (±15 %) and one swapped label (a cut at half the limit
    written "chatter"): the 90 % intervals of a grid posterior (two free parameters, one engine call)
    cover the truth with ε = 0.02 and miss it with ε = 0."""
    rpm = np.linspace(5200, 9000, 12)
    covered = {}
    for eps in (0.0, 0.02):
        cfg = parse_config(TOML + f'[prior]\nfixed = ["zeta_x", "fn_y", "k_y", "zeta_y"]\nlabel_error = {eps}\n')
        prior = make_prior(cfg.structure, cfg.cutting, cfg.prior)
        assert prior.label_error == eps
        truth = np.log(prior.median * np.array([1.03, 0.85]))
        b = limits(prior, truth[None], rpm)[0][0]
        depth = b * np.where(np.arange(12) % 2, 1.15, 0.85)
        label = np.where(depth > b, "chatter", "stable")
        depth[4], label[4] = 0.5 * b[4], "chatter"  # the operator's slip
        lik = Likelihood(prior, Evidence.from_points(PointSet(rpm, depth, label)))
        g = [prior.mean_u[j] + np.linspace(-5, 5, 120) * prior.spread[j] for j in (0, 1)]
        uu = np.stack(np.meshgrid(*g, indexing="ij"), -1).reshape(-1, 2)
        logp = prior.logpdf(uu) + lik(uu)
        w = np.exp(logp - logp.max()).reshape(120, 120)
        w /= w.sum()
        covered[eps] = []
        for j, marg in enumerate((w.sum(1), w.sum(0))):
            lo, hi = np.interp([0.05, 0.95], np.cumsum(marg), g[j])
            covered[eps].append(bool(lo <= truth[j] <= hi))
    assert covered[0.02] == [True, True]
    assert covered[0.0] == [False, False]


def test_frequency_distance_sees_through_tooth_passing_aliases():
    ftp = 300.0
    fc = np.array([903.0])
    for measured in (903.0, 903 + 2 * ftp, 903 - 3 * ftp, abs(-903 + 4 * ftp)):  # ±fc + m·ftp
        assert frequency_distance(measured, fc, ftp)[0] == pytest.approx(0.0, abs=1e-9)
    assert frequency_distance(913.0, fc, ftp)[0] == pytest.approx(10.0)
    # the members +903 and -903 (mod 300: 3 and 297) are 6 Hz apart; 1053 is 150 from 903 and 144 from 1197
    assert frequency_distance(903 + 150.0, fc, ftp)[0] == pytest.approx(144.0)
    # far from every member: at most ftp/2; no boundary (NaN) is the worst case
    assert frequency_distance(1050.0, np.array([900.0]), ftp)[0] == pytest.approx(150.0)
    assert frequency_distance(903.0, np.array([np.nan]), ftp)[0] == pytest.approx(150.0)


def test_likelihood_matches_a_hand_computation():
    prior = make_prior(STRUCT, CUT)
    cuts = PointSet([5000, 6000, 7000, 6500], [1.0, 2.0, 1.5, 1.7], ["stable", "chatter", "marginal", ""],
                    [1, 2, 1, 1], chatter_hz=[np.nan, 1000.0, np.nan, np.nan])
    lik = Likelihood(prior, Evidence.from_points(cuts))
    u = prior.sample(5, np.random.default_rng(3))
    depth, hz = limits(prior, u, lik.speeds, "zoa", True)
    s = 0.05
    i = {r: j for j, r in enumerate(lik.speeds)}
    b = lambda r: depth[:, i[r]]  # noqa: E731
    ftp = 2 * 6000 / 60
    d = frequency_distance(1000.0, hz[:, i[6000]], ftp)
    e = prior.label_error
    assert e == 0.02  # the default: a label swapped now and then

    def lab(z):  # P(chatter label) of the swap mixture
        return np.log((1 - e) * norm.cdf(z) + e * norm.cdf(-z))

    # the frequency term: the reading's σ and its share of another vibration grow with x = ln(depth / limit) above
    # the limit (FREQ_DRIFT 0.017, FREQ_OUTLIER 0.05 + 0.12 x, at most 0.3); read as the member near the mode with
    # 1 − a, any member with a
    x = np.maximum(np.log(2.0 / b(6000)), 0.0)
    sf, o, a = np.hypot(20.0, 0.017 * 1000.0 * x), np.minimum(0.05 + 0.12 * x, 0.3), prior.chatter_hz_alias
    d0 = np.abs(1000.0 - hz[:, i[6000]])
    freq = np.log((1 - o) * ((1 - a) * norm.pdf(d0, scale=sf) + a * norm.pdf(d, scale=sf)) + o / ftp)
    want = (lab(-(1.0 - b(5000)) / s) + 2 * lab((2.0 - b(6000)) / s)
            + 0.5 * (lab((1.5 - b(7000)) / s) + lab(-(1.5 - b(7000)) / s))
            + 2 * freq + norm.logpdf(1.7, loc=b(6500), scale=s))
    np.testing.assert_allclose(lik(u), want, rtol=1e-10)
    assert lik.n_calls == 1 and lik.n_sets == 5


def test_free_kt_scales_depth_exactly():
    prior = make_prior(STRUCT, CUT, parse_config(TOML + '[prior]\nkt = "10 %"\n').prior)
    assert prior.names[-1] == "kt"
    u = prior.mean_u.copy()
    u[-1] = math.log(1.3 * CUT.kt)
    rpm = np.linspace(5000, 9000, 7)
    got, _ = limits(prior, u[None], rpm)
    want = zoa.envelope(STRUCT, CUT.scaled_kt(1.3), rpm).depth_mm
    np.testing.assert_allclose(got[0], want, rtol=1e-9)


# --- prior and [prior] table -------------------------------------------------------------------------
def test_prior_defaults_and_table():
    p = make_prior(STRUCT, CUT)
    assert p.names == ("fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y")
    np.testing.assert_allclose(p.spread, [0.05, 0.3, 0.3] * 2)
    assert p.sigma_depth_m == 0.05e-3 and p.sigma_chatter_hz == 20.0 and p.label_error == 0.02
    cfg = parse_config(TOML + '[prior]\nfn = "3 %"\nk_y = 0.1\nfixed = ["zeta_y"]\nsigma_depth = "4 %"\n'
                       'sigma_chatter_hz = "10 Hz"\n')
    p = make_prior(cfg.structure, cfg.cutting, cfg.prior)
    assert p.names == ("fn_x", "k_x", "zeta_x", "fn_y", "k_y")
    np.testing.assert_allclose(p.spread, [0.03, 0.3, 0.3, 0.03, 0.1])
    np.testing.assert_allclose(p.sigma_depth_mm(np.array([2.0])), [0.08])
    assert p.sigma_chatter_hz == 10.0


@pytest.mark.parametrize("table, field", [('fn = "0 %"', "prior.fn"), ("k_x = -0.1", "prior.k_x"),
                                          ('sigma_depth = 0.05', "prior.sigma_depth"),
                                          ("fn_z = 0.1", "prior.fn_z"), ('fixed = ["fn_q"]', "prior.fixed")])
def test_bad_prior_tables_are_named(table, field):
    with pytest.raises(InputError) as info:
        cfg = parse_config(TOML + "[prior]\n" + table + "\n")
        make_prior(cfg.structure, cfg.cutting, cfg.prior)
    assert info.value.field == field


# --- cuts files ---------------------------------------------------------------------------------------
def test_cuts_file_with_marginal_and_chatter_frequency(tmp_path):
    f = tmp_path / "cuts.csv"
    f.write_text("rpm,depth_mm,label,chatter_hz\n5000,1.0,stable,\n5200,2.0,chatter,1012.5\n5400,1.4,Marginal,\n"
                 "5600,1.1,,\n")
    ps = read_points(f)
    assert list(ps.label) == ["stable", "chatter", "marginal", ""]
    np.testing.assert_array_equal(ps.marginal, [False, False, True, False])
    assert ps.chatter_hz[1] == 1012.5 and np.isnan(ps.chatter_hz[[0, 2, 3]]).all()
    write_points(tmp_path / "back.csv", ps)
    back = read_points(tmp_path / "back.csv")
    np.testing.assert_array_equal(back.chatter_hz[1], 1012.5)
    ev = Evidence.from_points(ps)
    assert ev.n_cuts == 3 and ev.pt_rpm.tolist() == [5600.0]


@pytest.mark.parametrize("row, field", [("5000,1.0,wobbly,", "label"), ("5000,1.0,stable,900", "chatter_hz"),
                                        ("5000,1.0,chatter,-5", "chatter_hz")])
def test_bad_cut_rows(tmp_path, row, field):
    f = tmp_path / "cuts.csv"
    f.write_text("rpm,depth_mm,label,chatter_hz\n" + row + "\n")
    with pytest.raises(InputError) as info:
        read_points(f)
    assert field in info.value.field and "line 2" in info.value.field


def test_evidence_needs_a_stable_or_chatter_cut_and_warns_when_one_sided():
    with pytest.raises(InputError, match="stable or chatter"):
        Evidence.from_points(PointSet([5000, 6000], [1, 2], ["marginal", "marginal"]))
    with pytest.warns(UserWarning, match="every cut is stable"):
        Evidence.from_points(PointSet([5000, 6000], [1, 2], ["stable", "stable"]))


# --- sampler ------------------------------------------------------------------------------------------
def test_smc_matches_a_conjugate_gaussian_posterior_and_its_evidence():
    # prior N(0, I), likelihood N(y; u, s²) per coordinate: posterior N(y/(1+s²), s²/(1+s²)) exactly
    y, s = np.array([1.5, -0.7]), np.array([0.3, 0.5])
    logprior = lambda u: -0.5 * (u**2).sum(1) - math.log(2 * math.pi)  # noqa: E731
    loglik = lambda u: (-0.5 * ((u - y) / s) ** 2 - np.log(s * math.sqrt(2 * math.pi))).sum(1)  # noqa: E731
    res = tempered_smc(lambda n, rng: rng.standard_normal((n, 2)), logprior, loglik, 4000, seed=1, moves=4)
    mean, var = y / (1 + s**2), s**2 / (1 + s**2)
    se = np.sqrt(var / 4000) * 4  # allow for the particles' correlation
    np.testing.assert_allclose(res.u.mean(0), mean, atol=4 * se.max())
    np.testing.assert_allclose(res.u.var(0), var, rtol=0.1)
    log_z = norm.logpdf(y, scale=np.sqrt(1 + s**2)).sum()
    assert abs(res.log_evidence - log_z) < 0.1
    assert res.betas[0] == 0 and res.betas[-1] == 1 and res.stages >= 2
    assert all(0 < a < 1 for a in res.acceptance)


def test_systematic_resampling_and_ess():
    rng = np.random.default_rng(0)
    logw = np.log(np.array([0.1, 0.2, 0.3, 0.4]))
    counts = np.bincount(np.concatenate([systematic_resample(np.repeat(logw, 250), rng) // 250 for _ in range(1)]),
                         minlength=4)
    np.testing.assert_array_equal(counts, [100, 200, 300, 400])  # systematic: exact for these weights
    assert ess_of(np.zeros(10)) == pytest.approx(10)
    assert ess_of(np.array([0.0, -np.inf, -np.inf])) == pytest.approx(1)


#: the grid tests' prior tails: their ±4-spread grids hold a multivariate-t posterior's mass; the default's rival
#: component (``multivariate_t_shift``) reaches ~20 spreads, beyond them (its 2 000-particle sd then also rests on
#: the few far draws)
GRID_TAILS = 'tails = "multivariate_t"\n'


def _truth_cuts(prior, theta, rpm, rel, seed=0):
    rng = np.random.default_rng(seed)
    b = limits(prior, np.log(theta)[None], rpm)[0][0]
    depth = b * rng.uniform(1 - rel, 1 + rel, rpm.size)
    return PointSet(rpm, depth, np.where(depth > b, "chatter", "stable"))


def test_smc_agrees_with_a_brute_force_grid_posterior():
    """Two free parameters (fn_x, k_x): posterior means and quantiles of SMC against a dense grid."""
    cfg = parse_config(TOML + '[prior]\nfixed = ["zeta_x", "fn_y", "k_y", "zeta_y", "label_error", "sigma_depth"]\n'
                       'sigma_depth = "15 %"\n' + GRID_TAILS)
    prior = make_prior(cfg.structure, cfg.cutting, cfg.prior)
    truth = prior.median * np.array([1.04, 0.8])
    cuts = _truth_cuts(prior, truth, np.linspace(5200, 9000, 8), 0.4)
    post = update(cfg, cuts, samples=2000, seed=2)
    lik = Likelihood(prior, Evidence.from_points(cuts))
    g1 = prior.mean_u[0] + np.linspace(-4, 4, 90) * prior.spread[0]
    g2 = prior.mean_u[1] + np.linspace(-4, 4, 90) * prior.spread[1]
    uu = np.stack(np.meshgrid(g1, g2, indexing="ij"), -1).reshape(-1, 2)
    logp = prior.logpdf(uu) + lik(uu)  # ONE engine call for the whole grid
    w = np.exp(logp - logp.max()).reshape(90, 90)
    w /= w.sum()
    for j, (grid, marg) in enumerate(((g1, w.sum(1)), (g2, w.sum(0)))):
        mean = (grid * marg).sum()
        sd = math.sqrt(((grid - mean) ** 2 * marg).sum())
        cdf = np.cumsum(marg)
        u = post.u[:, j]
        assert abs(u.mean() - mean) < 0.15 * sd, (j, u.mean(), mean, sd)
        assert abs(u.std() - sd) < 0.15 * sd
        for q in (0.05, 0.5, 0.95):
            assert abs(np.quantile(u, q) - np.interp(q, cdf, grid)) < 0.25 * sd
    # the data moved the posterior: it is narrower than the prior in fn_x
    assert post.u[:, 0].std() < 0.8 * prior.spread[0]


def test_same_seed_same_samples():
    cuts = PointSet([5500, 6500, 8000], [1.0, 3.0, 2.0], ["stable", "chatter", "stable"])
    cfg = parse_config(TOML)
    a = update(cfg, cuts, samples=200, seed=5)
    b = update(cfg, cuts, samples=200, seed=5)
    c = update(cfg, cuts, samples=200, seed=6)
    np.testing.assert_array_equal(a.samples, b.samples)
    assert not np.array_equal(a.samples, c.samples)
    back = Posterior.from_json(a.to_json())
    np.testing.assert_array_equal(back.samples, a.samples)
    assert back.prior.names == a.prior.names and back.prior.cutting == a.prior.cutting
    doc = a.to_json()
    assert (doc["schema"] == "millstab.posterior/3"
            and set(doc["parameters"]["fn_x"]) == {"mean", "sd", "q05", "q50", "q95"})


def test_exchange_twins_are_reported_as_modes():
    prior = make_prior(STRUCT, CUT)  # slotting: the exact exchange swaps fn, ζ and k of x and y
    rng = np.random.default_rng(0)
    theta = np.exp(prior.sample(300, rng))
    twin = theta[:, [3, 4, 5, 0, 1, 2]]
    assert not split_modes(prior, theta[:5] * 0 + prior.median, "zoa").any()
    both = np.vstack([theta, twin[:100]])
    mask = split_modes(prior, both, "zoa")
    assert mask[300:].mean() > 0.9 and mask[:300].mean() < 0.1
    post = Posterior(prior, both)
    modes = post.to_json()["modes"]
    assert len(modes) == 2 and modes[1]["label"] == "x<->y exchanged"
    assert modes[1]["share"] == pytest.approx(mask.mean())
    assert any("bimodal" in w for w in post.to_json()["warnings"])
    assert split_modes(prior, theta, "sdm") is None  # the exchange is exact for the zero-order model only


# --- decisions -----------------------------------------------------------------------------------------
def test_p_stable_map_counts_samples_and_is_monotone_in_depth():
    rng = np.random.default_rng(0)
    blim = rng.gamma(3.0, 1.0, (500, 7))
    blim[::17, 2] = np.inf
    depth = np.linspace(-1, 12, 50)
    got = p_stable_from_limits(blim, depth)
    brute = (blim[:, :, None] > depth[None, None, :]).mean(0)  # independent: every (sample, speed, depth)
    np.testing.assert_allclose(got, brute, atol=1e-12)
    assert (np.diff(got, axis=1) <= 0).all()


def test_safe_depth_respects_the_risk_exactly():
    rng = np.random.default_rng(1)
    blim = rng.lognormal(0, 0.3, (1000, 5))
    for risk in (0.01, 0.05, 0.3):
        d = safe_depth(blim, risk)
        assert ((blim <= d).mean(0) <= risk).all()
        assert ((blim <= d * 1.001).mean(0) > risk - 0.002).all()  # and is the largest such depth


def test_recommend_respects_the_risk_and_beats_the_grid():
    prior = make_prior(STRUCT, CUT)
    post = Posterior(prior, np.exp(prior.sample(400, np.random.default_rng(4))), cuts={"rpm": [5000.0, 9000.0]})
    # the plain rule (no Monte Carlo bound, no speed tolerance): the search against a grid
    rec = recommend(post, 0.1, (5000, 9000), width_mm=10, feed_mm=0.1, confidence=None, speed_tolerance=0.0)
    blim = limits(prior, post.u, [rec.rpm])[0][:, 0]
    assert rec.p_chatter == pytest.approx((blim <= rec.depth_mm).mean())
    assert rec.p_chatter <= 0.1
    grid = np.linspace(5000, 9000, 61)
    best_grid = (safe_depth(limits(prior, post.u, grid)[0], 0.1) * grid).max()
    assert rec.productivity >= best_grid * (1 - 1e-9)
    assert rec.mrr_cm3_per_min == pytest.approx(rec.depth_mm * rec.rpm * 10 * 0.1 * 2 / 1000)
    assert rec.next_test["relative_productivity"] > 1 and 0 < rec.next_test["p_chatter"] < 1
    capped = recommend(post, 0.1, (5000, 9000), max_depth_mm=0.5 * rec.depth_mm, confidence=None, speed_tolerance=0.0)
    assert capped.depth_mm <= 0.5 * rec.depth_mm and capped.limited_by == "max_depth"
    with pytest.raises(InputError, match="--risk"):
        recommend(post, 1.5, (5000, 9000))
    with pytest.warns(UserWarning, match="beyond the tested speeds"):
        recommend(post, 0.1, (2000, 9000))


def test_decisions_beyond_the_tested_speeds_warn_in_one_text():
    """A map and a recommendation over the same speeds beyond the tested ones say it in the same words (the app shows
    both on one page: one line, not two that differ in one word); within 10 % of the tested speeds nothing is said."""
    from millstab import api

    prior = make_prior(STRUCT, CUT)
    post = Posterior(prior, np.exp(prior.sample(200, np.random.default_rng(4))), cuts={"rpm": [5000.0, 9000.0]})
    texts = []
    for call in (lambda: api.p_stable(post, np.linspace(2000, 9000, 8), np.linspace(0, 4, 5)),
                 lambda: recommend(post, 0.1, (2000, 9000))):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            call()
        texts.append([str(w.message) for w in caught if "tested speeds" in str(w.message)])
    assert texts[0] == texts[1] and len(texts[0]) == 1, texts
    assert "2000-9000 rpm" in texts[0][0] and "(5000-9000 rpm)" in texts[0][0]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        recommend(post, 0.1, (4600, 9800))  # within 10 %
    assert not [w for w in caught if "tested speeds" in str(w.message)]


def test_allowed_count_is_the_clopper_pearson_bound():
    from scipy.stats import binom

    from millstab.update.decide import allowed_count

    n, risk = 1000, 0.05
    for conf in (0.5, 0.8, 0.9, 0.99):
        # independent: the Clopper–Pearson upper bound of k/n is ≤ risk ⟺ P(X ≤ k; n, risk) ≤ 1 − confidence
        ks = np.arange(51)
        want = ks[binom.cdf(ks, n, risk) <= 1 - conf].max()
        assert allowed_count(n, risk, n, conf) == want
    assert allowed_count(n, risk, n, None) == 50  # the plain count ⌊risk·N⌋
    # fewer effective samples: a smaller count; too few to bound the risk at all: −1
    assert allowed_count(n, risk, 300, 0.9) < allowed_count(n, risk, 1000, 0.9) < 50
    assert allowed_count(n, risk, 20, 0.9) == -1  # 1 − 0.1^(1/20) = 0.109 > 0.05 even with no sample below


def test_effective_samples_counts_distinct_samples_and_the_last_ess():
    from millstab.update.decide import effective_samples

    prior = make_prior(STRUCT, CUT)
    u = prior.sample(200, np.random.default_rng(0))
    dup = Posterior(prior, np.exp(np.vstack([u, u[:50]])))  # resampling duplicates
    assert effective_samples(dup) == 200
    assert effective_samples(Posterior(prior, np.exp(u), diagnostics={"ess": [150.0, 120.5]})) == 120.5


def test_recommendation_holds_the_risk_at_its_speed_error_by_brute_force():
    """The recommended depth keeps the epistemic P(chatter) (the fraction of samples whose OWN limit,
    one engine call per sample, is at or below the depth) within the allowed count at the speed and
    at ±tolerance; the reported probabilities are those counts; tolerance and bound cost depth."""
    from millstab.update.decide import allowed_count

    prior = make_prior(STRUCT, CUT)
    post = Posterior(prior, np.exp(prior.sample(300, np.random.default_rng(4))), cuts={"rpm": [5000.0, 9000.0]})
    tol = 0.005
    rec = recommend(post, 0.1, (5000, 9000), confidence=0.9, speed_tolerance=tol)
    speeds = rec.rpm * np.array([1 - tol, 1.0, 1 + tol])
    own = np.array([zoa.envelope(prior.par.structure(t), CUT, speeds).depth_mm for t in post.samples])  # (N, 3)
    frac = (own <= rec.depth_mm).mean(0)
    assert rec.p_chatter == pytest.approx(frac[1], abs=1e-12)
    assert rec.p_chatter_speed_error == pytest.approx(frac.max(), abs=1e-12)
    assert frac.max() <= allowed_count(300, 0.1, 300, 0.9) / 300 < 0.1
    assert rec.p_chatter_bound <= 0.1 + 1e-9 and rec.effective_samples == 300
    plain = recommend(post, 0.1, (5000, 9000), confidence=None, speed_tolerance=0.0)
    assert rec.productivity < plain.productivity
    assert rec.to_json()["speed_tolerance"] == tol
    with pytest.raises(InputError, match="speed_tolerance"):
        recommend(post, 0.1, (5000, 9000), speed_tolerance=-0.01)
    with pytest.raises(InputError, match="confidence"):
        recommend(post, 0.1, (5000, 9000), confidence=1.0)


def test_map_from_posterior_uses_one_engine_call():
    prior = make_prior(STRUCT, CUT)
    post = Posterior(prior, np.exp(prior.sample(300, np.random.default_rng(2))))
    rpm, depth = np.linspace(5000, 9000, 11), np.linspace(0, 6, 13)
    pm = p_stable_map(post, rpm, depth)
    env = zoa.envelope_batch(prior.par.batch(post.samples), CUT, rpm) * 1e3
    np.testing.assert_allclose(pm, (env[:, :, None] > depth).mean(0))


def test_boundary_points_combine_with_cuts_and_frequency_term_points_to_the_truth():
    prior = make_prior(STRUCT, CUT)
    cuts = PointSet([6000.0, 7000.0], [5.0, 1.0], ["chatter", "stable"])
    pts = PointSet([6500.0, 8000.0], [2.0, 2.5])
    ev = Evidence.from_points(cuts, pts)
    assert ev.n_cuts == 2 and ev.pt_rpm.tolist() == [6500.0, 8000.0] and ev.speeds.tolist() == [6000, 6500, 7000, 8000]
    # a chatter cut whose measured frequency is the truth's: the frequency term prefers the truth
    u0 = prior.mean_u[None]
    hz = limits(prior, u0, [6000.0], "zoa", True)[1][0, 0]
    only = PointSet([6000.0], [50.0], ["chatter"], chatter_hz=[hz])  # deep: the same label term for all
    with pytest.warns(UserWarning, match="every cut is chatter"):
        ev1 = Evidence.from_points(only)
    lik = Likelihood(prior, ev1)
    shifted = u0.copy()
    shifted[0, 0] += 0.05  # fn_x 5 % higher moves the limiting lobe's f_c
    ll = lik(np.vstack([u0, shifted]))
    hz2 = limits(prior, shifted, [6000.0], "zoa", True)[1][0, 0]
    d = frequency_distance(hz, hz2, 200.0)
    assert 5 < d < 100
    label = math.log(1 - prior.label_error)  # a cut this deep is written "chatter" unless the label is swapped
    b = [limits(prior, v, [6000.0], "zoa")[0][0, 0] for v in (u0, shifted)]

    def freq(dist, limit):  # σ and the share of another vibration grow with x = ln(50 mm / limit) (FREQ_DRIFT, ...)
        x = math.log(50.0 / limit)
        sf, o = math.hypot(20.0, 0.017 * hz * x), min(0.05 + 0.12 * x, 0.3)
        return math.log((1 - o) * norm.pdf(dist, scale=sf) + o / 200.0)  # d0 = d here: any alias mixture is moot

    assert ll[0] == pytest.approx(label + freq(0.0, b[0]), abs=1e-6)
    assert ll[1] == pytest.approx(label + freq(d, b[1]), abs=1e-6)
    assert ll[0] > ll[1]
    with pytest.warns(UserWarning, match="not used"):
        assert not Likelihood(prior, ev1, "sdm").uses_frequency


def test_frequencies_come_from_any_engine_declaring_them(monkeypatch):
    """The likelihood asks ``reports_chatter_frequency`` and calls ``envelope_batch_hz`` (it tested the
    name "zoa" and called zoa's kernel): a plug-in declaring it has its frequencies used; the spectral
    engine's agree with its own single-structure envelope."""
    import types

    import millstab.stability as stab

    prior = make_prior(STRUCT, CUT)
    u0 = prior.mean_u[None]
    hz = limits(prior, u0, [6000.0], "zoa", True)[1][0, 0]
    with pytest.warns(UserWarning, match="every cut is chatter"):
        ev = Evidence.from_points(PointSet([6000.0], [50.0], ["chatter"], chatter_hz=[hz]))
    plug = types.ModuleType("plug")
    for a in stab.base.CONTRACT:
        setattr(plug, a, getattr(zoa, a))
    plug.name = "plug"
    plug.envelope_batch_hz = lambda b, c, r: tuple(2 * x for x in zoa.envelope_batch_hz(b, c, r))
    stab.register(plug)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # no "not used" warning
            lik = Likelihood(prior, ev, "plug")
        assert lik.uses_frequency
        d, f = limits(prior, u0, [6000.0], "plug", True)
        assert f[0, 0] == pytest.approx(2 * hz, rel=1e-12)
    finally:
        stab.unregister("plug")
    d, f = limits(prior, u0, [6000.0, 7000.0], "spectral", True)
    # the depths and frequencies of the engine itself, at the discretisation the forward function fixes
    # for a problem (the settings capability), so the frequency path and the depths-only path agree
    spec = stab.get_engine("spectral")
    nodes = spec.settings(prior.par.batch(np.exp(u0)), CUT, [6000.0, 7000.0])["nodes"]
    env = spec.envelope(prior.par.structure(np.exp(u0[0])), CUT, [6000.0, 7000.0], nodes=nodes)
    np.testing.assert_allclose(d[0], limits(prior, u0, [6000.0, 7000.0], "spectral")[0][0], rtol=1e-12)
    np.testing.assert_allclose(d[0], env.depth_mm, rtol=1e-12)
    np.testing.assert_allclose(f[0], env.chatter_hz, rtol=1e-12)


def test_smc_refuses_to_return_an_unfinished_tempering():
    loglik = lambda u: -0.5 * ((u - 3.0) / 0.01) ** 2  # noqa: E731  (far and narrow: many stages)
    with pytest.raises(RuntimeError, match="beta"):
        tempered_smc(lambda n, rng: rng.standard_normal((n, 1)), lambda u: -0.5 * (u**2).sum(1),
                     lambda u: loglik(u).sum(1), 200, max_stages=2)


# --- sequential reuse and the compiled next-test criterion ------------------------------------------
def _grid_posterior(prior, cuts, n=90):
    lik = Likelihood(prior, Evidence.from_points(cuts))
    g1 = prior.mean_u[0] + np.linspace(-4, 4, n) * prior.spread[0]
    g2 = prior.mean_u[1] + np.linspace(-4, 4, n) * prior.spread[1]
    uu = np.stack(np.meshgrid(g1, g2, indexing="ij"), -1).reshape(-1, 2)
    logp = prior.logpdf(uu) + lik(uu)
    w = np.exp(logp - logp.max()).reshape(n, n)
    return g1, g2, w / w.sum()


def test_sequential_reuse_matches_the_grid_posterior_and_a_fresh_update():
    """Posterior of 4 cuts as the start of an update of 8: same answer as the brute-force grid of all 8
    (and as a fresh update), in fewer tempering stages."""
    cfg = parse_config(TOML + '[prior]\nfixed = ["zeta_x", "fn_y", "k_y", "zeta_y", "label_error", "sigma_depth"]\n'
                       'sigma_depth = "15 %"\n' + GRID_TAILS)
    prior = make_prior(cfg.structure, cfg.cutting, cfg.prior)
    truth = prior.median * np.array([1.04, 0.8])
    cuts = _truth_cuts(prior, truth, np.linspace(5200, 9000, 8), 0.4)
    first = cuts.subset(np.arange(8) < 4)
    # an informative first half, so that a start ignoring it (L_old left out) would be visibly wrong
    early = update(cfg, first, samples=2000, seed=1)
    seq = update(cfg, cuts, samples=2000, seed=3, start=early)
    fresh = update(cfg, cuts, samples=2000, seed=3)
    assert seq.diagnostics["stages"] < fresh.diagnostics["stages"]
    g1, g2, w = _grid_posterior(prior, cuts)
    for j, (grid, marg) in enumerate(((g1, w.sum(1)), (g2, w.sum(0)))):
        mean = (grid * marg).sum()
        sd = math.sqrt(((grid - mean) ** 2 * marg).sum())
        cdf = np.cumsum(marg)
        for post in (seq, fresh):
            u = post.u[:, j]
            assert abs(u.mean() - mean) < 0.15 * sd, (j, u.mean(), mean, sd)
            assert abs(u.std() - sd) < 0.15 * sd
            for q in (0.05, 0.95):
                assert abs(np.quantile(u, q) - np.interp(q, cdf, grid)) < 0.25 * sd


def test_sequential_reuse_refuses_a_start_of_other_data():
    cfg = parse_config(TOML)
    cuts = PointSet([5500, 6500, 8000], [1.0, 3.0, 2.0], ["stable", "chatter", "stable"])
    early = update(cfg, cuts.subset(np.array([True, True, False])), samples=100, seed=1)
    other = PointSet([5500, 6600, 8000], [1.0, 3.0, 2.0], ["stable", "chatter", "stable"])
    with pytest.raises(InputError, match="start"):
        update(cfg, other, samples=100, seed=1, start=early)
    with pytest.raises(InputError, match="start"):
        update(cfg, cuts, samples=100, seed=1, start=early, engine="sdm")


def test_label_information_kernel_matches_the_numpy_form():
    from scipy.special import ndtr

    from millstab.update._bald import label_information

    rng = np.random.default_rng(0)
    blim = rng.uniform(1.0, 4.0, (300, 7))
    blim[5, 2] = np.inf  # no boundary: surely stable
    depths = np.linspace(0.1, 5.0, 40)
    sig = 0.05 + 0.02 * depths
    pi = ndtr((depths[None, None, :] - blim[:, :, None]) / sig)

    def h(p):
        q = np.clip(p, 1e-12, 1 - 1e-12)
        return -(q * np.log(q) + (1 - q) * np.log(1 - q))

    for eps in (0.0, 0.02):
        pe = eps + (1 - 2 * eps) * pi  # the label swapped with probability ε
        pbar, info, proc = label_information(blim, depths, sig, eps)
        np.testing.assert_allclose(proc, pi.mean(0), atol=1e-12)
        np.testing.assert_allclose(pbar, pe.mean(0), atol=1e-12)
        np.testing.assert_allclose(info, h(pe.mean(0)) - h(pe).mean(0), atol=1e-9)
        assert info.min() > -1e-12 and info.max() <= math.log(2)
    # a swapped label now and then makes every test less informative
    assert (label_information(blim, depths, sig, 0.1)[1] <= label_information(blim, depths, sig)[1] + 1e-12).all()
    # one label error and depth-noise factor per sample (the posterior's learned label model)
    eps = rng.uniform(0.0, 0.2, blim.shape[0])
    fac = rng.uniform(0.5, 2.0, blim.shape[0])
    pi = ndtr((depths[None, None, :] - blim[:, :, None]) / (sig[None, None, :] * fac[:, None, None]))
    pe = eps[:, None, None] + (1 - 2 * eps[:, None, None]) * pi
    pbar, info, proc = label_information(blim, depths, sig, eps, fac)
    np.testing.assert_allclose(pbar, pe.mean(0), atol=1e-12)
    np.testing.assert_allclose(info, h(pe.mean(0)) - h(pe).mean(0), atol=1e-9)
    np.testing.assert_allclose(proc, pi.mean(0), atol=1e-12)  # the process's chance, no label error


def test_the_summary_line_shows_the_acceptance_of_stages_that_moved():
    """An accurate update's first stages temper the zero-order screen without moves: their acceptance (0) is not
    the sampler's, and the one-line summary leaves them out (it read "acceptance 0.00-0.14" before)."""
    prior = make_prior(STRUCT, CUT)
    post = Posterior(prior, np.exp(prior.sample(5, np.random.default_rng(0))), "spectral",
                     diagnostics={"stages": 4, "acceptance": [0.21, 0.0, 0.13, 0.18], "moves": [4, 0, 4, 3],
                                  "loglik_calls": 9, "time_s": 1.31})
    assert post.summary() == "4 tempering stages, acceptance 0.13-0.21, 9 likelihood calls, 1.3 s"
    plain = Posterior(prior, post.samples, "zoa", diagnostics={"stages": 2, "acceptance": [0.3, 0.2],
                                                              "loglik_calls": 5, "time_s": 0.5})
    assert "acceptance 0.20-0.30" in plain.summary()
    one = Posterior(prior, post.samples, "zoa", diagnostics={"stages": 1, "acceptance": [0.14], "loglik_calls": 2,
                                                            "time_s": 0.1})
    assert one.summary() == "1 tempering stage, acceptance 0.14, 2 likelihood calls, 0.1 s"  # read "1 ... stages"
