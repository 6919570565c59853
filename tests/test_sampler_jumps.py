"""Lobe jumps in the SMC sampler (issue 24, campaign 41): a symmetric mode-jumping MH move in ln fn keeps
the target invariant and reaches a far mode that the random walk misses.

The target mimics a lobe shift in a sequential update (the campaigns' case: the particles start from the
posterior of the earlier cuts, none of them near the truth): u = (ln fn/fn₀, w), prior N(0, σ²) in each
(σ = 0.05, the default fn spread); the earlier cuts' likelihood is a broad Gaussian in ln fn (σ 0.08), and
the new cuts' likelihood has two narrow peaks, at 0 (the tap test's lobe) and at ln(6/5) (the next lobe:
fn·(n + 1)/n with n = 5, 3.65σ out, where a 20 % wrong tap test puts the truth), separated by a valley;
w is a nuisance coordinate with its own Gaussian likelihood. The reference is a brute-force grid
posterior (1-D in ln fn; the target is separable, so w does not change the mode masses)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from millstab.errors import InputError
from millstab.update.sampler import tempered_smc

SIG = 0.05
FAR = math.log(6 / 5)
WIDTH = 0.006  # the peaks' σ in ln fn (narrow: a few cuts bracketing a lobe)
LOG_WEIGHT_FAR = 9.5  # the far peak's height over the near one's, in nats (the new cuts favour the far lobe)
OLD = 0.08  # σ in ln fn of the earlier cuts' (Gaussian) likelihood


def _loglik_fn(x):
    near = -0.5 * (x / WIDTH) ** 2
    far = LOG_WEIGHT_FAR - 0.5 * ((x - FAR) / WIDTH) ** 2
    return np.logaddexp(near, far)


def _loglik(u):
    """(untempered log L of the earlier cuts, log L of the new ones): the sampler's ``init`` form."""
    return -0.5 * (u[:, 0] / OLD) ** 2, _loglik_fn(u[:, 0]) - 0.5 * ((u[:, 1] - 0.02) / 0.03) ** 2


def _start(n, seed):
    """n exact draws of the earlier posterior, prior · L_old (Gaussian: the conjugate product)."""
    sd = 1 / math.sqrt(1 / SIG**2 + 1 / OLD**2)
    return np.random.default_rng(seed).standard_normal((n, 2)) * np.array([sd, SIG])


def _logprior(u):
    return -0.5 * ((u / SIG) ** 2).sum(1)


def _draws(n, rng):
    return SIG * rng.standard_normal((n, 2))


def _grid_far_mass() -> float:
    x = np.linspace(-0.1, 0.35, 200001)
    lp = -0.5 * (x / SIG) ** 2 - 0.5 * (x / OLD) ** 2 + _loglik_fn(x)
    w = np.exp(lp - lp.max())
    return float(w[x > FAR - 5 * WIDTH].sum() / w.sum())


def _far_mass(res) -> float:
    return float((res.u[:, 0] > FAR - 5 * WIDTH).mean())


def test_grid_reference_is_bimodal_with_a_real_far_mode():
    m = _grid_far_mass()
    assert 0.4 < m < 0.8  # both modes hold mass: a sampler that misses either is visibly wrong


# enough MH moves per stage for the jumps to carry particles both ways until the mode masses settle (at the
# default 3 moves and 20 % jumps they reach 0.07-0.30 of the grid's 0.61 here: better than 0, not there)
MIX = {"moves": 20, "jump_rate": 0.5}


@pytest.mark.parametrize("seed", [1, 2])
def test_lobe_jumps_reach_the_far_mode_with_the_grid_mass(seed):
    ref = _grid_far_mass()
    res = tempered_smc(_draws, _logprior, _loglik, 2000, seed=seed, init=_start(2000, 2), jumps=((0,),), **MIX)
    got = _far_mass(res)
    # binomial sd of 2000 independent draws ≈ 0.011; SMC particles are correlated, so allow ~3 of them
    assert abs(got - ref) < 0.035, (got, ref)
    # within each mode the samples are the grid's (mean of ln fn in the far mode)
    x = np.linspace(FAR - 5 * WIDTH, 0.35, 100001)
    lp = -0.5 * (x / SIG) ** 2 - 0.5 * (x / OLD) ** 2 + _loglik_fn(x)
    w = np.exp(lp - lp.max())
    far = res.u[res.u[:, 0] > FAR - 5 * WIDTH, 0]
    assert abs(far.mean() - (w * x).sum() / w.sum()) < 0.002
    # the nuisance coordinate is untouched by the jumps: its conjugate posterior mean and sd
    v = 1 / (1 / SIG**2 + 1 / 0.03**2)
    assert abs(res.u[:, 1].mean() - v * 0.02 / 0.03**2) < 0.25 * math.sqrt(v)
    assert abs(res.u[:, 1].std() / math.sqrt(v) - 1) < 0.2


@pytest.mark.parametrize("seed", [1, 2])
def test_without_lobe_jumps_the_far_mode_is_missed(seed):
    """The failure the jumps fix, same seeds and moves (fails if the random walk alone already crossed:
    then this target would not show the bug; with other seeds it sometimes does, through the particles
    that the early, flat stages spread into the valley)."""
    ref = _grid_far_mass()
    assert (_start(2000, 2)[:, 0] > FAR - 5 * WIDTH).sum() == 0  # no starting particle in the far mode
    res = tempered_smc(_draws, _logprior, _loglik, 2000, seed=seed, init=_start(2000, 2), moves=MIX["moves"])
    assert _far_mass(res) < ref / 3, (_far_mass(res), ref)


def test_jumps_keep_a_unimodal_target_and_same_seed_same_samples():
    """A jump that lands nowhere must cost nothing but rejections: the conjugate posterior is unchanged."""
    def loglik(u):
        return -0.5 * (((u - 0.03) / 0.02) ** 2).sum(1)

    a = tempered_smc(_draws, _logprior, loglik, 1500, seed=5, jumps=((0,), (0, 1)))
    b = tempered_smc(_draws, _logprior, loglik, 1500, seed=5, jumps=((0,), (0, 1)))
    np.testing.assert_array_equal(a.u, b.u)
    v = 1 / (1 / SIG**2 + 1 / 0.02**2)
    np.testing.assert_allclose(a.u.mean(0), v * 0.03 / 0.02**2, atol=0.003)
    np.testing.assert_allclose(a.u.std(0), math.sqrt(v), atol=0.003)


@pytest.mark.parametrize("kw", [{"jumps": ((2,),)}, {"jumps": ((0, 0),)}, {"jumps": ((0,),), "jump_rate": 1.0}])
def test_bad_jump_settings_are_named(kw):
    with pytest.raises(InputError):
        tempered_smc(_draws, _logprior, lambda u: _loglik(u)[1], 100, seed=0, **kw)


def test_update_jumps_every_fn_alone_and_all_together():
    from millstab.io import load_config
    from millstab.io.config import PriorTable
    from millstab.update import lobe_jump_groups, make_prior

    cfg = load_config("example:ex1")
    pr = make_prior(cfg.structure, cfg.cutting, PriorTable({}))
    groups = lobe_jump_groups(pr)
    assert groups == ((pr.names.index("fn_x"),), (pr.names.index("fn_y"),),
                      (pr.names.index("fn_x"), pr.names.index("fn_y")))
    held = make_prior(cfg.structure, cfg.cutting, PriorTable({}, fixed=("fn_x", "fn_y")))
    assert lobe_jump_groups(held) == ()
