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


def _case(spreads: dict, low_rpm: float = 5000.0):
    cfg = load_config("example:ex1")
    prior = make_prior(cfg.structure, cfg.cutting, PriorTable(spreads))
    u = prior.sample(12, np.random.default_rng(3))
    rpm = np.linspace(low_rpm, 12000.0, 6)
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
    prior, u, rpm, cond = _case({}, low_rpm=8000.0)  # (sdm's steps grow as the speed falls: 25 s from 5 000 rpm)
    sdm = get_engine("sdm")
    whole = sdm.envelope_batch(prior.par.batch(prior.split(u)[0]), cond, rpm) * 1e3
    depth, hz = limits(prior, u, rpm, "sdm", conditions=cond)
    np.testing.assert_array_equal(depth, whole)
    assert hz is None
    pinned = forward(prior.par, prior.cutting, "sdm").pinned(rpm, prior.split(u)[0], cond)
    part, _ = sample_depths(pinned, prior, u[3:8])
    np.testing.assert_array_equal(part, whole[3:8])


# --- the row at which a pinned model's settings are chosen (issue 26: they came from Forward's cache order) -----

def _choosing_engine(chosen_at: list):
    """zoa under another name, with a ``settings`` capability that records the set it chose at (its fn_x) and
    hands it back as a keyword, which ``envelope_batch`` ignores."""
    from plugin_engines import zoa_plugin

    from millstab import stability as stab

    zoa = get_engine("zoa")
    m = zoa_plugin("choosing")

    def settings(batch, cutting, rpm, purpose="fit"):
        chosen_at.append(float(batch.fn_x[0, 0]))
        return {"at_fn": chosen_at[-1]}

    m.settings = settings
    m.envelope_batch = lambda batch, cutting, rpm, at_fn=None, **kw: zoa.envelope_batch(batch, cutting, rpm, **kw)
    return stab.register(m)


@pytest.fixture
def choosing():
    from millstab import stability as stab

    chosen_at: list[float] = []
    _choosing_engine(chosen_at)
    yield chosen_at
    stab.unregister("choosing")


def test_pinned_chooses_its_settings_at_the_row_it_is_given_not_at_the_first_call(choosing):
    """``Forward.pinned(..., at=θ0)`` chooses at θ0 although the model was first called at another row and the
    rows' first row is a third: the old ``pinned`` took the cached choice of the first call, and
    ``pinned_model`` relied on asking ``settings(r, None)`` first (fails on the old code: no ``at=``, and the
    likelihood's pinned model got the first call's choice)."""
    from millstab.update.likelihood import SAMPLING, pinned_model

    prior, u, rpm, _ = _case({})
    theta0 = prior.par.theta0
    fn0 = float(prior.par.batch(theta0[None]).fn_x[0, 0])
    other = theta0 * 1.05
    fwd = forward(prior.par, prior.cutting, "choosing", SAMPLING)
    fwd(other, rpm)  # a first call elsewhere: Forward's own (fit) choice is made at that row
    assert choosing == [pytest.approx(fn0 * 1.05)]
    rows = prior.split(u)[0]
    assert not np.allclose(rows[0], theta0)
    assert dict(fwd.pinned(rpm, rows, at=theta0).settings) == {"at_fn": fn0}
    assert dict(fwd.pinned(rpm, rows).settings) == {"at_fn": float(prior.par.batch(rows[:1]).fn_x[0, 0])}
    assert dict(pinned_model(prior, u, rpm, "choosing", fwd=fwd).settings) == {"at_fn": fn0}
    # the fit's first-row choice is untouched by the pinned models
    assert fwd.settings(np.asarray(rpm, float)) == {"at_fn": choosing[0]}
