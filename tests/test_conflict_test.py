"""The conflict test (millstab.update.discriminate.conflict_test): the cut that tells the posterior from a
hammer test off by 3.5σ in one kind of parameter, checked against the limits of the two structures
computed independently (one engine call each)."""

from __future__ import annotations

import numpy as np

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


def test_conflict_test_names_the_shifted_lobes_and_splits_their_limits():
    """Cuts labelled by a tool whose natural frequencies are 3.5σ (17 %) above the tap test's, at depths
    between the two structures' limits: the far-off alternative the cuts fit best is "fn +3.5σ", and the
    proposed cut lies between the posterior's median limit and the alternative's at its speed (one of them
    says stable, the other chatter), where the posterior gives it at most the test risk to chatter."""
    prior = make_prior(*(lambda c: (c.structure, c.cutting, c.prior))(parse_config(TWO_MODE_TOML + ONLY_FN)))
    truth = prior.mean_u + SHIFT * prior.spread
    rpm = np.linspace(6000, 12000, 7)
    b0 = limits(prior, prior.mean_u[None], rpm)[0][0]
    bt = limits(prior, truth[None], rpm)[0][0]
    post = _posterior(prior, truth, rpm, np.sqrt(b0 * bt))
    assert 0 < sum(x == "chatter" for x in post.cuts["label"]) < rpm.size  # the cuts contradict the tap test
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
