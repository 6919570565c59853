"""The engine contract, checked on EVERY registered engine with the same tests: the 1-DOF closed form
where the zero-order model is exact, the scaling laws, batch = single, speed-order invariance and
bad-input errors. A dummy engine registered in a fixture shows that a new engine needs no other file:
the contract checks run on it (and the closed form catches that it is wrong) and `millstab lobes
--engine dummy` accepts it."""

from __future__ import annotations

import csv
import math
import types

import numpy as np
import pytest

import millstab.stability as stab
from millstab.cli import main
from millstab.errors import InputError
from millstab.frf import ModalBatch
from millstab.model import Conditions, Cutting, MeasuredFRF, Mode, Structure
from millstab.stability import ENGINES, get_engine, zoa

#: relative tolerance per engine: zoa root-finds to machine level; the time-domain engines bracket the
#: root to ~1e-4 (RTOL), so a ratio of two of their depths is good to ~2e-4
RTOL = {"zoa": 1e-9}
TIME_DOMAIN_RTOL = 1e-3

FN, ZETA, K = 922.0, 0.011, 1.34e6
KT, KR = 6e8, 1.0 / 3.0
ONE_DOF = Structure(x=(Mode(FN, K, ZETA),))
TWO_DOF = Structure(x=(Mode(FN, K, ZETA),), y=(Mode(1100.0, 1.6 * K, 0.02),))
#: four-tooth slotting: [A(t)] is constant, so the zero-order boundary is exact for every engine
SLOT4 = Cutting(4, KT, KR, 0.0, math.pi)
HALF3 = Cutting.from_immersion(3, KT, KR, 0.5, "down")
SPEEDS = np.array([7000.0, 9500.0, 13000.0, 17500.0])


def tol(name: str) -> float:
    return RTOL.get(name, TIME_DOMAIN_RTOL)


def lobe_bottoms(cut: Cutting, ks) -> np.ndarray:
    """x-only slotting: ν = α_xx G = −πKr G; Re G is least at r² = 1 + 2ζ, where b = b_min; the lobe
    bottoms are at Ω_k = 60ω*/(N(ε* + 2kπ)), ε* = π + 2 arg ν(ω*) (zero-order theory, written here
    from the closed form, not from the engine)."""
    r = math.sqrt(1 + 2 * ZETA)
    nu = -math.pi * cut.kr / (K * complex(1 - r * r, 2 * ZETA * r))
    eps = math.pi + 2 * math.atan2(nu.imag, nu.real)
    return np.array([60.0 * 2 * math.pi * FN * r / (cut.teeth * (eps + 2 * math.pi * k)) for k in ks])


# --- the checks (each takes an engine object, so a plug-in's tests can call them too) --------------


def check_closed_form(eng, rtol: float) -> None:
    """1-DOF four-tooth slotting: b_min = 8kζ(1+ζ)/(N Kt Kr) at the lobe bottoms, above it elsewhere."""
    b_min = 8 * K * ZETA * (1 + ZETA) / (SLOT4.teeth * KT * KR)
    bottoms = lobe_bottoms(SLOT4, (1, 2))
    env = eng.envelope(ONE_DOF, SLOT4, bottoms)
    np.testing.assert_allclose(env.depth, b_min, rtol=rtol)
    between = eng.envelope(ONE_DOF, SLOT4, 0.5 * (bottoms[:-1] + bottoms[1:])).depth
    assert np.all(between > b_min * (1 + 10 * rtol))


def check_scaling(eng, rtol: float) -> None:
    """k × c ⇒ b × c (ν ∝ 1/k) and Kt × c ⇒ b / c (b ∝ 1/Kt), at partial immersion, two modes."""
    c = 2.5
    base = eng.envelope(TWO_DOF, HALF3, SPEEDS).depth
    stiff = Structure(x=tuple(Mode(m.fn, m.k * c, m.zeta) for m in TWO_DOF.x),
                      y=tuple(Mode(m.fn, m.k * c, m.zeta) for m in TWO_DOF.y))
    np.testing.assert_allclose(eng.envelope(stiff, HALF3, SPEEDS).depth, base * c, rtol=rtol)
    sharp = Cutting(HALF3.teeth, HALF3.kt * c, HALF3.kr, HALF3.entry, HALF3.exit)
    np.testing.assert_allclose(eng.envelope(TWO_DOF, sharp, SPEEDS).depth, base / c, rtol=rtol)


def check_batch_equals_single(eng, rtol: float) -> None:
    other = Structure(x=(Mode(800.0, 2 * K, 0.03),), y=(Mode(1300.0, K, 0.015),))
    batch = eng.envelope_batch(ModalBatch.from_structures([TWO_DOF, other]), HALF3, SPEEDS)
    assert batch.shape == (2, SPEEDS.size)
    for row, s in zip(batch, (TWO_DOF, other)):
        np.testing.assert_allclose(row, eng.envelope(s, HALF3, SPEEDS).depth, rtol=rtol)


def check_speed_order(eng, rtol: float) -> None:
    perm = np.array([2, 0, 3, 1])
    ordered = eng.envelope(TWO_DOF, HALF3, SPEEDS)
    shuffled = eng.envelope(TWO_DOF, HALF3, SPEEDS[perm])
    np.testing.assert_array_equal(shuffled.rpm, SPEEDS[perm])
    np.testing.assert_allclose(shuffled.depth, ordered.depth[perm], rtol=rtol)
    np.testing.assert_allclose(eng.envelope_batch(ModalBatch.from_structures([TWO_DOF]), HALF3, SPEEDS[perm])[0],
                               ordered.depth[perm], rtol=rtol)


def check_bad_input(eng) -> None:
    for rpm, shown in (([5000.0, -1.0], "-1"), ([], "[]"), ([5000.0, float("nan")], "nan"),
                       (["5000", "x"], "'x'"), ({"rpm": 5000.0}, "5000")):
        with pytest.raises(InputError, match="rpm") as err:
            eng.envelope(TWO_DOF, HALF3, rpm)
        assert shown in str(err.value)
    with pytest.raises(InputError, match="rpm"):
        eng.envelope_batch(ModalBatch.from_structures([TWO_DOF]), HALF3, [0.0])
    f = np.linspace(300.0, 3000.0, 4001)
    g = zoa.structure_receptance(ONE_DOF, f)[:, 0, 0]
    measured = Structure(frf=MeasuredFRF(f, g, g))
    if eng.accepts_measured_frf:
        assert np.all(np.isfinite(eng.envelope(measured, HALF3, SPEEDS[:2]).depth))
    else:
        with pytest.raises(InputError, match="structure"):
            eng.envelope(measured, HALF3, SPEEDS[:2])


def check_capabilities(eng, name: str) -> None:
    assert isinstance(eng, stab.Engine) and not stab.missing_attributes(eng)
    assert eng.name == name
    for flag in ("exact_xy_exchange", "accepts_measured_frf", "reports_lobe_type", "reports_progress", "cheap",
                 "reports_chatter_frequency", "time_averaged"):
        assert isinstance(getattr(eng, flag), bool), flag
    assert 0 < eng.depth_accuracy < 0.01
    for n_speeds in (1, 50, 10**6):
        rows = eng.chunk_rows(n_speeds)
        assert isinstance(rows, int) and rows >= 1
    assert eng.chunk_rows(10**6) * 10**6 <= 10**8 or eng.chunk_rows(10**6) == 1  # bounded memory per call


def check_chatter_frequency(eng, rtol: float) -> None:
    """An engine declaring ``reports_chatter_frequency``: ``envelope_batch_hz`` gives the batched depths
    and, per row, the chatter frequency that ``envelope`` reports for that row's structure."""
    if not eng.reports_chatter_frequency:
        assert not stab.missing_attributes(eng)
        return
    other = Structure(x=(Mode(FN * 1.05, K, ZETA),), y=(Mode(1100.0, 1.6 * K, 0.02),))
    batch = ModalBatch.from_structures([TWO_DOF, other])
    depth, hz = eng.envelope_batch_hz(batch, HALF3, SPEEDS)
    assert depth.shape == hz.shape == (2, SPEEDS.size)
    np.testing.assert_allclose(depth, eng.envelope_batch(batch, HALF3, SPEEDS), rtol=1e-12)
    for row, s in enumerate((TWO_DOF, other)):
        env = eng.envelope(s, HALF3, SPEEDS)
        np.testing.assert_allclose(depth[row], env.depth, rtol=rtol)
        np.testing.assert_allclose(hz[row], env.chatter_hz, rtol=rtol)
    # a chatter frequency lies near the structure's modes (the limiting lobe is a structural one)
    assert np.all((hz > 0.8 * FN) & (hz < 1.3 * 1100.0))


#: three conditions of one call: four-tooth slotting, three-tooth half-immersion down milling, four-tooth
#: 25 % up milling; 9 500 rpm appears under two of them (two columns)
MIXED = Conditions.of((SLOT4, HALF3, Cutting.from_immersion(4, KT, KR, 0.25, "up")), [0, 1, 2, 1, 0, 2, 1])
MIXED_RPM = np.array([7000.0, 9500.0, 13000.0, 17500.0, 9500.0, 8000.0, 11000.0])


def check_conditions(eng, rtol: float) -> None:
    """Per-column conditions: a mixed call equals the single-condition calls column for column (the zero-order
    engine bit for bit: the grid it shares reaches 4·f_n,max, above every tooth-passing frequency here), and
    permuting the columns (with their conditions) permutes the result; a wrong count of conditions is refused."""
    other = Structure(x=(Mode(800.0, 2 * K, 0.03),), y=(Mode(1300.0, K, 0.015),))
    batch = ModalBatch.from_structures([TWO_DOF, other])
    mixed = eng.envelope_batch(batch, MIXED, MIXED_RPM)
    assert mixed.shape == (2, MIXED_RPM.size)
    for cut, cols in MIXED.groups():
        single = eng.envelope_batch(batch, cut, MIXED_RPM[cols])
        if rtol <= 1e-9:
            np.testing.assert_array_equal(mixed[:, cols], single)
        else:
            np.testing.assert_allclose(mixed[:, cols], single, rtol=rtol)
    assert mixed[0, 1] != mixed[0, 4]  # one speed, two conditions: two different limits
    perm = np.array([3, 6, 0, 4, 2, 5, 1])
    np.testing.assert_allclose(eng.envelope_batch(batch, MIXED.subset(perm), MIXED_RPM[perm]), mixed[:, perm],
                               rtol=rtol)
    if eng.reports_chatter_frequency:
        depth, hz = eng.envelope_batch_hz(batch, MIXED, MIXED_RPM)
        np.testing.assert_allclose(depth, mixed, rtol=1e-12)
        for cut, cols in MIXED.groups():
            np.testing.assert_allclose(hz[:, cols], eng.envelope_batch_hz(batch, cut, MIXED_RPM[cols])[1], rtol=rtol)
    with pytest.raises(InputError, match="conditions"):
        eng.envelope_batch(batch, MIXED, MIXED_RPM[:-1])


CHECKS = {"closed_form": check_closed_form, "scaling": check_scaling, "batch": check_batch_equals_single,
          "speed_order": check_speed_order, "chatter_frequency": check_chatter_frequency,
          "conditions": check_conditions}


# --- every registered engine ------------------------------------------------------------------------


@pytest.mark.parametrize("name", list(ENGINES))
@pytest.mark.parametrize("check", list(CHECKS))
def test_contract(name, check, monkeypatch):
    # the spectral engine solves a time-invariant cutting (SLOT4) by the zero-order model; its collocation is what
    # the closed form checks here (the hand-over: tests/test_spectral_invariant.py)
    from millstab.stability import spectral

    monkeypatch.setattr(spectral, "INVARIANT_BY_ZOA", False)
    CHECKS[check](get_engine(name), tol(name))


@pytest.mark.parametrize("name", list(ENGINES))
def test_bad_input_and_capabilities(name):
    eng = get_engine(name)
    check_bad_input(eng)
    check_capabilities(eng, name)


def test_builtin_engines_and_their_capabilities():
    assert {"zoa", "sdm", "spectral"} <= set(ENGINES)
    assert [n for n in ENGINES if get_engine(n).exact_xy_exchange] == ["zoa"]
    assert get_engine("spectral").reports_lobe_type and not get_engine("zoa").reports_lobe_type
    assert get_engine("sdm").reports_progress and not get_engine("sdm").cheap
    assert [n for n in ENGINES if get_engine(n).reports_chatter_frequency] == ["zoa", "spectral"]
    assert [n for n in ENGINES if get_engine(n).time_averaged] == ["zoa"]
    with pytest.raises(InputError, match="engine") as err:
        get_engine("fast")
    assert all(n in str(err.value) for n in ENGINES) and "'fast'" in str(err.value)


def test_envelope_is_reexported_from_zoa():
    from millstab.stability.base import Envelope
    from millstab.stability.zoa import Envelope as FromZoa

    assert FromZoa is Envelope and stab.Envelope is Envelope


def test_register_rejects_an_object_without_the_contract():
    with pytest.raises(InputError, match="envelope_batch"):
        stab.register(types.SimpleNamespace(name="half", envelope=zoa.envelope))
    assert "half" not in ENGINES
    # declaring chatter frequencies needs the entry point that returns them
    m = _dummy_module()
    m.reports_chatter_frequency = True
    with pytest.raises(InputError, match="envelope_batch_hz"):
        stab.register(m)
    assert "dummy" not in ENGINES


# --- a plug-in engine: one module-like object, one register call ------------------------------------

SCALE = 0.9


def _dummy_module() -> types.ModuleType:
    """ZOA scaled by 0.9: a complete engine by the contract (and wrong, which the closed form sees)."""
    from plugin_engines import zoa_plugin

    m = zoa_plugin("dummy")

    def envelope(structure, cutting, rpm):
        e = zoa.envelope(structure, cutting, rpm)
        return stab.Envelope(e.rpm, SCALE * e.depth, e.lobe, e.chatter_hz)

    m.envelope = envelope
    # written for one Cutting; by_condition makes it take per-column Conditions (the plug-in's one line)
    m.envelope_batch = stab.by_condition(lambda batch, cutting, rpm: SCALE * zoa.envelope_batch(batch, cutting, rpm))
    return m


@pytest.fixture
def dummy():
    eng = stab.register(_dummy_module())
    yield eng
    stab.unregister("dummy")
    assert "dummy" not in ENGINES


def test_a_registered_engine_runs_the_contract(dummy):
    assert "dummy" in ENGINES and get_engine("dummy") is dummy
    for name, check in CHECKS.items():
        if name == "closed_form":
            with pytest.raises(AssertionError):  # the contract catches a 10 % error
                check(dummy, tol("dummy"))
        else:
            check(dummy, tol("dummy"))
    check_bad_input(dummy)
    check_capabilities(dummy, "dummy")


def test_cli_lobes_accepts_a_registered_engine(dummy, tmp_path):
    out = tmp_path / "sld.csv"
    rc = main(["lobes", "example:ex1", "--rpm", "3000:3500:100", "--engine", "dummy", "--compare", "zoa",
               "--out", str(out)])
    assert rc == 0
    rows = list(csv.DictReader(out.open()))
    ours = np.array([float(r["blim_mm"]) for r in rows])
    theirs = np.array([float(r["blim_mm_zoa"]) for r in rows])
    np.testing.assert_allclose(ours, SCALE * theirs, rtol=1e-12)


def test_cli_lobes_rejects_an_unregistered_engine(capsys):
    assert main(["lobes", "example:ex1", "--rpm", "3000:3500:100", "--engine", "dummy"]) == 2
    err = capsys.readouterr().err
    assert "dummy" in err and "zoa" in err


def test_check_engine_name_sees_registered_engines_before_import(dummy):
    """The one name check of validate, design and sensitivity: a plug-in registered after import passes, an unknown
    name is refused naming the option, the value and every registered engine (the plug-in among them)."""
    assert stab.check_engine_name("dummy") == "dummy"
    with pytest.raises(InputError) as err:
        stab.check_engine_name("fem", field="--compare")
    text = str(err.value)
    assert "--compare" in text and "fem" in text
    assert all(name in text for name in ("zoa", "sdm", "spectral", "dummy"))
    with pytest.raises(InputError, match="must be one of"):
        stab.check_engine_name(None)


def test_sensitivity_streams_in_the_engines_own_chunks(dummy, monkeypatch):
    """Sensitivity asks the engine for its chunk size (it used the zero-order one for every engine)."""
    from millstab.params import Parameterization
    from millstab.sensitivity._core import depths_chunked, pin

    calls = []
    batch_fn = dummy.envelope_batch
    monkeypatch.setattr(dummy, "chunk_rows", lambda n_speeds: 3)
    monkeypatch.setattr(dummy, "envelope_batch", lambda b, c, r: calls.append(b.size) or batch_fn(b, c, r))
    par = Parameterization(TWO_DOF)
    rows = par.theta0[None] * np.linspace(0.9, 1.1, 7)[:, None]
    d = depths_chunked(pin("dummy", par, HALF3, SPEEDS, rows, at=par.theta0), rows)
    assert calls == [3, 3, 1]
    np.testing.assert_allclose(d, SCALE * zoa.envelope_batch(par.batch(rows), HALF3, SPEEDS), rtol=1e-12)


def test_exchange_map_follows_the_capability_not_the_name(dummy):
    """The exact x↔y exchange is offered for any engine declaring ``exact_xy_exchange`` (it was "zoa" only)."""
    from millstab.identify.objective import exchange_map
    from millstab.params import Parameterization

    par = Parameterization(Structure(x=(Mode(FN, K, ZETA),), y=(Mode(1100.0, 1.6 * K, 0.02),)))
    ref = exchange_map(par, SLOT4, "zoa")
    assert ref is not None
    got = exchange_map(par, SLOT4, "dummy")
    assert got is not None and all(np.array_equal(a, b) for a, b in zip(got, ref))
    assert exchange_map(par, SLOT4, "sdm") is None
