"""The conflict test (millstab.update.discriminate.conflict_test): the cut that tells the posterior from a
hammer test off by 3.5σ in one kind of parameter, checked against the limits of the two structures
computed independently (one engine call each)."""

from __future__ import annotations

import numpy as np
import pytest

from millstab.errors import InputError
from millstab.io.config import parse_config
from millstab.points import PointSet
from millstab.update import make_prior
from millstab.update.discriminate import SHIFT, conflict_test
from millstab.update.likelihood import limits
from millstab.update.posterior import Posterior
from configs import TWO_MODE_TOML

ONLY_FN = '[prior]\nfixed = ["k_x", "zeta_x", "k_y", "zeta_y", "label_error", "sigma_depth"]\n'


def _posterior(prior, labels_from_u, rpm, depth, n=400, seed=0):
    """A posterior at the tap test (prior draws within 1σ) holding cuts labelled by the structure u."""
    rng = np.random.default_rng(seed)
    z = np.clip(rng.standard_normal((n, prior.size)), -1, 1)
    u = prior.mean_u + z * prior.spread
    b = limits(prior, labels_from_u[None], rpm)[0][0]
    lab = np.where(depth > b, "chatter", "stable").tolist()
    return Posterior(prior, np.exp(u), "zoa", {}, {"rpm": list(rpm), "depth_mm": list(depth), "label": lab}, ())


def _fn_case():
    """(prior, the truth u: every fn +3.5σ, a posterior at the tap test holding 7 cuts the truth labels, at depths
    between the tap test's and the truth's limits)."""
    prior = make_prior(*(lambda c: (c.structure, c.cutting, c.prior))(parse_config(TWO_MODE_TOML + ONLY_FN)))
    truth = prior.mean_u + SHIFT * prior.spread
    rpm = np.linspace(6000, 12000, 7)
    b0 = limits(prior, prior.mean_u[None], rpm)[0][0]
    bt = limits(prior, truth[None], rpm)[0][0]
    return prior, truth, _posterior(prior, truth, rpm, np.sqrt(b0 * bt))


def test_conflict_test_names_the_shifted_lobes_and_splits_their_limits():
    """Cuts labelled by a tool whose natural frequencies are 3.5σ (17 %) above the tap test's, at depths
    between the two structures' limits: the far-off alternative the cuts fit best is "fn +3.5σ", and the
    proposed cut lies between the posterior's median limit and the alternative's at its speed (one of them
    says stable, the other chatter), where the posterior gives it at most the test risk to chatter."""
    prior, truth, post = _fn_case()
    assert 0 < sum(x == "chatter" for x in post.cuts["label"]) < 7  # the cuts contradict the tap test
    ct = conflict_test(post, (5000, 12000), 10.0, test_risk=0.5, seed=2)
    assert ct["rival"] == f"fn +{SHIFT:g}σ" and ct["rival_log_likelihood_ratio"] > 0
    b_post = np.median(limits(prior, post.u, [ct["rpm"]])[0][:, 0])
    b_rival = limits(prior, truth[None], [ct["rpm"]])[0][0, 0]
    assert min(b_post, b_rival) < ct["depth_mm"] < max(b_post, b_rival)
    assert ct["p_chatter"] <= 0.5 and abs(ct["p_chatter_rival"] - ct["p_chatter"]) > 0.5 and ct["divergence_nats"] > 0.1


def test_no_cuts_no_conflict_test():
    prior = make_prior(*(lambda c: (c.structure, c.cutting, c.prior))(parse_config(TWO_MODE_TOML + ONLY_FN)))
    post = Posterior(prior, np.exp(prior.sample(100, np.random.default_rng(0))), "zoa", {}, {}, ())
    assert conflict_test(post, (5000, 12000)) is None


CONFLICT = "the cuts contradict the hammer test: fn_x is 1.2× the tap test's (+3.5σ)"


def test_recommend_proposes_the_conflict_test_while_a_conflict_is_named():
    """Issue 24: while the posterior names a prior–data conflict, recommend's next test is the conflict test (the
    cut that tells the posterior from the far-off alternative the cuts fit best), not the most informative cut
    about θ; checked against the two structures' limits computed here (the cut lies between the posterior's
    median limit and the alternative's at its speed). Without a named conflict, with discriminate="never", or
    when the rival fits the cuts worse than the threshold asks, the next test is the most informative cut, more
    productive than the recommendation. Fails on the old code
    (its next test under a conflict was the most informative cut, with no rival)."""
    from millstab.update.decide import recommend

    prior, truth, quiet = _fn_case()
    named = Posterior(prior, quiet.samples, "zoa", {}, quiet.cuts, (CONFLICT,))
    kw = {"max_depth_mm": 10.0, "seed": 2}
    rec = recommend(named, 0.05, (5000, 12000), discriminate="conflict", **kw)
    nt = rec.next_test
    assert nt["rival"] == f"fn +{SHIFT:g}σ" and nt["why"].startswith("the conflict test")
    b_post = np.median(limits(prior, named.u, [nt["rpm"]])[0][:, 0])
    b_rival = limits(prior, truth[None], [nt["rpm"]])[0][0, 0]
    assert min(b_post, b_rival) < nt["depth_mm"] < max(b_post, b_rival) and nt["p_chatter"] <= 0.5
    assert nt["relative_productivity"] == pytest.approx(nt["rpm"] * nt["depth_mm"] / (rec.rpm * rec.depth_mm))
    # the most informative cut, above the recommendation: no conflict named; "never"; a rival the cuts fit worse
    # than the posterior by more than the threshold (here any: +inf)
    for post, how, lr in ((quiet, "conflict", 0.0), (named, "never", 0.0), (named, "conflict", np.inf)):
        other = recommend(post, 0.05, (5000, 12000), discriminate=how, discriminate_rival_lr=lr, **kw)
        assert "rival" not in other.next_test and other.next_test["why"].startswith("largest expected information")
        assert other.next_test["rpm"] * other.next_test["depth_mm"] > other.rpm * other.depth_mm
    with pytest.raises(InputError, match="--discriminate"):
        recommend(named, 0.05, (5000, 12000), discriminate="sometimes")


def test_the_conflict_test_respects_the_data_guard():
    """A chatter cut the posterior does not explain guards its neighbourhood: the conflict test is never proposed
    at or above its cap there (the same rule as the recommendation's next test). The guard here covers the
    conflict test's own cut, so the test must move."""
    prior, truth, post = _fn_case()
    free = conflict_test(post, (5000, 12000), 10.0, seed=2)
    g = [{"rpm": free["rpm"], "half_width_rpm": 0.05 * free["rpm"], "cap_mm": 0.5 * free["depth_mm"]}]
    held = conflict_test(post, (5000, 12000), 10.0, seed=2, guard=g)
    assert held is not None and (abs(held["rpm"] - free["rpm"]) > 0.05 * free["rpm"]
                                 or held["depth_mm"] < 0.5 * free["depth_mm"])


def test_recommend_command_discriminate_option(tmp_path, capsys):
    """`millstab recommend --discriminate`: the default is the library's; a bad value is one line naming the option
    (exit 2), checked before the posterior is read, and nothing is written."""
    import inspect

    from millstab.cli import main
    from millstab.cli.recommend import recommend_cmd
    from millstab.update.decide import DISCRIMINATE

    assert inspect.signature(recommend_cmd).parameters["discriminate"].default.default == DISCRIMINATE
    out = tmp_path / "rec.json"
    assert main(["recommend", str(tmp_path / "none.json"), "--rpm", "5000:9000", "--discriminate", "sometimes",
                 "--out", str(out)]) == 2
    assert "--discriminate" in capsys.readouterr().err and not out.exists()


def test_the_blind_spot_keeps_priority_over_the_conflict_test():
    """While a conflict is named, a recommendation that no test bounds (the last two cuts chattered, both more
    productive, no stable cut near it as deep: decide.blind_spot) is still tested first; without the blind spot the
    conflict test replaces the next test."""
    from millstab.update.decide import blind_spot, next_test_discriminating

    prior, truth, _ = _fn_case()
    rpm = np.array([6000.0, 8000, 10000, 11000, 12000])
    post = _posterior(prior, truth, rpm, np.array([0.05, 0.05, 0.05, 20.0, 20.0]))  # the last two chatter
    assert post.cuts["label"][-2:] == ["chatter", "chatter"]
    sentinel = {"rpm": 5100.0, "depth_mm": 0.01, "why": "the recommendation itself"}
    assert blind_spot(post, 5100.0, 0.01) is not None
    assert next_test_discriminating(post, sentinel, (5100.0, 0.01), (5000, 12000), 30.0, seed=2) is sentinel
    assert blind_spot(post, 5100.0, 100.0) is None  # the chattering cuts are less productive than this one
    ct = next_test_discriminating(post, sentinel, (5100.0, 100.0), (5000, 12000), 30.0, seed=2)
    assert ct is not sentinel and "rival" in ct and ct["why"].startswith("the conflict test")
