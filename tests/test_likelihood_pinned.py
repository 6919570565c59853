"""The likelihood evaluates through the one evaluator, ``forward(par, cut, engine).pinned(rpm, rows)`` (issue 26):
its depths are those of a direct batched engine call on all the samples (bit for bit: the evaluation path
only moved), with a free Kt's exact factor and a free Kr per row, and any part of the samples evaluated by the
whole batch's pinned model (a cluster task) gives the whole call's rows."""

from __future__ import annotations

import math

import numpy as np
import pytest

from millstab.forward import forward
from millstab.io import load_config
from millstab.io.config import PriorTable
from millstab.model import Conditions, Cutting
from millstab.stability import get_engine
from millstab.update import make_prior
from millstab.update.likelihood import limits, sample_depths


def _case(spreads: dict):
    cfg = load_config("example:ex1")
    prior = make_prior(cfg.structure, cfg.cutting, PriorTable(spreads))
    u = prior.sample(12, np.random.default_rng(3))
    rpm = np.linspace(5000.0, 12000.0, 6)
    other = Cutting(2, cfg.cutting.kt, cfg.cutting.kr, 0.0, math.pi / 3)  # half immersion beside the slot
    return prior, u, rpm, Conditions.of((cfg.cutting, other), np.arange(rpm.size) % 2)


@pytest.mark.parametrize("with_freq", [False, True])
def test_zoa_limits_are_the_direct_engine_call_with_kt_and_kr_free(with_freq):
    prior, u, rpm, cond = _case({"kt": 0.1, "kr": 0.1})
    theta, factor = prior.split(u)
    kr = prior.kr_of(u)
    assert kr is not None and not np.all(factor == 1.0)
    zoa = get_engine("zoa")
    batch = prior.par.batch(theta)
    if with_freq:
        direct, hz_direct = zoa.envelope_batch_hz(batch, cond, rpm, kr=kr)
    else:
        direct, hz_direct = zoa.envelope_batch(batch, cond, rpm, kr=kr), None
    depth, hz = limits(prior, u, rpm, "zoa", with_freq=with_freq, conditions=cond)
    np.testing.assert_array_equal(depth, direct * 1e3 * factor[:, None])
    if with_freq:
        np.testing.assert_array_equal(hz, hz_direct)
    else:
        assert hz is None


def test_sdm_limits_are_the_whole_batch_call_and_a_part_pinned_on_the_whole_gives_its_rows():
    """sdm chooses its steps from the batch's highest natural frequency: the likelihood's pinned model is the
    engine's own call on all samples, and five samples evaluated under it (a cluster task's share) give those
    rows exactly; alone, with their own choice, they need not (why the cluster pins on the client)."""
    prior, u, rpm, cond = _case({})
    sdm = get_engine("sdm")
    whole = sdm.envelope_batch(prior.par.batch(prior.split(u)[0]), cond, rpm) * 1e3
    depth, hz = limits(prior, u, rpm, "sdm", conditions=cond)
    np.testing.assert_array_equal(depth, whole)
    assert hz is None
    pinned = forward(prior.par, prior.cutting, "sdm").pinned(rpm, prior.split(u)[0], cond)
    part, _ = sample_depths(pinned, prior, u[3:8])
    np.testing.assert_array_equal(part, whole[3:8])
