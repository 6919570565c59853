"""Process damping as a learned parameter (issue 27: "one coefficient and a prior"): ``[prior] process_damping``
frees the coefficient C of the C·b/V flank-contact term; each sample's C goes to the engine that carries the term
(sdm, ``per_set_process_damping``), and the data move it.

Independent checks: a batched call with a C per set against one call per set with a Cutting of that C (bit for
bit); the likelihood's limits of C-free samples against each sample's own engine call; the posterior of C on a dense
grid (quadrature of prior × likelihood, no sampler) against the truth the cuts were labelled with.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from millstab.config import PriorTable
from millstab.errors import InputError
from millstab.frf import ModalBatch
from millstab.io.config import parse_config
from millstab.model import Conditions, Cutting, Mode, Structure
from millstab.stability import sdm
from millstab.update import Evidence, make_prior, screen_model
from millstab.update.likelihood import Likelihood
from millstab.update.prior import PD, Prior

FN, ZETA, MASS = 922.0, 0.011, 0.03993
K = MASS * (2 * math.pi * FN) ** 2
TWO = Structure(x=(Mode(FN, K, ZETA),), y=(Mode(1150.0, 1.3 * K, 0.015),))
KT, KR, D = 6e8, 0.3, 0.016
C0 = 1e4  # the config's coefficient [N/m], the prior median
#: a coarse fixed step count without Richardson extrapolation: cheap, and one function of θ for the whole test
STEPS = 60
CUT = Cutting.from_immersion(3, KT, KR, 0.5, "down", process_damping=C0, diameter=D)


def _table(**spreads) -> PriorTable:
    return PriorTable(spreads, fixed=("fn_y", "k_x", "k_y", "zeta_x", "zeta_y"))


def _prior(spread: float = 1.0) -> Prior:
    """fn_x (its default 5 %) and C (``spread``) free, the other modal parameters held at the hammer test."""
    return make_prior(TWO, CUT, _table(process_damping=spread))


def test_sdm_takes_a_coefficient_per_set_bit_for_bit():
    """envelope_batch(..., process_damping=C (B,)) gives each set the depths of its own call with a Cutting of that C,
    under one cutting and under per-column conditions; the limit rises with C at low speed."""
    other = Structure(x=(Mode(FN * 1.03, 0.9 * K, ZETA),), y=(Mode(1150.0, 1.3 * K, 0.015),))
    structs = [TWO, other, TWO]
    c = np.array([5e3, 2e4, 6e4])
    rpm = np.array([1500.0, 4000.0])
    got = sdm.envelope_batch(ModalBatch.from_structures(structs), CUT, rpm, steps=STEPS, process_damping=c)
    for i, s in enumerate(structs):
        own = sdm.envelope_batch(ModalBatch.from_structures([s]), replace(CUT, process_damping=c[i]), rpm, steps=STEPS)
        np.testing.assert_array_equal(got[i], own[0])
    assert got[0, 0] < got[2, 0]  # same structure, C × 12: deeper at 1 500 rpm
    up = Cutting.from_immersion(3, KT, KR, 0.25, "up", process_damping=C0, diameter=D)
    cond = Conditions.of((CUT, up), np.array([0, 1]))
    mixed = sdm.envelope_batch(ModalBatch.from_structures(structs), cond, rpm, steps=STEPS, process_damping=c)
    np.testing.assert_array_equal(mixed[:, 0], got[:, 0])
    for i, s in enumerate(structs):
        own = sdm.envelope_batch(ModalBatch.from_structures([s]), replace(up, process_damping=c[i]), rpm[1:],
                                 steps=STEPS)
        assert mixed[i, 1] == own[0, 0]


@pytest.mark.parametrize("pd,cutting,field", [
    (np.array([1e4]), CUT, "process_damping"),  # one value for two sets
    (np.array([1e4, -1.0]), CUT, "process_damping"),
    (np.array([1e4, np.nan]), CUT, "process_damping"),
    (np.array([1e4, 1e4]), Cutting.from_immersion(3, KT, KR, 0.5, "down"), "cutting.diameter"),  # no V without D
])
def test_a_bad_per_set_coefficient_is_a_clear_error(pd, cutting, field):
    with pytest.raises(InputError) as exc:
        sdm.envelope_batch(ModalBatch.from_structures([TWO, TWO]), cutting, [3000.0], steps=STEPS, process_damping=pd)
    assert exc.value.field == field


def test_the_prior_frees_c_from_the_config():
    cfg = parse_config("""
[structure]
x = [{fn = "922 Hz", k = "%.6g N/m", zeta = 0.011}]
y = [{fn = "1150 Hz", k = "%.6g N/m", zeta = 0.015}]
[cutting]
teeth = 3
kt = "600 N/mm^2"
kr = 0.3
radial_immersion = 0.5
milling = "down"
process_damping = "0.01 N/um"
diameter = "16 mm"
[prior]
process_damping = "50 %%"
""" % (K, 1.3 * K))
    prior = make_prior(cfg.structure, cfg.cutting, cfg.prior)
    assert prior.names[-1] == PD and prior.pd_free and prior.n_modal == prior.size - 1
    assert prior.median[-1] == pytest.approx(C0) and prior.spread[-1] == pytest.approx(0.5)
    assert prior.units()[-1] == "N/m"
    u = prior.sample(5, np.random.default_rng(1))
    np.testing.assert_allclose(prior.pd_of(u), np.exp(u[:, -1]), rtol=0, atol=0)
    again = Prior.from_dict(prior.to_dict())
    assert again.names == prior.names and again.n_modal == prior.n_modal
    np.testing.assert_array_equal(again.pd_of(u), prior.pd_of(u))
    # the zero-order screen's prior (the cutting without the term) gives the engine no C
    assert screen_model(prior, _evidence(np.array([3000.0]), np.array([1.0]), np.array([0])), "zoa")[0].pd_of(u) is None


def test_c_cannot_be_freed_without_its_median_or_learned_by_an_engine_without_it():
    with pytest.raises(InputError) as exc:
        make_prior(TWO, CUT.without_process_damping(), _table(process_damping=0.5))
    assert exc.value.field == "prior.process_damping" and "cutting.process_damping" in str(exc.value)
    ev = _evidence(np.array([3000.0]), np.array([1.0]), np.array([0]))
    for engine in ("zoa", "spectral"):
        with pytest.raises(InputError) as exc:
            Likelihood(_prior(), ev, engine)
        assert "sdm" in str(exc.value) and exc.value.field in ("prior.process_damping", "cutting.process_damping")


def _evidence(rpm, depth_mm, kind) -> Evidence:
    n = rpm.size
    return Evidence(rpm, depth_mm, kind, np.ones(n), np.full(n, np.nan), np.zeros(0), np.zeros(0), np.zeros(0))


def test_the_likelihood_gives_each_sample_its_own_c():
    """The limits the likelihood reads for C-free samples are each sample's own sdm call with a Cutting of its C."""
    prior = _prior()
    rpm = np.array([1500.0, 2500.0, 6000.0])
    lik = Likelihood(prior, _evidence(rpm, np.array([0.5, 0.4, 0.3]), np.array([0, 1, 0])), "sdm",
                     engine_options={"steps": STEPS})
    v = prior.sample_full(3, np.random.default_rng(3))
    _, depth_mm = lik.depths(v)
    theta = np.exp(v[:, :prior.size])
    for i in range(3):
        own = sdm.envelope_batch(prior.par.batch(theta[i:i + 1, :prior.n_modal]),
                                 replace(CUT, process_damping=theta[i, -1]), lik.speeds, steps=STEPS)
        np.testing.assert_array_equal(depth_mm[i], own[0] * 1e3)


def test_the_posterior_of_c_moves_to_the_truth():
    """Cuts labelled by a tool whose C is 3× the config's (stable at 0.85 and chatter at 1.15 of the true limit at
    low speeds, where the term matters): the posterior of C on a dense grid (prior × likelihood, the structure at the
    truth) puts its median within 25 % of the truth and its mass away from the config's C, which the cuts
    contradict. A wrong column (C read as another parameter, or not passed) leaves the likelihood flat in C."""
    prior = _prior(spread=1.0)
    c_true = 3.0 * C0
    rpm = np.array([1500.0, 1800.0, 2200.0, 2600.0])
    true = sdm.envelope_batch(ModalBatch.from_structures([TWO]), replace(CUT, process_damping=c_true), rpm,
                              steps=STEPS)[0] * 1e3
    ev = _evidence(np.repeat(rpm, 2), np.ravel(np.column_stack([0.85 * true, 1.15 * true])), np.tile([0, 1], 4))
    lik = Likelihood(prior, ev, "sdm", engine_options={"steps": STEPS})
    grid = np.exp(np.linspace(math.log(C0 / 4), math.log(C0 * 12), 41))
    held = prior.noise_coordinates(np.array([prior.label_error]), np.ones(1))[0]  # the noise levels' prior medians
    v = np.tile(np.append(np.log(prior.median), held), (41, 1))
    v[:, prior.size - 1] = np.log(grid)
    log_post = lik(v) + prior.logpdf_full(v)
    w = np.exp(log_post - log_post.max())
    cdf = np.cumsum(w) / w.sum()
    median = grid[np.searchsorted(cdf, 0.5)]
    assert abs(median / c_true - 1) < 0.25
    assert cdf[np.searchsorted(grid, 1.5 * C0)] < 0.05  # the config's C (and up to 1.5× it) is ruled out
    assert lik(v[[int(np.argmin(abs(grid - C0)))]])[0] < lik(v[[int(np.argmin(abs(grid - c_true)))]])[0] - 3


def test_a_posterior_with_c_predicts_with_each_samples_c_after_its_json():
    """A posterior whose samples carry C keeps it through its JSON, and its predictions read each sample's C: P(stable)
    of a cut is the share of samples whose own limit (a Cutting of that sample's C) lies above its depth."""
    from millstab.update.posterior import Posterior
    from millstab.update.predict import predict_cuts

    prior = _prior()
    theta = np.exp(prior.sample(6, np.random.default_rng(5)))
    theta[:, -1] = np.array([2e3, 5e3, 1e4, 2e4, 4e4, 8e4])  # a wide spread of C, so the cuts split the samples
    post = Posterior.from_json(Posterior(prior, theta, "sdm", engine_options={"steps": STEPS}).to_json())
    np.testing.assert_array_equal(post.samples, theta)
    rpm = np.array([1500.0, 1500.0, 2500.0])
    own = np.array([sdm.envelope_batch(prior.par.batch(t[None, :prior.n_modal]), replace(CUT, process_damping=t[-1]),
                                       np.unique(rpm), steps=STEPS)[0] * 1e3 for t in theta])  # (6, 2) [mm]
    depth = np.array([np.median(own[:, 0]), 0.9 * own[:, 0].max(), np.median(own[:, 1])])
    want = np.mean(own[:, [0, 0, 1]] > depth, axis=0)
    got, _ = predict_cuts(post, rpm, depth)
    np.testing.assert_array_equal(got, want)
    assert 0 < want[0] < 1 and 0 < want[2] < 1  # the cuts do split the samples: a C ignored would fail
