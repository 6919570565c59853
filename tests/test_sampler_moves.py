"""Fewer MH moves after a reweighting that kept more than the target ESS (issue 27): the rule itself, and the
posterior of an update over cuts in two cutting conditions against a brute-force grid, with the adaptive and
the fixed number of moves."""

from __future__ import annotations

import math

import numpy as np
import pytest

from millstab.io.config import parse_config
from millstab.model import Cutting
from millstab.update import make_prior
from millstab.update.likelihood import Evidence, Likelihood, limits_by_condition
from millstab.update.sampler import stage_moves, tempered_smc
from configs import TWO_MODE_TOML


def test_stage_moves_scale_with_the_duplicates_resampling_makes():
    # every stage the ESS rule chose (ESS at the target, or below it: impossible particles removed): all moves
    assert stage_moves(3, 2000.0, 4000, 0.5) == 3
    assert stage_moves(3, 2000.0 * (1 + 1e-7), 4000, 0.5) == 3  # the bisection's tolerance
    assert stage_moves(3, 100.0, 4000, 0.5) == 3
    # above it: ⌈3·(1 − ESS/N)/0.5⌉, at least one
    assert stage_moves(3, 0.7 * 4000, 4000, 0.5) == 2  # ⌈1.8⌉
    assert stage_moves(3, 0.97 * 4000, 4000, 0.5) == 1  # a sliver of β: ⌈0.18⌉
    assert stage_moves(3, 4000.0, 4000, 0.5) == 1
    assert stage_moves(5, 0.75 * 1000, 1000, 0.5) == 3  # ⌈2.5⌉


def _two_condition_case():
    """Two free parameters (fn_x, k_x) and 12 cuts, 6 in slotting and 6 at 50 % down milling, labelled by
    the zero-order limits of a truth (fn +4 %, k −20 %)."""
    cfg = parse_config(TWO_MODE_TOML + '[prior]\nfixed = ["zeta_x", "fn_y", "k_y", "zeta_y", "label_error", '
                       '"sigma_depth"]\nsigma_depth = "15 %"\ntails = "multivariate_t"\n')  # a ±4-spread grid
    prior = make_prior(cfg.structure, cfg.cutting, cfg.prior)
    c = cfg.cutting
    conds = (Cutting.from_immersion(c.teeth, c.kt, c.kr, 1.0, "down"),
             Cutting.from_immersion(c.teeth, c.kt, c.kr, 0.5, "down"))
    rng = np.random.default_rng(0)
    rpm = np.linspace(5200, 9000, 12)
    cond = np.arange(12) % 2
    truth = np.log(prior.median * np.array([1.04, 0.8]))[None]
    b = limits_by_condition(prior, truth, rpm, cond, conds)[0][0]
    depth = b * rng.uniform(0.6, 1.4, rpm.size)
    ev = Evidence(rpm, depth, (depth > b).astype(np.int64), np.ones(12), np.full(12, np.nan), np.zeros(0),
                  np.zeros(0), np.zeros(0), cut_cond=cond, conditions=conds)
    return prior, Likelihood(prior, ev)


@pytest.mark.slow
def test_adaptive_moves_keep_the_grid_posterior_of_cuts_in_two_conditions():
    prior, lik = _two_condition_case()
    n = 90
    g1 = prior.mean_u[0] + np.linspace(-4, 4, n) * prior.spread[0]
    g2 = prior.mean_u[1] + np.linspace(-4, 4, n) * prior.spread[1]
    uu = np.stack(np.meshgrid(g1, g2, indexing="ij"), -1).reshape(-1, 2)
    logp = prior.logpdf(uu) + lik(uu)  # ONE engine call for the whole grid
    w = np.exp(logp - logp.max()).reshape(n, n)
    w /= w.sum()
    runs = {a: tempered_smc(prior.sample_full, prior.logpdf_full, lik, 2000, seed=5, adaptive_moves=a)
            for a in (True, False)}
    new, old = runs[True], runs[False]
    # the last step to β = 1 kept more than the target ESS, so it moved less: the rule is exercised
    assert new.moves[-1] < 3 and all(m == 3 for m in old.moves) and sum(new.moves) < sum(old.moves)
    assert new.diagnostics()["moves"] == new.moves
    for j, (grid, marg) in enumerate(((g1, w.sum(1)), (g2, w.sum(0)))):
        mean = (grid * marg).sum()
        sd = math.sqrt(((grid - mean) ** 2 * marg).sum())
        for res in (new, old):
            x = res.u[:, j]
            assert abs(x.mean() - mean) < 0.15 * sd and abs(x.std() - sd) < 0.15 * sd, (j, x.mean(), mean, x.std(), sd)
            for q in (0.05, 0.5, 0.95):
                assert abs(np.quantile(x, q) - np.interp(q, np.cumsum(marg), grid)) < 0.25 * sd
