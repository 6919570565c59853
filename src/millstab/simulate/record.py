"""What a microphone or an accelerometer would record of a simulated cut (a virtual recording).

The model is deliberately simple; every part of it is a feature a real shop recording has, so that
``millstab listen`` can be tested end to end on cuts whose truth (the simulation's own label and
chatter frequency) is known.

1. Source: the tool-tip acceleration a(t) = d²u/dt² (second central difference of the simulated
   displacement at the simulation's own rate m f_T, m ≥ 200 steps per tooth period and ≥ 100 per
   natural period, so the difference is accurate to < 0.1 % at the modes), projected on the sensor's
   direction θ: a_θ = a_x cos θ + a_y sin θ. A vibrating surface radiates a pressure proportional to
   its acceleration at low frequency (baffled piston, ka ≪ 1), so both sensors start from a_θ.
2. Spindle lines (``runout``): a slightly eccentric tool and the spindle's imbalance add the spindle
   frequency f_s = Ω/60 and its first harmonics: Σ_{k=1..4} runout · A_forced / k · sin(2π k f_s t + φ_k),
   A_forced the RMS of the source (random phases, seeded).
3. Microphone only: a room of a direct path and three wall reflections (delays 4.3, 7.9, 12.6 ms, gains
   0.5, 0.35, 0.25: a machine enclosure a few metres across), a 20 Hz first-order high-pass (the
   capsule), mains hum (``hum`` × RMS at 50 Hz, half that at 100 Hz, a third at 150 Hz: fluorescent
   lights and the drive), and 1/f noise (pink, ``noise`` / 2 × RMS).
4. Both: white noise (``noise`` × RMS: air noise, electronics), then the sample rate ``fs`` (a
   linear-phase low-pass at 0.45 fs before resampling by interpolation when fs is below the
   simulation's rate), an automatic gain that puts the peak at half of full scale, and quantisation
   to ``bits`` (16: a phone's or a sound card's PCM).

Units: the returned signal is dimensionless in [-1, 1] (full scale), as in a WAV file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from millstab.errors import InputError

Sensor = Literal["microphone", "accelerometer"]
SENSORS = ("microphone", "accelerometer")
#: room reflections (delay [s], gain) of the microphone model
ROOM = ((0.0043, 0.5), (0.0079, 0.35), (0.0126, 0.25))
#: spindle (runout) harmonics added
RUNOUT_HARMONICS = 4
#: high-pass corner of the microphone capsule [Hz]
CAPSULE_HZ = 20.0


@dataclass(frozen=True, eq=False)
class Recording:
    """A virtual recording: ``signal`` in full-scale units [-1, 1] at ``fs`` [Hz]; the settings used."""

    fs: int
    signal: np.ndarray = field(repr=False)
    sensor: str = "microphone"
    mains_hz: float = 50.0
    noise: float = 0.0
    hum: float = 0.0
    runout: float = 0.0
    bits: int = 16

    @property
    def seconds(self) -> float:
        return self.signal.size / self.fs


def acceleration(result, direction_deg: float = 45.0) -> tuple[np.ndarray, np.ndarray]:
    """(t [s], tool-tip acceleration along the sensor direction [m/s²]) of a simulated cut."""
    dt = result.tooth_period_s / result.steps_per_tooth
    th = math.radians(direction_deg)
    u = math.cos(th) * result.x + math.sin(th) * result.y
    if u.size < 3:
        raise InputError("result", f"{u.size} samples", "a recording needs a simulated cut of at least 3 samples")
    a = np.empty_like(u)
    a[1:-1] = (u[2:] - 2.0 * u[1:-1] + u[:-2]) / dt**2
    a[0], a[-1] = a[1], a[-2]
    return result.t, a


def _resample(t: np.ndarray, a: np.ndarray, fs: float) -> np.ndarray:
    from scipy import signal as sg

    fs_sim = 1.0 / (t[1] - t[0])
    if fs < fs_sim:  # anti-alias: the band above fs/2 would fold onto the chatter band
        sos = sg.butter(8, 0.45 * fs, fs=fs_sim, output="sos")
        a = sg.sosfiltfilt(sos, a)
    n = int(math.floor((t[-1] - t[0]) * fs)) + 1
    return np.interp(t[0] + np.arange(n) / fs, t, a)


def _pink(n: int, rng: np.random.Generator) -> np.ndarray:
    """Unit-RMS 1/f noise: white noise shaped by 1/sqrt(f) in the frequency domain."""
    spec = rng.standard_normal(n // 2 + 1) + 1j * rng.standard_normal(n // 2 + 1)
    f = np.arange(spec.size, dtype=float)
    f[0] = 1.0
    x = np.fft.irfft(spec / np.sqrt(f), n)
    return x / (x.std() or 1.0)


def record(result, *, sensor: Sensor = "microphone", fs: int = 48000, noise: float = 0.02, hum: float = 0.05,
           runout: float = 0.05, mains_hz: float = 50.0, direction_deg: float = 45.0, bits: int = 16,
           seed: int = 0) -> Recording:
    """A virtual recording of a simulated cut (:class:`millstab.simulate.CutResult`); model in the module docstring.

    Args:
        sensor: ``"microphone"`` or ``"accelerometer"``; fs: sample rate [Hz] (8 000-192 000).
        noise: white-noise RMS relative to the source RMS [-] (≥ 0); hum: mains hum relative RMS (microphone);
        runout: spindle-line amplitude relative to the source RMS; mains_hz: 50 or 60.
        direction_deg: sensor direction from the feed (x) axis [°]; bits: quantisation (8-32; 0: none).
        seed: seed of the noise and of the runout phases.
    """
    if sensor not in SENSORS:
        raise InputError("sensor", sensor, f"one of {', '.join(SENSORS)}")
    if not (isinstance(fs, (int, np.integer)) and 8000 <= fs <= 192000):
        raise InputError("fs", fs, "a whole sample rate from 8000 to 192000 Hz")
    for name, v in (("noise", noise), ("hum", hum), ("runout", runout)):
        if not (math.isfinite(v) and v >= 0):
            raise InputError(name, v, "a level >= 0 relative to the vibration's RMS")
    if mains_hz not in (50.0, 60.0):
        raise InputError("mains_hz", mains_hz, "50 or 60 Hz")
    if bits not in (0, 8, 16, 24, 32):
        raise InputError("bits", bits, "0 (no quantisation), 8, 16, 24 or 32")
    rng = np.random.default_rng(seed)
    t, a = acceleration(result, direction_deg)
    s = _resample(t, a, float(fs))
    tt = np.arange(s.size) / fs
    rms = float(np.sqrt(np.mean((s - s.mean()) ** 2))) or 1.0
    f_s = result.rpm / 60.0
    for k in range(1, RUNOUT_HARMONICS + 1):
        if k * f_s < 0.45 * fs:
            s = s + runout * rms / k * np.sin(2 * math.pi * k * f_s * tt + rng.uniform(0, 2 * math.pi))
    if sensor == "microphone":
        room = s.copy()
        for delay, gain in ROOM:
            d = int(round(delay * fs))
            room[d:] += gain * s[: s.size - d]
        from scipy import signal as sg

        b, a_ = sg.butter(1, CAPSULE_HZ, btype="highpass", fs=fs)
        s = sg.lfilter(b, a_, room)
        for k, g in ((1, 1.0), (2, 0.5), (3, 1 / 3)):
            s = s + hum * rms * g * math.sqrt(2) * np.sin(2 * math.pi * k * mains_hz * tt + rng.uniform(0, 6.3))
        s = s + 0.5 * noise * rms * _pink(s.size, rng)
    s = s + noise * rms * rng.standard_normal(s.size)
    s = s - s.mean()
    peak = float(np.abs(s).max()) or 1.0
    s = 0.5 * s / peak
    if bits:
        q = 2.0 ** (bits - 1) - 1
        s = np.round(s * q) / q
    return Recording(int(fs), s, sensor, float(mains_hz), float(noise), float(hum), float(runout), int(bits))
