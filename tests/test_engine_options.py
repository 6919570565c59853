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


@pytest.mark.parametrize("engine", ["zoa", "sdm", "spectral"])
def test_the_doors_name_the_keywords_the_check_names(engine):
    """What the app shows before any error (api.engine_keywords) is what a refused option's error names."""
    from millstab import api

    with pytest.raises(InputError) as e:
        engine_options(engine, {"no_such_keyword": 1})
    assert api.engine_keywords(engine) == e.value.allowed
    assert "warm" not in api.engine_keywords(engine)  # the spectral engine's own per-purpose choice


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


# --- issues 27/28: the posterior keeps its engine options, and every decision from it uses them ----------------
#: the fitted discretisation (sdm steps per tooth period), coarser than sdm's own choice here (>= 30 at these speeds)
STEPS = 10


def _direct(post, rpm, steps):
    """The posterior's limits (N, S) [mm] at ``rpm`` by the sdm engine itself at ``steps`` (None: its own choice),
    beside the library's decision code: ln θ split into the structure and the exact Kt factor."""
    theta, factor = post.prior.split(post.decision_u)
    return sdm.envelope_batch(post.prior.par.batch(theta), post.prior.cutting, np.asarray(rpm, float),
                              steps=steps) * 1e3 * factor[:, None]


def _default_differs(post, rpm):
    """Whether the engine's own discretisation (43..73 steps at these speeds: ~4× the cost, so on 5 samples at one
    speed) gives other limits than the fitted STEPS: the old code's decisions were not the fitted model's."""
    theta, _ = post.prior.split(post.decision_u[:5])
    b = post.prior.par.batch(theta)
    own = sdm.envelope_batch(b, post.prior.cutting, np.array([rpm]))
    return np.min(np.abs(own / sdm.envelope_batch(b, post.prior.cutting, np.array([rpm]), steps=STEPS) - 1)) > 1e-3


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    """(posterior read back from its JSON, its file): sdm at STEPS steps, 20 samples."""
    import json

    from millstab.io import write_json
    from millstab.update import Posterior

    cfg = parse_config(TWO_MODE_TOML + '[prior]\nfixed = ["zeta_x", "fn_y", "k_y", "zeta_y", "label_error", '
                       '"sigma_depth"]\nsigma_depth = "15 %"\n')
    rpm = np.array([5600.0, 7400.0, 8800.0])
    cuts = PointSet(rpm, np.array([0.9, 2.6, 1.1]), np.array(["stable", "chatter", "stable"]))
    post = update(cfg, cuts, engine="sdm", samples=20, seed=1, engine_options={"steps": STEPS})
    path = tmp_path_factory.mktemp("engopt") / "post.json"
    write_json(path, post.to_json())
    return Posterior.from_json(json.loads(path.read_text())), path


def test_the_posterior_keeps_its_engine_options_through_json(fitted):
    import json

    from millstab.update import Posterior

    post, path = fitted
    doc = json.loads(path.read_text())
    assert doc["engine_options"] == {"steps": STEPS} and post.engine_options == {"steps": STEPS}
    old = {k: v for k, v in doc.items() if k != "engine_options"}  # the first version kept them in the diagnostics
    assert Posterior.from_json(old).engine_options == {"steps": STEPS}
    older = dict(old, diagnostics={k: v for k, v in doc["diagnostics"].items() if k != "engine_options"})
    assert Posterior.from_json(older).engine_options == {}  # a file from before: the engine's own choice
    with pytest.raises(InputError, match="nodes") as e:  # a file naming a keyword its engine does not take
        Posterior.from_json(dict(doc, engine_options={"nodes": 8}), "p.json")
    assert e.value.field == "p.json engine_options" and "steps" in str(e.value)


def test_map_and_predict_use_the_fitted_steps(fitted):
    """P(stable) on a grid and per cut equal the fraction of samples whose limit, by the engine at the fitted
    steps, lies above the depth; at the engine's own steps (the old code's) or other ones the limits differ."""
    from millstab.update import p_stable_map
    from millstab.update.predict import predict_cuts

    post, _ = fitted
    rpm = np.array([5200.0, 6300.0, 7400.0, 8500.0])
    mine, other = _direct(post, rpm, STEPS), _direct(post, rpm, STEPS + 4)
    assert _default_differs(post, 6300.0) and np.min(np.abs(mine / other - 1)) > 1e-3  # the steps tell apart
    depths = np.linspace(0.5, 1.5, 201) * np.median(mine)
    np.testing.assert_allclose(p_stable_map(post, rpm, depths), np.mean(mine[:, :, None] > depths, axis=0), atol=1e-12)
    d = np.median(mine, axis=0)  # each cut at its speed's median fitted limit: the default moves the count
    ps, _ = predict_cuts(post, rpm, d)
    np.testing.assert_allclose(ps, np.mean(mine > d, axis=0), atol=1e-12)
    assert np.abs(ps - np.mean(other > d, axis=0)).max() > 0.01


def test_recommend_and_the_next_test_use_the_fitted_steps(fitted, monkeypatch):
    from dataclasses import replace

    from millstab.update import decide, recommend

    post, _ = fitted
    post = replace(post, samples=post.samples[:10])  # sdm costs ~6 ms a limit: 10 samples, a short refinement
    monkeypatch.setattr(decide, "REFINE_POINTS", 6)
    seen = []
    plain = sdm.envelope_batch

    @functools.wraps(plain)
    def spy(*args, **kwargs):
        seen.append(kwargs.get("steps"))
        return plain(*args, **kwargs)

    monkeypatch.setattr(sdm, "envelope_batch", spy)
    rec = recommend(post, 0.2, (5600.0, 8800.0), confidence=None, speed_tolerance=0.0, guard=False, coarse_points=5)
    assert seen and all(s == STEPS for s in seen)  # the recommendation's and the next test's calls alike
    seen.clear()  # the cuts that vouch for a recommendation (confirm) are judged at the fitted steps too
    recommend(post, 0.2, (5600.0, 8800.0), confidence=None, speed_tolerance=0.0, guard=False, coarse_points=5,
              confirm="always")
    assert seen and all(s == STEPS for s in seen)
    monkeypatch.setattr(sdm, "envelope_batch", plain)
    # its depth: the ⌊0.2·N⌋-th smallest limit at its speed, by the engine at the fitted steps
    col = np.sort(_direct(post, [rec.rpm], STEPS)[:, 0])
    assert rec.depth_mm == pytest.approx(col[2] * (1 - 1e-9), rel=1e-12)
    assert _default_differs(post, rec.rpm)


def test_a_caller_overrides_the_fitted_options(fitted):
    from millstab.update.predict import predict_cuts

    post, _ = fitted
    other = post.with_engine_options({"steps": 14})
    assert other.engine_options == {"steps": 14} and post.engine_options == {"steps": STEPS}
    rpm = np.array([6000.0, 8000.0])
    d = np.median(_direct(post, rpm, 14), axis=0)
    np.testing.assert_allclose(predict_cuts(other, rpm, d)[0], np.mean(_direct(post, rpm, 14) > d, axis=0), atol=1e-12)
    assert post.with_engine_options(None) is post
    with pytest.raises(InputError, match="steps") as e:
        post.with_engine_options({"steps": 0}, "--engine-option")
    assert e.value.field == "--engine-option steps" and e.value.value == 0


@pytest.mark.parametrize("engine, options, field, text", [
    ("sdm", {"steps": 2.5}, "engine_options steps", "whole number"),
    ("sdm", {"steps": True}, "engine_options steps", "whole number"),
    ("sdm", {"fn_max_hz": -1.0}, "engine_options fn_max_hz", "> 0"),
    ("spectral", {"nodes": 1}, "engine_options nodes", "in 2..40"),
    ("spectral", {"near": 1.5}, "engine_options near", "[0, 1)"),
    ("sdm", {"steps": "forty"}, "engine_options steps", "fn_max_hz, steps"),  # the engine's keywords named too
])
def test_a_bad_value_is_named_with_its_keyword(engine, options, field, text):
    with pytest.raises(InputError) as e:
        engine_options(engine, options)
    assert e.value.field == field and text in str(e.value)
    assert engine_options("sdm", {"steps": np.int64(12)}) == (("steps", 12),)  # numpy ints as plain ints (JSON)


# --- the doors: --engine-option on the command line, the shop database --------------------------------------
PRIOR_TOML = TWO_MODE_TOML + ('[prior]\nfixed = ["zeta_x", "fn_y", "k_y", "zeta_y", "label_error", "sigma_depth"]\n'
                              'sigma_depth = "15 %"\n')


def _one_line_error(capsys, args, *texts):
    from millstab.cli import main

    capsys.readouterr()
    assert main([str(a) for a in args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("millstab: error:"), err
    for t in texts:
        assert t in err[0], err[0]


def test_map_on_the_command_line_uses_the_posteriors_steps_or_the_override(fitted, tmp_path):
    import csv

    from millstab.cli import main

    post, path = fitted
    rpm, depths = np.array([6000.0, 7000.0, 8000.0]), np.arange(1, 31) * 0.1
    for extra, steps in ((["--plot", str(tmp_path / "m.png")], STEPS), (["--engine-option", "steps=14"], 14)):
        out = tmp_path / f"map{steps}.csv"
        assert main(["map", str(path), "--rpm", "6000:8000:1000", "--depth", "0.1:3:0.1", "--out", str(out),
                     *extra]) == 0
        got = np.array([float(r["p_stable"]) for r in csv.DictReader(out.open())]).reshape(3, -1)
        np.testing.assert_allclose(got, np.mean(_direct(post, rpm, steps)[:, :, None] > depths, axis=0), atol=1e-12)
    assert (tmp_path / "m.png").stat().st_size > 1000  # the prior's SLD on it at the fitted steps too


def test_validate_fits_and_predicts_every_fold_with_the_options(fitted):
    from millstab.update.validate import cross_validate

    post, _ = fitted
    got = []

    def fit(cfg, train, **kw):  # the sampling is tested above: here what each fold's update is given
        got.append(kw.get("engine_options"))
        return post.with_engine_options(kw.get("engine_options"))

    cuts = PointSet(np.array([5600.0, 7400.0, 8800.0, 6500.0]), np.array([0.9, 2.6, 1.1, 1.0]),
                    np.array(["stable", "chatter", "stable", "stable"]))
    res = cross_validate(parse_config(PRIOR_TOML), cuts, n_folds=2, samples=100, engine="sdm", schemes=("random",),
                         update_fn=fit, engine_options={"steps": STEPS})
    assert got == [{"steps": STEPS}] * 2 and res.settings["engine_options"] == {"steps": STEPS}
    with pytest.raises(InputError, match="nodes"):  # before any fold
        cross_validate(parse_config(PRIOR_TOML), cuts, engine="sdm", update_fn=fit, engine_options={"nodes": 6})
    assert len(got) == 2


@pytest.mark.parametrize("args, texts", [
    (["map", "{post}", "--engine-option", "nodes=8"], ("--engine-option", "'nodes'", "steps")),
    (["map", "{post}", "--engine-option", "steps=0"], ("--engine-option steps", "= 0", "fn_max_hz, steps")),
    (["map", "{post}", "--engine-option", "steps=ten"], ("--engine-option steps", "'ten'", "whole number")),
    (["map", "{post}", "--engine-option", "steps"], ("--engine-option", "KEY=VALUE")),
    (["map", "{post}", "--engine-option", "steps=8", "--engine-option", "steps=9"], ("each keyword once",)),
    (["predict", "{post}", "{cuts}", "--out", "{d}/p.csv", "--engine-option", "near=0.5"], ("'near'", "steps")),
    (["recommend", "{post}", "--rpm", "6000:8000", "--out", "{d}/r.json", "--engine-option", "steps=1.5"],
     ("--engine-option steps", "1.5")),
    (["update", "{cfg}", "{cuts}", "--out", "{d}/p.json", "--engine-option", "steps=40"], ("zoa", "none")),
    (["update", "{cfg}", "{cuts}", "--out", "{d}/p.json", "--engine", "spectral", "--engine-option", "nodes=1"],
     ("--engine-option nodes", "in 2..40", "near, nodes")),
    (["validate", "{cfg}", "{cuts}", "--engine", "sdm", "--engine-option", "nodes=6"], ("'nodes'", "steps")),
])
def test_a_wrong_engine_option_is_one_line(fitted, tmp_path, capsys, args, texts):
    _, path = fitted
    (tmp_path / "c.toml").write_text(PRIOR_TOML)
    (tmp_path / "cuts.csv").write_text("rpm,depth_mm,label\n5600,0.9,stable\n7400,2.6,chatter\n8800,1.1,stable\n"
                                       "6500,1.0,stable\n")
    fill = {"post": path, "d": tmp_path, "cfg": tmp_path / "c.toml", "cuts": tmp_path / "cuts.csv"}
    if args[0] == "map":
        args = args + ["--rpm", "6000:8000:1000", "--depth", "0.1:3:0.1", "--out", "{d}/m.csv"]
    _one_line_error(capsys, [a.format(**fill) for a in args], *texts)
    assert not (tmp_path / "p.json").exists() and not (tmp_path / "m.csv").exists()


def test_the_shop_database_update_passes_the_options_and_starts_afresh_when_they_change(fitted, tmp_path, monkeypatch):
    """update_in_db hands the options to the update, the campaign's posterior keeps them, and an update with other
    options does not start from a posterior sampled under another discretisation."""
    import importlib

    from millstab.api import shop
    from millstab.shopdb import open_store

    post, _ = fitted
    calls = []

    def fake_update(*args, **kwargs):  # the sampling itself is tested above; here what the service passes on
        calls.append(kwargs)
        return post.with_engine_options(kwargs.get("engine_options"))

    monkeypatch.setattr(importlib.import_module("millstab.api.update"), "update", fake_update)
    cfg = parse_config(PRIOR_TOML)
    cuts = PointSet(np.array([5600.0, 7400.0]), np.array([0.9, 2.6]), np.array(["stable", "chatter"]))
    db = tmp_path / "shop.db"
    shop.update_in_db(db, "c", cfg, cuts, engine="sdm", samples=100, engine_options={"steps": STEPS})
    assert calls[-1]["engine_options"] == {"steps": STEPS} and calls[-1]["start"] is None
    assert open_store(db).snapshot("c").posterior().engine_options == {"steps": STEPS}
    more = PointSet(np.array([8800.0]), np.array([1.1]), np.array(["stable"]))
    shop.update_in_db(db, "c", cfg, more, engine="sdm", samples=100, engine_options={"steps": STEPS})
    assert calls[-1]["start"] is not None  # the same options: sequential reuse
    done = shop.update_in_db(db, "c", cfg, PointSet(np.array([6500.0]), np.array([1.0]), np.array(["stable"])),
                             engine="sdm", samples=100, engine_options={"steps": 14})
    assert calls[-1]["start"] is None and any("engine options differ" in n for n in done.notes)


@pytest.mark.slow
def test_update_on_the_command_line_fits_and_records_the_steps(tmp_path):
    """`millstab update --engine sdm --engine-option steps=S` (file and --db) writes a posterior that keeps S."""
    import json

    from millstab.cli import main
    from millstab.update import Posterior

    (tmp_path / "c.toml").write_text(PRIOR_TOML)
    (tmp_path / "cuts.csv").write_text("rpm,depth_mm,label\n5600,0.9,stable\n7400,2.6,chatter\n8800,1.1,stable\n")
    base = ["update", str(tmp_path / "c.toml"), str(tmp_path / "cuts.csv"), "--engine", "sdm", "--samples", "100",
            "--engine-option", "steps=8"]
    assert main(base + ["--out", str(tmp_path / "p.json")]) == 0
    doc = json.loads((tmp_path / "p.json").read_text())
    assert doc["engine_options"] == {"steps": 8} and Posterior.from_json(doc).engine_options == {"steps": 8}
    assert main(base + ["--db", str(tmp_path / "shop.db"), "--campaign", "c"]) == 0
    from millstab.api.shop import posterior_from_db

    assert posterior_from_db(tmp_path / "shop.db", "c")[1].engine_options == {"steps": 8}


def test_a_model_pinned_at_a_row_keeps_the_fixed_nodes(monkeypatch):
    """Forward.pinned(at=) (the decisions' and the likelihood's evaluator) takes the caller's spectral nodes over
    the engine's choice at that row (fails on the merged pinned(at=) code, which kept the engine's choice)."""
    from millstab.stability import spectral

    cfg = load_example("ex1")
    par = Parameterization(cfg.structure)
    monkeypatch.setattr(spectral, "settings", lambda batch, cutting, rpm, purpose="fit": {"nodes": 5, "near": 0.0})
    rpm = np.array([6000.0, 7000.0])
    pin = forward(par, cfg.cutting, "spectral", options={"nodes": 9}).pinned(rpm, par.theta0[None], at=par.theta0)
    assert dict(pin.settings) == {"nodes": 9, "near": 0.0}
    assert dict(forward(par, cfg.cutting, "spectral").pinned(rpm, par.theta0[None], at=par.theta0)
                .settings)["nodes"] == 5
