"""Hand-made microphone signals for the listen tests (independent of millstab's simulator).

A milling sound: the forced vibration (tooth-passing harmonics k f_T with amplitudes 1/k, random
phases), runout (spindle harmonics k f_s, 1/k²), mains hum (50/60 Hz and two harmonics), white and
1/f noise, and optionally a chatter tone of amplitude ``ratio`` × the RMS amplitude of the forced
harmonics, switched on at ``onset`` [s] with a 50 ms rise, plus entry and exit bursts (damped rings
of all modes) and air-cut silence before and after.
"""

from __future__ import annotations

import math

import numpy as np


def milling_sound(*, fs=48000, seconds=4.0, rpm=10000.0, teeth=3, chatter_hz=None, ratio=1.0, onset=None,
                  true_rpm=None, runout=0.3, hum=0.3, mains=50.0, noise=0.02, pink=0.05, air=0.0,
                  bursts=False, seed=0, harmonics=12, tones=()):
    rng = np.random.default_rng(seed)
    n = int(seconds * fs)
    t = np.arange(n) / fs
    f_s = (true_rpm or rpm) / 60.0
    f_t = teeth * f_s
    x = np.zeros(n)
    forced_amp = []
    for k in range(1, harmonics + 1):
        if k * f_t < 0.45 * fs:
            a = 1.0 / k
            forced_amp.append(a)
            x += a * np.sin(2 * math.pi * k * f_t * t + rng.uniform(0, 2 * math.pi))
    a_forced = math.sqrt(sum(a * a for a in forced_amp))  # RMS amplitude of the forced part × √2
    for k in range(1, 6):
        if k % teeth:
            x += runout * a_forced / k**2 * np.sin(2 * math.pi * k * f_s * t + rng.uniform(0, 2 * math.pi))
    if chatter_hz is not None:
        env = np.ones(n) if onset is None else np.clip((t - onset) / 0.05, 0.0, 1.0)
        x += ratio * a_forced * env * np.sin(2 * math.pi * chatter_hz * t + rng.uniform(0, 2 * math.pi))
    for hz, r in tones:  # further non-synchronous tones (hz, amplitude ratio), e.g. chatter sidebands
        x += r * a_forced * np.sin(2 * math.pi * hz * t + rng.uniform(0, 2 * math.pi))
    if air:  # silence (idle spindle) before and after the cut
        quiet = (t < air) | (t > seconds - air)
        x[quiet] *= 0.02
    if bursts:
        for t0 in ((air or 0.05), seconds - (air or 0.05) - 0.05):
            for fm in (713.0, 1630.0, 2900.0):
                m = t >= t0
                x[m] += 2 * a_forced * np.exp(-(t[m] - t0) / 0.01) * np.sin(2 * math.pi * fm * (t[m] - t0))
    for k, g in ((1, 1.0), (2, 0.5), (3, 0.3)):
        x += hum * a_forced * g * np.sin(2 * math.pi * k * mains * t + rng.uniform(0, 6.3))
    spec = rng.standard_normal(n // 2 + 1) + 1j * rng.standard_normal(n // 2 + 1)
    fr = np.arange(spec.size, dtype=float)
    fr[0] = 1.0
    p = np.fft.irfft(spec / np.sqrt(fr), n)
    x += pink * a_forced * p / p.std() + noise * a_forced * rng.standard_normal(n)
    return x / np.abs(x).max() * 0.5
