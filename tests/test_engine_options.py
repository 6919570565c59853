"""The engine's discretisation fixed by the caller (``options`` of the forward model, ``engine_options`` of
``update``): sdm's steps per tooth period reach every engine call of an update, override what the engine
would choose, and a keyword the engine does not take is a clear error."""

from __future__ import annotations

import functools
import pickle

import numpy as np
import pytest

from millstab.datasets import load_example
from millstab.errors import InputError
from millstab.forward import engine_options, forward
from millstab.io.config import parse_config
from millstab.params import Parameterization
from millstab.points import PointSet
from millstab.stability import sdm
from millstab.update import make_prior, update
from millstab.update.likelihood import limits
from configs import TWO_MODE_TOML


def test_sdm_steps_override_the_engines_choice_in_calls_and_pinned_models():
    cfg = load_example("ex3")
    par = Parameterization(cfg.structure)
    rpm = np.array([6000.0, 9000.0])
    theta = par.theta0[None] * np.array([[1.0] * par.size])
    f = forward(par, cfg.cutting, "sdm", options={"steps": 12})
    exact = sdm.envelope_batch(par.batch(theta), cfg.cutting, rpm, steps=12)
    np.testing.assert_array_equal(f(theta, rpm), exact)
    pin = f.pinned(rpm, theta)
    assert pin.settings["steps"] == 12 and "fn_max_hz" in pin.settings  # the engine's own choice is kept beside
    np.testing.assert_array_equal(pin(theta), exact)
    # the default (steps following the highest natural frequency) is another discretisation: the option is used
    assert not np.array_equal(forward(par, cfg.cutting, "sdm")(theta, rpm), exact)
    # a cluster's task gets the model by pickling: the options travel with it
    assert pickle.loads(pickle.dumps(f)).options == (("steps", 12),)


def test_an_option_the_engine_does_not_take_is_an_input_error():
    with pytest.raises(InputError, match="none") as e:
        engine_options("zoa", {"steps": 40})
    assert e.value.field == "engine_options"
    with pytest.raises(InputError, match="steps"):
        engine_options("sdm", {"nodes": 8})
    assert engine_options("spectral", {"nodes": 8}) == (("nodes", 8),)
    assert engine_options("sdm", None) == ()


def test_update_passes_the_steps_to_every_engine_call(monkeypatch):
    cfg = parse_config(TWO_MODE_TOML + '[prior]\nfixed = ["zeta_x", "fn_y", "k_y", "zeta_y", "label_error", '
                       '"sigma_depth"]\nsigma_depth = "15 %"\n')
    prior = make_prior(cfg.structure, cfg.cutting, cfg.prior)
    rpm = np.array([5600.0, 7400.0, 8800.0])
    b = limits(prior, np.log(prior.median)[None], rpm)[0][0]
    cuts = PointSet(rpm, b * np.array([0.7, 1.3, 0.8]), np.array(["stable", "chatter", "stable"]))
    seen = []
    plain = sdm.envelope_batch

    @functools.wraps(plain)  # the signature too: the options are checked against it
    def spy(*args, **kwargs):
        seen.append(kwargs.get("steps"))
        return plain(*args, **kwargs)

    monkeypatch.setattr(sdm, "envelope_batch", spy)
    post = update(cfg, cuts, engine="sdm", samples=20, seed=0, engine_options={"steps": 10})
    assert seen and all(s == 10 for s in seen)  # the zero-order screen of delayed acceptance keeps its own grid
    assert post.diagnostics["engine_options"] == {"steps": 10}
    with pytest.raises(InputError, match="engine_options"):
        update(cfg, cuts, engine="zoa", samples=20, engine_options={"steps": 10})


def test_the_service_passes_the_options_on():
    from millstab import api

    cfg = load_example("ex1")
    cuts = PointSet(np.array([6000.0, 8000.0]), np.array([1.0, 3.0]), np.array(["stable", "chatter"]))
    with pytest.raises(InputError, match="engine_options"):  # checked before any sampling
        api.update(cfg, cuts, samples=100, engine_options={"nodes": 8})
