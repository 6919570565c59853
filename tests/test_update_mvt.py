"""The multivariate-t prior (``tails = "multivariate_t"``): one t scale shared by the modal parameters.

Checked against scipy's multivariate t (density), the F distribution of |z|²/M (draws), the importance
identity the conflict check rests on, and a brute-force grid posterior over two modal parameters (the sampler).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from configs import TWO_MODE_TOML
from scipy.stats import f as f_dist
from scipy.stats import kstest, multivariate_t
from scipy.stats import t as student_t

from millstab.io.config import parse_config
from millstab.points import PointSet
from millstab.update import make_prior, update
from millstab.update.conflict import check
from millstab.update.likelihood import Evidence, Likelihood, limits
from millstab.update.prior import Prior

MVT = '[prior]\ntails = "multivariate_t"\n'


def _prior(extra: str = MVT):
    cfg = parse_config(TWO_MODE_TOML + extra)
    return cfg, make_prior(cfg.structure, cfg.cutting, cfg.prior)


def test_density_is_scipys_multivariate_t_and_a_free_kt_keeps_its_own_t(tmp_path):
    cfg, prior = _prior()
    assert prior.tails == "multivariate_t" and prior.n_modal == prior.size == 6
    rng = np.random.default_rng(0)
    u = prior.mean_u + prior.spread * 3.0 * rng.standard_normal((7, prior.size))
    u[:, [2, 5]] = np.minimum(u[:, [2, 5]], -0.1)  # ζ < 1: inside the support
    want = multivariate_t(prior.mean_u, np.diag(prior.spread ** 2), df=prior.nu).logpdf(u)
    np.testing.assert_allclose(prior.logpdf(u), want, rtol=1e-12)
    # Kt free: the modal parameters' multivariate t times Kt's own independent t_ν
    _, pk = _prior(MVT + 'kt = "10 %"\n')
    assert pk.names[-1] == "kt" and pk.n_modal == 5 + 1 == pk.size - 1
    uk = np.c_[u, pk.mean_u[-1] + 0.1 * rng.standard_normal(7) * 4]
    zk = (uk[:, -1] - pk.mean_u[-1]) / pk.spread[-1]
    want = (multivariate_t(pk.mean_u[:6], np.diag(pk.spread[:6] ** 2), df=4.0).logpdf(uk[:, :6])
            + student_t.logpdf(zk, 4.0) - math.log(pk.spread[-1]))
    np.testing.assert_allclose(pk.logpdf(uk), want, rtol=1e-12)
    # the reason for it: the whole tap test 3.6σ off in all six vs one stiffness 8.6σ off and the rest right
    whole, one = np.full((1, 6), -3.6), np.zeros((1, 6))
    one[0, 1] = -8.6
    gap = {t: float(np.diff(_prior(f'[prior]\ntails = "{t}"\n')[1].logpdf(prior.mean_u + prior.spread
                                                                            * np.r_[whole, one]))[0])
           for t in ("student", "multivariate_t")}
    assert gap["student"] > 10.0 and abs(gap["multivariate_t"]) < 1.0, gap
    # the config (parsed, written, read back) and the posterior file carry it; support rules hold (ζ ≥ 1: 0)
    from millstab.io.config import PRIOR_TAILS, load_config, write_config
    from millstab.update.prior import TAILS

    assert PRIOR_TAILS == TAILS
    back = load_config(write_config(tmp_path / "c.toml", parse_config(TWO_MODE_TOML + MVT))).prior
    assert make_prior(cfg.structure, cfg.cutting, back).tails == "multivariate_t"
    assert Prior.from_dict(prior.to_dict()).tails == "multivariate_t"
    bad = prior.mean_u.copy()
    bad[2] = 0.0
    assert prior.logpdf(bad)[0] == -np.inf


def test_draws_share_one_scale_and_match_the_F_distribution():
    _, prior = _prior(MVT + 'kt = "10 %"\n')
    m = prior.n_modal
    u = prior.sample(20000, np.random.default_rng(2))
    z = (u - prior.mean_u) / prior.spread
    # |z|²/M of a multivariate t with ν degrees of freedom is F(M, ν)
    assert kstest((z[:, :m] ** 2).sum(1) / m, f_dist(m, prior.nu).cdf).pvalue > 0.01
    for j in (0, 1, 2, m):  # each parameter alone is t_ν (Kt too)
        assert kstest(z[:, j], student_t(prior.nu).cdf).pvalue > 0.01
    # one shared scale: the modal |z|'s move together; Kt's does not move with them
    a = np.abs(z)
    assert np.corrcoef(a[:, 0], a[:, 1])[0, 1] > 0.2
    assert abs(np.corrcoef(a[:, 0], a[:, m])[0, 1]) < 0.03
    ui = _prior('[prior]\ntails = "student"\n')[1].sample(20000, np.random.default_rng(2))
    assert abs(np.corrcoef(np.abs(ui[:, 0] - prior.mean_u[0]), np.abs(ui[:, 1] - prior.mean_u[1]))[0, 1]) < 0.03
    # draws and density agree, normalisation included: E_prior[N(z)/p(z)] = 1, i.e. the conflict check's
    # evidence ratio of the prior's own draws is 1 (ln 0 within Monte Carlo error)
    msg, info = check(prior, u)
    assert msg is None and abs(info["log_bayes_factor"]) < 0.05


@pytest.mark.slow
def test_two_parameter_posterior_matches_a_brute_force_grid():
    """k_x and k_y free with the multivariate-t prior (noise held), 12 cuts from a tool softer in both
    directions (each k 3× below the tap test, −3.7σ): the sampler's marginals against a 2-D grid of
    the same prior × likelihood. The two priors' grids differ by more than the tolerance, so a sampler
    that used independent tails would fail."""
    fixed = ('[prior]\nfixed = ["fn_x", "zeta_x", "fn_y", "zeta_y", "label_error", "sigma_depth"]\n'
             'sigma_depth = "15 %"\n')
    cfg, prior = _prior(fixed + 'tails = "multivariate_t"\n')
    assert prior.names == ("k_x", "k_y") and prior.dim == 2
    rng = np.random.default_rng(5)
    rpm = np.linspace(5200, 11800, 12)
    truth = prior.mean_u - math.log(3.0)
    b = limits(prior, truth[None], rpm)[0][0]
    depth = b * rng.uniform(0.6, 1.5, 2 * rpm.size)[rpm.size:]  # 7 chatter, 5 stable
    cuts = PointSet(rpm, depth, np.where(depth > b, "chatter", "stable"))
    post = update(cfg, cuts, samples=1500, seed=3)
    g = [prior.mean_u[j] + np.linspace(-9, 4, 131) * prior.spread[j] for j in range(2)]
    uu = np.stack(np.meshgrid(*g, indexing="ij"), -1).reshape(-1, 2)
    ll = Likelihood(prior, Evidence.from_points(cuts))(uu)
    means = {}
    for tails in ("multivariate_t", "student"):
        p = prior if tails == "multivariate_t" else _prior(fixed + 'tails = "student"\n')[1]
        logp = p.logpdf(uu) + ll
        w = np.exp(logp - logp.max()).reshape(131, 131)
        w /= w.sum()
        means[tails] = [((gj * mj).sum(), mj) for gj, mj in zip(g, (w.sum(1), w.sum(0)))]
    for j in range(2):
        mean, marg = means["multivariate_t"][j]
        s = math.sqrt(((g[j] - mean) ** 2 * marg).sum())
        x = post.u[:, j]
        assert abs(x.mean() - mean) < 0.12 * s, (j, x.mean(), mean, s)
        assert abs(x.std() - s) < 0.15 * s
        for q in (0.05, 0.5, 0.95):
            assert abs(np.quantile(x, q) - np.interp(q, np.cumsum(marg), g[j])) < 0.25 * s
    shift = max(abs(means["multivariate_t"][j][0] - means["student"][j][0]) for j in range(2))
    assert shift > 0.25 * s, (shift, s)  # the test can tell the two priors apart
