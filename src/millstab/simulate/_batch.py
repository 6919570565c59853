"""Compiled batch of cuts: simulate and detect many (rpm, depth) cuts in parallel (numba prange)."""

from __future__ import annotations

import numba as nb
import numpy as np

from millstab.simulate import _kernel as _k
from millstab.simulate.detect import detect_core


@nb.njit(cache=True)
def initial_state(n_teeth, kt, kr, phi_s, phi_e, rpm, m, depth, ft, wn, zeta, mass, mdir, steady, perturb, n_harm):
    """(q0, v0, surface) of a cut starting at rest, or on the forced periodic motion with every modal
    displacement moved by ``perturb`` [m]."""
    if steady:
        q0, v0, S = _k.steady_start(n_teeth, kt, kr, phi_s, phi_e, rpm, m, depth, ft, wn, zeta, mass, mdir, n_harm, 16 * n_harm)
        for j in range(wn.size):
            q0[j] += perturb
        return q0, v0, S
    return np.zeros(wn.size), np.zeros(wn.size), _k.rest_surface(n_teeth, phi_s, phi_e, m, ft)


@nb.njit(cache=True, parallel=True)
def label_batch(n_teeth, kt, kr, phi_s, phi_e, rpm, depth, steps, periods, ft, wn, zeta, mass, mdir, steady,
                perturb_rel, n_harm, bound, f_hi, out_label, out_hz, out_lobe, out_level, out_growth):
    """Simulate and label cuts (rpm[i], depth[i]) with steps[i] nodes per tooth period over
    periods[i] periods; writes the detector's label/frequency/lobe codes and metrics per cut."""
    for i in nb.prange(rpm.size):
        m = steps[i]
        q0, v0, S = initial_state(n_teeth, kt, kr, phi_s, phi_e, rpm[i], m, depth[i], ft, wn, zeta, mass, mdir,
                                  steady, perturb_rel * ft, n_harm)
        n = periods[i] * m + 1
        x = np.empty(n)
        y = np.empty(n)
        fx = np.empty(n)
        fy = np.empty(n)
        n_out = _k.simulate(n_teeth, kt, kr, phi_s, phi_e, rpm[i], m, periods[i], depth[i], ft, wn, zeta, mass,
                            mdir, q0, v0, S, bound[i], x, y, fx, fy)
        f_tooth = n_teeth * rpm[i] / 60.0
        lab, hz, lobe, level, growth, _ = detect_core(x, y, n_out, m, ft, f_tooth, f_hi[i], n_out < n)
        out_label[i] = lab
        out_hz[i] = hz
        out_lobe[i] = lobe
        out_level[i] = level
        out_growth[i] = growth
