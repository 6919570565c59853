"""Independent reference for the tool-tip tests: the exact (continuous) Timoshenko beam by transfer matrices.

State z = [w, ψ, M, V] (displacement, section rotation, bending moment EIψ', shear force κGA(w' − ψ)); under
e^{iωt} the Timoshenko equations are the constant-coefficient system per uniform section

    w' = ψ + V/(κGA),   ψ' = M/(EI),   M' = −V − ρIω²ψ,   V' = −ρAω² w,

so z(z₁) = expm(A ℓ) z(z₀) exactly, and a stepped beam is the product of its sections' matrices (w, ψ, M, V
are continuous at a step). At a free end z = L with an external force P (along w) and moment Q (along ψ),
[M, V] = [Q, P] (checked in the Euler–Bernoulli limit: a tip force P gives M = P(L − z), V = P).
Hysteretic damping: E and G multiplied by (1 + iη). This shares no code with millstab's FE.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg


def transfer(sections, omega, eta=0.0):
    """The 4×4 transfer matrix over ``sections`` [(length, E, G, kappa, rho, A, I), ...] at ω [rad/s]."""
    T = np.eye(4, dtype=complex)
    for ell, E, G, kappa, rho, A, I in sections:
        Ec, Gc = E * (1 + 1j * eta), G * (1 + 1j * eta)
        A_ = np.array([[0, 1, 0, 1 / (kappa * Gc * A)],
                       [0, 0, 1 / (Ec * I), 0],
                       [0, -rho * I * omega**2, 0, -1],
                       [-rho * A * omega**2, 0, 0, 0]], dtype=complex)
        T = scipy.linalg.expm(A_ * ell) @ T
    return T


def clamped_tip(sections, freq_hz, eta=0.0):
    """Tip receptance matrix [[w/P, w/Q], [ψ/P, ψ/Q]] (F, 2, 2) of the stepped beam clamped at its start."""
    out = []
    for f in np.atleast_1d(freq_hz):
        T = transfer(sections, 2 * np.pi * f, eta)
        # [M(L), V(L)] = T22 [M0, V0] = [Q, P];  [w, ψ](L) = T12 [M0, V0]
        G = T[0:2, 2:4] @ np.linalg.inv(T[2:4, 2:4])  # maps (Q, P) -> (w, ψ)
        out.append(G[:, ::-1])
    return np.array(out)


def clamped_frequencies(sections, f_lo, f_hi, n=4000):
    """Natural frequencies [Hz] of the clamped-free stepped beam in (f_lo, f_hi): roots of det T22(ω)."""
    from scipy.optimize import brentq

    def d(f):
        T = transfer(sections, 2 * np.pi * f)
        return np.real(np.linalg.det(T[2:4, 2:4]))

    fs = np.linspace(f_lo, f_hi, n)
    vals = np.array([d(f) for f in fs])
    roots = []
    for i in np.nonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))[0]:
        roots.append(brentq(d, fs[i], fs[i + 1], xtol=1e-12, rtol=1e-14))
    return np.array(roots)


def section(length, diameter, E, rho, nu):
    """A solid circular section tuple with Cowper's κ."""
    A = np.pi / 4 * diameter**2
    I = np.pi / 64 * diameter**4
    return (length, E, E / (2 * (1 + nu)), 6 * (1 + nu) / (7 + 6 * nu), rho, A, I)
