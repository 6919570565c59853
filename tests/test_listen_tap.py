"""``listen --tap``: a tap recorded by the cut's own sensor measures the sensor path (a room's reflections), and the
chatter family's member reported is then the displacement's even where the room notches it
(:mod:`millstab.listen.tap`). Each test fails on the code before the tap: there the member in the notch lost
to a neighbour the room lifts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from millstab.errors import InputError
from millstab.listen import listen, sensor_path
from millstab.model import Cutting, Mode, Structure

FS = 48000
#: a hand-made room: one reflection of gain 0.9 after 9/(2·880) s = 5.1 ms (a wall 0.9 m further than the direct
#: path): notches (−20 dB) every 195.6 Hz through 880 Hz, maxima (+5.6 dB) between them, at 587 and 1173 Hz
#: (not the simulator's room)
DELAY, GAIN = 9.0 / (2 * 880.0), 0.9


def _room(f):
    return 1.0 + GAIN * np.exp(-2j * np.pi * np.asarray(f, float) * DELAY)


def _mode(fn=830.0, zeta=0.02, k=1e7):
    return Structure(x=(Mode(fn, k, zeta),))


def _cut_in_notch(seconds=2.0, seed=0):
    """A three-tooth cut at 6000 rpm (f_T = 300 Hz) whose Hopf chatter's displacement peaks at 880 Hz (1.0),
    with members 1180 Hz (0.5) and 580 Hz (0.3): acceleration amplitudes ∝ displacement × f², each line through
    the room's complex gain, forced lines 1/k, runout, white noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * FS)) / FS
    x = np.zeros(t.size)
    forced = [(k * 300.0, 1.0 / k) for k in range(1, 13)] + [(k * 100.0, 0.3 / k**2) for k in (1, 2, 4, 5)]
    members = [(880.0, 1.0), (1180.0, 0.5), (580.0, 0.3)]
    a880 = math.sqrt(sum(a * a for _, a in forced[:12]))  # the chatter as loud as the forced vibration at 880 Hz
    lines = forced + [(f, a880 * d * (f / 880.0) ** 2) for f, d in members]
    for f, a in lines:
        h = _room(f)
        x += a * abs(h) * np.sin(2 * math.pi * f * t + np.angle(h) + rng.uniform(0, 2 * math.pi))
    x += 0.01 * a880 * rng.standard_normal(t.size)
    return x / np.abs(x).max() * 0.5


def _tap(structure, seconds=1.0, hit_s=0.2, noise=1e-3, seed=1):
    """A hammer hit on ``structure`` (x) at ``hit_s``: the acceleration −(2πf)² G_xx(f) through the same room."""
    from millstab.frf import structure_receptance

    n = int(seconds * FS)
    f = np.fft.rfftfreq(n, 1.0 / FS)
    g = np.zeros(f.size, complex)
    g[1:] = structure_receptance(structure, f[1:])[:, 0, 0]
    spec = -((2 * np.pi * f) ** 2) * g * _room(f) * np.exp(-2j * np.pi * f * hit_s) * (f < 0.4 * FS)
    x = np.fft.irfft(spec, n)
    x = x / np.abs(x).max() * 0.5
    return x + noise * np.random.default_rng(seed).standard_normal(n)


def test_a_member_in_a_room_notch_is_heard_with_the_tap():
    """The displacement's peak (880 Hz) sits in the room's −20 dB notch and its neighbour 1180 Hz on a +5.5 dB
    maximum: by power / f⁴ the recording alone hears 1180 Hz; the tap, through the same room, gives 880 Hz with
    or without the structure (and the label is the recording's either way)."""
    cut, st = _cut_in_notch(), _mode()
    path = sensor_path(_tap(st), FS, cut_fs=FS)
    alone = listen(cut, FS, 6000.0, 3)
    assert alone.label == "chatter" and abs(alone.chatter_hz - 1180.0) <= 2.0, alone.chatter_hz  # the old answer
    for kw in ({}, {"structure": st}):
        r = listen(cut, FS, 6000.0, 3, tap=path, **kw)
        assert abs(r.chatter_hz - 880.0) <= 2.0, (kw, r.chatter_hz)
        assert (r.label, r.score, r.trend) == (alone.label, alone.score, alone.trend)


def test_the_tap_measures_the_room():
    """The path measured, P_tap / (f⁴ Σ|G|²) with the structure known, is the room's |H|² to 0.5 dB (median)
    between 500 and 2000 Hz outside its notches (where the tap's noise bounds the depth seen); from the tap
    alone (all-pole envelope of the structure) to 2 dB."""
    st = _mode()
    path = sensor_path(_tap(st), FS)
    f = np.arange(500.0, 2000.0, 2.5)
    room = 20 * np.log10(np.abs(_room(f)))
    f, room = f[room > -10], room[room > -10]
    for w, tol in ((path.weight(f, st), 0.5), (path.weight(f), 2.0)):
        e = 10 * np.log10(w / f**4) - room
        e -= np.median(e)
        assert np.median(np.abs(e)) < tol, np.median(np.abs(e))
    assert path.hits_s == (0.2,)


def test_several_hits_are_averaged_and_found():
    st = _mode()
    one = _tap(st, seconds=1.0, hit_s=0.2)
    two = np.concatenate([one, _tap(st, seconds=1.0, hit_s=0.3, seed=2)])
    path = sensor_path(two, FS)
    assert len(path.hits_s) == 2 and abs(path.hits_s[0] - 0.2) < 1e-3 and abs(path.hits_s[1] - 1.3) < 1e-3


def test_a_bad_tap_is_refused_clearly():
    st = _mode()
    tap = _tap(st)
    with pytest.raises(InputError, match="hammer hit"):  # a cut is no tap
        sensor_path(_cut_in_notch(seconds=1.0), FS)
    with pytest.raises(InputError, match="clipped"):
        sensor_path(np.clip(50 * tap, -0.5, 0.5), FS)  # the recorder overloaded
    with pytest.raises(InputError, match="sample rate"):
        sensor_path(tap, FS, cut_fs=44100)
    with pytest.raises(InputError, match="sample rate"):
        listen(_cut_in_notch(seconds=1.0), 44100, 6000.0, 3, tap=sensor_path(tap, FS))


def test_bench_cut_flip_in_a_notch_heard_with_its_virtual_tap():
    """bench_listen --seed 1 cut 145 as the bench draws it: the 1-DOF benchmark at a/D 0.05, 16 531 rpm, 1.19 × the
    limit, a flip chatter at 1.5 f_T = 826.6 Hz in a notch of the microphone's room (−19 dB), a line at 895 Hz near
    the mode lifted +3.8 dB. Without the tap (structure known or not) 895 Hz is heard; with the tap that
    ``record_tap`` makes through the same sensor and room, 826.6 Hz."""
    from millstab.simulate import detect, simulate_cut
    from millstab.simulate.record import record, record_tap

    fn, zeta, mass = 922.0, 0.011, 0.03993
    st = Structure(x=(Mode(fn, mass * (2 * math.pi * fn) ** 2, zeta),))
    cut = Cutting.from_immersion(2, 6e8, 1 / 3, 0.05, "down")
    rpm = 16531.338602960437
    res = simulate_cut(st, cut, rpm, 0.005173795669106367, 1e-4, revs=551.0446200986812,
                       perturbation=0.0013207490192452993)
    det = detect(res)
    assert det.label == "chatter" and abs(det.chatter_hz - 826.6) < 0.5
    kw = {"sensor": "microphone", "fs": 44100, "noise": 0.01678351732547361, "hum": 0.0, "mains_hz": 60.0,
          "direction_deg": 66.1202812302515, "seed": 145}
    rec = record(res, runout=0.04811433753831623, **kw)
    path = sensor_path(record_tap(st, **kw).signal, 44100, cut_fs=rec.fs)
    given = 16400.513778113727
    tol = max(2.0, 0.005 * det.chatter_hz)
    for structure in (None, st):
        before = listen(rec.signal, rec.fs, given, 2, structure=structure)
        after = listen(rec.signal, rec.fs, given, 2, structure=structure, tap=path)
        assert before.label == after.label == "chatter"
        assert abs(before.chatter_hz - det.chatter_hz) > tol, before.chatter_hz  # the room's notch, unheard
        assert abs(after.chatter_hz - det.chatter_hz) <= tol, after.chatter_hz


def test_record_tap_is_seeded_and_goes_through_the_cut_s_room():
    """``record_tap``: same seed, same samples; its path (structure known) is the microphone model's room
    (:data:`millstab.simulate.record.ROOM`, recomputed here) to 1 dB (median) where the tap rings, and flat for an
    accelerometer."""
    from millstab.simulate.record import ROOM, record_tap

    st = _mode()
    a, b = record_tap(st, seed=3), record_tap(st, seed=3)
    assert np.array_equal(a.signal, b.signal) and a.fs == FS and abs(a.seconds - 1.0) < 1e-9
    f = np.arange(600.0, 1500.0, 2.5)
    room = 10 * np.log10(np.abs(1.0 + sum(g * np.exp(-2j * np.pi * f * d) for d, g in ROOM)) ** 2)
    for sensor, want in (("microphone", room), ("accelerometer", np.zeros(f.size))):
        e = 10 * np.log10(sensor_path(record_tap(st, sensor=sensor, seed=3).signal, FS).weight(f, st) / f**4) - want
        keep = want > -10
        e = e[keep] - np.median(e[keep])
        assert np.median(np.abs(e)) < 1.0, (sensor, np.median(np.abs(e)))
    with pytest.raises(InputError, match="seconds"):
        record_tap(st, seconds=0.3, hit_s=0.2)


def test_cli_simulate_record_tap_then_listen_tap(tmp_path, capsys):
    from millstab.cli import main

    cut, tap = tmp_path / "cut.wav", tmp_path / "tap.wav"
    assert main(["simulate", "example:ex1", "--rpm", "9000", "--depth", "8", "--revs", "60", "--record", str(cut),
                 "--record-tap", str(tap), "--seed", "2"]) == 0
    assert "wrote" in capsys.readouterr().out and tap.exists()
    assert main(["listen", str(cut), "--rpm", "9000", "--teeth", "2", "--tap", str(tap)]) == 0
    from millstab import api
    from millstab.io.recordings import read_recording

    x, fs = read_recording(cut)
    by_path = api.listen_signal(x, fs, 9000.0, 2, tap=str(tap)).listening  # a path or its SensorPath: the same
    by_obj = api.listen_signal(x, fs, 9000.0, 2, tap=api.tap_path(tap, cut_fs=fs)).listening
    assert by_path.label == by_obj.label == "chatter" and by_path.chatter_hz == by_obj.chatter_hz
    assert main(["listen", str(cut), "--rpm", "9000", "--teeth", "2", "--tap", str(cut)]) == 2
    err = capsys.readouterr().err
    assert "--tap cut.wav" in err and "hammer hit" in err
    assert main(["simulate", "example:ex1", "--cuts", str(tmp_path / "c.csv"), "--record-tap", str(tap)]) == 2


def test_a_cuts_csv_names_a_tap_per_cut(tmp_path):
    """``update``'s cuts labelled by ear: a ``tap`` column beside ``recording`` (a path relative to the CSV) is the
    cut's measured path; a row without one is heard as before; a tap that does not exist is refused, named."""
    from millstab import api
    from millstab.io.recordings import write_wav

    write_wav(tmp_path / "cut.wav", FS, _cut_in_notch())
    write_wav(tmp_path / "tap.wav", FS, _tap(_mode()))
    csv = tmp_path / "cuts.csv"
    csv.write_text("rpm,depth_mm,label,recording,tap\n6000,2,,cut.wav,tap.wav\n6000,2,,cut.wav,\n")
    pts, notes = api.label_from_recordings(csv, 3)
    assert list(pts.label) == ["chatter", "chatter"]
    assert abs(pts.chatter_hz[0] - 880.0) <= 2.0 and abs(pts.chatter_hz[1] - 1180.0) <= 2.0, pts.chatter_hz
    assert "path measured by tap.wav" in notes[0] and "tap" not in notes[1]
    csv.write_text("rpm,depth_mm,label,recording,tap\n6000,2,,cut.wav,nowhere.wav\n")
    with pytest.raises(InputError, match="cuts.csv:2 tap"):
        api.label_from_recordings(csv, 3)
