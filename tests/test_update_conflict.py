"""The prior–data conflict check (millstab.update.conflict): its evidence ratio against closed forms and
a brute-force quadrature, the threshold that names a wrong hammer test whose cuts give only moderate
evidence, and silence when the hammer test is right."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import logsumexp
from scipy.stats import norm, t as student_t

from millstab.io.config import parse_config
from millstab.points import PointSet
from millstab.update import conflict, make_prior, update
from millstab.update.conflict import BAYES_FACTOR, check
from millstab.update.likelihood import Evidence, Likelihood, limits
from millstab.update.prior import TRUNCATE
from configs import TWO_MODE_TOML

#: the closed forms below are the independent Student-t's (one parameter's t tail against the Gaussian's)
STUDENT = '[prior]\ntails = "student"\n'
ONLY_KX = '[prior]\nfixed = ["fn_x", "zeta_x", "fn_y", "k_y", "zeta_y", "label_error", "sigma_depth"]\n'


def _prior(extra: str = ""):
    cfg = parse_config(TWO_MODE_TOML + extra)
    return cfg, make_prior(cfg.structure, cfg.cutting, cfg.prior)


def _one_sided_posterior(prior, j: int, c: float, n: int, rng) -> np.ndarray:
    """Exact posterior draws of the robust prior under a step likelihood z_j ≥ c (stable cuts that bound
    one parameter from below, noise-free): prior draws, parameter j redrawn from the t's tail beyond c."""
    u = prior.sample(n, rng)
    q = rng.uniform(student_t.cdf(c, prior.nu), student_t.cdf(TRUNCATE, prior.nu), n)
    u[:, j] = prior.mean_u[j] + prior.spread[j] * student_t.ppf(q, prior.nu)
    return u


def test_moderate_one_sided_evidence_is_named_where_the_old_rule_was_silent():
    """Stable cuts that put k_x beyond +2.6σ of its tap test and say nothing else: the evidence ratio is the
    closed form sf_t(2.6)/sf_N(2.6) = 6.5 (the robust prior explains the cuts 6.5× better). The rule before
    (a ratio ≥ 10) stayed silent here — the measured miss of the wrong-hammer-test campaigns (docs/updating.md,
    "Prior–data conflict"); the rule now (≥ 5, set from the calibration campaigns' false-alarm rate) names it.
    Fails on the old code (BAYES_FACTOR = 10)."""
    _, prior = _prior(STUDENT)
    c = 2.6
    exact = math.log(student_t.sf(c, prior.nu) / norm.sf(c))
    assert 1.6 < exact < math.log(10)  # the case: between the new and the old threshold
    u = _one_sided_posterior(prior, 1, c, 4000, np.random.default_rng(3))
    msg, info = check(prior, u)
    assert info["log_bayes_factor"] == pytest.approx(exact, abs=0.12)  # the estimator against the closed form
    assert info["conflict"] and msg.startswith("the cuts contradict the hammer test: k_x is ")
    assert "(+" in msg and "the data favour the heavy-tailed prior over the hammer test's spreads" in msg
    # the same cuts bounding k_x only beyond +1.5σ (an ordinary tap test's error) stay quiet
    u = _one_sided_posterior(prior, 1, 1.5, 4000, np.random.default_rng(4))
    msg, info = check(prior, u)
    assert msg is None and info["log_bayes_factor"] == pytest.approx(
        math.log(student_t.sf(1.5, prior.nu) / norm.sf(1.5)), abs=0.1)


def test_evidence_ratio_of_an_update_equals_a_brute_force_quadrature():
    """One free parameter (k_x), cuts of a tool 2.5× stiffer, stable at 0.9× its limit (capped at 3× the tap
    test's): the log Bayes factor the check reads off 1 000 posterior samples equals ln Z_robust/Z_tight by
    quadrature of likelihood × prior on 4 801 points over the prior's support."""
    cfg, prior = _prior(ONLY_KX)
    rpm = np.linspace(5000, 12000, 8)
    b0 = limits(prior, prior.mean_u[None], rpm)[0][0]
    bt = limits(prior, (prior.mean_u + 3.0 * prior.spread)[None], rpm)[0][0]
    cuts = PointSet(rpm, np.minimum(0.9 * bt, 3 * b0), ["stable"] * rpm.size)
    z = np.linspace(-12, 12, 4801)
    u = prior.mean_u + z[:, None] * prior.spread
    with pytest.warns(UserWarning, match="every cut is stable"):
        ll = Likelihood(prior, Evidence.from_points(cuts))(u)
        post = update(cfg, cuts, samples=1000, seed=0)
    brute = float(logsumexp(ll + prior.logpdf(u)) - logsumexp(ll + prior.logpdf(u, "normal")))
    assert 1.0 < brute < 3.0  # a moderate conflict
    assert post.diagnostics["conflict"]["log_bayes_factor"] == pytest.approx(brute, abs=0.15)


def test_right_hammer_test_stays_quiet():
    """Cuts labelled by the tap test's own structure on both sides of its limit (0.7× stable, 1.3× chatter at
    six speeds): no conflict, the evidence ratio near 1."""
    cfg, prior = _prior()
    rpm = np.linspace(5500, 11500, 6)
    b = limits(prior, prior.mean_u[None], rpm)[0][0]
    cuts = PointSet(np.r_[rpm, rpm], np.r_[0.7 * b, 1.3 * b], ["stable"] * 6 + ["chatter"] * 6)
    post = update(cfg, cuts, samples=1000, seed=0)
    info = post.diagnostics["conflict"]
    assert not info["conflict"] and not any(w.startswith("the cuts contradict") for w in post.warnings)
    assert abs(info["log_bayes_factor"]) < 0.5 < math.log(BAYES_FACTOR)


def test_a_named_conflict_is_kept_while_the_ratio_stays_above_two():
    """Hysteresis, against closed forms: stable cuts bounding k_x beyond +2.2σ hold a ratio
    sf_t(2.2)/sf_N(2.2) = 3.3 — below the naming threshold 5, above the keeping one 2. A first update is quiet; one
    that continues an update that named the conflict keeps naming it (and says so); bounded only beyond +1σ
    (ratio 1.2) the conflict is dropped. Fails on the old code (no hysteresis: check had no ``named_before``)."""
    _, prior = _prior(STUDENT)
    c = 2.2
    exact = math.log(student_t.sf(c, prior.nu) / norm.sf(c))
    assert math.log(conflict.BAYES_FACTOR_KEEP) < exact < math.log(BAYES_FACTOR)
    u = _one_sided_posterior(prior, 1, c, 4000, np.random.default_rng(5))
    msg, info = check(prior, u)
    assert msg is None and not info["conflict"] and info["log_bayes_factor"] == pytest.approx(exact, abs=0.12)
    msg, info = check(prior, u, named_before=True)
    assert info["conflict"] and info["kept"] and msg.startswith("the cuts contradict the hammer test: k_x is ")
    assert f"kept until below {conflict.BAYES_FACTOR_KEEP:g}:1" in msg
    u = _one_sided_posterior(prior, 1, 1.0, 4000, np.random.default_rng(6))
    msg, info = check(prior, u, named_before=True)
    assert msg is None and not info["conflict"] and info["log_bayes_factor"] < math.log(conflict.BAYES_FACTOR_KEEP)
    # named afresh (ratio ≥ 5) is not "kept"
    msg, info = check(prior, _one_sided_posterior(prior, 1, 3.0, 4000, np.random.default_rng(7)), named_before=True)
    assert info["conflict"] and not info["kept"] and "kept until" not in msg


def test_a_sequential_update_keeps_the_conflict_its_start_named():
    """update(..., start=post) reads whether ``post`` named the conflict (its diagnostics, as post.json keeps
    them): one free parameter, stable cuts at 1.5× the tap test's limit (ln BF ≈ 1.0, a ratio of ≈ 2.8: quiet
    alone). Continued from a posterior that named the conflict, the next update names it, marked kept; continued
    from one that did not, it stays quiet. Fails on the old code (the start's verdict was not read)."""
    cfg, prior = _prior(ONLY_KX + 'tails = "multivariate_t"\n')  # (the default's rival makes ln BF ≈ 1.9 here)
    rpm = np.linspace(5000, 12000, 8)
    b0 = limits(prior, prior.mean_u[None], rpm)[0][0]
    cuts = PointSet(rpm[:7], 1.5 * b0[:7], ["stable"] * 7)
    more = PointSet(rpm, 1.5 * b0, ["stable"] * 8)
    with pytest.warns(UserWarning, match="every cut is stable"):
        first = update(cfg, cuts, samples=1000, seed=0)
        quiet = update(cfg, more, samples=1000, seed=1, start=first)
    lbf = first.diagnostics["conflict"]["log_bayes_factor"]
    assert (math.log(conflict.BAYES_FACTOR_KEEP) < lbf < math.log(BAYES_FACTOR)
            and not first.diagnostics["conflict"]["conflict"])
    assert not quiet.diagnostics["conflict"]["conflict"]
    assert not any(w.startswith("the cuts contradict") for w in quiet.warnings)
    first.diagnostics["conflict"]["conflict"] = True  # as if an earlier update had named it
    with pytest.warns(UserWarning, match="the cuts contradict the hammer test"):
        kept = update(cfg, more, samples=1000, seed=1, start=first)
    info = kept.diagnostics["conflict"]
    assert info["conflict"] and info["kept"] and math.log(conflict.BAYES_FACTOR_KEEP) <= info["log_bayes_factor"]
    assert [w for w in kept.warnings if w.startswith("the cuts contradict")][0].count("kept until below 2:1") == 1


def test_with_a_gaussian_prior_a_named_conflict_is_kept_beyond_two_sigma():
    """tails = "normal" (no robust alternative): named when a posterior median lies beyond 3σ, kept while it
    stays beyond 2σ (samples centred 2.5σ off in k_x: quiet alone, kept after a named update; 1.5σ: dropped).
    Fails on the old code (no hysteresis)."""
    _, prior = _prior('[prior]\ntails = "normal"\n')
    rng = np.random.default_rng(8)
    for off, alone, after in ((2.5, False, True), (1.5, False, False), (3.5, True, True)):
        u = prior.mean_u + prior.spread * (0.2 * rng.standard_normal((2000, prior.size)))
        u[:, 1] += off * prior.spread[1]
        assert check(prior, u)[1]["conflict"] is alone
        msg, info = check(prior, u, named_before=True)
        assert info["conflict"] is after and info["kept"] is (after and not alone)
        assert (msg is not None) is after and (not info["kept"] or "named earlier, kept until within 2σ" in msg)
