"""``millstab listen`` on recordings that are not what the analysis assumes (an exploratory user test): a cut
after seconds of air, silence and noise, a speed or a count of teeth given wrong, a window too short, a
clipped or stereo file, a cuts CSV whose written label or recording disagrees. Every recording is made here,
its truth known by construction (tests/listen_synth.py: a milling sound independent of the simulator)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from listen_synth import milling_sound
from millstab.errors import InputError
from millstab.listen import listen

FS = 48000


def _air_then_cut(air_s: float, *, rpm=9000.0, teeth=2, seed=3, **kw) -> np.ndarray:
    """``air_s`` seconds of an idle spindle (its once-per-revolution line and noise: no tooth passing) and then a
    2 s cut (stable unless ``kw`` says otherwise)."""
    rng = np.random.default_rng(seed)
    cut = milling_sound(seconds=2.0, rpm=rpm, teeth=teeth, seed=seed, **kw)
    n = int(air_s * FS)
    t = np.arange(n) / FS
    air = 0.02 * np.sin(2 * math.pi * rpm / 60.0 * t) + 0.01 * rng.standard_normal(n)
    return np.concatenate([air, cut])


@pytest.mark.parametrize("air_s", [2.0, 4.0])
def test_a_cut_after_seconds_of_air_is_heard_in_its_own_window(air_s):
    """More air than cut: the median level of the comb was the air's and the window took the air in; the tooth
    line switching on was heard as "chatter" at f_T (a stable cut into a posterior as chatter)."""
    r = listen(_air_then_cut(air_s), FS, 9000.0, 2)
    assert r.label == "stable", (r.label, r.chatter_hz, r.window_s)
    assert air_s - 0.05 <= r.window_s[0] <= air_s + 0.2 and r.window_s[1] >= air_s + 1.8
    c = listen(_air_then_cut(air_s, chatter_hz=876.2, ratio=0.5), FS, 9000.0, 2)
    assert c.label == "chatter" and abs(c.chatter_hz - 876.2) < 0.3 and c.window_s[0] >= air_s - 0.05


def test_a_window_given_over_the_air_is_noted_when_a_tooth_harmonic_is_heard():
    r = listen(_air_then_cut(4.0), FS, 9000.0, 2, start=0.0)
    if r.label != "stable":  # the tooth line switching on within the window: never chatter, so noted
        assert any("tooth-passing harmonic" in n for n in r.notes), (r.label, r.chatter_hz, r.notes)


def test_silence_and_noise_alone_are_refused_not_stable():
    with pytest.raises(InputError, match="silent"):
        listen(np.zeros(2 * FS), FS, 9000.0, 2)
    rng = np.random.default_rng(0)
    with pytest.raises(InputError, match="no tooth-passing sound"):
        listen(0.1 * rng.standard_normal(2 * FS), FS, 9000.0, 2)
    pink = np.cumsum(rng.standard_normal(2 * FS))
    with pytest.raises(InputError, match="no tooth-passing sound"):
        listen(pink - np.convolve(pink, np.ones(480) / 480, "same"), FS, 9000.0, 2)


@pytest.mark.parametrize("true_rpm", [9270.0, 8700.0])
def test_a_stable_cut_at_another_speed_than_given_is_refused_naming_it(true_rpm):
    """An override at 103 % (or 97 %): the tooth line was unmasked and heard as "chatter at 309.0 Hz"."""
    x = milling_sound(seconds=2.0, rpm=9000.0, true_rpm=true_rpm, teeth=2, seed=1)
    with pytest.raises(InputError) as e:
        listen(x, FS, 9000.0, 2)
    assert e.value.field == "--rpm" and f"{true_rpm:.0f} rpm" in str(e.value)


def test_a_chatter_cut_at_another_speed_keeps_its_chatter_with_a_note():
    x = milling_sound(seconds=2.0, rpm=9000.0, true_rpm=9270.0, teeth=2, seed=1, chatter_hz=880.0, ratio=2.0)
    r = listen(x, FS, 9000.0, 2)
    assert r.label == "chatter" and abs(r.chatter_hz - 880.0) < 0.5
    assert any("better than the speed given" in n for n in r.notes), r.notes


@pytest.mark.parametrize("teeth,given", [(3, 2), (5, 2)])
def test_a_cut_given_the_wrong_count_of_teeth_is_refused(teeth, given):
    """A three-flute cut given two: its tooth line 3 f_s = 1.5 f_T was heard as flip chatter at 450 Hz (five:
    5 f_s = 2.5 f_T). (Teeth given as a multiple of the true count leave its tooth lines masked: stable.)"""
    x = milling_sound(seconds=2.0, rpm=9000.0, teeth=teeth, seed=2)
    with pytest.raises(InputError) as e:
        listen(x, FS, 9000.0, given)
    assert e.value.field == "--teeth" and f"--teeth {teeth}" in str(e.value)
    assert listen(x, FS, 9000.0, teeth).label == "stable"


def test_a_cut_too_short_is_refused_and_a_short_one_noted():
    x = milling_sound(seconds=0.07, rpm=9000.0, teeth=2, seed=4)
    with pytest.raises(InputError, match="at least 0.1 s"):
        listen(x, FS, 9000.0, 2)
    r = listen(milling_sound(seconds=0.3, rpm=9000.0, teeth=2, seed=4, chatter_hz=876.2), FS, 9000.0, 2)
    assert r.label == "chatter" and any(n.startswith("short") for n in r.notes)
    assert listen(milling_sound(seconds=2.0, rpm=9000.0, teeth=2, seed=4), FS, 9000.0, 2).notes == ()


def test_clipped_and_stereo_files_are_noted_and_a_refusal_names_the_file(tmp_path):
    from scipy.io import wavfile

    from millstab import api

    x = milling_sound(seconds=2.0, rpm=9000.0, teeth=2, seed=5, chatter_hz=876.2)
    wavfile.write(tmp_path / "clip.wav", FS, np.round(np.clip(6 * x, -1, 1) * 32767).astype(np.int16))
    h = api.listen_file(tmp_path / "clip.wav", 9000.0, 2)
    assert any("clip.wav is clipped" in n for n in h.listening.notes) and "note: clip.wav is clipped" in h.summary()
    wavfile.write(tmp_path / "ok.wav", FS, np.round(x * 32767).astype(np.int16))
    assert api.listen_file(tmp_path / "ok.wav", 9000.0, 2).listening.notes == ()
    noise = 0.05 * np.random.default_rng(1).standard_normal(x.size)
    wavfile.write(tmp_path / "st.wav", FS, np.round(np.stack([noise, x], axis=1) * 32767).astype(np.int16))
    with pytest.raises(InputError, match=r"st\.wav.*channel 1 is \d+ dB louder"):
        api.listen_file(tmp_path / "st.wav", 9000.0, 2)
    h = api.listen_file(tmp_path / "st.wav", 9000.0, 2, channel=1)
    assert h.listening.label == "chatter" and any("channel 1 of 2 heard" in n for n in h.listening.notes)


def test_cuts_csv_notes_a_written_label_replaced_and_a_recording_on_two_rows(tmp_path):
    from millstab import api

    from millstab.io.recordings import write_recording

    write_recording(tmp_path / "c02.wav", FS, milling_sound(seconds=2.0, rpm=9000.0, teeth=2, seed=6,
                                                            chatter_hz=876.2))
    write_recording(tmp_path / "c01.wav", FS, milling_sound(seconds=2.0, rpm=9000.0, teeth=2, seed=7))
    csv = tmp_path / "cuts.csv"
    csv.write_text("rpm,depth_mm,label,recording\n9000,1.5,stable,c01.wav\n9000,8,,c02.wav\n9000,7.0,stable,c02.wav\n")
    pts, notes = api.label_from_recordings(csv, teeth=2)
    assert list(pts.label) == ["stable", "chatter", "chatter"]
    assert "replaced" not in notes[0] and "replaced" not in notes[1]
    assert "written label 'stable' is replaced" in notes[2]
    assert any("c02.wav is named on lines 3" in n and "4 (9000 rpm, 7 mm)" in n for n in notes), notes
    quiet = np.column_stack([np.arange(16384) / 8000.0, np.zeros(16384)])  # a muted accelerometer's export
    np.savetxt(tmp_path / "quiet.csv", quiet, delimiter=",", header="time_s,signal", comments="")
    csv.write_text("rpm,depth_mm,label,recording\n9000,1.5,,c01.wav\n9000,6,,quiet.csv\n")
    with pytest.raises(InputError, match=r"cuts\.csv:3 recording quiet\.csv"):
        api.label_from_recordings(csv, teeth=2)
