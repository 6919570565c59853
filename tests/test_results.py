"""Frozen result objects and their JSON: from_json(to_json(x)) equals x field by field (arrays equal,
inf and NaN included), the JSON holds plain types only (json.dumps with allow_nan=False works), a
document of another schema or with a field missing is an InputError that names the source and field,
and a fit is never changed after it is built (tie test, quality checks and the two-stage SDM fit make
new objects). The fit's public JSON is checked against the contract as it was before the schema: the
same keys and values, plus ``schema`` and ``parameterization``."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from millstab.cli import main
from millstab.datasets import load_example
from millstab.errors import InputError
from millstab.identify import make_problem
from millstab.identify.design import DESIGN_SCHEMA, SpeedDesign, design_speeds
from millstab.identify.quality import diagnose
from millstab.identify.result import SCHEMA as FIT_SCHEMA
from millstab.identify.result import Fit, cutting_record
from millstab.identify.synthetic import boundary_points
from millstab.identify.tie import prefer_tied
from millstab.io.results import to_jsonable
from millstab.model import Cutting, Mode, Structure
from millstab.params import Parameterization
from millstab.sensitivity import monte_carlo, morris, oat, sobol
from millstab.sensitivity.results import MCResult, MorrisResult, OATResult, SobolResult
from millstab.stability import zoa
from millstab.stability.base import ENVELOPE_SCHEMA, Envelope
from millstab.update import Posterior, make_prior

SPEEDS = np.linspace(4000.0, 12000.0, 25)


def same(a, b, where: str = "") -> None:
    """Field-by-field equality of two result objects (arrays bit-equal with NaN = NaN, same shape)."""
    assert type(a) is type(b), (where, type(a), type(b))
    if isinstance(a, Parameterization):
        assert (a.base, a.free, a.axisymmetric) == (b.base, b.free, b.axisymmetric), where
        assert dict(a.bounds) == dict(b.bounds), where
    elif dataclasses.is_dataclass(a):
        for f in dataclasses.fields(a):
            same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, np.ndarray):
        assert a.shape == b.shape, (where, a.shape, b.shape)
        np.testing.assert_array_equal(a, b, err_msg=where)
    elif isinstance(a, dict):
        assert list(a) == list(b), where
        for k in a:
            same(a[k], b[k], f"{where}[{k}]")
    elif isinstance(a, (list, tuple)) and any(isinstance(x, np.ndarray) for x in a):  # ragged arrays
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            same(x, y, f"{where}[{i}]")
    elif isinstance(a, float) and math.isnan(a):
        assert math.isnan(b), where
    else:
        assert a == b, (where, a, b)


def roundtrip(obj, cls=None):
    """Through text, as a file would: strict JSON (no NaN/Infinity literals, no numpy types)."""
    text = json.dumps(obj.to_json(), allow_nan=False)
    return (cls or type(obj)).from_json(json.loads(text), "test.json")


# --- Fit --------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def ex3():
    return load_example("ex3")


def _fit(cfg, **changes) -> Fit:
    """A fit as lsq builds one (every field set), on Example 3 with four free parameters and own bounds."""
    par = Parameterization(cfg.structure, ("fn_x", "k_x", "zeta_x", "fn_y"), False, {"fn_x": (500.0, 1500.0)})
    est = par.theta0 * np.array([1.01, 0.98, 1.05, 0.99])
    corr = np.eye(4)
    corr[0, 1] = corr[1, 0] = -0.25
    fields = dict(
        method="lsq", par=par, estimate=est, start=par.theta0.copy(), mlae=0.123, rss=4.5e-3, iterations=7,
        evaluations=900, engine_calls=12, time_s=1.25, history_theta=np.vstack([par.theta0, est]),
        history_mlae=np.array([0.5, 0.123]), history_rss=np.array([0.1, 4.5e-3]), std_errors=est * 0.01,
        correlation=corr, condition=3.2e5, warnings=("some combination is weak", "the zero-order model..."),
        codes=("near_singular", "zoa_model"),
        alternatives=({"estimate": dict(zip(par.free, est * 1.1)), "mlae": 0.13, "rss": 5e-3, "why": "another"},),
        symmetry=None, test_cuts={"stable_cuts": 3, "chatter_cuts": 2, "stable_predicted_chatter": 0,
                                  "chatter_predicted_stable": 1},
        settings={"n_candidates": 32, "seed": 0, "schedule": [[4, 5], [1, 30]], "noise": None, "search": {"fn": 1.5},
                  "xy_tie_test": {"F": 1.5, "p_value": 0.01, "tied_pairs": 3, "chosen": "free"}},
        dof=10, n_points=14, noise={"source": "residuals", "estimated": 0.02, "stated": None, "assumed": None,
                                    "sigma": 0.02},
        checks={"rms": 0.018, "runs_test": {"runs": 6, "expected": 7.5, "z": -0.9, "p_value": 0.18}},
        cutting=cfg.cutting)
    return Fit(**{**fields, **changes})


def test_fit_round_trips_field_by_field(ex3):
    fit = _fit(ex3)
    doc = fit.to_json()
    assert doc["schema"] == FIT_SCHEMA == "millstab.fit/1"
    same(roundtrip(fit), fit)


@pytest.mark.parametrize("case", ["newton", "singular", "axisymmetric", "no_cutting"])
def test_fit_round_trips_its_special_values(ex3, case):
    """Newton (no standard errors, RSS history not computed: NaN ↔ null), an exactly singular JᵀJ
    (condition ∞ ↔ null beside standard errors), an axisymmetric parameterization, no cutting record."""
    if case == "newton":
        fit = _fit(ex3, method="newton", std_errors=None, correlation=None, condition=None,
                   history_rss=np.full(2, np.nan), dof=None, n_points=None, noise=None, checks={}, alternatives=())
    elif case == "singular":
        fit = _fit(ex3, condition=math.inf)
    elif case == "axisymmetric":
        s = Structure(x=(Mode(900.0, 1e7, 0.03),), y=(Mode(900.0, 1e7, 0.03),))
        par = Parameterization(s, (), True)
        fit = _fit(ex3, par=par, estimate=par.theta0 * 1.02, start=par.theta0, std_errors=par.theta0 * 0.01,
                   correlation=np.eye(3), history_theta=par.theta0[None], history_mlae=np.array([0.1]),
                   history_rss=np.array([0.01]), alternatives=())
        assert set(fit.to_json()["parameters"]) == {"fn", "k", "zeta"}
    else:
        fit = _fit(ex3, cutting=None, test_cuts=None, symmetry="x and y are interchangeable")
    same(roundtrip(fit), fit)


def legacy_fit_json(fit: Fit) -> dict:
    """The fit's JSON exactly as ``Fit.to_json`` wrote it before the schema (commit b98e4d3), kept here as
    the public contract the new JSON must still hold key for key and value for value."""
    s = fit.structure
    se = None if fit.std_errors is None else {n: float(v) for n, v in zip(fit.names, fit.std_errors)}
    return to_jsonable({
        "parameters": fit.parameters(), "mlae": float(fit.mlae), "rss": float(fit.rss), "method": fit.method,
        "free": list(fit.names), "units": dict(zip(fit.names, fit.units)), "estimate": fit.as_dict(),
        "start": fit.par.as_dict(fit.start), "std_errors": se, "correlation": fit.correlation,
        "condition": fit.condition, "iterations": int(fit.iterations), "evaluations": int(fit.evaluations),
        "engine_calls": int(fit.engine_calls), "time_s": float(fit.time_s), "warnings": list(fit.warnings),
        "alternatives": list(fit.alternatives), "symmetry": fit.symmetry, "test_cuts": fit.test_cuts,
        "structure": {d: [{"fn": m.fn, "k": m.k, "zeta": m.zeta} for m in getattr(s, d)] for d in ("x", "y")},
        "settings": fit.settings, "dof": fit.dof, "n_points": fit.n_points, "noise": fit.noise,
        "warning_codes": list(fit.codes), "checks": fit.checks,
        "cutting": None if fit.cutting is None else cutting_record(fit.cutting),
        "history": {"theta": fit.history_theta, "mlae": fit.history_mlae, "rss": fit.history_rss}})


def _only_added(doc: dict, legacy: dict) -> None:
    """``doc`` is ``legacy`` plus exactly ``schema``, ``parameterization`` and ``residuals`` (the per-point
    record, added since: keys may be added), every old value unchanged."""
    assert set(doc) - set(legacy) == {"schema", "parameterization", "residuals"} and not set(legacy) - set(doc)
    for key, value in legacy.items():
        assert doc[key] == value, key


def test_fit_json_keeps_every_field_it_had_before(ex3):
    for fit in (_fit(ex3), _fit(ex3, condition=math.inf, history_rss=np.array([np.nan, 1.0]))):
        _only_added(json.loads(json.dumps(fit.to_json(), allow_nan=False)), legacy_fit_json(fit))


def test_cli_identify_out_of_a_packaged_example_is_the_old_json_plus_schema(ex3, tmp_path, capsys):
    """``millstab identify example:ex3 <its packaged points> --out``: the file holds every field of the
    old contract with the old values (recomputed from the fit the file rebuilds) plus ``schema`` and
    ``parameterization``, and the rebuilt fit writes the file's content again."""
    from importlib.resources import files

    points = files("millstab.datasets") / "ex3_points.csv"
    out = tmp_path / "fit.json"
    assert main(["identify", "example:ex3", str(points), "--quiet", "--out", str(out)]) == 0
    capsys.readouterr()
    doc = json.loads(out.read_text())
    assert doc["schema"] == FIT_SCHEMA and (doc["config"], doc["points"]) == (ex3.name, str(points))
    back = Fit.from_json(doc, str(out))
    # the provenance is the fit's own (issue 26: the CLI added these keys, so the web download lacked them
    # and a rebuilt fit dropped them)
    assert back.provenance == {"config": ex3.name, "points": str(points)} and back.to_json() == doc
    _only_added({k: v for k, v in doc.items() if k not in ("config", "points")}, legacy_fit_json(back))
    assert doc["parameters"]["fn_x"] == pytest.approx(900, rel=0.05) and back.cutting == ex3.cutting


def test_fit_is_frozen_and_its_warnings_carry_codes(ex3):
    fit = _fit(ex3)
    with pytest.raises(dataclasses.FrozenInstanceError):
        fit.mlae = 0.0
    assert isinstance(fit.warnings, tuple) and isinstance(fit.codes, tuple)
    assert fit.notes[1] == {"code": "zoa_model", "message": "the zero-order model..."}
    assert fit.tie["chosen"] == "free" and not fit.tied
    with pytest.raises(ValueError, match="code"):
        _fit(ex3, codes=("near_singular",))  # a warning without its code


def test_diagnose_returns_a_new_fit_and_leaves_the_old_one(ex3):
    """The quality checks used to write dof, noise, checks and warnings into the fit in place."""
    pts = boundary_points(ex3.structure, ex3.cutting, np.linspace(3000, 21000, 6), noise=0.0, seed=0)
    problem = make_problem(ex3.structure, ex3.cutting, pts)
    fit = _fit(ex3, par=problem.par, estimate=problem.par.theta0, start=problem.par.theta0,
               std_errors=problem.par.theta0 * 0.01, correlation=np.eye(problem.p),
               history_theta=problem.par.theta0[None], history_mlae=np.zeros(1), history_rss=np.zeros(1),
               dof=None, n_points=None, noise=None, checks={}, alternatives=(), settings={})
    before = legacy_fit_json(fit)
    new = diagnose(fit, problem)
    assert new is not fit and legacy_fit_json(fit) == before
    assert (new.dof, new.n_points) == (0, 6) and "no_dof" in new.codes and new.codes[:2] == fit.codes
    assert len(new.codes) == len(new.warnings) and new.noise["source"] == "assumed"


def _tie_problem(noise_seed: int = 0):
    ex1 = load_example("ex1")  # slotting, x = y: the tie test applies
    pts = boundary_points(ex1.structure, ex1.cutting, np.linspace(3000, 12000, 12), noise=0.02, seed=noise_seed)
    return ex1, make_problem(ex1.structure, ex1.cutting, pts)


@pytest.mark.parametrize("chosen", ["tied", "free"])
def test_tie_test_makes_a_new_fit_and_drops_the_symmetry_warning_by_its_code(ex3, chosen):
    """prefer_tied used to write the test into the free fit's settings, and to drop the tied fit's
    symmetry warning by a substring of its text; a symmetry note worded otherwise was kept."""
    ex1, problem = _tie_problem()
    par = problem.par
    free = _fit(ex3, par=par, estimate=par.theta0, start=par.theta0, std_errors=par.theta0 * 0.01,
                correlation=np.eye(par.size), history_theta=par.theta0[None], history_mlae=np.zeros(1),
                history_rss=np.array([0.01]), rss=0.01, alternatives=(), settings={"seed": 0},
                warnings=("x and y are interchangeable here",), codes=("xy_symmetry",), cutting=ex1.cutting)

    def refit(tprob, start):
        return _fit(ex3, par=tprob.par, estimate=start, start=start, std_errors=start * 0.01,
                    correlation=np.eye(tprob.p), history_theta=start[None], history_mlae=np.zeros(1),
                    history_rss=np.array([0.0100001 if chosen == "tied" else 10.0]),
                    rss=0.0100001 if chosen == "tied" else 10.0, alternatives=(), settings={},
                    warnings=("interchangeable x and y (worded without the old marker)", "weak"),
                    codes=("xy_symmetry", "near_singular"), cutting=ex1.cutting)

    before = legacy_fit_json(free)
    fit = prefer_tied(problem, free, refit)
    assert legacy_fit_json(free) == before and "xy_tie_test" not in free.settings  # the free fit untouched
    assert fit.tie["chosen"] == chosen and fit.tied == (chosen == "tied")
    if chosen == "tied":
        assert fit.codes == ("xy_tied", "near_singular") and len(fit.warnings) == 2
        assert fit.symmetry_kind == "xy_swap"
    else:
        assert fit.codes == free.codes and fit.warnings == free.warnings
    same(roundtrip(fit), fit)


def test_fit_from_json_errors_name_source_and_field(ex3):
    doc = _fit(ex3).to_json()
    with pytest.raises(InputError, match="schema") as e:
        Fit.from_json({**doc, "schema": "millstab.design/1"}, "fit.json")
    assert "fit.json" in str(e.value)
    for key in ("estimate", "parameterization", "history", "warning_codes"):
        with pytest.raises(InputError, match=key) as e:
            Fit.from_json({k: v for k, v in doc.items() if k != key}, "fit.json")
        assert "fit.json" in str(e.value)
    with pytest.raises(InputError, match="estimate.k_x"):
        Fit.from_json({**doc, "estimate": {"fn_x": 1.0}}, "fit.json")
    with pytest.raises(InputError, match="warning_codes"):
        Fit.from_json({**doc, "warning_codes": ["near_singular"]}, "fit.json")
    with pytest.raises(InputError, match="mlae"):
        Fit.from_json({**doc, "mlae": "small"}, "fit.json")


def test_fit_file_written_before_the_schema_is_still_read(ex3):
    """An older ``identify --out`` file: no schema, no parameterization; the structure it identified
    with default bounds around it (what ``millstab design --fit`` did with it)."""
    fit = _fit(ex3)
    old = legacy_fit_json(fit)
    back = Fit.from_json(old, "old.json")
    np.testing.assert_array_equal(back.estimate, fit.estimate)
    assert back.par.free == fit.par.free and back.structure == fit.structure and back.codes == fit.codes
    assert back.par.bounds == Parameterization(fit.structure, fit.names).bounds


# --- Envelope ---------------------------------------------------------------------------------------
def test_envelope_round_trips_with_inf_and_undefined_frequencies(ex3):
    env = zoa.envelope(ex3.structure, ex3.cutting, SPEEDS)
    same(roundtrip(env), env)
    no_boundary = Envelope(np.array([1000.0, 2000.0]), np.array([np.inf, 1e-3]), np.array([-1, 3]),
                           np.array([np.nan, 812.5]))
    doc = no_boundary.to_json()
    assert doc["schema"] == ENVELOPE_SCHEMA and doc["depth"][0] == "inf" and doc["chatter_hz"][0] is None
    back = roundtrip(no_boundary)
    same(back, no_boundary)
    assert back.lobe.dtype.kind == "i"
    with pytest.raises(ValueError, match="depth"):
        Envelope(np.array([1000.0]), np.array([np.nan]), np.array([-1]), np.array([np.nan])).to_json()


def test_envelope_from_json_errors():
    env = Envelope(np.array([1000.0, 2000.0]), np.array([1e-3, 2e-3]), np.array([1, 2]), np.array([800.0, 900.0]))
    doc = env.to_json()
    with pytest.raises(InputError, match="env.json: schema"):
        Envelope.from_json({**doc, "schema": "millstab.fit/1"}, "env.json")
    with pytest.raises(InputError, match="env.json: depth"):
        Envelope.from_json({k: v for k, v in doc.items() if k != "depth"}, "env.json")
    with pytest.raises(InputError, match="env.json: lobe"):
        Envelope.from_json({**doc, "lobe": [1]}, "env.json")
    with pytest.raises(InputError, match="env.json: depth"):
        Envelope.from_json({**doc, "depth": [1e-3, None]}, "env.json")  # null is no depth


# --- SpeedDesign ------------------------------------------------------------------------------------
def test_speed_design_round_trips(ex3):
    par = Parameterization(ex3.structure, ("fn_x", "fn_y"))
    plan = design_speeds(par, ex3.cutting, np.linspace(5000, 15000, 21), 4, samples=4, seed=1,
                         existing_rpm=np.array([6000.0, 9000.0]))
    assert plan.to_json()["schema"] == DESIGN_SCHEMA and plan.to_json()["tests"][0]["tests"] >= 1
    same(roundtrip(plan), plan)
    # a parameter the existing points cannot determine: inf must survive; a criterion not computed: NaN
    odd = dataclasses.replace(plan, sigma_existing=np.array([np.inf, 0.01]), criterion_uniform=float("nan"),
                              sigma_uniform_mean=None)
    assert odd.to_json()["sigma_existing"][0] == "inf"
    same(roundtrip(odd), odd)
    with pytest.raises(ValueError, match="sigma_design"):
        dataclasses.replace(plan, sigma_design=np.array([np.nan, 0.1])).to_json()
    doc = plan.to_json()
    with pytest.raises(InputError, match="plan.json: schema"):
        SpeedDesign.from_json({**doc, "schema": None}, "plan.json")
    with pytest.raises(InputError, match="plan.json: weights"):
        SpeedDesign.from_json({k: v for k, v in doc.items() if k != "weights"}, "plan.json")


# --- sensitivity --------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def studies(ex3):
    rpm = np.linspace(5000, 15000, 12)
    return {"oat": oat(ex3.structure, ex3.cutting, rpm, [-0.01, 0.01]),
            "mc": monte_carlo(ex3.structure, ex3.cutting, rpm, n=9, seed=3),
            "sobol": sobol(ex3.structure, ex3.cutting, rpm, n=8, seed=2, num_resamples=10),
            "morris": morris(ex3.structure, ex3.cutting, rpm, trajectories=3, seed=2, num_resamples=10)}


@pytest.mark.parametrize("kind", ["oat", "mc", "sobol", "morris"])
def test_sensitivity_results_round_trip_and_keep_their_fields(studies, kind):
    res = studies[kind]
    doc = res.to_json()
    assert doc["schema"] == f"millstab.sensitivity.{kind}/1"
    # every field of the written summary is kept, same values (to_dict is what --out writes)
    legacy = json.loads(json.dumps(to_jsonable(res.to_dict())))
    for key, value in legacy.items():
        assert doc[key] == value or json.loads(json.dumps(doc[key])) == value, key
    same(roundtrip(res), res)


def test_mc_json_keeps_mean_and_sd_per_parameter_in_mm2(studies):
    res = studies["mc"]
    doc = json.loads(json.dumps(res.to_json(), allow_nan=False))
    for j, name in enumerate(res.names):
        col = [float(v) for v in res.mse_mm2[:, j]]  # by hand: mean and population SD (1/n) of the paths
        mean = sum(col) / len(col)
        assert doc[name]["mean"] == pytest.approx(mean, rel=1e-12)
        assert doc[name]["sd"] == pytest.approx(math.sqrt(sum((v - mean) ** 2 for v in col) / len(col)), rel=1e-9)
    assert doc["units"]["mse"] == "mm^2" and len(doc["paths"]["mse_mm2"]["fn_x"]) == res.n


def test_mc_with_one_path_has_undefined_sample_sd(studies):
    """One path: the sample SD is not defined (NaN ↔ null) and round-trips as such."""
    res = studies["mc"]
    one = MCResult(res.names, res.theta, res.t, res.eps, res.seed, 1, res.rpm, res.mse_mm2[:1], res.engine)
    assert one.to_json()["fn_x"]["sd_sample"] is None
    same(roundtrip(one), one)


@pytest.mark.parametrize("cls, kind, drop", [(OATResult, "oat", "mse_mm2"), (MCResult, "mc", "paths"),
                                             (SobolResult, "sobol", "blim"), (MorrisResult, "morris", "outputs")])
def test_sensitivity_from_json_errors(studies, cls, kind, drop):
    doc = studies[kind].to_json()
    with pytest.raises(InputError, match="s.json: schema"):
        cls.from_json({**doc, "schema": "millstab.sensitivity.other/1"}, "s.json")
    with pytest.raises(InputError, match=f"s.json: {drop}"):
        cls.from_json({k: v for k, v in doc.items() if k != drop}, "s.json")


# --- Posterior ------------------------------------------------------------------------------------------
def test_posterior_round_trips_and_carries_its_schema():
    cut = Cutting(2, 556.31e6, 0.404, 0.0, math.pi)
    prior = make_prior(Structure(x=(Mode(903.0, 12.53e6, 0.03),), y=(Mode(1050.0, 15e6, 0.04),)), cut)
    samples = np.exp(prior.sample(40, np.random.default_rng(0)))
    post = Posterior(prior, samples, "zoa", {"ess": 38.5, "stages": 3}, {"rpm": [5000.0], "depth_mm": [1.0],
                                                                         "label": ["stable"], "chatter_hz": [None]},
                     ("one-sided evidence",))
    doc = json.loads(json.dumps(post.to_json(), allow_nan=False))
    assert doc["schema"] == "millstab.posterior/3"
    back = Posterior.from_json(doc, "post.json")
    assert back.prior.to_dict() == prior.to_dict()
    same(dataclasses.replace(back, prior=prior), post)
    with pytest.raises(InputError, match="post.json schema"):
        Posterior.from_json({**doc, "schema": "millstab.fit/1"}, "post.json")


# --- the float conventions (millstab.jsondoc) ---------------------------------------------------------
def test_schema_floats_keep_inf_and_refuse_what_is_not_a_number():
    from millstab.jsondoc import floats_in, floats_out, number_in

    a = np.array([[1.5, -np.inf], [np.inf, 0.1]])
    assert floats_out(a, "a") == [[1.5, "-inf"], ["inf", 0.1]]
    np.testing.assert_array_equal(floats_in(json.loads(json.dumps(floats_out(a, "a"))), "a", ndim=2), a)
    assert floats_out(np.array([np.nan, 1.0]), "hz", nan_ok=True) == [None, 1.0]
    with pytest.raises(ValueError, match="x holds NaN"):
        floats_out(np.array([np.nan]), "x")
    for bad in (True, "nan", "Infinity", None, [1.0]):
        with pytest.raises(InputError, match="doc: x"):
            number_in(bad, "doc: x")
    assert math.isnan(number_in(None, "x", nan_ok=True))
    with pytest.raises(InputError, match="equal lengths"):
        floats_in([[1.0, 2.0], [3.0]], "t", ndim=2)
    with pytest.raises(InputError, match="2-d"):
        floats_in([1.0, 2.0], "t", ndim=2)


# --- one Result protocol over every type (issue 26) ----------------------------------------------------------
def _one_of_each(ex3, studies) -> dict:
    """{class name: a small instance} of every result in millstab.jsondoc.RESULTS, with the awkward values a
    file must keep (∞, NaN where "not defined", empty tuples)."""
    from millstab.simulate import CutResult, Labels
    from millstab.simulate.detect import Detection
    from millstab.update.decide import Recommendation

    cut = Cutting(2, 556.31e6, 0.404, 0.0, math.pi)
    prior = make_prior(Structure(x=(Mode(903.0, 12.53e6, 0.03),), y=(Mode(1050.0, 15e6, 0.04),)), cut)
    t = np.linspace(0.0, 1e-3, 5)
    return {
        "Fit": _fit(ex3, provenance={"config": "ex3", "points": "p.csv"}),
        "SpeedDesign": design_speeds(Parameterization(ex3.structure, ("fn_x",)), ex3.cutting,
                                     np.linspace(5000, 15000, 11), 2, samples=4, seed=1),
        "Envelope": Envelope(np.array([1000.0, 2000.0]), np.array([np.inf, 1e-3]), np.array([-1, 3]),
                             np.array([np.nan, 812.5])),
        "OATResult": studies["oat"], "MCResult": studies["mc"], "SobolResult": studies["sobol"],
        "MorrisResult": studies["morris"],
        "Posterior": Posterior(prior, np.exp(prior.sample(8, np.random.default_rng(0))), "zoa", {"stages": 2}),
        "Recommendation": Recommendation(6000.0, 1.5, 0.01, 9000.0, None, 0.05,
                                         {"rpm": 7000.0, "depth_mm": 2.0, "p_chatter": 0.3, "why": "most informative"},
                                         "risk", 0.02, 0.03, 350.5, 0.95, 100.0,
                                         ({"rpm": 6100.0, "depth_mm": 1.2, "cap_mm": 1.0, "half_width_rpm": 150.0,
                                           "binding": True},), 0.2,
                                         {"radial_immersion": 0.5, "milling": "down", "teeth": 2},
                                         ("the cuts contradict the hammer test: k_x 0.3×", "speeds beyond the tests")),
        "CutResult": CutResult(6000.0, 1e-3, 1e-4, 2, 4, t, t * 2, t * 3, t + 1, t - 1, False, 1050.0, (True, False)),
        "Labels": Labels(np.array([5000.0, 6000.0]), np.array([1e-3, 2e-3]), np.array(["stable", "chatter"]),
                         np.array(["stable", "chatter"]), np.array([np.nan, 812.5]), np.array(["", "hopf"]),
                         np.array([0.01, 3.0]), np.array([0.9, np.inf]), seed=4, multiplier=np.array([0.99, 1.2])),
        "Detection": Detection("stable", math.nan, "", 0.01, math.inf, 20, 200.0, np.array([0.0, 100.0]),
                               np.array([1e-6, 2e-6])),
        **_service_results(ex3, studies),
    }


def _service_results(ex3, studies) -> dict:
    """Lobes, Study, Heard and ModalResult (issue 26: they had no ``from_json``), small and built by hand, with
    a measured-FRF config (complex receptances), NaN "not heard" values and ragged stabilisation orders."""
    from millstab.api.listen import Heard
    from millstab.api.lobes import Lobes
    from millstab.api.sensitivity import Study
    from millstab.config import Config
    from millstab.listen import Listening
    from millstab.modal.fit import DirectionFit, FittedMode
    from millstab.modal.lscf import Stabilisation
    from millstab.modal.run import ModalResult
    from millstab.model import MeasuredFRF
    from millstab.sensitivity import table6

    f = np.linspace(500.0, 1500.0, 6)
    h = 1e-7 / ((1 - (f / 903.0) ** 2) + 2j * 0.03 * f / 903.0)  # a 1-DOF receptance (Im < 0 at resonance)
    frf_cfg = Config(Cutting(3, 6e8, 0.3, 0.2, math.pi, 1e4, 0.012),
                     Structure(frf=MeasuredFRF(f, h, h * 1.1, h * 0.01)), "tap", description="a measured tool")
    env = Envelope(np.array([1000.0, 2000.0]), np.array([np.inf, 1e-3]), np.array([-1, 3]), np.array([np.nan, 812.5]))
    modal_cfg = Config(ex3.cutting, ex3.structure, ex3.name, description=ex3.description)
    rpm = studies["mc"].rpm
    listening = Listening("stable", math.nan, 0.004, -math.inf, math.nan, 1.1, 6000.0, 6003.5, 2, 200.1, (0.1, 1.9),
                          (50.0, 100.0), 48000.0, f, f * 1e-9, f * 1e-11, np.array([True, False] * 3), np.zeros(0),
                          np.zeros(0))
    stab = Stabilisation(np.array([2, 4]), [np.array([900.0]), np.array([901.0, 1400.0])],
                         [np.array([0.03]), np.array([0.031, 0.02])], [np.zeros(1, int), np.array([2, 0])])
    fit = DirectionFit("x", "tap_x.csv", f, h, h * (1 + 1e-3j),
                       (FittedMode(903.0, 1.2e7, 0.03, -1.5, 80.0, 2, 2, 0.01),), 1e-9, -2e-10, 0.012, 3e-10, stab)
    return {
        **_tool_and_prediction(),
        "Lobes": Lobes(frf_cfg, "zoa", env, "sdm", dataclasses.replace(env, depth=np.array([5e-3, 1.1e-3]))),
        "Study": Study("mc", studies["mc"], modal_cfg, rpm, "zoa", "paper", "the paper's ex1", "ex1", table6(), True,
                       {"note": 1.5}),
        "Heard": Heard(listening, math.nan, "stable: keep the speed", "harmonizer"),
        "ModalResult": ModalResult({"x": fit}, Structure(x=(Mode(903.0, 1.2e7, 0.03, "structure.x[0]"),)),
                                   (500.0, 1500.0)),
    }


def _tool_and_prediction() -> dict:
    """``api.TipFRF`` (a carbide tool in a rigid holder: its config from text, the tip FRF computed) and
    ``api.Prediction`` (three cuts, one a boundary point, with a test day, a per-cut condition and provenance):
    they had no JSON (issue 26)."""
    import tomllib

    from millstab.api.predict import Prediction
    from millstab.api.tooltip import TipFRF
    from millstab.io.config import parse_config, tool_setup
    from millstab.points import PointSet
    from millstab.tooltip import peaks

    text = ('[cutting]\nteeth = 3\nkt = "700 MPa"\nkr = 0.3\nradial_immersion = 1\n[tool]\ndiameter = "12 mm"\n'
            'stickout = "45 mm"\nfluted_length = "26 mm"\nmaterial = "carbide"\nzeta = 0.01\n[holder]\nrigid = true\n')
    cfg, (tool, holder) = parse_config(text), tool_setup(tomllib.loads(text))
    frf = cfg.structure.frf
    fn, pk = peaks(frf.freq_hz, frf.xx, 2)
    cuts = PointSet(np.array([5000.0, 6000.0, 7000.0]), np.array([1.0, 2.0, 1.5]), np.array(["stable", "chatter", ""]),
                    chatter_hz=np.array([np.nan, 812.5, np.nan]), batch=np.array(["mon", "tue", ""]),
                    conditions={"radial_immersion": np.array([0.5, np.nan, 1.0])}, source="cuts.csv")
    return {"TipFRF": TipFRF(cfg, tool, holder, frf.freq_hz, frf.xx, fn, pk),
            "Prediction": Prediction(cuts, np.array([0.9, 0.2, 0.5]), np.array([0.1, 0.7, 0.4]), ("a warning",),
                                     np.array(["a/D 0.5", "a/D 1", "a/D 1"], dtype=object),
                                     {"config": "ex1", "points": "cuts.csv"})}


@pytest.fixture(scope="module")
def one_of_each(ex3, studies):
    return _one_of_each(ex3, studies)


def _registered():
    from millstab.jsondoc import RESULTS

    return [pytest.param(m, c, s, id=c) for m, c, s in RESULTS]


@pytest.mark.parametrize("module, name, schema", _registered())
def test_every_result_round_trips_and_refuses_another_schema(one_of_each, module, name, schema):
    """The Result protocol over every registered type: ``to_json()`` is strict JSON with its ``"schema"``,
    ``from_json(doc, source)`` rebuilds an equal object field by field (∞ and NaN kept), and a document of
    another schema, or no object at all, is an InputError naming the source (CutResult, Labels and
    Detection had ``to_dict`` only, Detection checked no schema and wrote growth ∞ as null; Recommendation
    had no ``from_json``: fails on the old code)."""
    import importlib

    cls = getattr(importlib.import_module(module), name)
    obj = one_of_each[name]
    assert type(obj) is cls
    doc = json.loads(json.dumps(obj.to_json(), allow_nan=False))
    assert doc["schema"] == schema
    back = cls.from_json(doc, "r.json")
    if name == "Posterior":  # the prior rebuilds from its own dict (it is not a dataclass field by field)
        assert back.prior.to_dict() == obj.prior.to_dict()
        back = dataclasses.replace(back, prior=obj.prior)
    same(back, obj)
    for bad in ({**doc, "schema": "millstab.other/1"}, [doc]):
        with pytest.raises(InputError, match="r.json"):
            cls.from_json(bad, "r.json")


def test_every_result_type_is_registered(one_of_each):
    """A class in src/ with both ``to_json`` and a ``from_json`` classmethod is in jsondoc.RESULTS (so the
    round-trip test and the docs table see it)."""
    import ast
    from pathlib import Path

    from millstab.jsondoc import RESULTS

    src = Path(__file__).resolve().parents[1] / "src" / "millstab"
    found = set()
    for path in src.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ClassDef):
                methods = {f.name for f in node.body if isinstance(f, ast.FunctionDef)}
                if {"to_json", "from_json"} <= methods:
                    found.add(node.name)
    assert found == {c for _, c, _ in RESULTS} == set(one_of_each)


def test_fit_table_and_summary_show_the_trades_units(ex3):
    """Fit.table(): the parameters in N/µm, Hz and bare ζ (the one units.SHOWN table; the CLI had its own
    copy); summary(): the lines the CLI prints under the table."""
    fit = _fit(ex3, dof=4, n_points=8, noise={"sigma": 0.02, "source": "stated"})
    header, cols = fit.table()
    assert header == ("parameter", "start", "estimate", "std_error", "unit")
    rows = dict(zip(cols[0], zip(*cols[1:])))
    j = fit.names.index("k_x")
    assert rows["k_x"][1] == pytest.approx(fit.estimate[j] / 1e6, rel=1e-15) and rows["k_x"][3] == "N/µm"
    assert rows["fn_x"][3] == "Hz" and rows["zeta_x"][3] == "" and rows["fn_y"][1] == fit.estimate[3]
    assert rows["k_x"][2] == pytest.approx(fit.std_errors[j] / 1e6, rel=1e-15)
    text = fit.summary().splitlines()
    assert text[0].startswith("MLAE 0.123 (mm, eq. 4)")
    assert text[1] == ("degrees of freedom: 8 boundary points − 4 parameters = 4; standard errors from the stated "
                       "depth noise (2 %)")
    assert "warning: some combination is weak" in text and any(t.startswith("alternative: fn_x=") for t in text)
    no_se = _fit(ex3, std_errors=None, correlation=None, condition=None)
    assert all(math.isnan(v) for v in no_se.table()[1][3])  # not computed: NaN, printed as "-"
    # loose(): relative standard errors of 1 % (the fixture's) are loose at 0.5 %, not at 5 %
    assert fit.loose(0.005) == fit.names and fit.loose(0.05) == () and no_se.loose(0.0) == ()


def test_speed_design_summary_and_table_say_what_the_plan_holds(one_of_each):
    """SpeedDesign.summary(): the lines `millstab design` prints (moved out of the door), recomputed here from
    the plan's fields; table(): the plan CSV, one row per distinct speed, the tests adding up to the plan."""
    plan = one_of_each["SpeedDesign"]
    lines = plan.summary().splitlines()
    assert lines[0].startswith("* = the parameters the plan pins") and f"{plan.samples} parameter samples" in lines[0]
    if not plan.uniform:
        assert f"({plan.criterion_design / plan.criterion_uniform:.2f}×)" in lines[1]
    assert f"efficiency of these {plan.rpm.size} tests ≥ {plan.efficiency:.3f}" in lines[1]
    speeds, counts = np.unique(plan.rpm, return_counts=True)
    shown = ", ".join(f"{r:.0f} ({c})" if c > 1 else f"{r:.0f}" for r, c in zip(speeds, counts))
    assert lines[-1] == "planned speeds, rev/min (tests): " + shown
    header, (rpm, tests, _) = plan.table()
    assert header == ("rpm", "tests", "predicted_depth_mm") and sum(tests) == plan.rpm.size
    np.testing.assert_allclose(rpm, speeds, atol=5e-4)


def test_simulate_results_present_themselves(one_of_each):
    """Detection.summary(), Labels.summary()/table(), CutResult.table(): what `millstab simulate` prints and
    writes, moved out of the door; a metric not defined is left out, never shown as 'nan'."""
    from millstab.simulate.detect import Detection

    det = one_of_each["Detection"]
    assert det.summary() == "stable; level 0.01"  # growth ∞ and the NaN multiplier are not printed
    chat = Detection("chatter", 845.04, "hopf", 0.31, 2.04, 20, 200.0, np.zeros(2), np.zeros(2), multiplier=1.01432)
    assert chat.summary() == "chatter at 845.0 Hz (hopf); growth 2.04 (|mu| 1.0143 per tooth period), level 0.31"
    # settled to round-off: its "growth" and |mu| > 1 are noise (an exploratory user read |mu| 1.0044 as unstable)
    quiet = Detection("stable", math.nan, "", 5e-14, 2.39, 20, 200.0, np.zeros(2), np.zeros(2), multiplier=1.0044)
    assert quiet.summary() == "stable; settled to round-off (level 5e-14 < 0.0001: no vibration left to grow)"
    lab = one_of_each["Labels"]
    assert lab.summary() == "2 cuts labelled: 1 stable, 0 marginal, 1 chatter"
    header, cols = lab.table()
    assert header == ["rpm", "depth_mm", "label", "chatter_hz"] and cols[2] == ["stable", "chatter"]
    np.testing.assert_array_equal(cols[1], [1.0, 2.0])
    cut = one_of_each["CutResult"]
    header, cols = cut.table()
    assert header == ["t_s", "x_m", "y_m", "fx_N", "fy_N"] and all(c is getattr(cut, n) for c, n in
                                                                   zip(cols, ("t", "x", "y", "fx", "fy")))


def test_posterior_table_shows_the_trades_units(one_of_each):
    """Posterior.table(): what `millstab update` prints (moved out of the door), recomputed from the samples:
    k in N/µm, fn in Hz, ζ bare, the prior's median beside the posterior mean, sd and 5/95 % quantiles."""
    post = one_of_each["Posterior"]
    header, cols = post.table()
    assert header == ("parameter", "prior", "mean", "sd", "q05", "q95", "unit")
    assert cols[0] == list(post.names)
    j = post.names.index("k_x")
    k = post.samples[:, j]
    assert cols[6][j] == "N/µm" and cols[6][post.names.index("fn_x")] == "Hz"
    assert cols[2][j] == pytest.approx(k.mean() / 1e6, rel=1e-12)
    assert cols[1][j] == pytest.approx(post.prior.median[j] / 1e6, rel=1e-12)
    np.testing.assert_allclose([cols[4][j], cols[5][j]], np.quantile(k, [0.05, 0.95]) / 1e6, rtol=1e-12)


# --- figure(ax=None): every result draws itself (issue 26) -----------------------------------------------
#: the results that draw themselves from what they hold (a figure that needs a new computation, e.g. the SLD of
#: a fit, a design's SLD or a P(stable) map, is assembled by the service: api.fit_figure, design_figure, map_figure)
FIGURED = ("Fit", "OATResult", "MCResult", "SobolResult", "MorrisResult", "Posterior", "Lobes", "Study", "Heard",
           "ModalResult", "SpeedDesign", "Envelope", "Recommendation", "CutResult", "Labels", "Prediction", "TipFRF",
           "Detection")


@pytest.fixture(scope="module")
def figured(one_of_each):
    """Every registered result (``api.Prediction`` and ``api.TipFRF`` among them since they read back too)."""
    return one_of_each


def _data_axes(fig) -> list:
    """The axes of ``fig`` that hold drawn data: a line with points, a filled or scattered collection, bars."""
    def has_data(ax) -> bool:
        return (any(len(line.get_xdata()) for line in ax.lines) or any(len(c.get_paths()) for c in ax.collections)
                or len(ax.patches) > 0 or len(ax.images) > 0)
    return [ax for ax in fig.axes if ax.get_visible() and has_data(ax)]


@pytest.mark.parametrize("name", FIGURED)
def test_every_result_draws_its_figure_and_into_a_given_ax(figured, name):
    """``figure()`` returns a matplotlib Figure whose axes hold data; ``figure(ax)`` draws into the caller's
    figure, in ax's place, leaving the caller's other axes alone (fails on the old code: Lobes, Heard,
    ModalResult, Posterior, Fit and the sensitivity results had no figure method, Study's took no ax; then
    SpeedDesign, Envelope, Recommendation, CutResult, Labels, Prediction and TipFRF had none)."""
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure

    obj = figured[name]
    fig = obj.figure()
    try:
        assert isinstance(fig, Figure) and _data_axes(fig), name
    finally:
        plt.close(fig)
    host = Figure(figsize=(12, 6))
    left, right = host.add_subplot(1, 2, 1), host.add_subplot(1, 2, 2)
    left.plot([0, 1], [0, 1])
    assert obj.figure(right) is host
    drawn = _data_axes(host)
    assert left in drawn and len(drawn) >= 2, name
    assert all(ax.get_position().x0 >= left.get_position().x1 for ax in drawn if ax is not left)


# --- table(): the rows a user puts in a spreadsheet (issue 26) -------------------------------------------
TABLED = ("Fit", "SpeedDesign", "Posterior", "CutResult", "Labels", "Lobes", "Study", "Heard", "ModalResult",
          "Recommendation", "Prediction", "TipFRF", "OATResult", "MCResult", "SobolResult", "MorrisResult",
          "Envelope", "Detection")


@pytest.mark.parametrize("name", TABLED)
def test_every_result_has_a_table_of_equal_columns(figured, name):
    """``table()`` is ``(header, columns)``: one name per column, every column as long as the others, and
    ``io.results.csv_text`` writes it (fails on the old code for Study, Heard, ModalResult, Recommendation and
    the four sensitivity results)."""
    from millstab.io.results import csv_text

    header, cols = figured[name].table()
    assert len(header) == len(cols) > 1 and len(set(header)) == len(header), name
    assert len({len(c) for c in cols}) == 1 and len(cols[0]) > 0, name
    assert csv_text(header, cols).splitlines()[0] == ",".join(header)


def test_study_tables_hold_each_methods_numbers(figured, studies):
    """Study.table(): one row per parameter; the numbers are the result's own (recomputed from its fields):
    OAT's MSE per change, MC's mean/SD/SEM and the paper's Table 6, Sobol's indices, Morris' μ*."""
    from millstab.api.sensitivity import Study

    mc = figured["Study"]
    header, cols = mc.table()
    res = mc.result
    assert cols[0] == list(res.names)
    assert header[:4] == ["parameter", "mean_mm2", "sd_mm2", "sem_mm2"]
    np.testing.assert_allclose(cols[1], res.mse_mm2.mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(cols[3], res.mse_mm2.std(axis=0, ddof=1) / math.sqrt(res.mse_mm2.shape[0]), rtol=1e-12)
    if "paper_mean_mm2" in header:
        assert cols[header.index("paper_mean_mm2")] == [mc.paper[n]["mean"] for n in res.names]
    for method in ("oat", "sobol", "morris"):
        r = studies[method]
        header, cols = dataclasses.replace(mc, method=method, result=r, paper=None).table()
        assert cols[0] == list(r.names), method
        if method == "oat":
            assert header[1:] == [f"mse_mm2_eps{e:+g}" for e in r.eps]
            np.testing.assert_array_equal(np.array(cols[1:]).T, r.mse_mm2)
        elif method == "sobol":
            np.testing.assert_array_equal(cols[header.index("minimum_ST")], r.minimum["ST"])
        else:
            np.testing.assert_array_equal(cols[header.index("mse_mu_star")], r.outputs["mse"]["mu_star"])
    assert isinstance(mc, Study)


def test_heard_modal_and_recommendation_tables(figured):
    """Heard: one row per recording (NaN "not heard" kept); ModalResult: one row per mode, k in N/µm;
    Recommendation: the cut and the next test."""
    heard = figured["Heard"]
    header, cols = heard.table()
    row = dict(zip(header, (c[0] for c in cols)))
    assert row["label"] == "stable" and math.isnan(row["chatter_hz"]) and row["rpm_heard"] == 6003.5
    assert row["suggested_rpm"] is heard.suggested_rpm and row["reason"] == heard.reason
    modal = figured["ModalResult"]
    header, cols = modal.table()
    m = modal.fits["x"].modes[0]
    assert header[:4] == ["direction", "fn_hz", "k_N_per_um", "zeta"] and cols[0] == ["x"]
    assert (cols[1][0], cols[2][0], cols[3][0]) == (m.fn, pytest.approx(m.k / 1e6, rel=1e-15), m.zeta)
    rec = figured["Recommendation"]
    header, cols = rec.table()
    assert header == ["cut", "rpm", "depth_mm", "p_chatter", "why"]
    assert cols[1] == [rec.rpm, rec.next_test["rpm"]] and cols[2] == [rec.depth_mm, rec.next_test["depth_mm"]]
    assert cols[3] == [rec.p_chatter, 0.3] and cols[4] == [f"limited by {rec.limited_by}", "most informative"]
    bare = dataclasses.replace(rec, next_test={"rpm": 7000.0, "depth_mm": 2.0})  # a hand-written file's next test
    assert math.isnan(bare.table()[1][3][1]) and bare.table()[1][4][1] == ""


def test_a_cut_with_its_detection_draws_three_panels_in_the_callers_place(one_of_each):
    """CutResult.figure(detection=…): trace, once-per-tooth map and spectrum (``millstab simulate --plot``),
    into a new figure or split into the caller's ax; without a detection the trace alone."""
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure

    cut, det = one_of_each["CutResult"], one_of_each["Detection"]
    fig = cut.figure(detection=det, title="a cut")
    try:
        assert len(_data_axes(fig)) == 3 and fig.get_suptitle() == "a cut"
    finally:
        plt.close(fig)
    host = Figure()
    host.add_subplot(1, 2, 1)
    right = host.add_subplot(1, 2, 2)
    assert cut.figure(right, detection=det, title="not the caller's") is host
    assert right not in host.axes and len(host.axes) == 4 and host.get_suptitle() == ""
    fig = cut.figure()
    try:
        assert len(_data_axes(fig)) == 1
    finally:
        plt.close(fig)


def test_prediction_summary_is_what_predict_prints(figured):
    """Prediction.summary() (moved out of `millstab predict`): the P(stable) range and the Brier score of the
    two labelled cuts, by hand: P(label chatter) 0.1 for a stable cut, 0.7 for a chatter cut → (0.1² + 0.3²)/2
    = 0.05; their own chatter rate 0.5 as a constant → 0.25."""
    lines = figured["Prediction"].summary().splitlines()
    assert lines[0] == "3 cuts: P(stable) 0.200-0.900"
    assert lines[1].startswith("  against the 2 labelled cuts: Brier score 0.0500 (their own chatter rate as a "
                               "constant: 0.2500)")


def test_sensitivity_results_summarise_themselves(studies):
    """The lines `millstab sensitivity` prints under its header come from each result's summary() (moved out of
    api/sensitivity.py): OAT one row per change, MC its mean/SD/SEM rows and the paper's only with Table 6,
    Sobol S1 and ST of both outputs, Morris μ* and σ of both."""
    from millstab.sensitivity import table6

    oat_lines = studies["oat"].summary().splitlines()
    r = studies["oat"]
    assert len(oat_lines) == 1 + r.eps.size
    assert [float(v) for v in oat_lines[1].split()[2:]] == pytest.approx(r.mse_mm2[:, 0], abs=6e-6)
    mc = studies["mc"]
    plain, with_paper = mc.summary().splitlines(), mc.summary(table6(), False).splitlines()
    assert plain[0] == f"Monte Carlo sensitivity: N = 9, t = {mc.t:g}, eps = {mc.eps:g}, seed 3"
    assert [float(v) for v in plain[2].split()[2:]] == pytest.approx(mc.mse_mm2.mean(axis=0), abs=6e-6)
    assert not any("paper Table 6" in x for x in plain)
    if set(mc.names) == set(table6()):
        assert any(x.endswith("[other structure]") for x in with_paper)
    sob = studies["sobol"].summary().splitlines()
    assert [x.split()[0:2] for x in sob[1:5]] == [["MSE", "S1"], ["MSE", "ST"], ["min", "b_lim"], ["min", "b_lim"]]
    mor = studies["morris"].summary().splitlines()
    assert [x.split()[:2] for x in mor[1:]] == [["mse", "mu*"], ["mse", "sigma"], ["minimum", "mu*"],
                                                ["minimum", "sigma"]]


def test_cut_summary_is_the_line_simulate_prints(one_of_each):
    """CutResult.summary(detection): the cut (6000 rpm, 1 mm, 0.1 mm/tooth, the periods simulated) and the
    verdict, with "the vibration diverged" only when it did (moved out of `millstab simulate`)."""
    cut, det = one_of_each["CutResult"], one_of_each["Detection"]
    assert cut.summary(det) == f"6000 rpm, 1 mm, 0.1 mm/tooth, {cut.periods} tooth periods: stable; level 0.01"
    gone = dataclasses.replace(cut, diverged=True)
    assert gone.summary() == f"6000 rpm, 1 mm, 0.1 mm/tooth, {cut.periods} tooth periods; the vibration diverged"


def test_envelope_summary_names_its_lowest_limit(one_of_each):
    """Envelope.summary(): the lowest finite limit and its speed; ∞ (no boundary) is counted, never the minimum."""
    env = one_of_each["Envelope"]
    assert env.summary() == "2 speeds 1000..2000 rpm; minimum limit 1 mm at 2000 rpm; no limit at 1 speed"
    none = dataclasses.replace(env, depth=np.full(2, np.inf))
    assert none.summary() == "2 speeds 1000..2000 rpm; no limit at any of the 2 speeds"


def test_every_registered_result_presents_itself(figured):
    """Every type in jsondoc.RESULTS is in the figure and table tests and has summary() -> str (issue 26: a new
    result without one of them fails here, not in a user's notebook)."""
    from millstab.jsondoc import RESULTS

    names = {c for _, c, _ in RESULTS}
    assert names <= set(FIGURED) and names <= set(TABLED) and set(FIGURED) == set(TABLED) == set(figured)
    for name in sorted(set(figured)):
        text = figured[name].summary()
        assert isinstance(text, str) and text.strip(), name
