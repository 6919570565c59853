"""Sensitivity studies: one-at-a-time, Monte Carlo, Sobol/Morris (millstab.sensitivity).

Checks that can fail: exact zeros and closed forms (scaling every stiffness by c scales every depth by
c, so MSE = (c − 1)²·mean(b²) in mm²), agreement with brute-force loops over single-structure
envelopes, seeding, chunk independence, indices of test functions with known answers, and rejection
of out-of-range settings before any engine call.
"""

from __future__ import annotations

import sys
import warnings

import numpy as np
import pytest

from millstab.datasets import load_example
from millstab.errors import InputError
from millstab.params import Parameterization
from millstab.sensitivity import (PAPER_EPS_GRID, match_example, monte_carlo, morris, mse_mm2, oat, predicted_theta,
                                  sobol, sobol_function, sobol_indices, table6)
from millstab.stability import zoa

CFG = load_example("ex1")
RPM = np.linspace(3000, 12000, 46)  # small speed set keeps the tests fast
THETA = predicted_theta("ex1")  # the paper's Ex.1 predicted values


def test_paper_constants():
    assert np.allclose(PAPER_EPS_GRID, np.arange(-0.2, 0.2001, 0.05))
    assert np.allclose(THETA, [910.4, 13.44e6, 0.0287, 910.4, 13.44e6, 0.0286])
    assert table6()["fn_x"] == {"mean": 0.06610, "sd": 0.03202}
    assert match_example(CFG.cutting, CFG.structure) == "ex1"
    assert match_example(load_example("ex3").cutting, CFG.structure) is None


def test_oat_zero_eps_is_exactly_zero_and_rows_match_single_envelopes():
    res = oat(CFG.structure, CFG.cutting, RPM, [-0.1, 0.0, 0.05], theta=THETA)
    assert res.mse_mm2.shape == (6, 3)
    assert np.all(res.mse_mm2[:, 1] == 0.0)
    assert np.all(res.mse_mm2[:, [0, 2]] > 0)
    par = Parameterization(CFG.structure)
    ref = zoa.envelope(par.structure(THETA), CFG.cutting, RPM).depth
    for j, e in ((0, -0.1), (4, 0.05), (5, -0.1)):
        th = THETA.copy()
        th[j] *= 1 + e
        b = zoa.envelope(par.structure(th), CFG.cutting, RPM).depth
        k = list(res.eps).index(e)
        assert res.mse_mm2[j, k] == pytest.approx(np.mean(((b - ref) * 1e3) ** 2), rel=1e-9)
    assert np.allclose(res.depth_ref_mm, ref * 1e3)


def test_oat_all_stiffness_closed_form():
    """k_x and k_y both × c ⇒ every depth × c, so MSE = (c − 1)² mean(b²) [mm²]."""
    par = Parameterization(CFG.structure, free=("k",), axisymmetric=True)
    eps = np.array([-0.2, -0.05, 0.1, 0.25])
    res = oat(par, CFG.cutting, RPM, eps)
    b2 = np.mean(res.depth_ref_mm ** 2)
    assert np.allclose(res.mse_mm2[0], eps ** 2 * b2, rtol=1e-8, atol=0)
    # with k_x alone the depth does not scale exactly: the closed form must not hold
    single = oat(CFG.structure, CFG.cutting, RPM, eps)
    assert not np.allclose(single.mse_mm2[1], eps ** 2 * b2, rtol=1e-3)


def test_oat_natural_frequency_dominates():
    res = oat(CFG.structure, CFG.cutting, RPM, theta=THETA)
    i = list(res.eps).index(0.05)
    m = dict(zip(res.names, res.mse_mm2[:, i]))
    assert min(m["fn_x"], m["fn_y"]) > 20 * max(m["k_x"], m["k_y"], m["zeta_x"], m["zeta_y"])


def test_mc_matches_brute_force_loop():
    n, t, eps, seed = 20, 0.1, 0.01, 7
    res = monte_carlo(CFG.structure, CFG.cutting, RPM, n=n, t=t, eps=eps, seed=seed, theta=THETA)
    par = Parameterization(CFG.structure)
    rng = np.random.default_rng(seed)
    star = THETA * (1 + t * (2 * rng.random((n, 6)) - 1))  # the documented draw: uniform in [(1-t)p, (1+t)p]
    mse = np.empty((n, 6))
    for i in range(n):
        ref = zoa.envelope(par.structure(star[i]), CFG.cutting, RPM).depth
        for j in range(6):
            th = star[i].copy()
            th[j] *= 1 + eps
            b = zoa.envelope(par.structure(th), CFG.cutting, RPM).depth
            mse[i, j] = np.mean(((b - ref) * 1e3) ** 2)
    assert np.allclose(res.mse_mm2, mse, rtol=1e-9, atol=1e-15)
    assert np.allclose(res.mean, mse.mean(axis=0), rtol=1e-9)
    assert np.allclose(res.sd, mse.std(axis=0, ddof=0), rtol=1e-9)  # the paper's SD is 1/N
    assert np.allclose(res.sem, mse.std(axis=0, ddof=1) / np.sqrt(n), rtol=1e-9)


def test_mc_seeded_and_chunk_independent():
    kw = dict(n=30, theta=THETA)
    a = monte_carlo(CFG.structure, CFG.cutting, RPM, seed=3, **kw)
    b = monte_carlo(CFG.structure, CFG.cutting, RPM, seed=3, chunk_paths=7, **kw)
    c = monte_carlo(CFG.structure, CFG.cutting, RPM, seed=4, **kw)
    assert np.array_equal(a.mse_mm2, b.mse_mm2)
    assert np.array_equal(a.mean, b.mean) and np.array_equal(a.sd, b.sd)
    assert not np.allclose(a.mean, c.mean)
    d = a.to_dict(paper=table6())
    for name in ("fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y"):
        assert set(d[name]) >= {"mean", "sd", "sem"}
        assert d[name]["mean"] == a.mean[a.names.index(name)]
    assert d["seed"] == 3 and d["n"] == 30 and d["paper"]["k_y"]["sd"] == 0.00026
    # ordering of the paper's Table 6: fn ≫ k > ζ
    m = dict(zip(a.names, a.mean))
    assert m["fn_x"] > 20 * m["k_x"] > 20 * m["zeta_x"]
    assert m["fn_y"] > 20 * m["k_y"] > 20 * m["zeta_y"]


def test_mc_running_mean_ends_at_mean():
    res = monte_carlo(CFG.structure, CFG.cutting, RPM[:10], n=12, seed=1)
    k, mean, sem = res.running(50)
    assert k[-1] == 12 and np.allclose(mean[-1], res.mean) and np.allclose(sem[-1], res.sem)
    assert np.allclose(mean[0], res.mse_mm2[0])


@pytest.mark.parametrize("kw, field", [
    (dict(t=1.0), "t"),
    (dict(t=-0.1), "t"),
    (dict(eps=40.0), "eps"),  # ζ 0.0287·1.1·41 ≥ 1
    (dict(eps=-1.0), "eps"),
    (dict(eps=0.0), "eps"),  # no change: an all-zero table and NaN ratios (an exploratory test)
    (dict(n=1), "n"),
    (dict(seed=-1), "seed"),
])
def test_mc_rejects_before_any_work(monkeypatch, kw, field):
    def boom(*a, **k):
        raise AssertionError("engine called")

    monkeypatch.setattr("millstab.forward.Pinned.__call__", boom)
    args = dict(n=10, t=0.1, eps=0.01, seed=0, theta=THETA) | kw
    with pytest.raises(InputError) as exc:
        monte_carlo(CFG.structure, CFG.cutting, RPM, **args)
    assert exc.value.field == field


def test_zeta_corner_names_parameter():
    with pytest.raises(InputError, match="zeta_x would reach"):
        monte_carlo(CFG.structure, CFG.cutting, RPM, n=10, t=0.5, eps=22.0)
    with pytest.raises(InputError) as exc:
        oat(CFG.structure, CFG.cutting, RPM, [0.1, 40.0])
    assert exc.value.field == "eps" and "zeta" in str(exc.value)
    with pytest.raises(InputError) as exc:
        sobol(CFG.structure, CFG.cutting, RPM, n=8, bounds={"zeta_y": (0.5, 1.2)})
    assert exc.value.field == "bounds.zeta_y"
    with pytest.raises(InputError):
        sobol(CFG.structure, CFG.cutting, RPM, n=100)  # not a power of 2


def test_mse_mm2_handles_missing_boundary():
    a = np.array([[1e-3, np.inf, 2e-3]])
    assert mse_mm2(a, a)[0] == 0.0
    assert mse_mm2(a, np.array([[2e-3, np.inf, 2e-3]]))[0] == pytest.approx(1 / 3)
    assert np.isinf(mse_mm2(a, np.array([[1e-3, 1e-3, 2e-3]]))[0])


def test_sobol_indices_match_salib_exactly():
    from SALib.analyze import sobol as sa

    from millstab.sensitivity.globalsa import problem, sobol_sample

    prob = problem(["a", "b", "c"], np.array([[0, 1], [0, 2], [1, 3.0]]))
    X = sobol_sample(prob, 64, seed=5)
    Y = np.column_stack([X[:, 0] + X[:, 1] ** 2 * X[:, 2], np.sin(X @ [1.0, 2.0, 3.0])])
    ours = sobol_indices(3, Y, seed=5)
    for col in range(2):
        ref = sa.analyze(prob, Y[:, col], calc_second_order=False, seed=6)
        for key in ("S1", "S1_conf", "ST", "ST_conf"):
            assert np.allclose(ours[key][col], ref[key], rtol=1e-10, atol=1e-12), key


def test_sobol_wrapper_on_functions_with_known_indices():
    # Ishigami (a = 7, b = 0.1) on [-π, π]^3: S1 = 0.3139, 0.4424, 0; ST = 0.5576, 0.4424, 0.2437
    def ishigami(X):
        return np.sin(X[:, 0]) + 7 * np.sin(X[:, 1]) ** 2 + 0.1 * X[:, 2] ** 4 * np.sin(X[:, 0])

    res = sobol_function(ishigami, ["x1", "x2", "x3"], np.array([[-np.pi, np.pi]] * 3), n=4096, seed=1)
    assert np.allclose(res["S1"], [0.3139, 0.4424, 0.0], atol=0.04)
    assert np.allclose(res["ST"], [0.5576, 0.4424, 0.2437], atol=0.04)
    # additive linear: S1 = ST = a_i² var_i / Σ, sum 1
    a = np.array([1.0, 2.0, 3.0])
    lin = sobol_function(lambda X: X @ a, ["a", "b", "c"], np.array([[0, 1.0]] * 3), n=1024, seed=2)
    assert np.allclose(lin["S1"], a ** 2 / np.sum(a ** 2), atol=0.02)
    assert abs(lin["S1"].sum() - 1) < 0.03


def test_sobol_on_sld_flank_fn_dominates():
    """Axisymmetric tool (fn, k, zeta tied in x and y): on a lobe flank b_lim is governed by fn."""
    par = Parameterization(CFG.structure, axisymmetric=True)
    ref = zoa.envelope(CFG.structure, CFG.cutting, np.linspace(7000, 10000, 301))
    # a flank: speed of steepest |db/dΩ| between 8000 and 8800 rpm (rising side of the 9 000 rpm lobe)
    sel = (ref.rpm > 8000) & (ref.rpm < 8800)
    flank = float(ref.rpm[sel][np.argmax(np.abs(np.gradient(ref.depth, ref.rpm))[sel])])
    res = sobol(par, CFG.cutting, [flank, 6000.0], n=256, t=0.05, seed=0)
    s1, st = res.blim["S1"][0], res.blim["ST"][0]
    assert res.names == ("fn", "k", "zeta")
    assert s1[0] > 0.8 and st[0] > 0.8
    assert st[0] > 5 * max(st[1], st[2])
    assert abs(s1.sum() - 1) < 0.15
    assert res.blim["S1"].shape == (2, 3) and np.all(res.blim["ST_conf"] >= 0)
    assert res.mse["ST"][0] == max(res.mse["ST"])


def test_morris_ranks_fn_first():
    res = morris(CFG.structure, CFG.cutting, RPM, trajectories=10, seed=2, theta=THETA)
    mu = dict(zip(res.names, res.outputs["mse"]["mu_star"]))
    assert min(mu["fn_x"], mu["fn_y"]) > max(mu["k_x"], mu["k_y"], mu["zeta_x"], mu["zeta_y"])
    d = res.to_dict()
    assert d["evaluations"] == 70 and set(d["outputs"]) == {"mse", "minimum"}


@pytest.mark.slow
def test_sdm_studies_do_not_depend_on_the_chunks():
    """The interrupted-cutting engines choose their discretisation per call (sdm: the steps follow the
    batch's highest natural frequency), so a study that evaluated each chunk alone gave other numbers for
    other chunk sizes (this test failed so); the study now pins it once (``Forward.pinned``): bit-identical.
    Sobol and Morris go through the same pinned chunks (``depths_chunked``)."""
    rpm = np.array([6000.0, 11000.0])
    kw = dict(n=2, theta=THETA, engine="sdm", t=0.2, seed=5)
    one = monte_carlo(CFG.structure, CFG.cutting, rpm, chunk_paths=1, **kw)
    whole = monte_carlo(CFG.structure, CFG.cutting, rpm, chunk_paths=2, **kw)
    assert np.array_equal(one.mse_mm2, whole.mse_mm2)


@pytest.mark.parametrize("study, kw, message", [
    (monte_carlo, dict(n=10_000, t=0.1, eps=0.01), "needs ~0.00192 GB of memory (10,000 paths x 6 parameters, "
                                                   "kept), this machine has 0.001 GB available; use at most 4,166"),
    (sobol, dict(n=1024, t=0.1), "needs ~0.0482 GB of memory (8,192 structures x 46 speeds), this machine has "
                                 "0.001 GB available; use at most 16"),
    (morris, dict(trajectories=200, t=0.1), "needs ~0.00264 GB of memory (1,400 structures x 46 speeds), this "
                                            "machine has 0.001 GB available; use at most 60"),
])
def test_studies_refuse_more_samples_than_memory_before_sampling(monkeypatch, study, kw, message):
    """A Sobol design of n = 2^22 at the config's 1 201 speeds sampled for 4.6 min and then failed on a
    300 GiB allocation (MemoryError); a study now says what it needs and the largest n that fits, first."""
    from millstab import bounds

    def boom(*a, **k):
        raise AssertionError("sampled or evaluated")

    monkeypatch.setattr(bounds, "available_memory", lambda: 1e6)
    for target in ("millstab.sensitivity.globalsa.sobol_sample", "SALib.sample.morris.sample",
                   "millstab.sensitivity.montecarlo._block"):
        monkeypatch.setattr(target, boom)
    with pytest.raises(InputError) as exc:
        study(CFG.structure, CFG.cutting, RPM, seed=0, theta=THETA, **kw)
    assert exc.value.field == "n" and message in str(exc.value), str(exc.value)


def test_every_result_document_carries_its_units():
    """The Sobol document had no ``units`` (OAT, MC and Morris had theirs) and Morris' named not its bounds'."""
    from millstab.sensitivity import SobolResult

    rpm = np.array([5000.0, 9000.0])
    so = sobol(CFG.structure, CFG.cutting, rpm, n=2, seed=0, theta=THETA).to_json()
    assert so["units"] == {"bounds": "Hz, N/m, -", "mse": "mm^2", "minimum": "mm", "blim": "mm", "indices": "-",
                           "depth_nominal_mm": "mm"}
    assert SobolResult.from_json(so).n == 2
    mo = morris(CFG.structure, CFG.cutting, rpm, trajectories=2, seed=0, theta=THETA).to_json()
    assert mo["units"] == {"mse": "mm^2", "minimum": "mm", "bounds": "Hz, N/m, -"}
    mc = monte_carlo(CFG.structure, CFG.cutting, rpm, n=2, seed=0, theta=THETA).to_json()
    assert mc["units"] == {"mse": "mm^2", "theta": "Hz, N/m, -"}


@pytest.mark.parametrize("study, kw, message", [
    (monte_carlo, dict(n=2, eps=1.0), r"eps = 1 is a relative change of \+100 % \(parameter x 2\); changes are "
                                      r"fractions \(0.01 is 1 %\): did you mean 0.01 \(1 %\)\?"),
    (oat, dict(eps=[0.0, 5.0, 20.0]), r"eps = 20 is a relative change of \+2000 % \(parameter x 21\); changes are "
                                      r"fractions \(0.01 is 1 %\): did you mean 0.2 \(20 %\)\?"),
])
def test_a_percentage_given_as_a_fraction_is_warned(monkeypatch, study, kw, message):
    """``--eps 1`` (the paper's 1 %) or an OAT grid 0:20:5 in % doubled (or ×21) a parameter without a word."""
    from millstab.errors import UnitWarning

    class Stop(Exception):
        pass

    def stop(*a, **k):
        raise Stop

    monkeypatch.setattr(sys.modules["millstab.sensitivity.oat"], "depths", stop)  # the package's oat is the function
    monkeypatch.setattr(sys.modules["millstab.sensitivity.montecarlo"], "pin", stop)
    with pytest.warns(UnitWarning, match=message), pytest.raises(Stop):
        study(CFG.structure, CFG.cutting, RPM, theta=THETA, **kw)
    with warnings.catch_warnings():  # a fraction is not warned about
        warnings.simplefilter("error", UnitWarning)
        with pytest.raises(Stop):
            study(CFG.structure, CFG.cutting, RPM, theta=THETA, **{**kw, "eps": 0.01 if study is monte_carlo else
                                                                      [-0.25, 0.25]})


def test_a_misspelt_bound_name_is_blamed_on_bounds(monkeypatch):
    """``--bound fnx=800:900`` said "parameter = 'fnx' is invalid" without naming the bounds that held it."""
    monkeypatch.setattr("millstab.sensitivity.globalsa.sobol_sample", lambda *a, **k: 1 / 0)
    with pytest.raises(InputError) as exc:
        sobol(CFG.structure, CFG.cutting, RPM, n=2, bounds={"fnx": (800.0, 900.0)}, theta=THETA)
    assert exc.value.field == "bounds" and exc.value.value == "fnx"
    assert str(exc.value) == "bounds = 'fnx' is invalid: unknown name; available: fn_x, k_x, zeta_x, fn_y, k_y, zeta_y"
