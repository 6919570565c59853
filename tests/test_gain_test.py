"""The gain test (``recommend(..., discriminate="gain")``, :func:`millstab.update.decide.next_test_gain`): while a
prior–data conflict is named, the next test is the cut whose label is expected to raise the recommendation's
productivity most. The kernel is checked against a brute-force re-computation (a weighted cumulative sum over
every sample), the choice against two structures' limits computed independently."""

from __future__ import annotations

import numpy as np
import pytest
from configs import TWO_MODE_TOML
from scipy.stats import norm

from millstab.io.config import parse_config
from millstab.update import make_prior
from millstab.update._gain import expected_best
from millstab.update.likelihood import limits
from millstab.update.posterior import Posterior

ONLY_FN = '[prior]\nfixed = ["k_x", "zeta_x", "k_y", "zeta_y", "label_error", "sigma_depth"]\n'
CONFLICT = "the cuts contradict the hammer test: fn_x is 0.83× the tap test's (-3.5σ)"


def _brute_best(b, speeds, cap, w, risk):
    """max over speeds of speed × the largest depth whose weighted P(limit ≤ depth) ≤ risk (capped)."""
    out = 0.0
    for s in range(speeds.size):
        o = np.argsort(b[:, s], kind="stable")
        k = int(np.sum(np.cumsum(w[o]) <= risk * w.sum()))
        out = max(out, speeds[s] * (cap[s] if k >= b.shape[0] else min(b[o[k], s], cap[s])))
    return out


def test_expected_best_matches_a_brute_force_look_ahead():
    rng = np.random.default_rng(0)
    m, s, d = 150, 12, 7
    b = rng.lognormal(0.0, 0.5, (m, s))
    b[rng.random((m, s)) < 0.05] = np.inf  # no boundary: never chatters
    speeds, cap = np.linspace(5000, 12000, s), np.full(s, 3.0)
    cap[4] = 0.4  # a data guard's cap at one speed
    depths, sig = np.linspace(0.1, 3.0, d), np.full(d, 0.05)
    eps, fac = rng.uniform(0.01, 0.05, m), rng.uniform(0.5, 2.0, m)
    e, now = expected_best(b, speeds, cap, np.arange(s), depths, sig, 0.05, eps, fac)
    assert now == pytest.approx(_brute_best(b, speeds, cap, np.ones(m), 0.05), rel=1e-12)
    want = np.zeros((s, d))
    for i in range(s):
        for j in range(d):
            p = eps + (1 - 2 * eps) * norm.cdf((depths[j] - b[:, i]) / (sig[j] * fac))
            want[i, j] = p.mean() * _brute_best(b, speeds, cap, p, 0.05) + (1 - p).mean() * _brute_best(
                b, speeds, cap, 1 - p, 0.05)
    np.testing.assert_allclose(e, want, rtol=1e-10)
    assert (e - now).max() > 0  # some label would lift the recommendation


def _two_structures():
    """(prior, u of the tap test, u of a tool whose natural frequencies are 3.5σ (17 %) lower, a posterior of 400
    samples: 85 % near the tap test, 15 % near the softer tool, holding three shallow stable cuts)."""
    cfg = parse_config(TWO_MODE_TOML + ONLY_FN)
    prior = make_prior(cfg.structure, cfg.cutting, cfg.prior)
    low = prior.mean_u - 3.5 * prior.spread
    rng = np.random.default_rng(1)
    minority = rng.random(400) < 0.15
    u = np.where(minority[:, None], low, prior.mean_u) + 0.2 * prior.spread * rng.standard_normal((400, prior.size))
    cuts = {"rpm": [5000.0, 8500.0, 12000.0], "depth_mm": [0.05, 0.05, 0.05], "label": ["stable"] * 3}
    return prior, prior.mean_u, low, Posterior(prior, np.exp(u), "zoa", {}, cuts, (CONFLICT,))


@pytest.mark.slow
def test_recommend_proposes_the_gain_test_while_a_conflict_is_named():
    """Issue 24: a posterior split between the tap test's lobes and a softer tool's holds the recommendation to the
    speeds where both are safe; the gain test is a cut whose label tells the two apart where it matters: its depth
    lies between the two structures' limits at its speed (computed here, one engine call each), and its expected
    gain is what the brute-force look-ahead gives. Without a named conflict, or with discriminate="never", the next
    test is the most informative cut. Fails on the old code (no "gain" choice: InputError)."""
    from millstab.update.decide import recommend

    prior, tap, low, post = _two_structures()
    kw = {"max_depth_mm": 10.0, "seed": 2}
    rec = recommend(post, 0.05, (5000, 12000), discriminate="gain", **kw)
    nt = rec.next_test
    assert nt["why"].startswith("the gain test") and nt["expected_gain"] > 0.05 and nt["p_chatter"] <= 0.5
    b_tap = limits(prior, tap[None], [nt["rpm"]])[0][0, 0]
    b_low = limits(prior, low[None], [nt["rpm"]])[0][0, 0]
    assert min(b_tap, b_low) < nt["depth_mm"] < max(b_tap, b_low)
    quiet = Posterior(prior, post.samples, "zoa", {}, post.cuts, ())
    for p, how in ((quiet, "gain"), (post, "never")):
        other = recommend(p, 0.05, (5000, 12000), discriminate=how, **kw)
        assert "expected_gain" not in other.next_test
        assert other.next_test["why"].startswith("largest expected information")
