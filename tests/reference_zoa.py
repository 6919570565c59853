"""An independent, brute-force zero-order reference for the tests (slow, simple, label-free).

At a fixed spindle speed (tooth period T) a root ν of [α][G(iω)] is on the stability boundary when
the phase condition ωT = π + 2 arg ν + 2mπ holds (m = 0, 1, …). For each root this is the zero of
Re(w ν̄) with w = exp(iωT/2), since Re(w ν̄) = |ν| cos(ωT/2 − arg ν). Their product over both roots
is a symmetric function of the roots, so it needs no eigenvalue labelling at all:

    P(ω) = Re(w ν̄1) Re(w ν̄2) = ½ Re(w̄² det) + (|tr|² − |tr² − 4 det|) / 8,

because Re(ν1 ν̄2) = (|ν1 + ν2|² − |ν1 − ν2|²)/4 and |ν1 − ν2|² = |tr² − 4 det|.

The reference scans P on a very fine uniform frequency grid, refines every sign change with Brent's
method, takes the eigenvalues there from numpy.linalg.eigvals (not the closed form), keeps the root
that satisfies the phase condition, and returns the smallest depth 2π/(N Kt Re ν) over the roots
with Re ν > 0. Nothing is shared with the production kernel except the directional matrix, which
the tests check separately against its closed forms.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

from millstab.frf import structure_receptance
from millstab.model import Cutting, Structure
from millstab.stability.zoa import directional_matrix


def _tr_det(alpha: np.ndarray, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    m = np.einsum("ij,fjk->fik", alpha, g)
    return m[:, 0, 0] + m[:, 1, 1], m[:, 0, 0] * m[:, 1, 1] - m[:, 0, 1] * m[:, 1, 0]


def reference_depth(structure: Structure, cutting: Cutting, rpm: float, f_max_hz: float | None = None,
                    n_grid: int = 400_000) -> tuple[float, float]:
    """Limiting depth [m] and chatter frequency [Hz] at one speed by brute force."""
    alpha = directional_matrix(cutting)
    n, kt = cutting.teeth, cutting.kt
    period = 60.0 / (n * rpm)
    if structure.is_modal:
        fns = [m.fn for m in structure.modes]
        f_lo = 0.02 * min(fns)
        f_hi = f_max_hz or max(8.0 * max(fns), 1.5 * n * rpm / 60.0)
    else:
        f_lo, f_hi = structure.frf.freq_hz[0], structure.frf.freq_hz[-1]
    f = np.linspace(f_lo, f_hi, n_grid)

    # a rigid direction makes one root identically zero (det ≡ 0) and P ≡ 0: the problem is then
    # scalar, ν = tr, and its own factor Re(w ν̄) is used instead
    rigid = structure.is_modal and not (structure.x and structure.y)

    def p_of(freq):
        freq = np.atleast_1d(freq)
        g = structure_receptance(structure, freq)
        tr, det = _tr_det(alpha, g)
        if rigid:
            return (np.exp(1j * math.pi * freq * period) * np.conj(tr)).real
        w2 = np.exp(-1j * 2 * math.pi * freq * period)  # conj(w)^2
        return 0.5 * (w2 * det).real + (np.abs(tr) ** 2 - np.abs(tr * tr - 4 * det)) / 8.0

    p = p_of(f)
    idx = np.nonzero(np.sign(p[:-1]) * np.sign(p[1:]) < 0)[0]
    best, best_f = math.inf, math.nan
    for i in idx:
        fc = brentq(lambda x: p_of(x)[0], f[i], f[i + 1], xtol=1e-13 * f[i], rtol=1e-15, maxiter=200)
        g = structure_receptance(structure, np.array([fc]))[0]
        nus = np.linalg.eigvals(alpha @ g)
        theta = math.pi * fc * period  # ωT/2
        resid = [abs(math.cos(theta - np.angle(v))) if abs(v) > 0 else math.inf for v in nus]
        v = nus[int(np.argmin(resid))]
        if v.real > 0:
            b = 2 * math.pi / (n * kt * v.real)
            if b < best:
                best, best_f = b, fc
    return best, best_f


def reference_envelope(structure: Structure, cutting: Cutting, rpm, **kw) -> tuple[np.ndarray, np.ndarray]:
    """:func:`reference_depth` at each speed: depths [m] and chatter frequencies [Hz]."""
    out = [reference_depth(structure, cutting, float(r), **kw) for r in np.atleast_1d(rpm)]
    return np.array([o[0] for o in out]), np.array([o[1] for o in out])
