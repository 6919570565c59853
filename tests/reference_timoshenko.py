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
    """The transfer matrices (W, 4, 4) over ``sections`` [(length, E, G, kappa, rho, A, I[, eta]), ...] at ω (W,)
    [rad/s] (a scalar ω gives one (4, 4)): expm(Aℓ) = V diag(e^{λℓ}) V⁻¹ per section, batched."""
    w = np.atleast_1d(np.asarray(omega, dtype=float))
    T = np.broadcast_to(np.eye(4, dtype=complex), (w.size, 4, 4)).copy()
    for sec in sections:
        ell, E, G, kappa, rho, A, I = sec[:7]
        e = sec[7] if len(sec) > 7 else eta  # a section's own loss factor, if it has one
        Ec, Gc = E * (1 + 1j * e), G * (1 + 1j * e)
        A_ = np.zeros((w.size, 4, 4), dtype=complex)
        A_[:, 0, 1] = 1
        A_[:, 0, 3] = 1 / (kappa * Gc * A)
        A_[:, 1, 2] = 1 / (Ec * I)
        A_[:, 2, 1] = -rho * I * w**2
        A_[:, 2, 3] = -1
        A_[:, 3, 0] = -rho * A * w**2
        lam, V = np.linalg.eig(A_ * ell)
        T = (V * np.exp(lam)[:, None, :]) @ np.linalg.inv(V) @ T
    return T if np.ndim(omega) else T[0]


def clamped_tip(sections, freq_hz, eta=0.0):
    """Tip receptance matrix [[w/P, w/Q], [ψ/P, ψ/Q]] (F, 2, 2) of the stepped beam clamped at its start."""
    T = transfer(sections, 2 * np.pi * np.atleast_1d(np.asarray(freq_hz, dtype=float)), eta)
    # [M(L), V(L)] = T22 [M0, V0] = [Q, P];  [w, ψ](L) = T12 [M0, V0]
    G = T[:, 0:2, 2:4] @ np.linalg.inv(T[:, 2:4, 2:4])  # maps (Q, P) -> (w, ψ)
    return G[:, :, ::-1]


def clamped_frequencies(sections, f_lo, f_hi, n=4000):
    """Natural frequencies [Hz] of the clamped-free stepped beam in (f_lo, f_hi): roots of det T22(ω)."""
    from scipy.optimize import brentq

    def d(f):
        T = transfer(sections, 2 * np.pi * f)
        return np.real(np.linalg.det(T[2:4, 2:4]))

    fs = np.linspace(f_lo, f_hi, n)
    vals = np.real(np.linalg.det(transfer(sections, 2 * np.pi * fs)[:, 2:4, 2:4]))
    roots = []
    for i in np.nonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))[0]:
        roots.append(brentq(d, fs[i], fs[i + 1], xtol=1e-12, rtol=1e-14))
    return np.array(roots)


def section(length, diameter, E, rho, nu):
    """A solid circular section tuple with Cowper's κ."""
    A = np.pi / 4 * diameter**2
    I = np.pi / 64 * diameter**4
    return (length, E, E / (2 * (1 + nu)), 6 * (1 + nu) / (7 + 6 * nu), rho, A, I)


def clamped_point_force(sections_before, sections_after, freq_hz, eta=0.0):
    """Responses (w at the load point s, w at the free end) (F, 2) to a unit force at s of a stepped beam
    clamped at its start: ``sections_before`` run from the clamp to s, ``sections_after`` from s to the end.

    A point force F at s makes the shear force jump by −F (V(z) is the load beyond z: V' = −q).
    """
    w = 2 * np.pi * np.atleast_1d(np.asarray(freq_hz, dtype=float))
    A = transfer(sections_before, w, eta)
    B = transfer(sections_after, w, eta)
    jump = np.array([0, 0, 0, -1.0])
    BA = B @ A
    Bj = B @ jump  # (F, 4)
    # z(L) = B (A z0 + jump), z0 = [0, 0, M0, V0]; M(L) = V(L) = 0
    m0v0 = np.linalg.solve(BA[:, 2:4, 2:4], -Bj[:, 2:4, None])[..., 0]
    zs = np.einsum("fij,fj->fi", A[:, :, 2:4], m0v0)  # the state just before s (w is continuous)
    zl = np.einsum("fij,fj->fi", BA[:, :, 2:4], m0v0) + Bj
    return np.stack([zs[:, 0], zl[:, 0]], axis=-1)
