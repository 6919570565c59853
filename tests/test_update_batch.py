"""The test-day (batch) random effect of updating (issue 24 item 3, :mod:`millstab.update.batch`): a day's
shift δ_g of ln fn, sampled with the parameters; decisions for a new day marginalise it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from configs import TWO_MODE_TOML

from millstab.errors import InputError
from millstab.io.config import config_to_toml, parse_config
from millstab.points import PointSet
from millstab.update import Posterior, make_prior, update
from millstab.update.batch import NEW_DAY_SEED, BatchPosterior, fn_columns
from millstab.update.likelihood import Evidence, Likelihood, limits
from millstab.update.predict import predict_cuts

#: fn_x and fn_y free (the effect shifts them), everything else held: a cheap, identifiable case
FN_ONLY = ('[prior]\nfixed = ["k_x", "zeta_x", "k_y", "zeta_y", "sigma_depth", "label_error"]\n')


def _prior(extra: str = ""):
    cfg = parse_config(TWO_MODE_TOML + extra)
    return cfg, make_prior(cfg.structure, cfg.cutting, cfg.prior)


def _cuts(n_days: int = 3, per_day: int = 6, seed: int = 0):
    rng = np.random.default_rng(seed)
    rpm = np.round(rng.uniform(5000, 12000, n_days * per_day), -1)
    depth = rng.uniform(0.5, 4.0, rpm.size)
    label = np.where(rng.random(rpm.size) < 0.5, "stable", "chatter")
    days = np.repeat([f"2026-11-{d + 2:02d}" for d in range(n_days)], per_day)
    return PointSet(rpm, depth, label, batch=days)


def test_each_days_cuts_are_the_plain_likelihood_at_the_shifted_structure():
    """The likelihood with shifts δ_g is the sum over days of the no-effect likelihood of that day's cuts
    at θ·exp(δ_g) on every free fn (an independent recomputation, day by day); δ = 0 (τ → 0) is the
    no-effect likelihood itself; one engine call per day."""
    _, plain = _prior(FN_ONLY)
    _, prior = _prior(FN_ONLY + 'batch_effect = "3 %"\n')
    cuts = _cuts()
    ev = Evidence.from_points(cuts)
    lik, lik0 = Likelihood(prior, ev), Likelihood(plain, ev)
    rng = np.random.default_rng(1)
    u = prior.sample(5, rng)
    delta = rng.normal(0, 0.03, (5, 3))
    days = list(dict.fromkeys(cuts.batch))
    got = lik(np.hstack([u, delta]))
    assert lik.n_calls == 3 and lik.n_sets == 15
    want = np.zeros(5)
    fn = fn_columns(prior)
    assert list(np.array(prior.names)[fn]) == ["fn_x", "fn_y"]
    for g, day in enumerate(days):
        m = cuts.batch == day
        ug = u.copy()
        ug[:, fn] += delta[:, g][:, None]
        want += Likelihood(plain, Evidence.from_points(cuts.subset(m)))(ug)
    np.testing.assert_allclose(got, want, rtol=1e-10)
    np.testing.assert_allclose(lik(np.hstack([u, np.zeros((5, 3))])), lik0(u), rtol=1e-12)


def test_tau_to_zero_is_no_effect_and_decisions_widen_for_a_new_day():
    """τ = 10⁻⁶: the posterior is the no-effect posterior (means within Monte Carlo error), the new-day
    samples are the samples; τ = 3 %: the decisions' samples are θ·exp(δ), δ ~ N(0, τ²) on the fn."""
    cuts = _cuts(per_day=4)
    cfg0, _ = _prior(FN_ONLY)
    cfg1, _ = _prior(FN_ONLY + "batch_effect = 1e-6\n")
    a = update(cfg0, cuts, samples=600, seed=3)
    b = update(cfg1, cuts, samples=600, seed=3)
    assert b.batch is not None and b.batch.days == tuple(dict.fromkeys(cuts.batch))
    assert np.abs(b.batch.shifts).max() < 1e-5
    se = np.hypot(a.u.std(axis=0), b.u.std(axis=0)) / math.sqrt(600 / 5)  # ESS of SMC particles ≈ N/5 at worst
    assert np.all(np.abs(a.u.mean(axis=0) - b.u.mean(axis=0)) < 4 * se + 1e-12)
    np.testing.assert_allclose(b.decision_u, b.u, atol=1e-4)
    # τ = 3 %: the decisions' shift is one N(0, τ²) draw per sample, the same on fn_x and fn_y
    _, p3 = _prior(FN_ONLY + 'batch_effect = "3 %"\n')
    post = Posterior(p3, a.samples, "zoa")
    d = post.decision_u - post.u
    np.testing.assert_allclose(d[:, 0], d[:, 1])
    np.testing.assert_allclose(d[:, 0], 0.03 * np.random.default_rng(NEW_DAY_SEED).standard_normal(600))
    # the P(stable) of a cut for a new day is that of the no-effect posterior with its fn spread by τ
    ps_new, _ = predict_cuts(post, [9000.0], [2.0])
    blim = limits(p3, post.decision_u, [9000.0])[0][:, 0]
    assert ps_new[0] == pytest.approx(np.mean(blim > 2.0))


@pytest.mark.slow
def test_a_campaign_with_a_known_daily_drift_recovers_the_shifts():
    """Three days whose structure is the hammer test's with fn × exp(−4 %, 0, +4 %); eight cuts a day
    labelled by the zero-order limit of that day's structure (probit noise 0.05 mm). With τ = 3 % each
    day's 90 % interval covers its true shift and the day-to-day differences are recovered within 1.5 %;
    without the effect the same cuts leave more of them unexplained (a lower log evidence)."""
    cfg, prior = _prior(FN_ONLY + 'batch_effect = "3 %"\n')
    true = np.array([-0.04, 0.0, 0.04])
    rng = np.random.default_rng(7)
    rpm, depth, label, day = [], [], [], []
    for g, dg in enumerate(true):
        r = np.round(rng.uniform(5000, 12000, 8), -1)
        u = prior.mean_u.copy()
        u[fn_columns(prior)] += dg
        blim = limits(prior, u[None], r)[0][0]
        b = blim * rng.uniform(0.6, 1.4, r.size)
        lab = np.where(b + 0.05 * rng.standard_normal(r.size) > blim, "chatter", "stable")
        rpm += list(r); depth += list(b); label += list(lab); day += [f"day{g}"] * r.size
    cuts = PointSet(np.array(rpm), np.array(depth), np.array(label), batch=np.array(day))
    post = update(cfg, cuts, samples=1000, seed=0)
    s = post.batch.shifts
    assert post.batch.days == ("day0", "day1", "day2")
    lo, hi = np.quantile(s, [0.05, 0.95], axis=0)
    assert np.all((lo <= true) & (true <= hi)), (lo, hi)
    diff = np.median(s[:, 2] - s[:, 0])
    assert abs(diff - 0.08) < 0.015, diff
    doc = post.to_json()
    again = Posterior.from_json(doc)
    np.testing.assert_array_equal(again.batch.shifts, s)
    assert set(doc["batch"]["parameters"]) == {"day0", "day1", "day2"} and doc["prior"]["batch_effect"] == 0.03
    plain = update(parse_config(TWO_MODE_TOML + FN_ONLY), cuts, samples=1000, seed=0)
    assert post.diagnostics["log_evidence"] > plain.diagnostics["log_evidence"] + 1.0


def test_sequential_reuse_keeps_the_known_days_and_draws_the_new_one():
    cfg, _ = _prior(FN_ONLY + 'batch_effect = "3 %"\n')
    cuts = _cuts(n_days=2, per_day=4)
    first = update(cfg, cuts.subset(np.arange(len(cuts)) < 4), samples=200, seed=0)
    assert first.batch.days == ("2026-11-02",)
    both = update(cfg, cuts, samples=200, seed=1, start=Posterior.from_json(first.to_json()))
    assert both.batch.days == ("2026-11-02", "2026-11-03") and both.batch.shifts.shape == (200, 2)
    other = PointSet(cuts.rpm, cuts.depth_mm, cuts.label, batch=np.where(cuts.batch == "2026-11-02", "x", cuts.batch))
    with pytest.raises(InputError, match="first cuts"):
        update(cfg, other, samples=200, seed=1, start=first)


def test_the_option_is_read_checked_and_written_back():
    cfg, prior = _prior('[prior]\nbatch_effect = "3 %"\n')
    assert prior.batch_effect == pytest.approx(0.03) and cfg.prior.batch_effect == pytest.approx(0.03)
    assert 'batch_effect = "3 %"' in config_to_toml(cfg)
    assert make_prior(cfg.structure, cfg.cutting).batch_effect == 0.0  # off by default
    with pytest.raises(InputError) as info:
        _prior('[prior]\nbatch_effect = "40 %"\n')
    assert info.value.field == "prior.batch_effect"
    _, held = _prior('[prior]\nbatch_effect = "3 %"\nfixed = ["fn_x", "fn_y"]\n')
    with pytest.raises(InputError, match="leave at least one fn free"):
        Likelihood(held, Evidence.from_points(_cuts()))


def test_predictions_use_a_known_days_shift_and_a_new_days_otherwise():
    """A posterior (built directly: no sampling) with two days whose shifts are −5 % and +5 %: a cut of a
    known day is predicted at θ·exp(δ_g) of that day's rows; an unknown day, no day, or no ``batch`` at
    the new day's θ·exp(δ), δ ~ N(0, τ²) (recomputed here from the limits of the shifted samples)."""
    _, prior = _prior(FN_ONLY + 'batch_effect = "3 %"\n')
    rng = np.random.default_rng(2)
    u = prior.sample(400, rng)
    shifts = np.column_stack([np.full(400, -0.05), np.full(400, 0.05)]) + 0.005 * rng.standard_normal((400, 2))
    post = Posterior(prior, np.exp(u), "zoa", batch=BatchPosterior(0.03, ("mon", "tue"), shifts))
    rpm = np.array([7000.0, 9000.0, 7000.0, 9000.0, 9000.0])
    depth = np.median(limits(prior, u, rpm)[0], axis=0)  # on the boundary: where a day's shift matters
    day = np.array(["mon", "tue", "wed", "", "tue"], dtype=object)
    ps, _ = predict_cuts(post, rpm, depth, batch=day)
    fn = fn_columns(prior)

    def p(uu, r, b):
        return float(np.mean(limits(prior, uu, [r])[0][:, 0] > b))

    for g, i in ((0, 0), (1, 1), (1, 4)):
        us = u.copy()
        us[:, fn] += shifts[:, g][:, None]
        assert ps[i] == pytest.approx(p(us, rpm[i], depth[i]))
    for i in (2, 3):
        assert ps[i] == pytest.approx(p(post.decision_u, rpm[i], depth[i]))
    np.testing.assert_array_equal(predict_cuts(post, rpm, depth)[0][[2, 3]], ps[[2, 3]])
    assert ps[0] != ps[2]  # the known Monday is not a new day


def test_the_cli_flag_writes_the_days_and_refuses_a_drift_that_is_no_drift(capsys, tmp_path):
    from millstab.cli import main

    cuts = tmp_path / "cuts.csv"
    cuts.write_text("rpm,depth_mm,label,date\n6000,1.0,stable,mon\n7000,3.0,chatter,mon\n9000,2.0,stable,tue\n"
                    "10000,4.0,chatter,tue\n")
    out = tmp_path / "post.json"
    code = main(["update", "example:ex1", str(cuts), "--samples", "100", "--batch-effect", "3%", "--out", str(out)])
    text, err = capsys.readouterr()
    assert code == 0, err
    doc = __import__("json").loads(out.read_text())
    assert doc["batch"]["days"] == ["mon", "tue"] and doc["prior"]["batch_effect"] == pytest.approx(0.03)
    assert "fn × mon" in text and doc["cuts"]["batch"] == ["mon", "mon", "tue", "tue"]
    code = main(["update", "example:ex1", str(cuts), "--batch-effect", "40%", "--out", str(tmp_path / "p2.json")])
    _, err = capsys.readouterr()
    assert code == 2 and err.count("\n") == 1 and "--batch-effect = '40%'" in err and "25%" in err
    assert not (tmp_path / "p2.json").exists()
