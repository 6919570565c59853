"""Compiled (numba) time-domain milling simulation. Use :mod:`millstab.simulate` instead.

Model (SI units). Every mode j is a 1-DOF oscillator in direction d_j (0 = x feed, 1 = y cross-feed):

    q̈_j + 2 ζ_j ω_j q̇_j + ω_j² q_j = F_{d_j}(t) / m_j,     x = Σ_{d_j = 0} q_j,  y = Σ_{d_j = 1} q_j.

N equally spaced straight teeth; tooth angle ψ measured from +y (Altintas), cutting in
[φst, φex]. The tooth's radial direction is n = (sin ψ, cos ψ); its position along n is
s = (X_f(t) + x) sin ψ + y cos ψ with X_f = f_t t / T the feed. The chip is the part of s beyond
the surface S(ψ) left by the last tooth that cut at that angle (multiple regeneration: a tooth that
was out of the cut leaves S unchanged, so the next tooth meets the older surface):

    h = s − S(ψ),   F = b Kt h (−cos ψ − Kr sin ψ,  sin ψ − Kr cos ψ)   if h > 0 and φst ≤ ψ ≤ φex,
    F = 0 otherwise,   S(ψ) ← s after a cut.

Process damping (optional, :mod:`millstab.stability.process_damping`): a tooth in contact (h > 0)
also carries F_d = −c_pd (n · u̇) n, c_pd = b C / V, instantaneous: its value at each end of a step
enters the same first-order hold (at the end it is linear in the unknown end velocity, solved with
the displacement in one 2×2 system). A tooth leaving or entering the cut within a step carries it at
the end where it is in contact (first order at those instants only); at a grid point where the
static chip is zero (ψ = 0 or π, see ZERO_CHIP) it carries none, so the term does not switch on and
off with the sign of a vanishing chip (the flank contact vanishes with the chip; the semi-discretization
engine's step averages give that instant no weight either).

Without vibration S(ψ) = X_f(t − T) sin ψ and h = f_t sin ψ; linearised about a T-periodic motion
h − f_t sin ψ = n·(u(t) − u(t − T)) with u = (x, y): the force of the semi-discretization engine,
F = ½ b Kt [A(t)] (u(t) − u(t − T)) (see :mod:`millstab.stability._sdm_kernel`), same signs; the 2×2 closed
forms of its free flight are :mod:`millstab.stability._linalg`'s.

Grid. One tooth period T = 60/(N Ω) is m equal steps ("nodes", the output samples) plus, where a
tooth leaves the cut between two nodes, that exit instant as one extra point: every entry is at a
node (tooth 0 enters at t = 0), every exit at a grid point, so no step straddles a jump of the
screen function. The grid repeats every period, so the angle of a "slot" k (the tooth that is k
pitches ahead of the one entering at the period start) at grid point p is the same in every period,
ψ(p, k) = φst + (phase_p + k) 2π/N, and the surface is stored per (p, k): the delay is exact (no
interpolation of the delayed state).

Step. Each mode is advanced exactly (matrix exponential of its 2×2 system) under a force that is
linear in time over the step between its values at the two ends (first-order hold):

    z_b = Φ z_a + Γ0 F_a + Γ1 F_b,  Φ = e^{Aτ},  Γ0 = (F1 − F2/τ) B,  Γ1 = (F2/τ) B,
    F1 = ∫₀^τ e^{A(τ−s)} ds,  F2 = ∫₀^τ e^{A(τ−s)} s ds,  B = (0, 1/m)ᵀ.

F_b depends on the unknown displacement at the step end (the chip is cut now): for the teeth in
the cut at both ends F_b = K u_b + r is linear, so u_b solves one 2×2 system (implicit, no
stability limit on the step), started from a predictor with F held constant and repeated (≤ 4
passes) while the contact changes. A tooth whose chip changes sign within the step (it leaves or
enters the cut there) contributes the endpoint values of the straight line with the same integral
and first moment as its clipped linear chip, so a chip that is zero at a grid point (ψ = 0 or π,
where f_t sin ψ = 0) does not spoil the order. The local error is O(τ³) (force interpolation), so
the scheme is second order in τ; free vibration is exact for any step.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from millstab.stability._linalg import _expm_2x2

TWO_PI = 2.0 * math.pi

# Every compiled function of the simulation lives in this one file: numba's on-disk cache of a
# function is only refreshed when its own file changes, so a kernel calling into another module
# could keep running stale code after an edit there. (The 2×2 matrix functions are the
# semi-discretization engine's, unchanged since they were written.)

# detector thresholds (rules and reasons in millstab.simulate.detect)
#: growth factor of the tooth-to-tooth RMS over W periods above which a cut is chatter
GROWTH = 1.5
#: level (RMS of the tooth-to-tooth change over the feed per tooth) of a sustained chatter
LEVEL_CHATTER = 0.1
#: level below which the once-per-tooth samples are converged (stable)
LEVEL_QUIET = 1e-4
#: at most this many of the last tooth periods enter the spectrum (cost, and resolution f_T / 64)
SPECTRUM_PERIODS = 64
#: the fewest tooth periods a detection needs (two halves of 4)
MIN_PERIODS = 8
#: blocks of the log-RMS trend fit over the analysed periods
TREND_BLOCKS = 8
STABLE, MARGINAL, CHATTER = 0, 1, 2
#: a tooth at a grid point is "in the cut" for surface updates when ψ ≤ φex + this [rad]
ANGLE_TOL = 1e-9
#: |sin ψ| below this: a grid point at ψ = 0 or π, where the static chip f_t sin ψ is zero. There the
#: surface always takes the tooth's path, cut or not: in continuous time the angles near 0 or π
#: where a small vibration makes the chip negative shrink with it (width ~ |Δu| / f_t), so keeping
#: the older surface at that one grid point would put an O(τ |Δu|) error into the linear dynamics.
ZERO_CHIP = 1e-9


@nb.njit(cache=True)
def period_points(n_teeth, phi_s, phi_e, m):
    """Grid of one tooth period: phases (P + 1,) in [0, 1] (last = 1) and node flags (P,).

    Nodes are k/m; the exit instant (φex − φst) mod pitch is added unless it falls on a node.
    """
    pitch = TWO_PI / n_teeth
    e = ((phi_e - phi_s) / pitch) % 1.0
    extra = not (e < 1e-9 or 1.0 - e < 1e-9 or abs(e * m - round(e * m)) < 1e-9 * m)
    P = m + (1 if extra else 0)
    phase = np.empty(P + 1)
    node = np.zeros(P, dtype=np.bool_)
    i = 0
    added = not extra
    for k in range(m):
        ph = k / m
        if not added and e < ph:
            phase[i] = e
            i += 1
            added = True
        phase[i] = ph
        node[i] = True
        i += 1
    if not added:
        phase[i] = e
        i += 1
    phase[P] = 1.0
    return phase, node


@nb.njit(cache=True)
def setup(n_teeth, phi_s, phi_e, rpm, m, wn, zeta, mass):
    """Per-period geometry and per-step modal matrices.

    Returns phase (P+1,), node (P,), sin/cos of ψ(p, k) (P, N), act (P, N) whether slot k cuts on
    step p, and per step p and mode j: Φ (P, M, 2, 2), Γ0 (P, M, 2), Γ1 (P, M, 2).
    """
    T = 60.0 / (n_teeth * rpm)
    pitch = TWO_PI / n_teeth
    phase, node = period_points(n_teeth, phi_s, phi_e, m)
    P = node.size
    sp = np.empty((P, n_teeth))
    cp = np.empty((P, n_teeth))
    act = np.zeros((P, n_teeth), dtype=np.bool_)
    for p in range(P):
        mid = 0.5 * (phase[p] + phase[p + 1])
        for k in range(n_teeth):
            psi = phi_s + (phase[p] + k) * pitch
            sp[p, k] = math.sin(psi)
            cp[p, k] = math.cos(psi)
            act[p, k] = phi_s + (mid + k) * pitch <= phi_e
    M = wn.size
    PH = np.empty((P, M, 2, 2))
    G0 = np.empty((P, M, 2))
    G1 = np.empty((P, M, 2))
    phi = np.empty((2, 2))
    f1 = np.empty((2, 2))
    f2 = np.empty((2, 2))
    for p in range(P):
        tau = (phase[p + 1] - phase[p]) * T
        for j in range(M):
            _expm_2x2(0.0, 1.0, -wn[j] * wn[j], -2.0 * zeta[j] * wn[j], tau, phi, f1, f2)
            PH[p, j] = phi
            for r in range(2):  # B = (0, 1/m): only the second column of F1, F2 enters
                G0[p, j, r] = (f1[r, 1] - f2[r, 1] / tau) / mass[j]
                G1[p, j, r] = f2[r, 1] / tau / mass[j]
    return phase, node, sp, cp, act, PH, G0, G1


@nb.njit(cache=True, inline="always")
def _contact(bkt, kr, s, c, xf, S, x, y):
    """Chip h at one tooth and the force direction; returns (h, fx_unit, fy_unit, base) with
    h = base + s x + c y, base = xf s − S."""
    base = xf * s - S
    h = base + s * x + c * y
    return h, -c - kr * s, s - kr * c, base


@nb.njit(cache=True, inline="always")
def _damp(cpd, s, c, vx, vy):
    """Process-damping force (fx, fy) [N] of one tooth in contact: −c_pd (n · u̇) n, n = (s, c)."""
    vn = cpd * (s * vx + c * vy)
    return -vn * s, -vn * c


@nb.njit(cache=True, inline="always")
def _free_dir(PH, G0, p, row, q, v, fx, fy, mdir):
    """Per direction (x, y), the sum over modes of row ``row`` (0: displacement, 1: velocity) of the
    step's free part Φ z + Γ0 F_a, F_a = (fx, fy) the start force."""
    sx = 0.0
    sy = 0.0
    for j in range(q.size):
        fa = fx if mdir[j] == 0 else fy
        val = PH[p, j, row, 0] * q[j] + PH[p, j, row, 1] * v[j] + G0[p, j, row] * fa
        if mdir[j] == 0:
            sx += val
        else:
            sy += val
    return sx, sy


@nb.njit(cache=True)
def _dir_sum(a, mdir):
    """(Σ over x modes, Σ over y modes) of the per-mode values a (M,)."""
    sx = 0.0
    sy = 0.0
    for j in range(a.size):
        if mdir[j] == 0:
            sx += a[j]
        else:
            sy += a[j]
    return sx, sy


@nb.njit(cache=True)
def simulate(n_teeth, kt, kr, phi_s, phi_e, rpm, m, n_periods, depth, ft, wn, zeta, mass, mdir,
             q0, v0, surf0, bound, out_x, out_y, out_fx, out_fy, cpd=0.0):
    """Integrate one cut over n_periods tooth periods with m nodes per period.

    q0, v0 (M,) initial modal displacement [m] and velocity [m/s]; surf0 (P, N) the initial surface
    (what the previous tooth left, absolute, including −f_t sin ψ from the feed). Writes the node
    samples x, y [m], fx, fy [N] into out_* (n_periods m + 1,). Stops when |x| or |y| exceeds
    ``bound`` [m] or is not finite. Returns the number of samples written. ``cpd`` = b C / V [N·s/m]:
    the process damping of a tooth in contact (0: none; that path is the one without the term).
    """
    phase, node, sp, cp, act, PH, G0, G1 = setup(n_teeth, phi_s, phi_e, rpm, m, wn, zeta, mass)
    P = node.size
    M = wn.size
    N = n_teeth
    bkt = depth * kt
    S = surf0.copy()
    q = q0.copy()
    v = v0.copy()
    x = 0.0
    y = 0.0
    for j in range(M):
        if mdir[j] == 0:
            x += q[j]
        else:
            y += q[j]
    # force just after t = 0 (step 0's contact set), then the surface update at point 0
    fxa = 0.0
    fya = 0.0
    ha = np.zeros(N)  # chip of each tooth at the start of the step (old surface), unclipped
    vx, vy = _dir_sum(v, mdir)
    for k in range(N):
        if act[0, k]:
            h, ux, uy, _ = _contact(bkt, kr, sp[0, k], cp[0, k], 0.0, S[0, k], x, y)
            ha[k] = h
            if h > 0.0:
                fxa += bkt * h * ux
                fya += bkt * h * uy
                if cpd != 0.0 and abs(sp[0, k]) >= ZERO_CHIP:
                    dx, dy = _damp(cpd, sp[0, k], cp[0, k], vx, vy)
                    fxa += dx
                    fya += dy
    for k in range(N):
        if phi_s + k * TWO_PI / N <= phi_e + ANGLE_TOL:
            h = 0.0 * sp[0, k] - S[0, k] + sp[0, k] * x + cp[0, k] * y
            if h > 0.0 or abs(sp[0, k]) < ZERO_CHIP:
                S[0, k] += h
    out_x[0] = x
    out_y[0] = y
    out_fx[0] = fxa
    out_fy[0] = fya
    n_out = 1
    qn = np.empty(M)
    vn = np.empty(M)
    for c in range(n_periods):
        for p in range(P):
            end = p + 1 == P
            xf_b = ft * (c + phase[p + 1])
            # free part w = C(Φ z + Γ0 F_a), predictor with F_b = F_a, and the Γ1 gains per direction
            wx = 0.0
            wy = 0.0
            px = 0.0
            py = 0.0
            g1x = 0.0
            g1y = 0.0
            for j in range(M):
                fa = fxa if mdir[j] == 0 else fya
                qf = PH[p, j, 0, 0] * q[j] + PH[p, j, 0, 1] * v[j] + G0[p, j, 0] * fa
                if mdir[j] == 0:
                    wx += qf
                    px += qf + G1[p, j, 0] * fa
                    g1x += G1[p, j, 0]
                else:
                    wy += qf
                    py += qf + G1[p, j, 0] * fa
                    g1y += G1[p, j, 0]
            # end force: chips at both ends of the step per tooth; where a chip changes sign within
            # the step the tooth leaves (enters) the cut there, and the clipped linear chip is
            # replaced by the linear one with the same integral and first moment (endpoint values
            # a, b below), so a chip that is zero at a node (ψ = 0, π) does not cost O(τ)
            xb = px
            yb = py
            fxb = 0.0
            fyb = 0.0
            fxe = fxa
            fye = fya
            vxa = 0.0
            vya = 0.0
            gvx = 0.0
            gvy = 0.0
            if cpd != 0.0:  # start velocity, and the end velocity's Γ1 gains per direction
                vxa, vya = _dir_sum(v, mdir)
                gvx, gvy = _dir_sum(G1[p, :, 1], mdir)
            for _it in range(4):
                k11 = 0.0
                k12 = 0.0
                k21 = 0.0
                k22 = 0.0
                r1 = 0.0
                r2 = 0.0
                fxe = 0.0  # start force of this step (effective)
                fye = 0.0
                cx = 0.0  # end force of crossing teeth, held fixed in this pass
                cy = 0.0
                d11 = 0.0  # process damping at the step end: Σ c_pd n nᵀ over the teeth in contact there
                d12 = 0.0
                d22 = 0.0
                for k in range(N):
                    if not act[p, k]:
                        continue
                    pb = 0 if end else p + 1
                    kb = (k + 1) % N if end else k
                    s = sp[pb, kb]
                    cc = cp[pb, kb]
                    hb, ux, uy, base = _contact(bkt, kr, s, cc, xf_b, S[pb, kb], xb, yb)
                    h0 = ha[k]
                    uxa = -cp[p, k] - kr * sp[p, k]
                    uya = sp[p, k] - kr * cp[p, k]
                    on_k = hb > 0.0
                    if cpd != 0.0:
                        if h0 > 0.0 and abs(sp[p, k]) >= ZERO_CHIP:
                            dx, dy = _damp(cpd, sp[p, k], cp[p, k], vxa, vya)
                            fxe += dx
                            fye += dy
                        if on_k and abs(s) >= ZERO_CHIP:
                            d11 += cpd * s * s
                            d12 += cpd * s * cc
                            d22 += cpd * cc * cc
                    if h0 > 0.0 and on_k:
                        k11 += bkt * ux * s
                        k12 += bkt * ux * cc
                        k21 += bkt * uy * s
                        k22 += bkt * uy * cc
                        r1 += bkt * ux * base
                        r2 += bkt * uy * base
                        fxe += bkt * h0 * uxa
                        fye += bkt * h0 * uya
                    elif h0 > 0.0 or on_k:
                        if h0 > 0.0:  # leaves at σ τ: a = h0 σ (2 − σ), b = h0 σ (σ − 1)
                            sg = h0 / (h0 - hb)
                            a = h0 * sg * (2.0 - sg)
                            b = h0 * sg * (sg - 1.0)
                        else:  # enters at (1 − ρ) τ: a = hb ρ (ρ − 1), b = hb ρ (2 − ρ)
                            rh = hb / (hb - h0)
                            a = hb * rh * (rh - 1.0)
                            b = hb * rh * (2.0 - rh)
                        fxe += bkt * a * uxa
                        fye += bkt * a * uya
                        cx += bkt * b * ux
                        cy += bkt * b * uy
                # w = C(Φ z + Γ0 F_a); (I − diag(g1) K) u = w + diag(g1) (r + crossing end force)
                wx, wy = _free_dir(PH, G0, p, 0, q, v, fxe, fye, mdir)
                if cpd == 0.0:
                    a11 = 1.0 - g1x * k11
                    a12 = -g1x * k12
                    a21 = -g1y * k21
                    a22 = 1.0 - g1y * k22
                    b1 = wx + g1x * (r1 + cx)
                    b2 = wy + g1y * (r2 + cy)
                    det = a11 * a22 - a12 * a21
                    xn = (b1 * a22 - a12 * b2) / det
                    yn = (a11 * b2 - a21 * b1) / det
                    fxb = k11 * xn + k12 * yn + r1 + cx
                    fyb = k21 * xn + k22 * yn + r2 + cy
                else:
                    # u_b = w + g1 F_b, u̇_b = wv + gv F_b, F_b = K u_b + r − D u̇_b:
                    # (I − K g1 + D gv) F_b = K w + r − D wv
                    wvx, wvy = _free_dir(PH, G0, p, 1, q, v, fxe, fye, mdir)
                    a11 = 1.0 - k11 * g1x + d11 * gvx
                    a12 = -k12 * g1y + d12 * gvy
                    a21 = -k21 * g1x + d12 * gvx
                    a22 = 1.0 - k22 * g1y + d22 * gvy
                    b1 = k11 * wx + k12 * wy + r1 + cx - (d11 * wvx + d12 * wvy)
                    b2 = k21 * wx + k22 * wy + r2 + cy - (d12 * wvx + d22 * wvy)
                    det = a11 * a22 - a12 * a21
                    fxb = (b1 * a22 - a12 * b2) / det
                    fyb = (a11 * b2 - a21 * b1) / det
                    xn = wx + g1x * fxb
                    yn = wy + g1y * fyb
                moved = abs(xn - xb) + abs(yn - yb)
                xb = xn
                yb = yn
                if moved <= 1e-13 * (abs(xb) + abs(yb)) + 1e-300:
                    break
            fxa = fxe
            fya = fye
            # advance every mode with the final end force
            x = 0.0
            y = 0.0
            for j in range(M):
                fa = fxa if mdir[j] == 0 else fya
                fb = fxb if mdir[j] == 0 else fyb
                qn[j] = PH[p, j, 0, 0] * q[j] + PH[p, j, 0, 1] * v[j] + G0[p, j, 0] * fa + G1[p, j, 0] * fb
                vn[j] = PH[p, j, 1, 0] * q[j] + PH[p, j, 1, 1] * v[j] + G0[p, j, 1] * fa + G1[p, j, 1] * fb
                if mdir[j] == 0:
                    x += qn[j]
                else:
                    y += qn[j]
            for j in range(M):
                q[j] = qn[j]
                v[j] = vn[j]
            if not (abs(x) <= bound and abs(y) <= bound):
                return n_out
            # the next point: force just after it (the next step's contact set, old surface), then
            # the surface it leaves
            pn = 0 if end else p + 1
            fxa = 0.0
            fya = 0.0
            if cpd != 0.0:
                vx, vy = _dir_sum(v, mdir)
            for k in range(N):
                ha[k] = 0.0
                if act[pn, k]:
                    h, ux, uy, _ = _contact(bkt, kr, sp[pn, k], cp[pn, k], xf_b, S[pn, k], x, y)
                    ha[k] = h
                    if h > 0.0:
                        fxa += bkt * h * ux
                        fya += bkt * h * uy
                        if cpd != 0.0 and abs(sp[pn, k]) >= ZERO_CHIP:
                            dx, dy = _damp(cpd, sp[pn, k], cp[pn, k], vx, vy)
                            fxa += dx
                            fya += dy
            for k in range(N):
                if phi_s + (phase[pn] + k) * TWO_PI / N <= phi_e + ANGLE_TOL:
                    h = xf_b * sp[pn, k] - S[pn, k] + sp[pn, k] * x + cp[pn, k] * y
                    if h > 0.0 or abs(sp[pn, k]) < ZERO_CHIP:
                        S[pn, k] += h
            if end or node[p + 1]:
                out_x[n_out] = x
                out_y[n_out] = y
                out_fx[n_out] = fxa
                out_fy[n_out] = fya
                n_out += 1
    return n_out


@nb.njit(cache=True)
def rest_surface(n_teeth, phi_s, phi_e, m, ft):
    """The surface left by a previous tooth without vibration: S(p, k) = f_t (phase_p − 1) sin ψ."""
    phase, node = period_points(n_teeth, phi_s, phi_e, m)
    P = node.size
    S = np.empty((P, n_teeth))
    pitch = TWO_PI / n_teeth
    for p in range(P):
        for k in range(n_teeth):
            S[p, k] = ft * (phase[p] - 1.0) * math.sin(phi_s + (phase[p] + k) * pitch)
    return S


# ---------------------------------------------------------------------------------------------------
# the forced T-periodic motion (no regeneration): Fourier series of the static force × receptance
# ---------------------------------------------------------------------------------------------------


@nb.njit(cache=True)
def force_harmonic(n, n_teeth, kt, kr, phi_s, phi_e, depth, ft):
    """Complex Fourier coefficient c_n (x, y) [N] of the force of an unvibrating cut, period T.

    F(t) = Σ_teeth b Kt f_t sin ψ (−cos ψ − Kr sin ψ, sin ψ − Kr cos ψ) over [φst, φex] (h = f_t sin ψ
    ≥ 0 there). With ψ = Ωt + φst for the tooth entering at t = 0 the N teeth fill one revolution, so
    c_n = (N / 2π) ∫_{φst}^{φex} F₁(ψ) e^{−i n N (ψ − φst)} dψ, in closed form from
    sin ψ cos ψ = ½ sin 2ψ and sin² ψ = ½ (1 − cos 2ψ).
    """
    q = n * n_teeth
    J = np.empty(3, dtype=np.complex128)  # ∫ e^{i a ψ} e^{−i q (ψ − φst)} dψ for a = −2, 0, 2
    for ia in range(3):
        a = 2 * (ia - 1)
        if a == q:
            J[ia] = np.exp(1j * q * phi_s) * (phi_e - phi_s)
        else:
            d = a - q
            J[ia] = np.exp(1j * q * phi_s) * (np.exp(1j * d * phi_e) - np.exp(1j * d * phi_s)) / (1j * d)
    s2 = (J[2] - J[0]) / 2j
    c2 = (J[2] + J[0]) / 2.0
    one = J[1]
    scale = n_teeth / TWO_PI * depth * kt * ft
    cx = scale * (-0.5 * s2 - 0.5 * kr * (one - c2))
    cy = scale * (0.5 * (one - c2) - 0.5 * kr * s2)
    return cx, cy


@nb.njit(cache=True)
def periodic_surface(n_teeth, phi_s, phi_e, m, ft, phase, ux, uy):
    """The surface (P, N) left on a T-periodic motion with tool-tip displacement ux, uy (P,) [m] at the
    grid points: the unvibrating one (:func:`rest_surface`) moved by the displacement along each n."""
    S = rest_surface(n_teeth, phi_s, phi_e, m, ft)
    pitch = TWO_PI / n_teeth
    for p in range(phase.size - 1):
        for k in range(n_teeth):
            psi = phi_s + (phase[p] + k) * pitch
            S[p, k] += ux[p] * math.sin(psi) + uy[p] * math.cos(psi)
    return S


@nb.njit(cache=True)
def steady_start(n_teeth, kt, kr, phi_s, phi_e, rpm, m, depth, ft, wn, zeta, mass, mdir, n_harm, n_harm_state):
    """Modal state (q, v) at t = 0 and the surface (P, N) of the forced T-periodic motion.

    On that motion u(t) = u(t − T), so the chip is f_t sin ψ and the force is the static one: its
    Fourier series times each mode's receptance 1/(m (ωn² − ω² + 2iζωnω)): n_harm harmonics for the
    surface (displacement terms fall as 1/n³), n_harm_state for the state at t = 0 (the velocity terms
    fall only as 1/n² where a tooth enters with a finite chip, and the sum there is cheap).
    """
    T = 60.0 / (n_teeth * rpm)
    wT = TWO_PI / T
    phase, node = period_points(n_teeth, phi_s, phi_e, m)
    P = node.size
    M = wn.size
    q0 = np.zeros(M)
    v0 = np.zeros(M)
    ux = np.zeros(P)
    uy = np.zeros(P)
    rot = np.empty(P, dtype=np.complex128)
    for p in range(P):
        rot[p] = np.exp(1j * wT * phase[p] * T)
    E = np.ones(P, dtype=np.complex128)  # e^{i n ωT t_p}, advanced by one harmonic per pass
    for n in range(max(n_harm, n_harm_state) + 1):
        if n > 0 and n <= n_harm:
            for p in range(P):
                E[p] *= rot[p]
        cx, cy = force_harmonic(n, n_teeth, kt, kr, phi_s, phi_e, depth, ft)
        w = n * wT
        wgt = 1.0 if n == 0 else 2.0
        for j in range(M):
            H = 1.0 / (mass[j] * (wn[j] * wn[j] - w * w + 2j * zeta[j] * wn[j] * w))
            qc = wgt * H * (cx if mdir[j] == 0 else cy)
            if n <= n_harm_state:
                q0[j] += qc.real
                v0[j] += (1j * w * qc).real
            if n > n_harm:
                continue
            for p in range(P):
                val = (qc * E[p]).real
                if mdir[j] == 0:
                    ux[p] += val
                else:
                    uy[p] += val
    return q0, v0, periodic_surface(n_teeth, phi_s, phi_e, m, ft, phase, ux, uy)


# ---------------------------------------------------------------------------------------------------
# the detector's metrics (rules in millstab.simulate.detect)
# ---------------------------------------------------------------------------------------------------


@nb.njit(cache=True)
def _rms_diff(x, y, m, c0, c1, lag):
    """RMS over c in [c0, c1) of |P_c − P_{c−lag}|, P_c = (x, y)[c m]."""
    s = 0.0
    for c in range(c0, c1):
        dx = x[c * m] - x[(c - lag) * m]
        dy = y[c * m] - y[(c - lag) * m]
        s += dx * dx + dy * dy
    return math.sqrt(s / max(c1 - c0, 1))


@nb.njit(cache=True)
def _peak(x, y, m, c_end, n_per, stride, k_hi):
    """(frequency in units of f_T, peak power) of the non-synchronous part of the last n_per periods.

    Residual = signal − its average over those periods at each phase (removes all harmonics of f_T);
    Hann window; DFT bins j / n_per (j = 1..k_hi, in units of f_T) on every ``stride``-th sample.
    """
    L = n_per * m
    i0 = (c_end - n_per) * m
    avg_x = np.zeros(m)
    avg_y = np.zeros(m)
    for c in range(n_per):
        for i in range(m):
            avg_x[i] += x[i0 + c * m + i]
            avg_y[i] += y[i0 + c * m + i]
    avg_x /= n_per
    avg_y /= n_per
    n_s = (L + stride - 1) // stride
    rx = np.empty(n_s)
    ry = np.empty(n_s)
    for s in range(n_s):
        i = s * stride
        w = 0.5 - 0.5 * math.cos(2.0 * math.pi * i / L)
        rx[s] = w * (x[i0 + i] - avg_x[i % m])
        ry[s] = w * (y[i0 + i] - avg_y[i % m])
    pw = np.zeros(k_hi + 2)
    for j in range(1, k_hi + 2):
        dth = 2.0 * math.pi * j * stride / L
        rot = complex(math.cos(dth), -math.sin(dth))
        e = 1.0 + 0.0j
        sx = 0.0j
        sy = 0.0j
        for s in range(n_s):
            sx += rx[s] * e
            sy += ry[s] * e
            e *= rot
        pw[j] = abs(sx) ** 2 + abs(sy) ** 2
    best = 1
    for j in range(1, k_hi + 1):
        if pw[j] > pw[best]:
            best = j
    f = float(best)
    if 1 < best and pw[best - 1] > 0 and pw[best + 1] > 0 and pw[best] > 0:
        a = math.log(pw[best - 1])
        b = math.log(pw[best])
        c = math.log(pw[best + 1])
        den = a - 2 * b + c
        if den < 0:
            f += 0.5 * (a - c) / den
    return f / n_per, pw[best]


@nb.njit(cache=True)
def _trend(x, y, m, c0, c1):
    """Per-tooth-period multiplier |μ| of the tooth-to-tooth change over c in [c0, c1): exp of the
    least-squares slope of log RMS(d_c) on TREND_BLOCKS equal blocks (a block of several periods
    averages the rotation of a Hopf pair, so the fit sees the envelope, not the beat)."""
    n = c1 - c0
    nb_ = min(TREND_BLOCKS, n // 2)
    if nb_ < 2:
        r1 = _rms_diff(x, y, m, c0, c0 + n // 2, 1)
        r2 = _rms_diff(x, y, m, c0 + n // 2, c1, 1)
        if r1 <= 0.0:
            return 1.0 if r2 <= 0.0 else np.inf
        return (r2 / r1) ** (1.0 / max(n / 2.0, 1.0))
    lb = n // nb_
    st = 0.0
    sl = 0.0
    stt = 0.0
    stl = 0.0
    for b in range(nb_):
        a = c1 - (nb_ - b) * lb  # blocks end at c1 (the latest periods count)
        r = max(_rms_diff(x, y, m, a, a + lb, 1), 1e-300)
        t = a + 0.5 * lb
        lr = math.log(r)
        st += t
        sl += lr
        stt += t * t
        stl += t * lr
    den = nb_ * stt - st * st
    return math.exp((nb_ * stl - st * sl) / den)


@nb.njit(cache=True)
def _crossing_hz(x, y, i0, i1, dt):
    """Half the rate of sign changes of the larger of x, y (mean removed) over samples [i0, i1) [Hz]."""
    best = 0.0
    for ch in range(2):
        z = x if ch == 0 else y
        mz = 0.0
        for i in range(i0, i1):
            mz += z[i]
        mz /= max(i1 - i0, 1)
        n = 0
        for i in range(i0 + 1, i1):
            if (z[i] - mz) * (z[i - 1] - mz) < 0.0:
                n += 1
        best = max(best, n / (2.0 * max(i1 - i0 - 1, 1) * dt))
    return best


@nb.njit(cache=True)
def _prony(x, y, i0, i1, stride, dt):
    """(frequency [Hz], per-second growth rate σ) of the dominant oscillation of x, y over samples
    [i0, i1): one second-order linear predictor z_n = a₁ z_{n−1} + a₂ z_{n−2} fitted to both (mean
    removed) by least squares; its roots e^{(σ ± iω) stride dt}. For a run that diverged before two
    tooth periods (no synchronous average possible): the exponential growth dominates there.
    Where the roots are real (no oscillation fits) the frequency is the zero-crossing rate, σ NaN."""
    mx = 0.0
    my = 0.0
    cnt = 0
    for i in range(i0, i1, stride):
        mx += x[i]
        my += y[i]
        cnt += 1
    mx /= max(cnt, 1)
    my /= max(cnt, 1)
    s11 = 0.0
    s12 = 0.0
    s22 = 0.0
    b1 = 0.0
    b2 = 0.0
    for ch in range(2):
        z = x if ch == 0 else y
        mz = mx if ch == 0 else my
        for i in range(i0 + 2 * stride, i1, stride):
            z0 = z[i] - mz
            z1 = z[i - stride] - mz
            z2 = z[i - 2 * stride] - mz
            s11 += z1 * z1
            s12 += z1 * z2
            s22 += z2 * z2
            b1 += z1 * z0
            b2 += z2 * z0
    det = s11 * s22 - s12 * s12
    if det <= 0.0:
        return _crossing_hz(x, y, i0, i1, dt), np.nan
    a1 = (b1 * s22 - s12 * b2) / det
    a2 = (s11 * b2 - s12 * b1) / det
    disc = a1 * a1 + 4.0 * a2
    if disc >= 0.0 or a2 >= 0.0:
        return _crossing_hz(x, y, i0, i1, dt), np.nan
    rho = math.sqrt(-a2)  # |λ|
    th = math.acos(max(-1.0, min(1.0, a1 / (2.0 * rho))))
    h = stride * dt
    return th / (2.0 * math.pi * h), math.log(rho) / h


@nb.njit(cache=True)
def detect_core(x, y, n_out, m, ft, f_tooth, f_hi, diverged):
    """Detection metrics of one simulated cut (node samples x, y, n_out of them, m per period).

    Returns (label code, chatter frequency [Hz] or NaN, lobe code, level L, growth G, spectral
    window periods, multiplier |μ| per tooth period). See :mod:`millstab.simulate.detect`.
    """
    C = (n_out - 1) // m  # complete periods; once-per-tooth samples at c m, c = 0..C
    nan = np.nan
    T = 1.0 / f_tooth
    fs = m * f_tooth
    stride = max(1, int(fs / (2.5 * f_hi)))
    if C < 2:
        if not diverged:
            return MARGINAL, nan, 0, nan, nan, 0, nan
        # diverged within two periods: frequency and growth of the blow-up itself
        i0 = n_out // 2
        st = max(1, min(stride, (n_out - i0) // 8))
        hz, _ = _prony(x, y, i0, n_out, st, T / m)
        # growth: the largest |u| on the last quarter of the samples over that on the quarter before,
        # per tooth period (a blow-up this fast is nonlinear: an envelope ratio, not a linear fit)
        q = max(n_out // 4, 1)
        a1 = 0.0
        a2 = 0.0
        for i in range(n_out - 2 * q, n_out - q):
            a1 = max(a1, abs(x[i]), abs(y[i]))
        for i in range(n_out - q, n_out):
            a2 = max(a2, abs(x[i]), abs(y[i]))
        mu = (a2 / a1) ** (m / q) if a1 > 0 else np.inf
        peak = a2
        lobe = 0
        if hz == hz:
            frac = hz / f_tooth
            lobe = 2 if abs((frac % 1.0) - 0.5) < 0.05 else 1
        return CHATTER, hz, lobe, peak / ft, mu, 0, mu
    if C >= MIN_PERIODS:
        W = C // 4
        c0 = C - 2 * W + 1  # the last half: the entry transient (the first half) is left out
        r2 = _rms_diff(x, y, m, C - W + 1, C + 1, 1)
    else:
        W = max(C // 2, 1)
        c0 = 1
        r2 = _rms_diff(x, y, m, C // 2 + 1, C + 1, 1)
    mu = _trend(x, y, m, c0, C + 1)
    level = r2 / ft
    growth = mu ** W if mu < np.inf else np.inf
    if diverged:
        label = CHATTER
    elif level < LEVEL_QUIET:
        label = STABLE  # numerical-noise level: any "growth" of it is no vibration at all
    elif growth >= GROWTH:
        label = CHATTER
    elif growth <= 1.0 / GROWTH:
        label = STABLE
    elif level >= LEVEL_CHATTER:
        label = CHATTER
    else:
        label = MARGINAL
    hz = nan
    lobe = 0
    n_per = min(SPECTRUM_PERIODS, max(C // 2, 1) if C >= MIN_PERIODS else C)
    if label != STABLE:
        k_hi = max(2, int(f_hi / f_tooth * n_per))
        frac, pw = _peak(x, y, m, C, n_per, stride, k_hi)
        if pw > 0:
            hz = frac * f_tooth
            half = (frac % 1.0) - 0.5
            lobe = 2 if abs(half) < 1.5 / n_per else 1
        elif diverged:
            hz, _ = _prony(x, y, 0, n_out, stride, T / m)
    return label, hz, lobe, level, growth, n_per, mu


# ---------------------------------------------------------------------------------------------------
# a batch of cuts, simulated and labelled in parallel
# ---------------------------------------------------------------------------------------------------


@nb.njit(cache=True)
def _static_period(n_teeth, kt, kr, phi_s, phi_e, rpm, m, depth, ft, wn, zeta, mass, mdir, cpd, z0, forced,
                   ux, uy):
    """One tooth period of the unregenerated cut (u(t − T) = u(t): the static chip f_t sin ψ) with
    process damping cpd [N·s/m], by the step of :func:`simulate` (first-order hold, the end force
    implicit in the end velocity). From the modal state z0 = (q, v) (2M,); ``forced``: with the static
    cutting force (else the homogeneous map). Writes u at the grid points into ux, uy (P,); returns z_T."""
    phase, node, sp, cp, act, PH, G0, G1 = setup(n_teeth, phi_s, phi_e, rpm, m, wn, zeta, mass)
    P = node.size
    M = wn.size
    N = n_teeth
    bkt = depth * kt
    f = ft if forced else 0.0
    q = z0[:M].copy()
    v = z0[M:].copy()
    for p in range(P):
        x, y = _dir_sum(q, mdir)
        ux[p] = x
        uy[p] = y
        vx, vy = _dir_sum(v, mdir)
        pb = p + 1
        fxa = 0.0
        fya = 0.0
        fsx = 0.0  # static force at the step end
        fsy = 0.0
        d11 = 0.0
        d12 = 0.0
        d22 = 0.0
        for k in range(N):
            if not act[p, k]:
                continue
            s0 = sp[p, k]
            c0 = cp[p, k]
            if s0 > ZERO_CHIP:  # the static chip f_t sin ψ > 0: in contact
                fxa += bkt * f * s0 * (-c0 - kr * s0)
                fya += bkt * f * s0 * (s0 - kr * c0)
                dx, dy = _damp(cpd, s0, c0, vx, vy)
                fxa += dx
                fya += dy
            sb = sp[0, (k + 1) % N] if pb == P else sp[pb, k]
            cb = cp[0, (k + 1) % N] if pb == P else cp[pb, k]
            if sb > ZERO_CHIP:
                fsx += bkt * f * sb * (-cb - kr * sb)
                fsy += bkt * f * sb * (sb - kr * cb)
                d11 += cpd * sb * sb
                d12 += cpd * sb * cb
                d22 += cpd * cb * cb
        # free part of the end velocity and its gains; (I + D gv) F_b = F_s − D wv
        wvx, wvy = _free_dir(PH, G0, p, 1, q, v, fxa, fya, mdir)
        gvx, gvy = _dir_sum(G1[p, :, 1], mdir)
        a11 = 1.0 + d11 * gvx
        a12 = d12 * gvy
        a21 = d12 * gvx
        a22 = 1.0 + d22 * gvy
        b1 = fsx - (d11 * wvx + d12 * wvy)
        b2 = fsy - (d12 * wvx + d22 * wvy)
        det = a11 * a22 - a12 * a21
        fxb = (b1 * a22 - a12 * b2) / det
        fyb = (a11 * b2 - a21 * b1) / det
        qn = np.empty(M)
        vn = np.empty(M)
        for j in range(M):
            fa = fxa if mdir[j] == 0 else fya
            fb = fxb if mdir[j] == 0 else fyb
            qn[j] = PH[p, j, 0, 0] * q[j] + PH[p, j, 0, 1] * v[j] + G0[p, j, 0] * fa + G1[p, j, 0] * fb
            vn[j] = PH[p, j, 1, 0] * q[j] + PH[p, j, 1, 1] * v[j] + G0[p, j, 1] * fa + G1[p, j, 1] * fb
        q = qn
        v = vn
    out = np.empty(2 * M)
    out[:M] = q
    out[M:] = v
    return out


@nb.njit(cache=True)
def steady_start_damped(n_teeth, kt, kr, phi_s, phi_e, rpm, m, depth, ft, wn, zeta, mass, mdir, cpd):
    """Modal state (q, v) at t = 0 and the surface (P, N) of the forced T-periodic motion with process
    damping cpd > 0 [N·s/m]. The damping acts on the periodic velocity with a time-varying matrix, so
    the harmonics of :func:`steady_start` couple; instead the one-period map of the discrete scheme,
    z_T = Φ z_0 + z_p (Φ from 2M homogeneous periods, z_p from one forced period from rest), gives
    the periodic state z_0 = (I − Φ)⁻¹ z_p exactly for the integrator (one more period records u)."""
    M = wn.size
    n = 2 * M
    phase, node = period_points(n_teeth, phi_s, phi_e, m)
    P = node.size
    ux = np.empty(P)
    uy = np.empty(P)
    phi = np.empty((n, n))
    e = np.zeros(n)
    for i in range(n):
        e[:] = 0.0
        e[i] = 1.0
        phi[:, i] = _static_period(n_teeth, kt, kr, phi_s, phi_e, rpm, m, depth, ft, wn, zeta, mass, mdir, cpd, e,
                                   False, ux, uy)
    e[:] = 0.0
    zp = _static_period(n_teeth, kt, kr, phi_s, phi_e, rpm, m, depth, ft, wn, zeta, mass, mdir, cpd, e, True, ux, uy)
    z0 = np.linalg.solve(np.eye(n) - phi, zp)
    _static_period(n_teeth, kt, kr, phi_s, phi_e, rpm, m, depth, ft, wn, zeta, mass, mdir, cpd, z0, True, ux, uy)
    S = periodic_surface(n_teeth, phi_s, phi_e, m, ft, phase, ux, uy)
    return z0[:M].copy(), z0[M:].copy(), S


@nb.njit(cache=True)
def initial_state(n_teeth, kt, kr, phi_s, phi_e, rpm, m, depth, ft, wn, zeta, mass, mdir, steady, perturb, n_harm,
                  cpd=0.0):
    """(q0, v0, surface) of a cut starting at rest, or on the forced periodic motion with every modal
    displacement moved by ``perturb`` [m] (with process damping cpd [N·s/m] > 0: that of the damped cut)."""
    if steady:
        if cpd != 0.0:
            q0, v0, S = steady_start_damped(n_teeth, kt, kr, phi_s, phi_e, rpm, m, depth, ft, wn, zeta, mass, mdir,
                                            cpd)
        else:
            q0, v0, S = steady_start(n_teeth, kt, kr, phi_s, phi_e, rpm, m, depth, ft, wn, zeta, mass, mdir, n_harm,
                                     16 * n_harm)
        for j in range(wn.size):
            q0[j] += perturb
        return q0, v0, S
    return np.zeros(wn.size), np.zeros(wn.size), rest_surface(n_teeth, phi_s, phi_e, m, ft)


@nb.njit(cache=True, parallel=True)
def label_batch(n_teeth, kt, kr, phi_s, phi_e, rpm, depth, steps, periods, ft, wn, zeta, mass, mdir, steady,
                perturb_rel, n_harm, bound, f_hi, out_label, out_hz, out_lobe, out_level, out_growth, out_mu, cv):
    """Simulate and label cuts (rpm[i], depth[i]) with steps[i] nodes per tooth period over
    periods[i] periods; writes the detector's label/frequency/lobe codes and metrics per cut. cv (n,):
    the process damping per unit depth C / V [N·s/m²] of each cut (zeros: none)."""
    for i in nb.prange(rpm.size):
        m = steps[i]
        q0, v0, S = initial_state(n_teeth, kt, kr, phi_s, phi_e, rpm[i], m, depth[i], ft, wn, zeta, mass, mdir,
                                  steady, perturb_rel * ft, n_harm, cv[i] * depth[i])
        n = periods[i] * m + 1
        x = np.empty(n)
        y = np.empty(n)
        fx = np.empty(n)
        fy = np.empty(n)
        n_out = simulate(n_teeth, kt, kr, phi_s, phi_e, rpm[i], m, periods[i], depth[i], ft, wn, zeta, mass,
                            mdir, q0, v0, S, bound[i], x, y, fx, fy, cv[i] * depth[i])
        f_tooth = n_teeth * rpm[i] / 60.0
        lab, hz, lobe, level, growth, _, mu = detect_core(x, y, n_out, m, ft, f_tooth, f_hi[i], n_out < n)
        out_label[i] = lab
        out_hz[i] = hz
        out_lobe[i] = lobe
        out_level[i] = level
        out_growth[i] = growth
        out_mu[i] = mu
