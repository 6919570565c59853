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



def ranked_roots(structure: Structure, cutting: Cutting, freq_hz: np.ndarray) -> np.ndarray:
    """Both roots of [α][G] at ``freq_hz`` (F,), larger modulus first: (2, F). No tracking along ω."""
    tr, det = _tr_det(directional_matrix(cutting), structure_receptance(structure, np.asarray(freq_hz, dtype=float)))
    sq = np.sqrt(tr * tr - 4 * det)
    a, b = 0.5 * (tr + sq), 0.5 * (tr - sq)
    swap = np.abs(b) > np.abs(a)
    return np.stack([np.where(swap, b, a), np.where(swap, a, b)])


def lobe_tips(structure: Structure, cutting: Cutting, rpm_lo: float, rpm_hi: float,
              step_widths: float = 0.02) -> tuple[np.ndarray, np.ndarray]:
    """Speeds [rpm] and depths [m] of the lobe tips in [rpm_lo, rpm_hi]: the interior extrema of each
    lobe's speed Ω_k(ω) = 60ω/(N(ε + 2kπ)) along ω (where a lobe turns back), on a uniform grid of
    ``step_widths`` × the narrowest half-power width, per root rank (see :func:`ranked_roots`; a rank
    swap can add a spurious "tip", which only adds a speed band to check)."""
    n, kt = cutting.teeth, cutting.kt
    fns = np.array([m.fn for m in structure.modes])
    widths = np.array([m.zeta * m.fn for m in structure.modes])
    f = np.arange(0.2 * fns.min(), 3.0 * fns.max(), step_widths * widths.min())
    nu = ranked_roots(structure, cutting, f)
    speeds, depths = [], []
    k_max = int(math.ceil(f[-1] * 60.0 / (n * rpm_lo)))
    for v in nu:
        ok = v.real > 0
        inner = ok[:-2] & ok[1:-1] & ok[2:]
        eps = math.pi + 2 * np.angle(v)
        for k in range(k_max + 1):
            sp = 60.0 * f / (n * (eps + 2 * math.pi * k) / (2 * math.pi))
            d = np.diff(sp)
            turn = np.nonzero(inner & (np.sign(d[:-1]) != np.sign(d[1:])))[0] + 1
            turn = turn[(sp[turn] >= rpm_lo) & (sp[turn] <= rpm_hi)]
            speeds.append(sp[turn])
            depths.append(2 * math.pi / (n * kt * v.real[turn]))
    return np.concatenate(speeds), np.concatenate(depths)


def reference_envelope_dense(structure: Structure, cutting: Cutting, rpm, depth_cap: float | None = None,
                             step_widths: float = 0.02, max_cells: int = 20_000_000) -> tuple[np.ndarray, np.ndarray]:
    """The brute-force reference at many speeds at once, vectorised with numpy.

    The roots ν1, ν2 of [α][G(iω)] are ranked by modulus at every frequency (|ν1| ≥ |ν2|: a rule
    that needs no tracking along ω), and each rank's phase condition is the zero of
    Re(w̄ ν) = |ν| cos(arg ν − ωT/2), w = exp(iωT/2). Keeping the two ranks apart (rather than the
    product P of :func:`reference_depth`) matters where both roots have nearly the same phase: their
    zeros then lie close together and a product would show no sign change between them. Each rank is
    scanned on one uniform grid whose step is ``step_widths`` × the narrowest half-power width ζ·fn
    of the structure (50 points per damping width by default, ten times finer than the narrowest
    step of the engine's grid, and uniform everywhere; a measured FRF: 50 points per table step). Every sign
    change is refined by bisection to the last bits of ω (all brackets at once); the root is then identified
    with numpy.linalg.eigvals and kept only if it meets the phase condition (a sign change at a rank swap
    |ν1| = |ν2| is a jump, not a root, and is dropped). Near a rank swap a rank's own sign change can be hidden by
    that jump, so the product Re(w̄ν1) Re(w̄ν2) (symmetric in the roots, continuous across swaps) is
    scanned as well: a root is missed only where both scans miss it at once.

    ``depth_cap`` [m] (optional) only saves time: it drops the frequencies where no root can have a
    depth ≤ depth_cap, using |ν| ≤ ρ = (|tr| + |tr² − 4 det|^½)/2 for both roots, so
    depth ≥ 2π/(N Kt ρ). The result is exact at every speed whose limiting depth is ≤ depth_cap, and
    ``inf`` at a speed whose limiting depth exceeds the cap (a caller comparing with an engine passes
    a cap above the engine's depths, so an engine that misses a lower root still fails the check).

    Returns the depths [m] and chatter frequencies [Hz], both (S,).
    """
    alpha = directional_matrix(cutting)
    n, kt = cutting.teeth, cutting.kt
    rpm = np.atleast_1d(np.asarray(rpm, dtype=float))
    period = 60.0 / (n * rpm)  # (S,)
    if structure.is_modal:
        fns = np.array([m.fn for m in structure.modes])
        widths = np.array([m.zeta * m.fn for m in structure.modes])
        f_lo = 0.02 * fns.min()
        f_hi = max(8.0 * fns.max(), 1.5 * n * rpm.max() / 60.0)
        df = step_widths * widths.min()
    else:  # a measured table, linearly interpolated: 50 points per table step
        f_lo, f_hi = structure.frf.freq_hz[0], structure.frf.freq_hz[-1]
        df = np.diff(structure.frf.freq_hz).min() / 50.0
    f = np.arange(f_lo, f_hi, df)

    def ranked(freq):
        return ranked_roots(structure, cutting, freq)

    nu = ranked(f)
    if depth_cap is not None:
        rho = np.abs(nu[0])
        near = rho >= 0.8 * 2 * math.pi / (n * kt * depth_cap)  # ρ changes by ≪ 20 % over one cell
        near[:-1] |= near[1:]
        near[1:] |= near[:-1].copy()
        keep = np.nonzero(near)[0]
        f, nu = f[keep], nu[:, keep]
        adjacent = np.diff(keep) == 1  # sign changes only between neighbours on the full grid
    else:
        adjacent = np.ones(f.size - 1, dtype=bool)

    def phase_fn(freq, per, v):
        """Re(w̄ ν) at frequencies ``freq`` and periods ``per`` (broadcast)."""
        half = math.pi * freq * per  # ωT/2
        return np.cos(half) * v.real + np.sin(half) * v.imag

    # brackets (speed, kind, cell) of every sign change, speeds in chunks to bound memory. Kinds 0 and
    # 1 are the ranks; kind 2 is their product Re(w̄ν1) Re(w̄ν2), symmetric in the roots and hence
    # continuous across a rank swap, where a rank's own sign change can be hidden by the jump
    spd, kind, cell = [], [], []
    rows = max(1, int(max_cells // max(2 * f.size, 1)))
    for s0 in range(0, rpm.size, rows):
        pr = period[s0:s0 + rows, None]
        q0 = phase_fn(f[None, :], pr, nu[0][None, :])
        q1 = phase_fn(f[None, :], pr, nu[1][None, :])
        for r, q in enumerate((q0, q1, q0 * q1)):
            neg = q < 0
            js, cs = np.nonzero((neg[:, :-1] != neg[:, 1:]) & adjacent[None, :])
            spd.append(js + s0)
            kind.append(np.full(js.size, r))
            cell.append(cs)
    spd, kind, cell = np.concatenate(spd), np.concatenate(kind), np.concatenate(cell)
    a, b = f[cell], f[cell + 1]
    per = period[spd]

    def value(freq, v):
        q0, q1 = phase_fn(freq, per, v[0]), phase_fn(freq, per, v[1])
        return np.where(kind == 0, q0, np.where(kind == 1, q1, q0 * q1))

    neg_a = value(a, nu[:, cell]) < 0
    for _ in range(64):  # bisection: every bracket to the last bits of ω
        m = 0.5 * (a + b)
        neg_m = value(m, ranked(m)) < 0
        left = neg_m != neg_a
        b = np.where(left, m, b)
        a = np.where(left, a, m)
        if np.all(b - a <= 4e-16 * b):
            break
    rows_ = np.arange(spd.size)
    fc = 0.5 * (a + b)
    g = structure_receptance(structure, fc)
    nus = np.linalg.eigvals(np.einsum("ij,fjk->fik", alpha, g))  # (R, 2)
    theta = (math.pi * fc * per)[:, None]  # ωT/2
    resid = np.where(np.abs(nus) > 0, np.abs(np.cos(theta - np.angle(nus))), np.inf)
    pick = np.argmin(resid, axis=1)
    v = nus[rows_, pick]
    ok = (v.real > 0) & (resid[rows_, pick] < 1e-6)  # a root, not a rank swap
    depth = np.full(rpm.size, np.inf)
    chatter = np.full(rpm.size, np.nan)
    cand = np.where(ok, 2 * math.pi / (n * kt * np.where(ok, v.real, 1.0)), np.inf)
    np.minimum.at(depth, spd, cand)
    hit = np.isfinite(cand) & (cand == depth[spd])
    chatter[spd[hit]] = fc[hit]
    return depth, chatter
