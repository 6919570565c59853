"""Modal parameters (fn, k, ζ per mode) of one measured drive-point receptance.

Steps, for one direction:

1. **Poles** by LSCF over model orders 2..:data:`MAX_ORDER` (:mod:`millstab.modal.lscf`); the poles that
   stay put across orders (the stabilisation diagram) are clustered into mode candidates.
2. **Residues and poles together** by least squares in the frequency domain (LSFD, refined): the poles
   (fn, ζ) are adjusted by :func:`scipy.optimize.least_squares` while, for each trial, the modal
   constants and the lower/upper residual terms follow from a linear least-squares solve (variable
   projection). The model is millstab's own receptance, so the fit gives (fn, k, ζ) directly::

       H(ω) = Σ_m g_m ωm² / (ωm² − ω² + 2iζm ωm ω)  +  U  −  L (ω_lo/ω)²,   g_m = 1/k_m,

   U (upper residual) is the flexibility of modes above the band, L (lower residual) the mass line of
   modes below it; both real.
3. **Which modes**: with ``modes="auto"`` every candidate whose peak 1/(2ζk) stands at least
   :data:`MIN_PEAK_TO_NOISE` times above the fit's noise (RMS residual) is kept; ``modes=N`` keeps the N
   candidates with the largest peaks, and where there are fewer grows the rest from the misfit (:func:`_grow`),
   warning about each mode that is not stable across orders or stands below the noise. A fit whose misfit is
   mostly structure rather than noise is warned about (:func:`_warn_poor_fit`).
4. **Drive-point check**: the residues are solved once more without the drive-point constraint (complex
   modal constants A_m, see below); a residue whose phase is more than :data:`MAX_PHASE_DEG` from −90°
   means the FRF is not a drive point (a cross FRF has modes of either sign) or the sign convention is
   flipped, and is refused; a smaller but visible deviation (> :data:`WARN_PHASE_DEG`) is warned about.

Pole/residue form ↔ modal stiffness form (derivation)
-----------------------------------------------------
millstab's receptance (x(t) = Re(G F e^{iωt}), see :mod:`millstab.model`) of one mode is

    G(ω) = 1/(k(1 − r² + 2iζr)) = (ωn²/k) / (ωn² − ω² + 2iζωn ω),   r = ω/ωn.

With s = iω the denominator is s² + 2ζωn s + ωn² = (s − λ)(s − λ*), λ = −ζωn + iωd, ωd = ωn√(1 − ζ²).
Partial fractions give 1/((s − λ)(s − λ*)) = A'/(s − λ) + A'*/(s − λ*) with A' = 1/(λ − λ*) = 1/(2iωd),
so

    G(ω) = A/(iω − λ) + A*/(iω − λ*),   A = (ωn²/k)·1/(2iωd) = −i ωn²/(2 k ωd).

Hence for a pole λ and residue A:  ωn = |λ|,  ζ = −Re λ/|λ|,  ωd = Im λ,  **k = ωn²/(2 ωd |A|)**, and a
drive point has **arg A = −90°** (A on the negative imaginary axis: Im G = −1/(2ζk) < 0 at ω = ωn).
A residue at +90° is a conjugated FRF (the e^{−iωt} convention or a negated imaginary column); one at
0° or 180°, or modes of both signs, is a cross (transfer) FRF; neither has a modal stiffness.

Units: frequencies in Hz at the interface, ω in rad/s inside; receptance in m/N; k in N/m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares
from threadpoolctl import threadpool_limits

from millstab.errors import FRFWarning, InputError
from millstab.modal.lscf import Candidate, Stabilisation, lscf, stable_clusters
from millstab.warnlog import warn

#: highest LSCF polynomial order of the stabilisation diagram (up to MAX_ORDER/2 pole pairs)
MAX_ORDER = 40
#: a mode is kept (``modes="auto"``) when its peak 1/(2ζk) is this many times the RMS misfit
MIN_PEAK_TO_NOISE = 5.0
#: a residue further than this from −90° is not a drive point → InputError
MAX_PHASE_DEG = 60.0
#: ... further than this → FRFWarning (non-proportional damping, a slightly skewed sensor)
WARN_PHASE_DEG = 20.0
#: misfit [share of max |H|] below which data count as exact (rounding): keeps peak-to-noise finite
NOISE_FLOOR = 1e-9
#: fewest frequency lines a fit accepts in its band
MIN_LINES = 20


@dataclass(frozen=True)
class FittedMode:
    """One fitted mode with its fit quality.

    Attributes:
        fn: natural frequency [Hz].  k: modal stiffness [N/m].  zeta: damping ratio [-].
        phase_deg: deviation of the free residue's phase from the drive-point −90° [deg].
        peak_to_noise: the mode's peak 1/(2ζk) over the fit's RMS misfit [-].
        stable_orders: model orders at which LSCF found this pole stable (of ``orders``).
        orders: number of model orders in the stabilisation diagram.
        local_error: RMS misfit within ±3 half-power bandwidths of fn over the peak [-].
    """

    fn: float
    k: float
    zeta: float
    phase_deg: float
    peak_to_noise: float
    stable_orders: int
    orders: int
    local_error: float


@dataclass(frozen=True)
class DirectionFit:
    """The fit of one direction's drive-point FRF.

    Attributes:
        direction: "x" or "y".  source: file name (for messages).
        freq_hz, h: the measured band [Hz, m/N].  h_fit: the fitted receptance there [m/N].
        modes: fitted modes, by frequency.  upper: residual flexibility U of modes above the band [m/N].
        lower: the mass line −L(ω_lo/ω)² of modes below the band, as its value L at the band's lowest line [m/N].
        nrmse: RMS misfit over the band / max |H| [-].  noise: RMS misfit [m/N].
        stabilisation: the LSCF poles over orders (for the diagram).
    """

    direction: str
    source: str
    freq_hz: np.ndarray
    h: np.ndarray
    h_fit: np.ndarray
    modes: tuple[FittedMode, ...]
    upper: float
    lower: float
    nrmse: float
    noise: float
    stabilisation: Stabilisation = field(repr=False)


def _basis(w: np.ndarray, wn: np.ndarray, zeta: np.ndarray, w_lo: float) -> np.ndarray:
    """Complex columns (N, M + 2): the unit-g modes ωm²/(ωm² − ω² + 2iζωmω), U (1) and L (−(ω_lo/ω)²)."""
    modes = wn**2 / (wn**2 - w[:, None] ** 2 + 2j * zeta * wn * w[:, None])
    return np.column_stack([modes, np.ones_like(w), -((w_lo / w) ** 2)])


def _real(b: np.ndarray) -> np.ndarray:
    """Complex (N, ...) → real (2N, ...): real parts stacked over imaginary parts."""
    return np.concatenate([b.real, b.imag])


def _lsq(a: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Least-squares solution of the real system a x = y (y may have several columns).

    Normal equations on unit-norm columns (a has M + 2 well-separated columns, so cond(aᵀa) stays far
    from 1/eps; ~20x faster than an SVD per call, which matters inside the optimiser), with the SVD as
    the fallback when a column is degenerate.
    """
    norm = np.sqrt(np.einsum("ij,ij->j", a, a))
    norm[norm == 0] = 1.0
    an = a / norm
    try:
        x = np.linalg.solve(an.T @ an, an.T @ y)
    except np.linalg.LinAlgError:
        x = np.linalg.lstsq(an, y, rcond=None)[0]
    return x / (norm if x.ndim == 1 else norm[:, None])


def _solve_real(b: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Real coefficients c minimising |b c − h| (complex b, h) by stacking real and imaginary parts."""
    return _lsq(_real(b), _real(h))


def _refine(w: np.ndarray, hs: np.ndarray, wn0: np.ndarray, zeta0: np.ndarray, w_lo: float):
    """Poles (ωn, ζ) and real coefficients by variable projection from the LSCF start.

    Unknowns θ = (ln ωn, ln ζ) per mode (positive by construction); for each θ the coefficients c are
    the linear least-squares solution, and the Jacobian is Kaufman's: J = P⊥ (∂B/∂θ) c, P⊥ = I − B B⁺.
    """
    m = wn0.size
    y = _real(hs)
    memo: dict[bytes, tuple] = {}

    def state(theta):
        key = theta.tobytes()
        if key not in memo:
            memo.clear()
            wn, zeta = np.exp(theta[:m]), np.exp(theta[m:])
            b = _basis(w, wn, zeta, w_lo)
            br = _real(b)
            memo[key] = (wn, zeta, b, br, _lsq(br, y))
        return memo[key]

    def resid(theta):
        _, _, _, br, c = state(theta)
        return br @ c - y

    def jac(theta):
        wn, zeta, _, br, c = state(theta)
        wc = w[:, None]
        den2 = (wn**2 - wc**2 + 2j * zeta * wn * wc) ** 2
        d_lnwn = (-2 * wn**2 * wc**2 + 2j * zeta * wn**3 * wc) / den2  # ∂/∂ln ωn of ωn²/den
        d_lnz = (-2j * zeta * wn**3 * wc) / den2  # ∂/∂ln ζ
        d = _real(np.concatenate([d_lnwn * c[:m], d_lnz * c[:m]], axis=1))
        return d - br @ _lsq(br, d)

    theta0 = np.concatenate([np.log(wn0), np.log(zeta0)])
    sol = least_squares(resid, theta0, jac=jac, method="lm", xtol=1e-12, ftol=1e-12)
    wn, zeta, b, _, c = state(sol.x)
    return wn, zeta, c, b


def _free_residue_phase(w: np.ndarray, hs: np.ndarray, wn: np.ndarray, zeta: np.ndarray, w_lo: float) -> np.ndarray:
    """Phase of each free (complex) residue A_m at the fitted poles, relative to −90° [deg], in (−180, 180].

    Pole pair basis 1/(iω − λ) + conj-pair term with complex A: A/(iω−λ) + A*/(iω−λ*) is linear in
    (Re A, Im A): Re A·(1/(iω−λ) + 1/(iω−λ*)) + Im A·(i/(iω−λ) − i/(iω−λ*)).
    """
    lam = -zeta * wn + 1j * wn * np.sqrt(1 - zeta**2)
    s = 1j * w[:, None]
    p, q = 1.0 / (s - lam), 1.0 / (s - lam.conj())
    cols = np.column_stack([p + q, 1j * (p - q), np.ones_like(w), -((w_lo / w) ** 2)])
    c = _solve_real(cols, hs)
    m = wn.size
    a = c[:m] + 1j * c[m:2 * m]
    return np.degrees(np.angle(a / -1j))


def fit_direction(freq_hz: np.ndarray, h: np.ndarray, *, direction: str = "x", source: str = "FRF",
                  modes: int | str = "auto", max_order: int = MAX_ORDER) -> DirectionFit:
    """Fit the drive-point receptance ``h`` [m/N] at ``freq_hz`` [Hz] (already cut to the band).

    Args:
        modes: ``"auto"`` (stabilisation diagram and peak-to-noise choice) or the number of modes.
        direction, source: used in messages and in the result.

    Raises:
        InputError: too few lines, no clear peak (no stable pole above the noise), fewer stable modes
            than ``modes`` asks for, or a residue of the wrong phase (not a drive point / sign slip).
    """
    with threadpool_limits(1):  # small matrices: BLAS threads only cost (x100 on a busy machine)
        return _fit_direction(freq_hz, h, direction, source, modes, max_order)


def _fit_direction(freq_hz, h, direction, source, modes, max_order) -> DirectionFit:
    f = np.asarray(freq_hz, float)
    h = np.asarray(h, complex)
    where = f"{direction} ({source})"
    if f.size < MIN_LINES:
        raise InputError(f"FRF {where}", f"{f.size} lines", f"the band needs at least {MIN_LINES} frequency lines")
    if (f.shape != h.shape or not (np.all(np.isfinite(f)) and np.all(np.isfinite(h))) or f[0] <= 0
            or np.any(np.diff(f) <= 0)):
        raise InputError(f"FRF {where}", f"{f.size} frequencies, {h.size} values",
                         "need one finite receptance per frequency, frequencies > 0 Hz and strictly increasing")
    scale = float(np.max(np.abs(h)))
    if not scale > 0:
        raise InputError(f"FRF {where}", "all zero", "the receptance is zero everywhere in the band")
    hs = h / scale
    w = 2 * np.pi * f
    w_lo = w[0]
    stab = lscf(f, hs, max_order)
    cands = stable_clusters(stab)
    band = f"{f[0]:g}..{f[-1]:g} Hz"
    no_peak = (f"no clear resonance peak in {band}: no pole stays stable across model orders with a peak above "
               f"the noise; check the file (a drive-point receptance in m/N), or, if you know how many modes the "
               f"band holds, --modes N fits that many (grown from the misfit where the diagram shows fewer, and "
               f"warned as not stabilised), or choose --band around the modes")
    cands = _drop_duplicates(cands)
    if cands:
        wn, zeta, c, b = _refine(w, hs, np.array([2 * np.pi * cd.fn for cd in cands]),
                                 np.array([cd.zeta for cd in cands]), w_lo)
    else:  # nothing stable (a mode at the band's edge, few lines per bandwidth): the residual terms alone, then grow
        wn, zeta = np.empty(0), np.empty(0)
        b = _basis(w, wn, zeta, w_lo)
        c = _solve_real(b, hs)
    wn, zeta, c, b, cands = _grow(w, hs, wn, zeta, c, b, w_lo, cands, None if modes == "auto" else int(modes),
                                  len(stab.orders))
    if wn.size == 0:
        if stable_clusters(lscf(f, hs.conj(), max_order)):  # conjugated data: every pole looks unstable
            raise InputError(f"FRF {where}", source, "its poles are stable only after conjugation: the imaginary part "
                             "has the opposite sign convention (e^{-iwt}, or a negated column); millstab's drive-point "
                             "receptance has Im G < 0 at each resonance: negate the imaginary column")
        raise InputError(f"FRF {where}", source, no_peak)
    m = wn.size
    noise = float(np.sqrt(np.mean(np.abs(b @ c - hs) ** 2)))
    peak = np.abs(c[:m]) / (2 * zeta)
    ptn = peak / max(noise, NOISE_FLOOR)
    if modes == "auto":
        keep = ptn >= MIN_PEAK_TO_NOISE
        if not keep.any():
            raise InputError(f"FRF {where}", source, no_peak)
    else:
        n = int(modes)
        if n > m:
            raise InputError("--modes", n, f"{where} gives only {m} physical mode(s) in {band} (stable across model "
                                           f"orders, or found in the misfit with a positive modal constant, "
                                           f"zeta < 0.3, inside the band); ask for at most {m} or widen the band")
        keep = np.zeros(m, bool)
        keep[np.argsort(-peak)[:n]] = True
    if not keep.all():  # refit without the dropped candidates: their share moves to the kept modes/residuals
        cands = [cd for cd, k in zip(cands, keep) if k]
        wn, zeta, c, b = _refine(w, hs, wn[keep], zeta[keep], w_lo)
        m = wn.size
        noise = float(np.sqrt(np.mean(np.abs(b @ c - hs) ** 2)))
        ptn = np.abs(c[:m]) / (2 * zeta) / max(noise, NOISE_FLOOR)
    phase = _free_residue_phase(w, hs, wn, zeta, w_lo)
    fn = wn / (2 * np.pi)
    _check_drive_point(fn, phase, c[:m], where)
    fitted = b @ c
    if modes != "auto":
        _warn_forced(fn, ptn, [cd.n_stable for cd in cands], len(stab.orders), int(modes), where)
    _warn_poor_fit(fitted - hs, noise, m, where)
    out = []
    for i in range(m):
        near = np.abs(f - fn[i]) <= 3 * zeta[i] * fn[i]
        if not near.any():  # a bandwidth narrower than the line spacing: the nearest line
            near = np.abs(f - fn[i]) == np.min(np.abs(f - fn[i]))
        local = float(np.sqrt(np.mean(np.abs(fitted[near] - hs[near]) ** 2)) / (abs(c[i]) / (2 * zeta[i])))
        out.append(FittedMode(float(fn[i]), float(1.0 / (c[i] * scale)), float(zeta[i]), float(phase[i]), float(ptn[i]),
                              cands[i].n_stable, cands[i].n_orders, local))
    order = np.argsort(fn)
    return DirectionFit(direction, source, f, h, fitted * scale, tuple(out[i] for i in order), float(c[m] * scale),
                        float(c[m + 1] * scale), noise, noise * scale, stab)


#: a mode added to the fit (:func:`_grow`) must cut the misfit's sum of squares by this many noise
#: variances: 3 more parameters fitting pure noise gain a chi-square with 3 degrees of freedom (> 25 with
#: probability 1e-5), a missed mode gains hundreds
GROW_CHI2 = 25.0
#: at most this many modes are added beyond the stabilisation diagram's candidates
MAX_GROW = 3


#: damping ratio a grown mode starts from when no mode is known yet
START_ZETA = 0.03


def _grow(w, hs, wn, zeta, c, b, w_lo, cands, wanted, n_orders):
    """Add modes the stabilisation diagram missed (two modes closer than their bandwidth look like one
    wandering pole when noisy): a trial mode at the largest (smoothed) misfit, refitted with the rest;
    kept when it cuts the misfit's sum of squares by :data:`GROW_CHI2` noise variances (not asked while
    fewer than ``wanted`` modes), stands above the noise and is physical (g > 0, ζ < 0.3, in the band).

    With ``wanted`` (the user's ``--modes N``) a mode below the noise is kept too (warned after the fit), and
    each fitted mode split in two (at fn(1 ∓ ζ), ζ/2 each) is tried beside the misfit's maximum, the physical
    trial with the smallest misfit kept: at 8 % noise two modes 7 % apart are first fitted as one broad mode,
    and a trial started next to it collapses onto it (two coincident poles with modal constants of ±10⁴ × the
    true one, measured on 2 of 8 noise draws of the 800/860/2400 Hz test FRF), while the split reaches both.
    """
    ss = float(np.sum(np.abs(b @ c - hs) ** 2))
    for _ in range(MAX_GROW if wanted is None else max(0, wanted - wn.size)):
        r = np.abs(b @ c - hs)
        z0 = float(np.median(zeta)) if zeta.size else START_ZETA
        width = max(3, int(r.size * z0 * (wn.mean() if wn.size else w.mean()) / (w[-1] - w[0] + 1e-300)))
        smooth = np.convolve(r, np.ones(width) / width, mode="same")
        i = int(np.argmax(smooth))
        new = Candidate(float(w[i] / (2 * np.pi)), z0, 0, n_orders)
        starts = [(np.append(wn, w[i]), np.append(zeta, z0), cands + [new])]
        if wanted is not None:
            for j in range(wn.size):
                split_wn = np.append(wn, wn[j] * (1 + zeta[j]))
                split_wn[j] = wn[j] * (1 - zeta[j])
                split_z = np.append(zeta, zeta[j] / 2)
                split_z[j] = zeta[j] / 2
                halves = [Candidate(float(x / (2 * np.pi)), float(zeta[j] / 2), 0, n_orders) for x in split_wn[[j, -1]]]
                starts.append((split_wn, split_z, cands[:j] + [halves[0]] + cands[j + 1:] + [halves[1]]))
        best = None
        for wn0, z0s, cands0 in starts:
            trial = _refine(w, hs, wn0, z0s, w_lo)
            t_ss = float(np.sum(np.abs(trial[3] @ trial[2] - hs) ** 2))
            if _physical(w, hs, w_lo, trial, t_ss, forced=wanted is not None) and (best is None or t_ss < best[1]):
                best = (trial, t_ss, cands0)
        if best is None:
            break
        trial, t_ss, cands0 = best
        var = max(t_ss / max(2 * w.size - 2 * trial[0].size - trial[2].size, 1), NOISE_FLOOR**2)  # per real component
        if wanted is None and (ss - t_ss) / var < GROW_CHI2:
            break
        wn, zeta, c, b = trial
        ss = t_ss
        cands = cands0
    return wn, zeta, c, b, cands


def _physical(w: np.ndarray, hs: np.ndarray, w_lo: float, trial, t_ss: float, forced: bool) -> bool:
    """Whether a refined trial (ωn, ζ, c, basis) has every modal constant g > 0, ζ < 0.3 and ωn in the band (a
    mode outside it is a residual's job); unless ``forced``, every peak ≥ :data:`MIN_PEAK_TO_NOISE` × noise;
    if ``forced``, every free residue within :data:`MAX_PHASE_DEG` of −90° (a forced split of a single mode
    can leave a pair whose constrained g are both positive but whose free residues are not a drive point's,
    and the fit would then be refused as a cross FRF: measured with --modes 5 on the exact 3-mode test FRF)."""
    wn, zeta, c = trial[0], trial[1], trial[2][:trial[0].size]
    ptn = np.abs(c) / (2 * zeta) / max(math.sqrt(t_ss / w.size), NOISE_FLOOR)
    ok = bool((forced or ptn.min() >= MIN_PEAK_TO_NOISE) and np.all(zeta < 0.3) and np.all(c > 0)
              and np.all((wn >= w[0]) & (wn <= w[-1])))
    return ok and (not forced or bool(np.all(np.abs(_free_residue_phase(w, hs, wn, zeta, w_lo)) <= MAX_PHASE_DEG)))


#: a fit's RMS misfit [share of max |H|] above which :func:`_warn_poor_fit` looks at the misfit's structure
POOR_FIT_NRMSE = 0.02
#: ... and warns when the RMS misfit is this many times the line-to-line noise. White noise gives 1. Measured
#: (the 3-mode x FRF of the modal tests, 1451 lines): 1 % noise 1.0 with its 3 modes, 7.9 with --modes 1 (9.3 %
#: misfit), 7.4 with --modes 2; 8 % noise with 3 modes 1.0; 1 % noise filtered over 3 lines by (1/4, 1/2, 1/4)
#: (neighbouring lines correlated) 1.7, by a Hann window's (-1/4, 1/2, -1/4) 0.8
POOR_FIT_STRUCTURE = 3.0


def _warn_poor_fit(resid: np.ndarray, noise: float, m: int, where: str) -> None:
    """Warn when the misfit ``resid`` (fit − data, per unit max |H|) is large and is structure, not noise.

    The line-to-line noise is RMS(diff(resid))/√2: the lines' noise is independent while a missed mode or a
    mode fitted in the wrong place changes smoothly over its bandwidth (many lines), so a misfit much larger
    than that noise is the model's, and the modes (their number or the band) are wrong.
    """
    if resid.size < 3 or noise <= POOR_FIT_NRMSE:
        return
    white = float(np.sqrt(np.mean(np.abs(np.diff(resid)) ** 2) / 2))
    ratio = noise / max(white, NOISE_FLOOR)
    if ratio > POOR_FIT_STRUCTURE:
        warn(f"FRF {where}: poor fit: the RMS misfit of the {m} mode(s) is {100 * noise:.2f} % of max|H|, "
             f"{ratio:.1f} times the line-to-line noise, so it is a shape the modes miss (a missing mode, two "
             f"close modes fitted as one, or a band that cuts a mode), not noise; compare the fit in --plot, "
             f"fit more modes (--modes auto, or a larger N) or choose --band around the modes",
             FRFWarning, stacklevel=4)


def _warn_forced(fn: np.ndarray, ptn: np.ndarray, n_stable: list[int], n_orders: int, asked: int,
                 where: str) -> None:
    """Warn about modes a given ``--modes N`` made the fit keep that ``auto`` would not vouch for: not stable
    across the LSCF model orders (found in the misfit), or with a peak below :data:`MIN_PEAK_TO_NOISE` × noise."""
    weak = [f"{fn[i]:.6g} Hz ({'not stabilised' if n_stable[i] == 0 else f'stable at {n_stable[i]}/{n_orders} orders'}"
            f", peak/noise {ptn[i]:.3g})" for i in range(fn.size)
            if n_stable[i] == 0 or ptn[i] < MIN_PEAK_TO_NOISE]
    if weak:
        warn(f"FRF {where}: --modes {asked} fitted {len(weak)} mode(s) that the stabilisation diagram does not "
             f"show as modes above the noise: {'; '.join(weak)}; check them against the measured FRF (--plot) "
             f"before using them", FRFWarning, stacklevel=4)


def _drop_duplicates(cands: list[Candidate]) -> list[Candidate]:
    """Candidates whose frequencies lie within a tenth of the damping bandwidth of a stronger one are one mode."""
    out: list[Candidate] = []
    for cd in sorted(cands, key=lambda c: -c.n_stable):
        if all(abs(cd.fn - o.fn) > 0.1 * o.zeta * o.fn for o in out):
            out.append(cd)
    return sorted(out, key=lambda c: c.fn)


def _check_drive_point(fn: np.ndarray, phase: np.ndarray, g: np.ndarray, where: str) -> None:
    """Refuse residues of the wrong sign/phase (cross FRF, conjugated data); warn about skewed ones."""
    bad = (np.abs(phase) > MAX_PHASE_DEG) | (g <= 0)
    if bad.any() and np.all(np.abs(phase) > 180 - MAX_PHASE_DEG):
        # every residue at +90 deg: −G, a whole sign flip (reversed hammer or sensor); a conjugated FRF has no
        # stable poles at all (caught before) and a cross FRF has residues of both signs
        raise InputError(f"FRF {where}", f"residue phases {', '.join(f'{p - 90:+.0f}' for p in phase)} deg",
                         "every residue sits at +90 deg instead of the drive point's -90 deg (Re G < 0 below each "
                         "resonance and Im G > 0 at it): the FRF has its sign reversed (hammer or sensor polarity); "
                         "negate both the real and the imaginary column")
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(f"FRF {where} mode at {fn[i]:.6g} Hz", f"residue phase {phase[i] - 90:+.0f} deg",
                         "a drive-point receptance has every residue at -90 deg (Im G < 0 at each resonance, "
                         "G = 1/(k(1 - r^2 + 2i zeta r))): this is a cross (transfer) FRF or its imaginary part has "
                         "the opposite sign convention; fit the direct FRF (hammer and sensor at the tool tip, same "
                         "direction), or negate the imaginary column of conjugated data")
    skew = np.abs(phase) > WARN_PHASE_DEG
    for i in np.flatnonzero(skew):
        warn(f"FRF {where}: the residue of the mode at {fn[i]:.6g} Hz is {phase[i]:+.0f} deg off the "
             f"drive-point -90 deg (non-proportional damping, a skewed sensor or a neighbouring mode); "
             f"k is fitted with the drive-point phase", FRFWarning, stacklevel=3)


__all__ = ["DirectionFit", "FittedMode", "MAX_ORDER", "MIN_PEAK_TO_NOISE", "fit_direction"]
