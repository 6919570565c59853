"""Closed-form 2×2 matrix functions shared by the time-domain kernels (semi-discretization and the
time-domain simulation): Φ = e^{Ah}, F1 = ∫₀ʰ e^{Au} du, F2 = ∫₀ʰ (h − u) e^{Au} du of a real 2×2 matrix A.
A helper of the engines' kernels, not an engine (the simulation imports it from here).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np


# ---------------------------------------------------------------------------------------------------
# scalar functions of λ:  E = e^{λh},  F1 = ∫₀ʰ e^{λu} du,  F2 = ∫₀ʰ (h − u) e^{λu} du
# written with J_k(z) = ∫₀¹ v^k e^{zv} dv, z = λh:  F1 = h J0,  F2 = h²(J0 − J1),  dJ_k/dz = J_{k+1}.
# ---------------------------------------------------------------------------------------------------


@nb.njit(cache=True)
def _jfun(z, kmax, out):
    """J_0..J_kmax at complex z (series for |z| < 1, else the upward recurrence, stable there)."""
    if abs(z) < 1.0:
        for k in range(kmax + 1):
            term = 1.0 + 0.0j
            s = term / (k + 1)
            for j in range(1, 30):
                term = term * z / j
                s += term / (j + k + 1)
            out[k] = s
    else:
        ez = np.exp(z)
        out[0] = (ez - 1.0) / z
        for k in range(1, kmax + 1):
            out[k] = (ez - k * out[k - 1]) / z


@nb.njit(cache=True)
def _expm_2x2(a, b, c, d, h, phi, f1, f2):
    """Φ, F1, F2 of the real 2×2 matrix [[a, b], [c, d]] over a step h, in closed form.

    f(A) = c0 I + c1 A with c1 = (f(s+δ) − f(s−δ))/(2δ), c0 = ½(f(s+δ) + f(s−δ)) − s c1, s = tr/2,
    δ² = s² − det. Near coalescing eigenvalues (|δh| < 1e-3) a Taylor series in δ² is used instead.
    """
    s = 0.5 * (a + d)
    d2 = s * s - (a * d - b * c)
    dl = np.sqrt(complex(d2))
    J = np.empty(5, dtype=np.complex128)
    cE1 = cE0 = cF1 = cF0 = cG1 = cG0 = 0.0
    if abs(dl) * h > 1e-3:
        lp = complex(s, 0.0) + dl
        lm = complex(s, 0.0) - dl
        _jfun(lp * h, 1, J)
        ep = np.exp(lp * h)
        f1p = h * J[0]
        f2p = h * h * (J[0] - J[1])
        _jfun(lm * h, 1, J)
        em = np.exp(lm * h)
        f1m = h * J[0]
        f2m = h * h * (J[0] - J[1])
        k1 = (ep - em) / (2.0 * dl)
        cE1 = k1.real
        cE0 = (0.5 * (ep + em) - s * k1).real
        k1 = (f1p - f1m) / (2.0 * dl)
        cF1 = k1.real
        cF0 = (0.5 * (f1p + f1m) - s * k1).real
        k1 = (f2p - f2m) / (2.0 * dl)
        cG1 = k1.real
        cG0 = (0.5 * (f2p + f2m) - s * k1).real
    else:
        # f(s±δ): c1 = f' + f''' δ²/6,  ½(f(s+δ)+f(s−δ)) = f + f'' δ²/2  (error O(δ⁴h⁴) < 1e-12)
        z = complex(s * h, 0.0)
        _jfun(z, 4, J)
        e = math.exp(s * h)
        # derivatives in λ: E^(k) = h^k e;  F1^(k) = h^{k+1} J_k;  F2^(k) = h^{k+2} (J_k − J_{k+1})
        cE1 = h * e + h ** 3 * e * d2 / 6.0
        cE0 = e + h * h * e * d2 / 2.0 - s * cE1
        cF1 = (h * h * J[1] + h ** 4 * J[3] * d2 / 6.0).real
        cF0 = (h * J[0] + h ** 3 * J[2] * d2 / 2.0).real - s * cF1
        cG1 = (h ** 3 * (J[1] - J[2]) + h ** 5 * (J[3] - J[4]) * d2 / 6.0).real
        cG0 = (h * h * (J[0] - J[1]) + h ** 4 * (J[2] - J[3]) * d2 / 2.0).real - s * cG1
    phi[0, 0] = cE0 + cE1 * a
    phi[0, 1] = cE1 * b
    phi[1, 0] = cE1 * c
    phi[1, 1] = cE0 + cE1 * d
    f1[0, 0] = cF0 + cF1 * a
    f1[0, 1] = cF1 * b
    f1[1, 0] = cF1 * c
    f1[1, 1] = cF0 + cF1 * d
    f2[0, 0] = cG0 + cG1 * a
    f2[0, 1] = cG1 * b
    f2[1, 0] = cG1 * c
    f2[1, 1] = cG0 + cG1 * d
