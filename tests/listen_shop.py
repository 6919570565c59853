"""A second hand-made shop recording for the listen tests, built differently from tests/listen_synth.py
and independent of millstab's simulator (plain numpy).

Where listen_synth adds sine tones, this one builds the sound as a machine makes it:

* the cutting force: one pulse per tooth engagement (a raised-sine of a third of a tooth period), its
  height varying from tooth to tooth with the runout (1 + e cos(2π j/N + φ) for tooth j), at an angle
  that advances with the true spindle speed (given ±1 % off to ``listen``): so the tooth-passing
  harmonics and the runout lines (spindle harmonics) come from the pulses, with their own spectrum;
* the structure and room: the force drives three resonances (damped impulse responses, by FFT
  convolution), which colour every line;
* chatter: a tone at ``chatter_hz`` whose amplitude grows exponentially from ``onset`` [s] (doubling
  every 30 ms) and saturates at ``ratio`` × the forced vibration's RMS, amplitude-modulated by the tooth
  passing (depth ``am``: sidebands chatter ± f_T) and with a slow frequency wander (±0.05 Hz);
* entry and exit: the first and last ``ramp`` seconds of the cut an impact rings the resonances, with
  ``air`` seconds of idle spindle (runout lines only, 3 %) before and after;
* mains hum: 50 or 60 Hz (slightly off the nominal, as mains is) with harmonics 1-7, odd ones
  strongest (a transformer's saturation), level ``hum`` of the forced RMS;
* noise: 1/f (a sum of first-order low-pass processes) and white, levels ``pink`` and ``noise``.

Returns the signal (peak 0.5 full scale) and the truth (chatter frequency, onset, true rpm).
"""

from __future__ import annotations

import math

import numpy as np


def _lowpass_noise(n: int, fs: float, corner: float, rng: np.random.Generator) -> np.ndarray:
    """White noise through a first-order low-pass at ``corner`` Hz (via the FFT), unit RMS."""
    spec = np.fft.rfft(rng.standard_normal(n))
    f = np.fft.rfftfreq(n, 1.0 / fs)
    x = np.fft.irfft(spec / (1.0 + 1j * f / corner), n)
    return x / (x.std() or 1.0)


def shop_recording(*, fs=48000, seconds=3.0, rpm=9000.0, teeth=2, off=0.0, chatter_hz=None, ratio=1.0,
                   onset=None, am=0.2, runout=0.1, hum=0.2, mains=50.0, noise=0.02, pink=0.05, air=0.3,
                   ramp=0.05, seed=0):
    """(signal, truth) of one cut; ``off``: the true speed is rpm × (1 + off). Units: s, Hz, rev/min."""
    rng = np.random.default_rng(seed)
    n = int(seconds * fs)
    t = np.arange(n) / fs
    true_rpm = rpm * (1.0 + off)
    f_s = true_rpm / 60.0
    f_t = teeth * f_s
    t_in, t_out = air, seconds - air
    cutting = (t >= t_in) & (t < t_out)
    # the cutting force: a pulse per tooth, height by tooth (runout); made at 4 fs and band-limited to
    # fs/2 before it is sampled (a recorder's anti-alias filter: the pulses' harmonics reach far above)
    up = 4
    turns = f_s * np.arange(up * n) / (up * fs) + rng.uniform()
    tooth = np.floor(turns * teeth)
    frac = turns * teeth - tooth  # 0-1 within a tooth period
    height = 1.0 + runout * np.cos(2 * math.pi * (tooth % teeth) / teeth + rng.uniform(0, 2 * math.pi))
    pulse = np.where(frac < 1 / 3, np.sin(3 * math.pi * frac) ** 2, 0.0) * height
    spec = np.fft.rfft(pulse)[: int(0.45 * n) + 1]
    pulse = np.fft.irfft(spec, n) / up
    force = np.where(cutting, pulse, 0.03 * runout * np.cos(2 * math.pi * turns[::up]))
    # structure and room: three damped resonances
    L = int(0.2 * fs)
    tl = np.arange(L) / fs
    h = np.zeros(L)
    for fn, zeta, g in ((float(rng.uniform(600, 900)), 0.02, 1.0), (float(rng.uniform(1500, 2200)), 0.03, 0.6),
                        (min(float(rng.uniform(3000, 4000)), 0.4 * fs), 0.03, 0.4)):
        h += g * np.exp(-zeta * 2 * math.pi * fn * tl) * np.sin(2 * math.pi * fn * tl)
    m = n + L
    x = np.fft.irfft(np.fft.rfft(force - force[cutting].mean() * cutting, m) * np.fft.rfft(h, m), m)[:n]
    a_forced = float(x[cutting].std())
    # entry and exit impacts ring the structure
    for t0 in (t_in, t_out - ramp):
        i = int(t0 * fs)
        k = min(L, n - i)
        x[i:i + k] += 3.0 * a_forced * h[:k] / np.abs(h).max()
    truth = {"rpm": true_rpm, "chatter_hz": chatter_hz, "onset": None}
    if chatter_hz is not None:
        amp = ratio * a_forced * math.sqrt(2.0)
        if onset is None:
            env = np.ones(n)
        else:  # exponential growth to saturation, doubling every 30 ms; half level at `onset`
            env = 1.0 / (1.0 + np.exp(-(t - onset) * math.log(2.0) / 0.03))
            truth["onset"] = onset
        wander = 0.05 * np.sin(2 * math.pi * 0.7 * t + rng.uniform(0, 6.3))
        phase = 2 * math.pi * np.cumsum(chatter_hz + wander) / fs + rng.uniform(0, 6.3)
        mod = 1.0 + am * np.cos(2 * math.pi * f_t * t + rng.uniform(0, 6.3))
        x += np.where(cutting, amp * env * mod * np.sin(phase), 0.0)
    fm = mains * (1.0 + float(rng.uniform(-1e-3, 1e-3)))
    for k in range(1, 8):
        g = (1.0 if k == 1 else 0.5 / k) if k % 2 else 0.15 / k
        x += hum * a_forced * math.sqrt(2) * g * np.sin(2 * math.pi * k * fm * t + rng.uniform(0, 6.3))
    # 1/f: low-pass processes with corners a decade apart, equal weights (a 1/f slope between them)
    p = sum(_lowpass_noise(n, fs, c, rng) / math.sqrt(c) for c in (3.0, 30.0, 300.0, 3000.0))
    x += pink * a_forced * p / p.std() + noise * a_forced * rng.standard_normal(n)
    return x / np.abs(x).max() * 0.5, truth
