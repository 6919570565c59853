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

5. A tap (:func:`record_tap`): the same sensor and steps 3-4 (the same room) on the tip's ring after an ideal
   hammer impulse, the spindle still: what ``millstab listen --tap`` reads to divide the sensor path out.
   The room is the same fixed :data:`ROOM` for every cut, so a cut and its tap always share it.

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
    _check_settings(sensor, fs, noise, hum, runout, mains_hz, bits)
    rng = np.random.default_rng(seed)
    t, a = acceleration(result, direction_deg)
    s = _resample(t, a, float(fs))
    tt = np.arange(s.size) / fs
    rms = float(np.sqrt(np.mean((s - s.mean()) ** 2))) or 1.0
    f_s = result.rpm / 60.0
    for k in range(1, RUNOUT_HARMONICS + 1):
        if k * f_s < 0.45 * fs:
            s = s + runout * rms / k * np.sin(2 * math.pi * k * f_s * tt + rng.uniform(0, 2 * math.pi))
    s = _sensor_path(s, fs, rms, rng, sensor=sensor, noise=noise, hum=hum, mains_hz=mains_hz, bits=bits)
    return Recording(int(fs), s, sensor, float(mains_hz), float(noise), float(hum), float(runout), int(bits))


def _check_settings(sensor, fs, noise, hum, runout, mains_hz, bits) -> None:
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


def record_tap(structure, *, sensor: Sensor = "microphone", fs: int = 48000, noise: float = 0.02, hum: float = 0.05,
               mains_hz: float = 50.0, direction_deg: float = 45.0, hit_deg: float | None = None,
               seconds: float = 1.0, hit_s: float = 0.2, bits: int = 16, seed: int = 0) -> Recording:
    """A virtual tap test heard by the sensor of :func:`record`: the tool tip hit by an ideal hammer (a unit
    impulse of force along ``hit_deg`` [°] from x, default the sensor's direction) at ``hit_s`` [s] of a recording
    ``seconds`` [s] long, the spindle still (no runout).

    The source is the tip's acceleration along the sensor's direction u from a force impulse along d: its
    spectrum is −(2πf)² uᵀ G(f) d (G the structure's receptance, :func:`millstab.frf.structure_receptance`),
    tapered to zero between 0.40 and 0.45 fs (the band a recording keeps) and transformed to time (``seconds``
    must hold the ring: a mode of damping ζ at f_n decays by e⁻¹ in 1/(2π ζ f_n), 16 ms for the 1-DOF
    benchmark). Then the same :func:`_sensor_path` as a cut's recording: for a microphone the same room
    (:data:`ROOM`), capsule, hum and 1/f noise; white noise; gain; quantisation. ``noise`` and ``hum`` are
    relative to the RMS of the source over the ring's first 0.1 s (a tap is heard as loud as it rings).
    Same sensor settings as the cut, same path: what ``millstab listen --tap`` divides out
    (:mod:`millstab.listen.tap`).
    """
    from millstab.frf import structure_receptance

    _check_settings(sensor, fs, noise, hum, 0.0, mains_hz, bits)
    if not (math.isfinite(seconds) and math.isfinite(hit_s) and 0.0 <= hit_s and seconds >= hit_s + 0.2):
        raise InputError("seconds", seconds, f"a recording at least 0.2 s longer than the hit at {hit_s:g} s")
    rng = np.random.default_rng(seed)
    n = int(round(seconds * fs))
    f = np.fft.rfftfreq(n, 1.0 / fs)
    th, ph = math.radians(direction_deg), math.radians(direction_deg if hit_deg is None else hit_deg)
    u, d = np.array([math.cos(th), math.sin(th)]), np.array([math.cos(ph), math.sin(ph)])
    G = np.zeros((f.size, 2, 2), complex)
    band = f > 0
    if structure.frf is not None:  # a measured FRF: inside its band only
        band &= (f >= structure.frf.freq_hz[0]) & (f <= structure.frf.freq_hz[-1])
    G[band] = structure_receptance(structure, f[band])
    taper = np.clip((0.45 * fs - f) / (0.05 * fs), 0.0, 1.0)
    taper = 0.5 - 0.5 * np.cos(math.pi * taper)
    spec = -((2 * math.pi * f) ** 2) * np.einsum("i,fij,j->f", u, G, d) * taper * np.exp(-2j * math.pi * f * hit_s)
    s = np.fft.irfft(spec * fs, n)  # × fs: the unit impulse's samples (any scale: only ratios are used)
    i0 = int(round(hit_s * fs))
    ring = s[i0: i0 + int(0.1 * fs)]
    rms = float(np.sqrt(np.mean(ring**2))) or 1.0
    s = _sensor_path(s, fs, rms, rng, sensor=sensor, noise=noise, hum=hum, mains_hz=mains_hz, bits=bits)
    return Recording(int(fs), s, sensor, float(mains_hz), float(noise), float(hum), 0.0, int(bits))


def _sensor_path(s: np.ndarray, fs: int, rms: float, rng: np.random.Generator, *, sensor: str, noise: float,
                 hum: float, mains_hz: float, bits: int) -> np.ndarray:
    """Steps 3-4 of the module docstring on a source ``s`` (acceleration along the sensor, runout added) of RMS
    ``rms``: the microphone's room, capsule, hum and 1/f noise; white noise; automatic gain; quantisation. The
    one chain of a cut's recording and of its tap (:func:`record_tap`): the same room for both."""
    if sensor == "microphone":
        room = s.copy()
        for delay, gain in ROOM:
            d = int(round(delay * fs))
            room[d:] += gain * s[: s.size - d]
        from scipy import signal as sg

        b, a_ = sg.butter(1, CAPSULE_HZ, btype="highpass", fs=fs)
        s = sg.lfilter(b, a_, room)
        tt = np.arange(s.size) / fs
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
    return s
