"""Virtual recordings end to end: ``simulate --record`` writes what a microphone would hear of a
simulated cut, and ``listen`` on that file agrees with the simulation's own detector (label, and the
chatter frequency within max(2 Hz, 0.5 %)). The full study (≥ 200 cuts) is benchmarks/bench_listen.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from millstab import api


@pytest.mark.slow
def test_simulate_record_then_listen_agrees_with_the_simulation(tmp_path, capsys):
    from millstab.cli import main
    from millstab.io.recordings import read_recording

    cfg = api.config("example:ex1")
    for depth, sensor in ((1.0, "microphone"), (8.0, "microphone"), (8.0, "accelerometer")):
        wav = tmp_path / f"cut_{depth}_{sensor}.wav"
        assert main(["simulate", "example:ex1", "--rpm", "9000", "--depth", str(depth), "--revs", "300",
                     "--record", str(wav), "--sensor", sensor, "--seed", "1"]) == 0
        _, det = api.simulate_cut(cfg, 9000.0, depth, revs=300)
        x, fs = read_recording(wav)
        assert fs == 48000 and abs(x.size / fs - 2.0) < 0.01 and 0.49 < np.abs(x).max() <= 0.5 + 1 / 32767
        r = api.listen_file(wav, 9000.0, cfg.cutting.teeth).listening
        assert r.label == det.label, (depth, sensor, r.label, det.label)
        assert abs(r.rpm_heard / 9000.0 - 1) < 1e-4
        if det.label == "chatter":
            assert abs(r.chatter_hz - det.chatter_hz) <= max(2.0, 0.005 * det.chatter_hz)
        else:
            assert math.isnan(r.chatter_hz) or r.score < 0.02


def test_sensor_model_is_seeded_quantised_and_checked():
    from millstab.errors import InputError
    from millstab.simulate.record import record

    cfg = api.config("example:ex1")
    res, _ = api.simulate_cut(cfg, 9000.0, 1.0, revs=20)
    a = record(res, seed=3)
    b = record(res, seed=3)
    c = record(res, seed=4)
    assert np.array_equal(a.signal, b.signal) and not np.array_equal(a.signal, c.signal)
    q = a.signal * 32767
    assert np.allclose(q, np.round(q)) and abs(np.abs(a.signal).max() - 0.5) < 1e-4
    with pytest.raises(InputError, match="sensor"):
        record(res, sensor="laser")
    with pytest.raises(InputError, match="fs"):
        record(res, fs=4000)


def test_the_structure_chooses_the_member_never_the_label():
    """With the structure known (``listen --config``, ``update``) only the member of a flip chatter reported
    changes: the label is the recording's. The cut is bench_listen --seed 3 cut 60 (the 1-DOF benchmark in
    two-tooth slotting, 22 515 rpm, 1.2 × the limit, a quasi-periodic chatter about 1.5 f_T), as the bench
    draws it. A version of the flip-member rule shadowed the near-line candidates with a mask of its own
    and heard this cut stable at 0.4 Hz with the structure (chatter at 1123 Hz without)."""
    from millstab.listen import listen
    from millstab.model import Cutting, Mode, Structure
    from millstab.simulate import detect, simulate_cut
    from millstab.simulate.record import record

    fn, zeta, mass = 922.0, 0.011, 0.03993
    st = Structure(x=(Mode(fn, mass * (2 * math.pi * fn) ** 2, zeta),))
    rpm = 22514.582737900048
    res = simulate_cut(st, Cutting(2, 6e8, 1 / 3, 0.0, math.pi), rpm, 0.004266088697373444, 1e-4, revs=750.486091263335,
                       perturbation=0.011475263617380218)
    rec = record(res, sensor="microphone", fs=44100, noise=0.06997487725972362, hum=0.0, runout=0.05788250103644084,
                 mains_hz=50.0, direction_deg=10.896140778875687, seed=60)
    assert detect(res).label == "chatter"
    alone = listen(rec.signal, rec.fs, 22625.243192490627, 2)
    known = listen(rec.signal, rec.fs, 22625.243192490627, 2, structure=st)
    assert alone.label == known.label == "chatter", (alone.label, known.label, known.chatter_hz)
    f_half = 0.5 * known.tooth_hz  # the structure moves a flip chatter to another odd multiple of f_T/2 only
    same = abs(known.chatter_hz - alone.chatter_hz) <= 2.0
    flip = abs(known.chatter_hz / f_half - round(known.chatter_hz / f_half)) * f_half <= 2.0
    assert same or (flip and round(known.chatter_hz / f_half) % 2 == 1), (alone.chatter_hz, known.chatter_hz)


def _bench_listen():
    """benchmarks/bench_listen.py as a module (its truth functions are tested here)."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_listen.py"
    spec = importlib.util.spec_from_file_location("bench_listen_for_test", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _displacement(parts, f_t=500.0, m=40, periods=1280):
    """A fake simulated cut (what the bench's truth reads): x(t) = Σ a sin(2π f(t) t) over ``parts``, each
    (amplitude, frequency [Hz] or a function of the tooth period index giving it, phase-continuous), plus a
    synchronous line at 2 f_T that the non-synchronous residual removes; y = 0."""
    from types import SimpleNamespace

    n = periods * m + 1
    dt = 1.0 / (f_t * m)
    k = np.arange(n) // m
    x = 0.3 * np.sin(2 * np.pi * 2 * f_t * np.arange(n) * dt)
    for a, f in parts:
        fk = np.asarray(f(k) if callable(f) else np.full(n, float(f)))
        x = x + a * np.sin(2 * np.pi * np.cumsum(fk) * dt)
    res = SimpleNamespace(x=x, y=np.zeros(n), steps_per_tooth=m, tooth_hz=f_t, fn_max_hz=1000.0)
    return res, SimpleNamespace(chatter_hz=1030.0, window_periods=64)


def test_the_truth_is_one_frequency_only_when_every_window_agrees():
    """The bench's truth of a chatter frequency (the displacement's non-synchronous peak over the detector's last
    64 tooth periods) is held to max(2 Hz, 0.5 %) only where it is one frequency: every 64-period window of the
    last half peaks within the tolerance of it, with no line of another frequency within 1 dB. A steady line is
    one frequency (and found to 0.5 Hz); a chatter whose frequency moves between two values from window to window
    (quasi-periodic) is not, nor are two steady lines 0.45 dB apart; a second line 6 dB down does not count."""
    b = _bench_listen()
    steady, det = _displacement([(1.0, 1030.0)])
    tset = b.truth_set_hz(steady, det)
    assert tset.size and np.all(np.abs(tset - 1030.0) <= 0.5), tset
    assert b.one_frequency(tset, 1030.0)
    # the frequency alternates between 1030 and 1080 Hz every 64 tooth periods (the windows' own length)
    wander, det = _displacement([(1.0, lambda k: np.where((k // 64) % 2 == 0, 1030.0, 1080.0))])
    tset = b.truth_set_hz(wander, det)
    assert np.any(np.abs(tset - 1030.0) <= 2.0) and np.any(np.abs(tset - 1080.0) <= 2.0), tset
    assert not b.one_frequency(tset, 1080.0) and not b.one_frequency(tset, 1030.0)
    tied, det = _displacement([(1.0, 1030.0), (10 ** (-0.45 / 20), 1530.0)])
    assert not b.one_frequency(b.truth_set_hz(tied, det), 1030.0)
    apart, det = _displacement([(1.0, 1030.0), (0.5, 1530.0)])
    assert b.one_frequency(b.truth_set_hz(apart, det), 1030.0)
