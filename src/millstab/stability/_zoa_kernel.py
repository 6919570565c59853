"""Compiled (numba) kernels of the zero-order solution. Use :mod:`millstab.stability.zoa` instead.

Notation (Altintas 2012, ch. 3): [α] is the 2×2 matrix of directional-coefficient brackets,
[G(ω)] the tool-tip receptance [m/N], ν an eigenvalue of [α][G]. A root ν gives a chatter boundary at
frequency ω with

    depth   b   = 2π / (N Kt Re ν)                  (only where Re ν > 0)
    phase   ε   = π + 2 arg ν   ∈ (0, 2π)
    speed   ω T = ε + 2kπ,  T = 60 / (N Ω[rpm]),     k = 0, 1, 2, ... the lobe number

For a speed Ω every integer k gives one or more chatter frequencies (roots of
H(ω) = ωT − ε(ω) − 2kπ); the limiting depth b_lim(Ω) is the smallest depth among them.

The roots are bracketed on a per-set frequency grid. Where a lobe turns back (its period
T_k(ω) = (ε + 2kπ)/ω has an extremum: a narrow tip, or a fold), a speed inside the tip has two roots
that can fall into one grid segment without a sign change of H; :func:`_collect` therefore splits
brackets at such turning points, located from the analytic dε/dω and d²ε/dω² (:func:`_phase_at`).

Where the time goes (benchmarks/profile_zoa.py prints these counts and times; issue 15, item 4).
Per envelope of the throughput benchmark (Example 1 sets within ±10 %, 200 speeds 2 000–12 000 rpm):
273 grid nodes (two receptances and both eigenvalues each), 16 evaluations locating Re ν = 0 edges,
243 valid segments of which 40 are visited (the rest lie below the worst speed's depth estimate), 41
node ε'/ε'' evaluations, 576 (segment, lobe) pairs scanned, 3 split-point evaluations, 279 candidate
crossings of which 210 are refined (1.05 per speed) with 365 root evaluations (1.74 per candidate; 533
and 2.54 with the secant start). About 80 k floating-point operations in all (hand counts per
evaluation × these counts), which at the core's vector peak (AVX2 FMA, ~40 Gflop/s) would be ~2 µs:
the work is scalar and latency-bound (square roots, divisions, atan2 and branches), and the honest
yardstick is the same machine's rate on a dense loop of root evaluations (~0.4 Gflop/s, one root per
~200 ns on the loaded machine). One thread, one envelope is then ~60 % refinement, ~30 % candidate
scan, ~10 % grid and eigenvalues, and its work done as that dense loop would take 70–85 % of its time
(two runs), so no reshuffling of the same work gains more than ~1.2–1.4×; more needs less work: fewer grid nodes, fewer
root evaluations per speed (≥ 1 each: the depth needs ν at the root), or cheaper ones (atan2 is ~15 %).

What made it faster (each step timed interleaved against the step before on the same sets, identical
or equal to ≤ 2e-7 depths): numba reference-counts an array on every iteration where it is a
loop-carried variable (the candidate buffers, grown inside the scan) or an argument of an inlined call
in a loop (the six mode arrays and the two receptance rows): 8 800 atomic increments and as many
decrements per envelope, now 640 (modes packed into one array by :func:`pack_modes`, the buffers
sized up front with a rerun on overflow, the root evaluation written out in :func:`_refine`), 1.36×;
the refinement's first iterate from the cubic Hermite interpolant of H (ε' at the bracket ends is
known from the scan), 1.2×; ε only at the nodes of visited segments, ε at the bracket ends handed to
the refinement, and complex square roots from two real ones (:func:`_csqrt`), 1.2×. In all 1.87× on
2 threads and 1.84× on one (bench_envelope.py --against the kernel before; 4 351 → 8 119 and
2 582 → 4 746 sets/s, measured on a shared 2-core machine at a load average of 15–20, where absolute
rates are well below an idle machine's: from the ~6 700 sets/s measured there before, ~12 500 expected).
The roots of a modal structure (no cross receptances) in real arithmetic (:func:`_disc_diag`: numba
multiplies a float by a complex as a full complex product, and the zero cross terms cost four more per
node), bit for bit the same: 1–6 % more (issue 27). The eigenvalues' square roots without a branch per node
(:func:`_branches_diag`) and the grid without zero-division checks (:func:`modal_grid`), bit for bit the same:
per set the grid 4.8 → 3.7 µs and a cutting condition's eigenvalues 4.0 → 2.6 µs (profile_zoa.py
--conditions), a condition now 12.7 µs with 1 speed, 20.0 with 10, 30.7 with 40 (docs/updating.md, "Several
cutting conditions", round 5: why an exact path per condition cannot go much below ~8 µs with 10 speeds).
The issue's 20 000 sets/s on 2 cores (100 µs per envelope
per core) is beyond this algorithm's work: it needs fewer root evaluations per speed or a coarser grid, which
the accuracy tests must then allow.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

TWO_PI = 2.0 * math.pi

#: work counts (``stats`` arrays of :func:`envelope_on_grid`): grid nodes, evaluations locating the
#: Re ν = 0 edges, segments with both ends valid, segments visited, their ε'/ε'' node evaluations,
#: (segment, lobe) pairs scanned, evaluations locating split points, candidates (crossings with a
#: linear estimate), candidates refined, refinement evaluations, levels of the segment scan
(S_NODES, S_EDGE, S_SEGMENTS, S_VISITED, S_SLOPES, S_PAIRS, S_SPLIT, S_CANDIDATES, S_REFINED, S_REFINE_EVALS,
 S_LEVELS) = range(11)
N_STATS = 11
STAT_NAMES = ("grid nodes", "edge evaluations", "valid segments", "segments visited", "node slope evaluations",
              "(segment, lobe) pairs", "split-point evaluations", "candidates", "candidates refined",
              "refinement evaluations", "scan levels")

#: Candidates whose grid estimate is within this factor of the best estimate at a speed are refined
#: exactly. Larger than the grid's interpolation error (tests compare with a brute-force reference).
REFINE_MARGIN = 1.15


def pack_modes(wnx, kx, zx, wny, ky, zy) -> np.ndarray:
    """The modal parameters of B sets as one array (B, 2, 3, M) [rad/s, N/m, 1]: direction (x, y), then
    (ωn, k, ζ), then the mode, padded with k = 0 (a stiffness no real mode has) where a direction has
    fewer than M modes. Inputs (B, Mx) and (B, My), or 1-D for one set (the result is then (2, 3, M)).

    One array instead of six: every call between the compiled functions that passes an array costs an
    atomic reference-count increment and decrement per array, which numba does not always remove.
    """
    wnx, kx, zx, wny, ky, zy = (np.asarray(v, dtype=float) for v in (wnx, kx, zx, wny, ky, zy))
    single = wnx.ndim == 1
    if single:
        wnx, kx, zx, wny, ky, zy = (v[None, :] for v in (wnx, kx, zx, wny, ky, zy))
    n_b = wnx.shape[0]
    m = max(wnx.shape[1], wny.shape[1], 1)
    md = np.zeros((n_b, 2, 3, m))
    for d, (wn, k, z) in enumerate(((wnx, kx, zx), (wny, ky, zy))):
        n = wn.shape[1]
        md[:, d, 0, :n] = wn
        md[:, d, 1, :n] = k
        md[:, d, 2, :n] = z
    return md[0] if single else md


def cluster_offsets(n: int = 61, half_width: float = 60.0, centre_step: float = 0.2) -> np.ndarray:
    """Offsets x of the dense frequency cluster around a mode: ω = ωn (1 + ζ x).

    sinh-spaced: steps of ``centre_step`` damping-widths at the resonance, growing outward to
    ±``half_width`` damping-widths.
    """
    # solve sinh(U)/U = half_width / (centre_step * (n - 1) / 2) for U by bisection
    target = half_width / (centre_step * (n - 1) / 2.0)
    lo, hi = 1e-6, 20.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if math.sinh(mid) / mid < target:
            lo = mid
        else:
            hi = mid
    u = np.linspace(-lo, lo, n)
    return half_width * np.sinh(u) / math.sinh(lo)


@nb.njit(cache=True)
def directional_brackets(kr, phi_s, phi_e):
    """Directional coefficient brackets α_xx, α_xy, α_yx, α_yy (each ½[...] from φst to φex)."""

    ce, se, cs, ss = math.cos(2 * phi_e), math.sin(2 * phi_e), math.cos(2 * phi_s), math.sin(2 * phi_s)
    dp = phi_e - phi_s
    axx = 0.5 * ((ce - cs) - 2 * kr * dp + kr * (se - ss))
    axy = 0.5 * (-(se - ss) - 2 * dp + kr * (ce - cs))
    ayx = 0.5 * (-(se - ss) + 2 * dp + kr * (ce - cs))
    ayy = 0.5 * (-(ce - cs) - 2 * kr * dp - kr * (se - ss))
    return axx, axy, ayx, ayy


@nb.njit(cache=True, inline="always")
def _modal_receptance(w, md, d):
    """Σ_m 1 / (k_m (1 − r² + 2iζ_m r)), r = ω/ωn_m [m/N] in direction d (0 x, 1 y) of the packed
    modes ``md`` (:func:`pack_modes`); zero for no modes (rigid)."""
    gr = 0.0
    gi = 0.0
    for m in range(md.shape[2]):
        km = md[d, 1, m]
        if km == 0.0:  # padding: no more modes in this direction
            break
        r = w / md[d, 0, m]
        re = 1.0 - r * r
        im = 2.0 * md[d, 2, m] * r
        inv = 1.0 / (km * (re * re + im * im))  # 1/(k(re + i im)) = (re − i im)/(k|.|²)
        gr += re * inv
        gi -= im * inv
    return complex(gr, gi)


@nb.njit(cache=True, inline="always")
def _tr_det(a, gxx, gxy, gyx, gyy):
    """Trace and determinant of [α][G]."""
    axx, axy, ayx, ayy = a
    m00 = axx * gxx + axy * gyx
    m01 = axx * gxy + axy * gyy
    m10 = ayx * gxx + ayy * gyx
    m11 = ayx * gxy + ayy * gyy
    return m00 + m11, m00 * m11 - m01 * m10


@nb.njit(cache=True, inline="always")
def _disc_diag(a, gr, gi, yr, yi):
    """(Re tr, Im tr, Re disc, Im disc) of [α][G] for a diagonal G = diag(gr + i gi, yr + i yi) (a modal
    structure), disc = tr² − 4 det: :func:`_tr_det` and ``tr * tr - 4.0 * det`` in real arithmetic, bit for
    bit. Why written out: numba multiplies a float by a complex as a complex product (four multiplications,
    two additions), and the zero cross receptances add four such products per node that LLVM may not drop
    (x·0 is not 0 for x = inf or NaN); every operation kept here is one the complex form performs on the
    same operands in the same order, and the dropped ones only add signed zeros."""
    axx, axy, ayx, ayy = a
    m00r = axx * gr
    m00i = axx * gi
    m01r = axy * yr
    m01i = axy * yi
    m10r = ayx * gr
    m10i = ayx * gi
    m11r = ayy * yr
    m11i = ayy * yi
    trr = m00r + m11r
    tri = m00i + m11i
    detr = (m00r * m11r - m00i * m11i) - (m01r * m10r - m01i * m10i)
    deti = (m00r * m11i + m00i * m11r) - (m01r * m10i + m01i * m10r)
    return trr, tri, (trr * trr - tri * tri) - 4.0 * detr, (trr * tri + tri * trr) - 4.0 * deti


@nb.njit(cache=True, error_model="numpy")
def _grid_frequencies(wn_all, z_all, w_lo, w_hi, n_base, offsets):
    """Sorted frequency grid [rad/s]: log-spaced base plus a dense cluster around every mode."""
    n_modes = wn_all.size
    n_off = offsets.size
    total = n_base + n_modes * n_off
    # the base and every cluster are ascending runs already (offsets ascending; the clip at 0.05 keeps
    # that): merge them run by run instead of sorting the whole grid
    w = np.empty(total)
    tmp = np.empty(total)
    run = np.empty(n_off)
    ratio = math.log(w_hi / w_lo) / (n_base - 1)
    for i in range(n_base):
        w[i] = w_lo * math.exp(ratio * i)
    n = n_base
    for m in range(n_modes):
        for j in range(n_off):
            r = 1.0 + z_all[m] * offsets[j]
            if r < 0.05:
                r = 0.05
            run[j] = wn_all[m] * r
        for j in range(1, n_off):
            if run[j] < run[j - 1]:  # offsets not ascending (not the engine's own): sort this run
                run.sort()
                break
        i = 0
        j = 0
        c = 0
        while i < n and j < n_off:
            if w[i] <= run[j]:
                tmp[c] = w[i]
                i += 1
            else:
                tmp[c] = run[j]
                j += 1
            c += 1
        while i < n:
            tmp[c] = w[i]
            i += 1
            c += 1
        while j < n_off:
            tmp[c] = run[j]
            j += 1
            c += 1
        n = c
        w, tmp = tmp, w
    # keep points inside [w_lo, w_hi] and drop near-duplicates (in place: the write index never passes
    # the read index)
    k = 0
    for i in range(n):
        x = w[i]
        if x < w_lo or x > w_hi:
            continue
        if k > 0 and x - w[k - 1] <= 1e-12 * x:
            continue
        w[k] = x
        k += 1
    return w[:k]


@nb.njit(cache=True, inline="always")
def _dist2(u, v):
    """|u − v|² (cheaper than abs(), which calls hypot)."""
    d = u - v
    return d.real * d.real + d.imag * d.imag


@nb.njit(cache=True, inline="always")
def _csqrt(z):
    """Principal square root of a complex number from two real square roots (numba's complex sqrt goes
    through hypot and special-case checks, ~2× slower here). Inputs whose |z|² would leave the double
    range (or NaN) go to np.sqrt; the engine's values (|z| ~ |α G|², G ~ 1e-9–1e-5 m/N) never do."""
    x = z.real
    y = z.imag
    r2 = x * x + y * y
    if not (1e-280 < r2 < 1e280):
        return np.sqrt(z)
    r = math.sqrt(r2)
    if x >= 0.0:
        t = math.sqrt(0.5 * (r + x))
        return complex(t, 0.5 * y / t)
    t = math.sqrt(0.5 * (r - x))
    return complex(0.5 * abs(y) / t, math.copysign(t, y))


@nb.njit(cache=True, inline="always")
def _eps(v):
    """Phase ε = π + 2 arg ν of a root with Re ν > 0, in (0, 2π)."""
    return math.pi + 2.0 * math.atan2(v.imag, v.real)


@nb.njit(cache=True)
def _branches(a, gxx, gxy, gyx, gyy):
    """Both eigenvalues of [α][G] on the grid, labelled so each branch is continuous in ω.

    The square root of the discriminant is chosen at each sample as the one nearer to the previous
    sample's root. A label swap can then only happen where the two roots nearly coincide (the
    discriminant passes near zero), where it moves a branch by at most the tiny root separation; the
    principal square root instead flips sign whenever the discriminant crosses the negative real
    axis, anywhere, which creates false lobe crossings.
    """
    n = gxx.size
    nu = np.empty((2, n), dtype=np.complex128)
    prev = 0.0 + 0.0j
    for i in range(n):
        tr, det = _tr_det(a, gxx[i], gxy[i], gyx[i], gyy[i])
        s = _csqrt(tr * tr - 4.0 * det)
        if i > 0 and _dist2(s, prev) > _dist2(-s, prev):
            s = -s
        prev = s
        nu[0, i] = 0.5 * (tr + s)
        nu[1, i] = 0.5 * (tr - s)
    return nu


@nb.njit(cache=True, error_model="numpy")  # numpy: no zero-division check per division (a branch)
def _branches_diag(a, gxx, gyy):
    """:func:`_branches` for a diagonal receptance (a modal structure: no cross terms), bit for bit, in the
    real arithmetic of :func:`_disc_diag` (the eigenvalues are the closed-form roots of the 2×2 quadratic
    either way; this computes them with about half the multiplications). Measured with the same change in
    the refinement and edge roots: the engine per set 6 % faster under four conditions, 1–4 % under one
    (benchmarks/bench_conditions.py and bench_envelope.py --against, interleaved, same depths).

    Two passes: the discriminant's square root at every node without a branch (:func:`_csqrt`'s two cases as
    selects: the same operations on the same operands, so the same bits; nodes outside its range go to
    :func:`_csqrt` itself), a loop the compiler can vectorize, then the sequential branch continuation."""
    n = gxx.size
    nu = np.empty((2, n), dtype=np.complex128)
    trr = np.empty(n)
    tri = np.empty(n)
    sqr = np.empty(n)
    sqi = np.empty(n)
    n_out = 0
    for i in range(n):
        g = gxx[i]
        y = gyy[i]
        tr_r, tr_i, dr, di = _disc_diag(a, g.real, g.imag, y.real, y.imag)
        trr[i] = tr_r
        tri[i] = tr_i
        r2 = dr * dr + di * di
        n_out += not (1e-280 < r2 < 1e280)
        t = math.sqrt(0.5 * (math.sqrt(r2) + abs(dr)))  # r + x for x ≥ 0, r − x for x < 0
        q = 0.5 * abs(di) / t
        pos = dr >= 0.0
        sqr[i] = t if pos else q
        sqi[i] = math.copysign(q if pos else t, di)
    if n_out:  # |disc|² beyond the double range (or NaN): _csqrt's own fallback
        for i in range(n):
            g = gxx[i]
            y = gyy[i]
            tr_r, tr_i, dr, di = _disc_diag(a, g.real, g.imag, y.real, y.imag)
            r2 = dr * dr + di * di
            if not (1e-280 < r2 < 1e280):
                sq = _csqrt(complex(dr, di))
                sqr[i] = sq.real
                sqi[i] = sq.imag
    pr = 0.0
    pi = 0.0
    for i in range(n):
        sr = sqr[i]
        si = sqi[i]
        if i > 0 and (sr - pr) * (sr - pr) + (si - pi) * (si - pi) > (-sr - pr) * (-sr - pr) + (-si - pi) * (-si - pi):
            sr = -sr
            si = -si
        pr = sr
        pi = si
        nu[0, i] = complex(0.5 * (trr[i] + sr), 0.5 * (tri[i] + si))
        nu[1, i] = complex(0.5 * (trr[i] - sr), 0.5 * (tri[i] - si))
    return nu


@nb.njit(cache=True, inline="always")
def _root_at(w, sa, sb, nua, nub, wi, wj, a, md, measured, gab):
    """The root of [α][G(ω)] at ω nearest the branch value interpolated between (sa, nua) and (sb, nub).

    For a modal structure G is exact; for a measured FRF it is linear on the table segment [wi, wj]
    (gab hold the four receptances at wi and wj).
    """
    if measured:
        t = (w - wi) / (wj - wi)
        gxx = gab[0, 0] + t * (gab[1, 0] - gab[0, 0])
        gxy = gab[0, 1] + t * (gab[1, 1] - gab[0, 1])
        gyx = gab[0, 2] + t * (gab[1, 2] - gab[0, 2])
        gyy = gab[0, 3] + t * (gab[1, 3] - gab[0, 3])
        tr, det = _tr_det(a, gxx, gxy, gyx, gyy)
        s = _csqrt(tr * tr - 4.0 * det)
    else:
        gxx = _modal_receptance(w, md, 0)
        gyy = _modal_receptance(w, md, 1)
        trr, tri, dr, di = _disc_diag(a, gxx.real, gxx.imag, gyy.real, gyy.imag)
        tr = complex(trr, tri)
        s = _csqrt(complex(dr, di))
    guess = nua + (w - sa) / (sb - sa) * (nub - nua)
    r1 = 0.5 * (tr + s)
    r2 = 0.5 * (tr - s)
    if _dist2(r1, guess) <= _dist2(r2, guess):
        return r1
    return r2


@nb.njit(cache=True, inline="always")
def _modal_d(w, md, d):
    """Σ_m 1/D_m and its first two ω-derivatives [m/N, m·s/N, m·s²/N], D_m = k_m(1 − r² + 2iζ_m r),
    in direction d of the packed modes ``md``."""
    g0 = 0.0j
    g1 = 0.0j
    g2 = 0.0j
    for m in range(md.shape[2]):
        km = md[d, 1, m]
        if km == 0.0:
            break
        wn = md[d, 0, m]
        z = md[d, 2, m]
        r = w / wn
        d0 = km * complex(1.0 - r * r, 2.0 * z * r)
        d1 = km * complex(-2.0 * r, 2.0 * z) / wn
        d2 = -2.0 * km / (wn * wn)
        inv = 1.0 / d0
        g0 += inv
        g1 -= d1 * inv * inv
        g2 += (2.0 * d1 * d1 - d0 * d2) * inv * inv * inv
    return g0, g1, g2


@nb.njit(cache=True)
def _phase_at(w, sa, sb, nua, nub, wi, wj, a, md, measured, gab):
    """The root ν at ω (chosen as in :func:`_root_at`) with dε/dω [s] and d²ε/dω² [s²].

    From ν² − tr ν + det = 0 (tr, det of [α][G(ω)]): ν' = (tr'ν − det')/(2ν − tr) and
    ν'' = (tr''ν + 2tr'ν' − 2ν'² − det'')/(2ν − tr); ε = π + 2 arg ν gives ε' = 2 Im(ν'/ν) and
    ε'' = 2 Im(ν''/ν − (ν'/ν)²). G', G'' are exact for modes; for a measured FRF G is linear on the
    table segment [wi, wj], so G' is its slope and G'' = 0 (the data between table points are the
    straight line the engine uses everywhere else).
    """
    axx, axy, ayx, ayy = a
    if measured:
        h = wj - wi
        t = (w - wi) / h
        gxx = gab[0, 0] + t * (gab[1, 0] - gab[0, 0])
        gxy = gab[0, 1] + t * (gab[1, 1] - gab[0, 1])
        gyx = gab[0, 2] + t * (gab[1, 2] - gab[0, 2])
        gyy = gab[0, 3] + t * (gab[1, 3] - gab[0, 3])
        dxx = (gab[1, 0] - gab[0, 0]) / h
        dxy = (gab[1, 1] - gab[0, 1]) / h
        dyx = (gab[1, 2] - gab[0, 2]) / h
        dyy = (gab[1, 3] - gab[0, 3]) / h
        exx = 0.0j
        exy = 0.0j
        eyx = 0.0j
        eyy = 0.0j
    else:
        gxx, dxx, exx = _modal_d(w, md, 0)
        gyy, dyy, eyy = _modal_d(w, md, 1)
        gxy = 0.0j
        gyx = 0.0j
        dxy = 0.0j
        dyx = 0.0j
        exy = 0.0j
        eyx = 0.0j
    det_a = axx * ayy - axy * ayx
    tr = axx * gxx + axy * gyx + ayx * gxy + ayy * gyy
    tr1 = axx * dxx + axy * dyx + ayx * dxy + ayy * dyy
    tr2 = axx * exx + axy * eyx + ayx * exy + ayy * eyy
    det = det_a * (gxx * gyy - gxy * gyx)
    det1 = det_a * (dxx * gyy + gxx * dyy - dxy * gyx - gxy * dyx)
    det2 = det_a * (exx * gyy + 2.0 * dxx * dyy + gxx * eyy - exy * gyx - 2.0 * dxy * dyx - gxy * eyx)
    s = _csqrt(tr * tr - 4.0 * det)
    guess = nua + (w - sa) / (sb - sa) * (nub - nua)
    nu = 0.5 * (tr + s)
    r2 = 0.5 * (tr - s)
    if _dist2(r2, guess) < _dist2(nu, guess):
        nu = r2
    q = 2.0 * nu - tr
    if q == 0.0 or nu == 0.0:  # a double root (measure zero): no derivative; report a flat phase
        return nu, 0.0, 0.0
    nu1 = (tr1 * nu - det1) / q
    nu2 = (tr2 * nu + 2.0 * tr1 * nu1 - 2.0 * nu1 * nu1 - det2) / q
    r1 = nu1 / nu
    return nu, 2.0 * r1.imag, 2.0 * (nu2 / nu - r1 * r1).imag


@nb.njit(cache=True, inline="always")
def _modal_d12(w, md, d):
    """The first two ω-derivatives of Σ_m 1/D_m [m·s/N, m·s²/N] (as :func:`_modal_d`, without a
    complex division: 1/D = conj(D)/|D|², and D'' = −2k/ωn² is real)."""
    g1 = 0.0j
    g2 = 0.0j
    for m in range(md.shape[2]):
        km = md[d, 1, m]
        if km == 0.0:
            break
        wn = md[d, 0, m]
        z = md[d, 2, m]
        r = w / wn
        re = 1.0 - r * r
        im = 2.0 * z * r
        sc = 1.0 / (km * (re * re + im * im))
        inv = complex(re * sc, -im * sc)
        d1 = km * complex(-2.0 * r, 2.0 * z) / wn
        inv2 = inv * inv
        g1 -= d1 * inv2
        g2 += inv2 * (2.0 * d1 * d1 * inv + 2.0 * km / (wn * wn))  # (2D'² − D D'')/D³
    return g1, g2


@nb.njit(cache=True, inline="always")
def _node_slopes(w, nu, nu_other, gxx, gyy, a, md):
    """dε/dω [s] and d²ε/dω² [s²] of the root ``nu`` at a grid node of a modal structure.

    The same formulas as :func:`_phase_at`, but the node's roots and receptances are already known:
    no square root or branch choice, and 2ν − tr is the difference of the two roots."""
    axx, axy, ayx, ayy = a
    dxx, exx = _modal_d12(w, md, 0)
    dyy, eyy = _modal_d12(w, md, 1)
    det_a = axx * ayy - axy * ayx
    tr1 = axx * dxx + ayy * dyy
    tr2 = axx * exx + ayy * eyy
    det1 = det_a * (dxx * gyy + gxx * dyy)
    det2 = det_a * (exx * gyy + 2.0 * dxx * dyy + gxx * eyy)
    q = nu - nu_other
    if q == 0.0 or nu == 0.0:  # a double root (measure zero): no derivative; report a flat phase
        return 0.0, 0.0
    iq = q.conjugate() / (q.real * q.real + q.imag * q.imag)
    inu = nu.conjugate() / (nu.real * nu.real + nu.imag * nu.imag)
    nu1 = (tr1 * nu - det1) * iq
    nu2 = (tr2 * nu + 2.0 * tr1 * nu1 - 2.0 * nu1 * nu1 - det2) * iq
    r1 = nu1 * inu
    return 2.0 * r1.imag, 2.0 * (nu2 * inu - r1 * r1).imag


@nb.njit(cache=True)
def _split_point(kind, target, p, q, fp, fq, i, w, nu_br, a, md, measured, gab):
    """A zero inside (p, q) ⊂ segment i of ε'' (kind 0) or of g = ωε' − ε − target (kind 1), given
    its values fp, fq of opposite signs at the ends. Illinois iteration on exact evaluations to 1e-11
    of ω for a lobe's turning point (a split point off by δ hides a tip only for speeds within ~δ²
    of it) and 1e-8 for an extremum of g (g then varies by ~δ² across the piece it overlaps).
    Returns (ω, ν, ε', ε'') at the zero and the number of evaluations."""
    wi = w[i]
    wj = w[i + 1]
    lo, hi, flo, fhi = p, q, fp, fq
    x = 0.5 * (lo + hi)
    v = 0.0j
    e1 = 0.0
    e2 = 0.0
    side = 0
    n_ev = 0
    for _ in range(100):
        x = (lo * fhi - hi * flo) / (fhi - flo)
        if not (min(lo, hi) < x < max(lo, hi)):
            x = 0.5 * (lo + hi)
        v, e1, e2 = _phase_at(x, wi, wj, nu_br[i], nu_br[i + 1], wi, wj, a, md, measured,
                              gab)
        n_ev += 1
        fx = e2 if kind == 0 else x * e1 - _eps(v) - target
        if fx == 0.0:
            break
        if (fx > 0.0) == (flo > 0.0):
            lo, flo = x, fx
            if side == -1:
                fhi *= 0.5
            side = -1
        else:
            hi, fhi = x, fx
            if side == 1:
                flo *= 0.5
            side = 1
        if abs(hi - lo) <= (1e-8 if kind == 0 else 1e-11) * x:
            break
    return x, v, e1, e2, n_ev


@nb.njit(cache=True)
def _hermite_root(h0, h1, s0, s1):
    """Zero t ∈ (0, 1) of the cubic Hermite interpolant with values h0, h1 (opposite signs) and slopes
    s0, s1 (per unit t) at t = 0, 1: Newton from the linear zero, kept inside (0, 1); the linear zero
    if Newton leaves the interval or stalls."""
    t_lin = h0 / (h0 - h1)
    t = t_lin
    for _ in range(6):
        t2 = t * t
        t3 = t2 * t
        p = (2.0 * t3 - 3.0 * t2 + 1.0) * h0 + (t3 - 2.0 * t2 + t) * s0 + (3.0 * t2 - 2.0 * t3) * h1 + (t3 - t2) * s1
        dp = (6.0 * t2 - 6.0 * t) * (h0 - h1) + (3.0 * t2 - 4.0 * t + 1.0) * s0 + (3.0 * t2 - 2.0 * t) * s1
        if dp == 0.0:
            return t_lin
        step = p / dp
        t -= step
        if not (0.0 < t < 1.0):
            return t_lin
        if abs(step) < 1e-12:
            break
    return t


@nb.njit(cache=True)
def _refine(T, k, wa, wb, nua, nub, da, db, ea, eb, wi, wj, a, md, measured, gab):
    """Solve H(ω) = ωT − ε(ω) − 2kπ = 0 in the bracket [wa, wb] (a sign change) of table segment
    [wi, wj], Brent-style; ν, dε/dω [s] and ε at the bracket ends are nua, nub, da, db, ea, eb.

    The first iterate is the zero of the cubic Hermite interpolant of H (values and slopes T − ε' at
    both ends; error O(h⁴) against O(h²) for the secant), then inverse quadratic interpolation through
    the three latest points (secant while only two are distinct), falling back to bisection whenever a
    step leaves the current bracket; stops at |H| < 1e-7 rad × min(1, |dH/dω|/T) (the secant slope:
    near a lobe tip H is flat and a residual moves the root further, so the tolerance tightens there).
    A phase error δH moves the depth by (d ln b/dω)/(dH/dω)·δH: near resonance both derivatives scale
    as 1/(ζωn), away from it the ratio is ≤ 2/ε, so depths are good to ~1e-6 (the tests compare with a
    brute-force reference at 1e-6). Typically one or two evaluations.
    Returns (Re ν, ω) at the root and the number of evaluations; Re ν ≤ 0 means the candidate is not a
    physical boundary.
    """
    target = TWO_PI * k
    lo, hi = wa, wb
    flo = wa * T - ea - target
    fhi = wb * T - eb - target
    if flo == 0.0:
        return nua.real, wa, 0
    if fhi == 0.0:
        return nub.real, wb, 0
    axx, axy, ayx, ayy = a
    n_m = md.shape[2]
    # the three latest points, newest last
    x0, f0, x1, f1, x2, f2 = lo, flo, lo, flo, hi, fhi
    n_pts = 2
    v = nua
    xm = wa
    n_ev = 0
    for _ in range(60):
        if n_ev == 0:
            h = wb - wa
            xm = wa + h * _hermite_root(flo, fhi, (T - da) * h, (T - db) * h)
        elif n_pts >= 3 and f0 != f1 and f0 != f2 and f1 != f2:
            xm = (x0 * f1 * f2 / ((f0 - f1) * (f0 - f2)) + x1 * f0 * f2 / ((f1 - f0) * (f1 - f2))
                  + x2 * f0 * f1 / ((f2 - f0) * (f2 - f1)))
        elif f2 != f1:
            xm = x2 - f2 * (x2 - x1) / (f2 - f1)
        else:
            xm = 0.5 * (lo + hi)
        if not (min(lo, hi) < xm < max(lo, hi)):
            xm = 0.5 * (lo + hi)
        # the root at xm (as _root_at, written out: an inlined call with the arrays md and gab makes
        # numba reference-count them on every iteration)
        if measured:
            t = (xm - wi) / (wj - wi)
            gxx = gab[0, 0] + t * (gab[1, 0] - gab[0, 0])
            gxy = gab[0, 1] + t * (gab[1, 1] - gab[0, 1])
            gyx = gab[0, 2] + t * (gab[1, 2] - gab[0, 2])
            gyy = gab[0, 3] + t * (gab[1, 3] - gab[0, 3])
            m00 = axx * gxx + axy * gyx
            m01 = axx * gxy + axy * gyy
            m10 = ayx * gxx + ayy * gyx
            m11 = ayx * gxy + ayy * gyy
            tr = m00 + m11
            det = m00 * m11 - m01 * m10
            sq = _csqrt(tr * tr - 4.0 * det)
        else:
            gr0 = 0.0
            gi0 = 0.0
            gr3 = 0.0
            gi3 = 0.0
            for m in range(n_m):
                km = md[0, 1, m]
                if km == 0.0:
                    break
                r = xm / md[0, 0, m]
                re = 1.0 - r * r
                im = 2.0 * md[0, 2, m] * r
                inv = 1.0 / (km * (re * re + im * im))
                gr0 += re * inv
                gi0 -= im * inv
            for m in range(n_m):
                km = md[1, 1, m]
                if km == 0.0:
                    break
                r = xm / md[1, 0, m]
                re = 1.0 - r * r
                im = 2.0 * md[1, 2, m] * r
                inv = 1.0 / (km * (re * re + im * im))
                gr3 += re * inv
                gi3 -= im * inv
            trr, tri, dr, di = _disc_diag(a, gr0, gi0, gr3, gi3)
            tr = complex(trr, tri)
            sq = _csqrt(complex(dr, di))
        guess = nua + (xm - wa) / (wb - wa) * (nub - nua)
        v = 0.5 * (tr + sq)
        r2 = 0.5 * (tr - sq)
        if _dist2(r2, guess) < _dist2(v, guess):
            v = r2
        n_ev += 1
        if v.real <= 0.0:
            return v.real, xm, n_ev
        fm = xm * T - _eps(v) - target
        # |H| < 1e-7 rad, tighter where H is flatter than its far-field slope T (near a lobe tip
        # dH/dω → 0 and the same residual would leave the root, and the depth, much less certain)
        slope = abs((fm - f2) / (xm - x2)) if xm != x2 else T
        if abs(fm) < 1e-7 * min(1.0, slope / T) or abs(hi - lo) <= 1e-14 * xm:
            break
        if fm * flo > 0.0:
            lo, flo = xm, fm
        else:
            hi, fhi = xm, fm
        x0, f0, x1, f1, x2, f2 = x1, f1, x2, f2, xm, fm
        n_pts += 1
    return v.real, xm, n_ev


@nb.njit(cache=True, inline="always")
def _any_speed(rpm, lo, hi):
    """Whether some speed of the ascending ``rpm`` lies in [lo, hi]."""
    j = np.searchsorted(rpm, lo)
    return j < rpm.size and rpm[j] <= hi


@nb.njit(cache=True)
def _collect(w, G, nu, valid, inv_b, T, rpm, n_teeth, est, uniform, a, md, measured, cap, stats):
    """Find every (branch, bracket, lobe k, speed) crossing that can matter, with a linear estimate.

    A crossing of lobe k at speed j lies in a bracket [x0, x1] of branch br when
    H = ωT_j − ε(ω) − 2kπ changes sign over it. The brackets are the grid segments, split wherever
    lobe k's period T_k(ω) = (ε + 2kπ)/ω turns back inside a segment (a lobe tip, or a fold): there
    dT_k/dω = (g − 2kπ)/ω² with g = ωε' − ε changes sign, and a speed beyond both ends' periods has
    two roots in the segment and no sign change. Per segment, g is made monotone by splitting at the
    zero of ε'' (g' = ωε'') where ε'' changes sign between the ends; then lobe k turns back at most
    once per piece, exactly where g − 2kπ changes sign, and that turning point is located (and the
    bracket split there) whenever a speed can lie in the tip beyond the ends: with g monotone,
    |T_k − T_k(end)| ≤ |g(end) − 2kπ|·h/ω_lo² bounds the tip. Between split points every speed has
    at most one root per bracket, found by the sign change.

    Segments are visited in levels of their largest 1/b (Re ν), each level a factor 2 below the last
    (a linear pass per level instead of a sort), so once every speed has an estimate, a segment whose
    best 1/b (times REFINE_MARGIN) is below the worst speed's estimate cannot matter and is skipped,
    and once a whole level lies below it the scan stops. On typical structures this skips the
    far-from-resonance 80–90 % of the grid.

    Returns the candidates (speed j, segment code br·F + i, k, bracket ends and their roots,
    estimated Re ν) and updates ``est`` with the best estimate per speed. ``stats`` (size 0: not
    counted) receives the work counts (S_* indices). At most ``cap`` candidates are kept: when there are
    more, the candidate arrays come back empty and ``overflow`` True, and the caller runs it again with a
    larger ``cap`` (buffers grown inside the loops would be loop-carried arrays, which numba reference-
    counts on every iteration).
    """
    counting = stats.size > 0
    n_w = w.size
    n_s = rpm.size
    t_min = T[n_s - 1]  # speeds ascending ⇒ periods descending
    t_max = T[0]
    rpm_top = rpm[n_s - 1]
    c60 = 60.0 / n_teeth
    step = (rpm[n_s - 1] - rpm[0]) / (n_s - 1) if n_s > 1 else 1.0
    # segments with both ends valid, ordered by their best 1/b
    seg_max = np.empty(2 * (n_w - 1))
    n_seg = 0
    seg_id = np.empty(2 * (n_w - 1), dtype=np.int64)
    for br in range(2):
        for i in range(n_w - 1):
            if valid[br, i] and valid[br, i + 1]:
                seg_max[n_seg] = max(inv_b[br, i], inv_b[br, i + 1])
                seg_id[n_seg] = br * n_w + i
                n_seg += 1
    if counting:
        stats[S_SEGMENTS] += n_seg
    overflow = False
    c_j = np.empty(cap, dtype=np.int64)
    c_seg = np.empty(cap, dtype=np.int64)
    c_k = np.empty(cap, dtype=np.int64)
    c_g = np.empty(cap)
    c_x = np.empty((cap, 6))  # bracket ends [rad/s], ε' [s] and ε there
    c_nu = np.empty((cap, 2), dtype=np.complex128)
    n_c = 0
    # dε/dω and d²ε/dω² at the nodes (modal structures; computed on first use)
    d1 = np.empty((2, n_w))
    d2 = np.empty((2, n_w))
    have = np.zeros((2, n_w), dtype=np.bool_)
    eps = np.empty((2, n_w))
    have_e = np.zeros((2, n_w), dtype=np.bool_)
    gab = np.empty((2, 4), dtype=np.complex128)
    # the bracket ends of one (segment, k): frequency, root, ε, 1/b
    bx = np.empty(5)
    bnu = np.empty(5, dtype=np.complex128)
    bd1 = np.empty(5)
    worst = 0.0
    # visit segments in levels of decreasing best 1/b (each level a factor 2 below the last): once the
    # worst speed's estimate exceeds a level's floor × REFINE_MARGIN, no later segment can matter
    top = seg_max[:n_seg].max() if n_seg > 0 else 0.0
    level_hi = np.inf
    level_lo = 0.5 * top
    n_vis = 0
    while n_seg > 0:
        for s in range(n_seg):
            m_s = seg_max[s]
            if m_s < level_lo or m_s >= level_hi:
                continue
            if n_vis % 8 == 0:
                worst = est.min()
            n_vis += 1
            if m_s * REFINE_MARGIN < worst:
                continue
            if counting:
                stats[S_VISITED] += 1
            code = seg_id[s]
            br = code // n_w
            i = code - br * n_w
            wa = w[i]
            wb = w[i + 1]
            nua = nu[br, i]
            nub = nu[br, i + 1]
            # ε at the ends, computed on first use: most nodes lie in segments that are never visited
            for e in range(i, i + 2):
                if not have_e[br, e]:
                    eps[br, e] = _eps(nu[br, e])
                    have_e[br, e] = True
            ea = eps[br, i]
            eb = eps[br, i + 1]
            # ε' and ε'' at the ends (a measured FRF: from this segment's straight line)
            if measured:
                for c4 in range(4):
                    gab[0, c4] = G[c4, i]
                    gab[1, c4] = G[c4, i + 1]
                _, d1a, d2a = _phase_at(wa, wa, wb, nua, nub, wa, wb, a, md, measured, gab)
                _, d1b, d2b = _phase_at(wb, wa, wb, nua, nub, wa, wb, a, md, measured, gab)
            else:
                for e in range(i, i + 2):
                    if not have[br, e]:
                        if counting:
                            stats[S_SLOPES] += 1
                        d1[br, e], d2[br, e] = _node_slopes(w[e], nu[br, e], nu[1 - br, e], G[0, e], G[3, e], a,
                                                            md)
                        have[br, e] = True
                d1a, d2a, d1b, d2b = d1[br, i], d2[br, i], d1[br, i + 1], d2[br, i + 1]
            g_a = wa * d1a - ea
            g_b = wb * d1b - eb
            # g = ωε' − ε is monotone on [wa, we] and [we, wb], we the zero of ε'' if it changes sign
            split_e = False
            we = 0.0
            nue = 0.0j
            ee = 0.0
            g_e = 0.0
            # lobes k whose speed on this segment can fall in [rpm_min, rpm_max] (any ε in (0, 2π))
            k_lo = int(math.floor((wa * t_min - TWO_PI) / TWO_PI))
            k_hi = int(math.ceil((wb * t_max) / TWO_PI))
            if k_lo < 0:
                k_lo = 0
            # an extremum of g can only hide crossings of 2kπ beyond both ends' values: above them for a
            # maximum (ε'' from + to −), below them for a minimum (near a resonance g ≪ 0: none)
            if d2a * d2b < 0.0 and (TWO_PI * k_hi > max(g_a, g_b) if d2a > 0.0 else TWO_PI * k_lo < min(g_a, g_b)):
                we, nue, d1e, _, n_ev = _split_point(0, 0.0, wa, wb, d2a, d2b, i, w, nu[br], a, md, measured, gab)
                if counting:
                    stats[S_SPLIT] += n_ev
                if nue.real > 0.0 and wa < we < wb:
                    split_e = True
                    ee = _eps(nue)
                    g_e = we * d1e - ee
            if counting:
                stats[S_PAIRS] += k_hi - k_lo + 1
            for k in range(k_lo, k_hi + 1):
                tk = TWO_PI * k
                # bracket ends for this lobe: wa, [tip in piece 1], [we], [tip in piece 2], wb
                nb_ = 0
                bx[0] = wa
                bnu[0] = nua
                bd1[0] = d1a
                nb_ = 1
                n_piece = 2 if split_e else 1
                for pc in range(n_piece):
                    if split_e and pc == 0:
                        p, pq, gp, gq, ep, eq = wa, we, g_a, g_e, ea, ee
                    elif split_e:
                        p, pq, gp, gq, ep, eq = we, wb, g_e, g_b, ee, eb
                    else:
                        p, pq, gp, gq, ep, eq = wa, wb, g_a, g_b, ea, eb
                    dp = gp - tk
                    dq = gq - tk
                    if dp * dq < 0.0:
                        # one turning point of T_k inside: only speeds in its tip (beyond both ends) are at risk
                        tp = (ep + tk) / p
                        tq = (eq + tk) / pq
                        room = (pq - p) / (p * p)
                        if dp > 0.0:  # T_k rises, then falls: a maximum of the period, a minimum of the speed
                            t_lo = max(tp, tq)
                            t_hi = min(tp + dp * room, tq - dq * room)
                        else:
                            t_hi = min(tp, tq)
                            t_lo = max(tp + dp * room, tq - dq * room)
                        if t_hi > 0.0 and t_hi >= t_lo and _any_speed(rpm, c60 / t_hi,
                                                                        c60 / t_lo if t_lo > 0.0 else np.inf):
                            x, v, xe1, _, n_ev = _split_point(1, tk, p, pq, dp, dq, i, w, nu[br], a, md, measured, gab)
                            if counting:
                                stats[S_SPLIT] += n_ev
                            if v.real > 0.0 and bx[nb_ - 1] < x < pq:
                                bx[nb_] = x
                                bnu[nb_] = v
                                bd1[nb_] = xe1
                                nb_ += 1
                    if split_e and pc == 0:
                        bx[nb_] = we
                        bnu[nb_] = nue
                        bd1[nb_] = d1e
                        nb_ += 1
                bx[nb_] = wb
                bnu[nb_] = nub
                bd1[nb_] = d1b
                nb_ += 1
                for m in range(nb_ - 1):
                    x0 = bx[m]
                    x1 = bx[m + 1]
                    n0 = bnu[m]
                    n1 = bnu[m + 1]
                    e0 = ea if m == 0 else _eps(n0)
                    e1 = eb if m == nb_ - 2 else _eps(n1)
                    # ε = 0 exactly at a Re ν = 0 edge node: the k = 0 speed is infinite (numba would raise)
                    da = e0 + tk
                    db = e1 + tk
                    sa = c60 * x0 / da if da > 0.0 else np.inf
                    sb = c60 * x1 / db if db > 0.0 else np.inf
                    lo_s = min(sa, sb)
                    if lo_s > rpm_top:  # the whole bracket lies above the top speed
                        continue
                    if uniform:  # evenly spaced speeds: the first index ≥ lo_s directly
                        j = max(0, int(math.ceil((lo_s - rpm[0]) / step - 1e-9)))
                        if j > 0 and rpm[j - 1] >= lo_s:
                            j -= 1
                    else:
                        j = np.searchsorted(rpm, lo_s)
                    hi = max(sa, sb)
                    while j < n_s and rpm[j] <= hi:
                        ha = x0 * T[j] - e0 - tk
                        hb = x1 * T[j] - e1 - tk
                        if ha * hb <= 0.0 and ha != hb:
                            t = ha / (ha - hb)
                            guess = n0.real + t * (n1.real - n0.real)
                            if guess > est[j]:
                                est[j] = guess
                            if n_c == cap:  # full: keep scanning (est stays exact), the caller runs it again
                                overflow = True
                                j += 1
                                continue
                            c_j[n_c] = j
                            c_seg[n_c] = code
                            c_k[n_c] = k
                            c_g[n_c] = guess
                            c_x[n_c, 0] = x0
                            c_x[n_c, 1] = x1
                            c_x[n_c, 2] = bd1[m]
                            c_x[n_c, 3] = bd1[m + 1]
                            c_x[n_c, 4] = e0
                            c_x[n_c, 5] = e1
                            c_nu[n_c, 0] = n0
                            c_nu[n_c, 1] = n1
                            n_c += 1
                        j += 1
        worst = est.min()
        if counting:
            stats[S_LEVELS] += 1
        if level_lo == 0.0 or level_lo * REFINE_MARGIN < worst:
            break
        level_hi = level_lo
        level_lo = 0.5 * level_lo if level_lo > 1e-3 * top else 0.0
    return overflow, c_j[:n_c], c_seg[:n_c], c_k[:n_c], c_g[:n_c], c_x[:n_c], c_nu[:n_c]


@nb.njit(cache=True)
def _validity_edges(w, nu, a, md, measured, G, stats):
    """Frequencies just inside the valid side wherever a branch's Re ν changes sign between nodes.

    Crossings right next to Re ν = 0 are real boundaries (near resonance |ν| is large, so the depth
    2π/(N Kt Re ν) can still be small) but would sit in a segment with one invalid end. Inserting a
    node where Re ν turns positive (Illinois root-finding on exact evaluations, to 1e-10 of the segment) makes
    every crossing lie inside a fully valid segment.
    """
    n_w = w.size
    out = np.empty(2 * n_w)
    n = 0
    gab = np.empty((2, 4), dtype=np.complex128)
    for br in range(2):
        for i in range(n_w - 1):
            va = nu[br, i].real > 0.0
            vb = nu[br, i + 1].real > 0.0
            if va == vb:
                continue
            if measured:
                for q in range(4):
                    gab[0, q] = G[q, i]
                    gab[1, q] = G[q, i + 1]
            lo = w[i]  # lo on the invalid side (Re ν ≤ 0), hi on the valid side (Re ν > 0)
            hi = w[i + 1]
            flo = nu[br, i].real
            fhi = nu[br, i + 1].real
            if va:
                lo, hi, flo, fhi = hi, lo, fhi, flo
            side = 0
            for _ in range(60):  # Illinois on the smooth Re ν: a handful of evaluations
                mid = (lo * fhi - hi * flo) / (fhi - flo)
                if not (min(lo, hi) < mid < max(lo, hi)):
                    mid = 0.5 * (lo + hi)
                v = _root_at(mid, w[i], w[i + 1], nu[br, i], nu[br, i + 1], w[i], w[i + 1], a, md,
                             measured, gab)
                if stats.size > 0:
                    stats[S_EDGE] += 1
                if v.real > 0.0:
                    hi, fhi = mid, v.real
                    if side == 1:
                        flo *= 0.5
                    side = 1
                else:
                    lo, flo = mid, v.real
                    if side == -1:
                        fhi *= 0.5
                    side = -1
                if abs(hi - lo) <= 1e-10 * (w[i + 1] - w[i]) + 1e-14 * hi:
                    break
            out[n] = hi
            n += 1
    return out[:n]


@nb.njit(cache=True)
def _with_nodes(w, G, nu, extra, a, measured, md):
    """The grid with the ``extra`` frequencies merged in: frequencies, receptances (exact for modes,
    linear between table points for a measured FRF) and the roots, each branch continued by
    proximity from the node before (as in :func:`_branches`). The old nodes between two new ones are
    copied as blocks (slices, no per-node branch: the merge was ~8 % of a condition's cost)."""
    n_old = w.size
    n_new = n_old + extra.size
    ex = np.sort(extra)
    w2 = np.empty(n_new)
    G2 = np.empty((4, n_new), dtype=np.complex128)
    nu2 = np.empty((2, n_new), dtype=np.complex128)
    i = 0
    c = 0
    for e in range(ex.size + 1):
        # the old nodes before the next new one (all the rest after the last): those with w ≤ x
        stop = n_old
        if e < ex.size:
            stop = i
            while stop < n_old and not (ex[e] < w[stop]):
                stop += 1
        n_blk = stop - i
        if n_blk > 0:
            w2[c:c + n_blk] = w[i:stop]
            G2[:, c:c + n_blk] = G[:, i:stop]
            nu2[:, c:c + n_blk] = nu[:, i:stop]
            c += n_blk
            i = stop
        if e == ex.size:
            break
        x = ex[e]
        j = min(max(i, 1), n_old - 1)  # segment [w[j-1], w[j]] containing x
        t = (x - w[j - 1]) / (w[j] - w[j - 1])
        if measured:
            for q in range(4):
                G2[q, c] = G[q, j - 1] + t * (G[q, j] - G[q, j - 1])
            tr, det = _tr_det(a, G2[0, c], G2[1, c], G2[2, c], G2[3, c])
            sq = _csqrt(tr * tr - 4.0 * det)
        else:
            gx = _modal_receptance(x, md, 0)
            gy = _modal_receptance(x, md, 1)
            G2[0, c] = gx
            G2[1, c] = 0.0j
            G2[2, c] = 0.0j
            G2[3, c] = gy
            trr, tri, dr, di = _disc_diag(a, gx.real, gx.imag, gy.real, gy.imag)
            tr = complex(trr, tri)
            sq = _csqrt(complex(dr, di))
        guess = nu[0, j - 1] + t * (nu[0, j] - nu[0, j - 1])
        r1 = 0.5 * (tr + sq)
        r2 = 0.5 * (tr - sq)
        if _dist2(r1, guess) <= _dist2(r2, guess):
            nu2[0, c] = r1
            nu2[1, c] = r2
        else:
            nu2[0, c] = r2
            nu2[1, c] = r1
        w2[c] = x
        c += 1
    return w2, G2, nu2


@nb.njit(cache=True)
def _distinct_new(w, extra):
    """The nodes of ``extra`` once each and not already in the ascending grid ``w``: a node twice makes a
    zero-length segment (a division by zero). A direction without data (a measured FRF with xx alone) has a
    root ν ≡ 0 whose Re ν = 0 edges fall on the other root's edges and on the grid."""
    if extra.size == 0:
        return extra
    ex = np.unique(extra)
    pos = np.searchsorted(w, ex)
    keep = np.ones(ex.size, dtype=np.bool_)
    for e in range(ex.size):
        if pos[e] < w.size and w[pos[e]] == ex[e]:
            keep[e] = False
    return ex[keep]


@nb.njit(cache=True)
def _scan(w, G, a, n_teeth, rpm, md, measured, floor, stats):
    """Everything before the exact refinement: both branches, the Re ν = 0 edges merged into the grid,
    the nodes' ε and 1/b, and the candidate crossings (:func:`_collect`). Returns the grid, receptances,
    the tooth periods T [s], the best estimate per speed and the candidates. ``floor`` (S,) [Re ν]: each
    speed's estimate starts there (a censored search, :func:`envelope_on_grid`; size 0: at 0)."""
    counting = stats.size > 0
    nu = _branches(a, G[0], G[1], G[2], G[3]) if measured else _branches_diag(a, G[0], G[3])
    extra = _distinct_new(w, _validity_edges(w, nu, a, md, measured, G, stats))
    if extra.size:
        w, G, nu = _with_nodes(w, G, nu, extra, a, measured, md)
    n_w = w.size
    n_s = rpm.size
    if counting:
        stats[S_NODES] += n_w
    valid = np.empty((2, n_w), dtype=np.bool_)
    inv_b = np.empty((2, n_w))
    for br in range(2):
        for i in range(n_w):
            v = nu[br, i]
            ok = v.real > 0.0 and math.isfinite(v.real) and math.isfinite(v.imag)
            valid[br, i] = ok
            inv_b[br, i] = v.real if ok else 0.0
    T = np.empty(n_s)
    for j in range(n_s):
        T[j] = 60.0 / (n_teeth * rpm[j])
    est = np.zeros(n_s)
    if floor.size:
        est[:] = floor
    # evenly spaced speeds let _collect index them directly; equal speeds (step 0) must not count
    uniform = n_s > 2 and rpm[n_s - 1] > rpm[0]
    for j in range(1, n_s):
        if abs(rpm[j] - rpm[j - 1] - (rpm[n_s - 1] - rpm[0]) / (n_s - 1)) > 1e-9 * rpm[n_s - 1]:
            uniform = False
    cap = 8 * n_s + 64
    while True:
        overflow, c_j, c_seg, c_k, c_g, c_x, c_nu = _collect(w, G, nu, valid, inv_b, T, rpm, n_teeth, est,
                                                             uniform, a, md, measured, cap, stats)
        if not overflow:
            break
        cap *= 4
        est[:] = 0.0
        if floor.size:
            est[:] = floor
    if counting:
        stats[S_CANDIDATES] += c_j.size
    return w, G, T, est, c_j, c_seg, c_k, c_g, c_x, c_nu


@nb.njit(cache=True)
def envelope_on_grid(w, G, a, n_teeth, kt, rpm, md, measured, depth, lobe, wc, stats, ceiling):
    """Lower envelope b_lim [m] at ascending speeds ``rpm`` from receptances G (4, F) on grid ``w``.

    Writes depth (inf where no boundary exists), the lobe number and the chatter frequency [rad/s].
    ``stats``: an int64 array of N_STATS work counts to add to (size 0: none are counted).
    ``ceiling`` (S,) [m] (size 0: none; inf: none for that speed): a censored search. A depth above the
    ceiling is a root with Re ν below f = 2π/(N Kt ceiling), so each speed's estimate starts at f: the scan
    then certifies only down to f (the segments it skips lie below f/REFINE_MARGIN as they do below a found
    estimate), and where no refined root reaches f the speed gets the ceiling itself (lobe −1, frequency NaN), a
    lower bound of its limit; where one does, the same limit as without a ceiling. Which candidates are refined
    is decided by the best ESTIMATE among them, as without a ceiling, not by f: a root above f can have a linear
    estimate more than REFINE_MARGIN below f (a lobe tip; tests/test_zoa_speed_independence.py holds one), and
    deciding by f returned the ceiling there (issue 27).
    """
    counting = stats.size > 0
    scale = TWO_PI / (n_teeth * kt)
    floor = np.zeros(0)
    if ceiling.size:
        floor = scale / ceiling
    w, G, T, est, c_j, c_seg, c_k, c_g, c_x, c_nu = _scan(w, G, a, n_teeth, rpm, md, measured, floor,
                                                          stats)
    n_w = w.size
    n_s = rpm.size
    best_inv = np.zeros(n_s)
    best_k = np.full(n_s, -1, dtype=np.int64)
    best_w = np.full(n_s, np.nan)
    # refine exactly only the crossings whose estimate is near the best estimate at their speed; censored, the best
    # ESTIMATE (not the ceiling's 1/b, which est starts at): a root at or above that 1/b can have a linear estimate
    # more than REFINE_MARGIN below it (a lobe tip), and the search without a ceiling refines it as the best estimate
    thr = est
    if floor.size:
        thr = np.zeros(n_s)
        for c in range(c_j.size):
            if c_g[c] > thr[c_j[c]]:
                thr[c_j[c]] = c_g[c]
    gab = np.empty((2, 4), dtype=np.complex128)
    for c in range(c_j.size):
        j = c_j[c]
        if c_g[c] * REFINE_MARGIN < thr[j]:
            continue
        br = c_seg[c] // n_w
        i = c_seg[c] - br * n_w
        if measured:
            for q in range(4):
                gab[0, q] = G[q, i]
                gab[1, q] = G[q, i + 1]
        re_nu, wcj, n_ev = _refine(T[j], c_k[c], c_x[c, 0], c_x[c, 1], c_nu[c, 0], c_nu[c, 1], c_x[c, 2], c_x[c, 3],
                                   c_x[c, 4], c_x[c, 5], w[i], w[i + 1], a,
                                   md, measured, gab)
        if counting:
            stats[S_REFINED] += 1
            stats[S_REFINE_EVALS] += n_ev
        if re_nu > best_inv[j]:
            best_inv[j] = re_nu
            best_k[j] = c_k[c]
            best_w[j] = wcj
    for j in range(n_s):
        if best_inv[j] > 0.0 and (floor.size == 0 or best_inv[j] >= floor[j]):
            depth[j] = scale / best_inv[j]
            lobe[j] = best_k[j]
            wc[j] = best_w[j]
        elif floor.size and floor[j] > 0.0:  # censored: no root below the ceiling
            depth[j] = ceiling[j]
            lobe[j] = -1
            wc[j] = np.nan
        else:
            depth[j] = np.inf
            lobe[j] = -1
            wc[j] = np.nan


@nb.njit(cache=True, error_model="numpy")
def modal_grid(md, w_top, n_base, offsets):
    """Frequency grid [rad/s] and the receptances (4, F) of a modal structure (packed modes ``md``).

    Compiled with numpy's error model: numba's default checks every division for a zero divisor (a branch
    that keeps the receptance loop scalar); here no divisor can be zero (k > 0 and 0 < ζ < 1, checked by
    ModalBatch.validate), and without the checks the same operations give the same bits in ~1 µs less per
    set (4.8 → 3.8 µs, profile_zoa.py --conditions, issue 27)."""
    n_m = md.shape[2]
    wn_all = np.empty(2 * n_m)
    z_all = np.empty(2 * n_m)
    n_all = 0
    for d in range(2):
        for m in range(n_m):
            if md[d, 1, m] == 0.0:
                break
            wn_all[n_all] = md[d, 0, m]
            z_all[n_all] = md[d, 2, m]
            n_all += 1
    wn_all = wn_all[:n_all]
    z_all = z_all[:n_all]
    w_lo = 0.1 * wn_all.min()
    w_hi = max(4.0 * wn_all.max(), 1.05 * w_top)
    w = _grid_frequencies(wn_all, z_all, w_lo, w_hi, n_base, offsets)
    G = np.zeros((4, w.size), dtype=np.complex128)
    # the receptance sums written out here (not _modal_receptance): an inlined call per node makes numba
    # reference-count md on every iteration
    for d in range(2):
        row = 3 * d
        for m in range(n_m):
            km = md[d, 1, m]
            if km == 0.0:
                break
            wn = md[d, 0, m]
            z2 = 2.0 * md[d, 2, m]
            for i in range(w.size):
                r = w[i] / wn
                re = 1.0 - r * r
                im = z2 * r
                inv = 1.0 / (km * (re * re + im * im))
                G[row, i] += complex(re * inv, -im * inv)
    return w, G


@nb.njit(cache=True, parallel=True)
def envelope_modal_batch(md, a, n_teeth, kt, rpm, n_base, offsets, depth, lobe, wc, stats):
    """Batched envelope for B modal structures: packed modes md (B, 2, 3, M) (:func:`pack_modes`),
    rpm ascending (S,).

    Writes depth (B, S) [m], lobe (B, S) and chatter frequency wc (B, S) [rad/s]. ``stats`` is
    (B, N_STATS) int64 zeros to receive each set's work counts, or (0, N_STATS) for none.
    """
    counting = stats.shape[0] > 0
    empty = np.zeros(0, dtype=np.int64)
    none = np.zeros(0)
    n_b = md.shape[0]
    w_top = TWO_PI * n_teeth * rpm[rpm.size - 1] / 60.0  # tooth-passing frequency at the top speed
    for b in nb.prange(n_b):
        w, G = modal_grid(md[b], w_top, n_base, offsets)
        envelope_on_grid(w, G, a, n_teeth, kt, rpm, md[b], False,
                         depth[b], lobe[b], wc[b], stats[b] if counting else empty, none)


@nb.njit(cache=True, parallel=True)
def envelope_modal_conditions(md, kr_set, teeth, kt, kr, phi_s, phi_e, rpm, starts, n_base, offsets, depth, lobe,
                              wc, stats, ceiling):
    """Batched envelope for B modal structures under C cutting conditions in one call.

    Condition c (``teeth``, ``kt`` [N/m²], ``kr``, ``phi_s``/``phi_e`` [rad], each (C,)) owns the speed
    columns ``starts[c]:starts[c + 1]`` of ``rpm`` (ascending within each condition). Each set's frequency
    grid and receptances (:func:`modal_grid`) are computed once, up to the highest tooth-passing frequency
    over all columns, and shared by every condition; each condition then scans and refines its own
    columns (:func:`envelope_on_grid`). ``kr_set`` (B,): a Kr per set overriding the conditions' (size 0:
    none). With one condition and no ``kr_set`` this is :func:`envelope_modal_batch`, bit for bit.
    Writes depth (B, S) [m], lobe (B, S), wc (B, S) [rad/s]; ``stats`` as there. ``ceiling`` (B, S) [m], or
    (0, S) for none: a censored search per set and column (:func:`envelope_on_grid`).
    """
    counting = stats.shape[0] > 0
    censored = ceiling.shape[0] > 0
    empty = np.zeros(0, dtype=np.int64)
    none = np.zeros(0)
    n_b = md.shape[0]
    n_c = teeth.size
    per_set = kr_set.size > 0
    w_top = 0.0
    for c in range(n_c):
        wt = TWO_PI * teeth[c] * rpm[starts[c + 1] - 1] / 60.0
        if wt > w_top:
            w_top = wt
    for b in nb.prange(n_b):
        w, G = modal_grid(md[b], w_top, n_base, offsets)
        for c in range(n_c):
            s0 = starts[c]
            s1 = starts[c + 1]
            a = directional_brackets(kr_set[b] if per_set else kr[c], phi_s[c], phi_e[c])
            envelope_on_grid(w, G, a, teeth[c], kt[c], rpm[s0:s1], md[b], False, depth[b, s0:s1], lobe[b, s0:s1],
                             wc[b, s0:s1], stats[b] if counting else empty, ceiling[b, s0:s1] if censored else none)
