"""Spectral-element collocation of the cutting intervals: an accurate and fast time-domain engine.

Same interface as :mod:`millstab.stability.zoa` and :mod:`millstab.stability.sdm` (``envelope``,
``envelope_batch``), plus :func:`monodromy`, :func:`rho_map` and the lobe type (Hopf / flip) in
:class:`SpectralEnvelope`. Modal structures only (as SDM); the force model is SDM's (see
:mod:`millstab.stability.sdm`): F = ½ b Kt [A(t)] (u(t) − u(t − T)).

Why this method (measured, see benchmarks/bench_spectral.py). The milling equation is a linear
delay equation with T-periodic coefficients; its stability is that of the monodromy operator over
one tooth period. Between cuts the tool vibrates freely, so the only part of the past that matters
is the displacement during the previous cut. This engine therefore discretises only the cutting
intervals, with spectral elements: each cutting segment (between entry/exit instants, where [A(t)]
is a smooth trigonometric function) is split into elements of at most ``ELEM_PERIODS`` natural
periods of the highest mode, and on each element the state is a polynomial of degree p collocated at
the p Gauss–Legendre points (order 2p at the element ends). The delayed displacement at a node is the
previous period's value at the same node, so no interpolation error enters; the free flight is one
exact exponential. The error falls spectrally with p (semi-discretization: O(h²)): 4 nodes per half
natural period give ρ to ~1e-5 on the benchmark, with a monodromy matrix of n + D·(nodes) = 6–20 rows
at a/D = 0.05, where SDM needs ~70 steps per period and a Richardson extrapolation (two grids). Measured
on the 1-DOF benchmark (81 speeds 5 000–25 000 rpm): within 0.11 % (a/D = 0.05), 0.12 % (0.1), 0.13 %
(0.5) and 0.47 % (slotting, a flip lobe at 23 000 rpm) of SDM's converged depths, flip speeds where SDM
has them. The multi-frequency (Hill) form was not chosen: at low immersion the directional matrix is a
short pulse with jumps, whose Fourier series converges like 1/r, so many harmonics (complex matrices of
2·(2h + 1) rows per direction) would be needed for 1 %, and its boundary needs a search in frequency.

Accuracy control (converged by default). p = ``P_NODES`` Gauss nodes per element, elements ≤
``ELEM_PERIODS`` natural periods of the highest mode. Per call, before the batch is solved, the boundary
points of the first set at three check speeds (the lowest, where elements are longest, the middle and
the highest) are found with p nodes and moved by Newton to p + ``P_STEP`` nodes; while one moves by more
than ``TOL`` (0.1 %, ten times below the 1 % target) p grows by P_STEP (up to ``P_MAX``), and the
moved points are the start of the next check (a fresh search only where Newton failed).

Root search (compiled, parallel over sets × speed blocks: a set's speeds are one block when the sets
fill the threads, else about ``BLOCKS_PER_THREAD`` blocks per thread, none shorter than ``BLOCK``). A
Floquet solution z(t + T) = μ z(t) has z(t − T) = z(t)/μ, so μ is a multiplier iff
det(μ I − Ψ(w (1 − 1/μ))) = 0, with Ψ(σ) the transition over one tooth period of the ODE
ż = (A0 + σ E(t) C) z (w = ½ b Kt): an n × n characteristic equation (n = 2 × modes), exact for the
discretised system too and far cheaper than the monodromy's eigenvalues. The boundary at a speed is
the smallest b with a multiplier e^{iθ} on the unit circle (θ = π: flip).
Branch tracking: every boundary root found (b, θ) is a branch (a lobe's boundary, Hopf or flip),
continued from speed to speed, up to ``_spectral_kernel.N_BRANCH`` at once (the lobe being left and the
one taking over), by Newton on the characteristic function with its exact Jacobian (Ψ and dΨ/dσ from
one LU per element, Jacobi's formula; a flip root, where F(b, π) is real, in b alone), from a
prediction linear in speed. Where the boundary's own branch is lost or moves by more than
``_spectral_kernel.BRANCH_JUMP`` (25 %) in one speed step (Newton may have jumped onto another lobe
over a closed band), the search starts from below as at a block start. The lowest branch is accepted if the full monodromy is stable at
b·CHECKS (0.7, 0.93, 0.995: nothing unknown crossed below, e.g. another lobe come down or a flip band);
a failed rung brackets the unknown crossing, Newton from inside it (θ from the rung's dominant
multiplier) adds its root to the set, and that root is checked in turn. Where no branch is left (a
block's first speed, or all lost): ρ(b) on b_ref·LADDER (b_ref the zero-order depth; inside a block the
last boundary·LADDER_CONT) up to the first unstable depth, Illinois on ρ − 1 to 1 %, Newton; the fine
Illinois (``RTOL``) only where Newton fails. The accepted depths are roots of the discretised
characteristic equation to ~1e-12, so they are smooth in the parameters (finite-difference Jacobians in
identification). Limitation, as for every ladder: an unstable band narrower than the spacing of the
checks can be missed (on the benchmark grids a 40-rung check changed nothing, see the benchmark). Known
case (x = y one mode each, benchmark modes, a/D = 0.05, 200 speeds 5 000–25 000 rpm): at 24 698 rpm a
dense ρ scan (:func:`rho_map`) shows an unstable island at 58–63 mm that both this engine and SDM step
over (both report 80.5 mm); at 23 894 rpm this engine finds the island at 33.7 mm that SDM misses
(42.9 mm). Such islands lie far above the lowest lobes (2–3 mm there).

Speed (200 speeds, x = y one mode each, a/D = 0.05; benchmarks/bench_spectral.py; the shared 2-core
machine ran at load 5–24 during these measurements, shared with 6 other sessions, so old/new were
run alternately in the same minutes and CPU time (process_time) is the robust figure; wall figures are
not comparable across days). With branch tracking the root search needs 1 951 evaluations (9.8 per speed) where the
previous continued-root-plus-rescue scheme needed 3 454 (17.3): root search alone, p = 6, one thread,
58 ms CPU (was 72 ms); a whole envelope (convergence check and zero-order guesses included) 64 ms CPU
on one thread, 83–87 ms CPU on two (was 101–112 ms), i.e. ~15 envelopes per CPU-second. Wall time, best
of 7: 181 ms, 5.5 envelopes/s (old 228 ms, 4.4/s, in the same minute at load ~5; at load 15–24,
388–588 ms against 572–748 ms). On the briefly idle machine (load 0.3, two alternating pairs, best of 7
each): new 61 and 45 ms (16 and 22 envelopes/s), old 56 and 54 ms (18/s): there the wall-clock gain is
within the run-to-run spread, and both engines are near the issue's 20 envelopes/s; the earlier figure
of 4–6 per second was taken under load. What
bounds it: a speed where the branch simply continues costs 3 ρ evaluations (the checks) and ~3.4
characteristic functions; ρ is a monodromy of 16 rows (one element, high speeds: build 13 µs, dgeev
21 µs) to 28 rows (two elements, low speeds: 28 + 57 µs), a characteristic function with its
derivatives 14–28 µs, so the checks are ~70 % of such a speed. Those ~170 of 200 speeds hold ~58 %
of the evaluations; the other ~30 (block starts, lobes that come down from above unannounced) hold 42 %,
each a bracketing on ρ plus Newton. Per call on top: the zero-order guesses (~8 ms CPU, independent of
the speed count) and the convergence check (~6 ms). Measured and not kept: the ρ checks on a coarser
discretisation (p = 4 while the roots use p = 6: at 8 216 rpm its crossing is 2 % off, the brackets
then disagree with Newton and the rescue costs more); a single check at 0.995 (−13 % CPU,
but it misses the island at 24 799 rpm: 93.1 mm instead of the 59.1 mm a 40-rung check finds).
Branch tracking also found a flip band the previous scheme missed: at 12 538 rpm (same case) the boundary
is a flip at 14.80 mm, not the Hopf crossing at 15.10 mm it reported (tests/test_spectral.py).
Identification (benchmarks/bench_spectral_identify.py: Example 1, a/D = 0.1, 40 SDM points, the same
global search; old and new run at the same time on the 2 cores): both recover every parameter within
0.1 % (max 0.096 %, RMS log residual 7.8e-4), but the new engine took 266 s for 5 884 envelope
evaluations against the old one's 158 s for 2 501: each evaluation is cheaper (45 against 63 ms), yet
the search takes 2.4 times as many steps on it; why is not known (the depths of the two agree within
0.07 % on 40 random sets of that search space). The issue's < 60 s is not reached by either. The
zero-order engine on the same points: 10.5 s, off by up to 83 % (the damping ratios; k 12–15 %).
Earlier measurements without gain: reusing the previous speed's Newton Jacobian, elements of one
natural period (3× faster in slotting, but 0.9 % off, too close to the 1 % target).

Lobe type and chatter frequency: the critical multiplier μ = e^{iθ} at the boundary; θ = π
(|arg μ| > π − FLIP_ARG) is a period-doubling (flip) boundary, otherwise Hopf. The chatter frequency
(±arg μ + 2πk)/T is taken nearest the most flexible mode's natural frequency, as in SDM; lobe =
floor(f_c T) (whole vibration waves per tooth period).

Units: rpm at the interface, depth in m (``depth_mm`` for mm), frequencies in Hz.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from threadpoolctl import threadpool_limits

from millstab.errors import InputError
from millstab.frf import ModalBatch
from millstab.model import Cutting, Structure
from millstab.stability import _spectral_kernel as _k
from millstab.stability import zoa
from millstab.stability.sdm import _arrays, _chatter_hz, _require_modal, _static_scale
from millstab.stability.base import Envelope, memory_chunk_rows
from millstab.stability.zoa import check_rpm

#: collocation nodes per element (degree of the polynomial) before the convergence check
P_NODES = 4
#: nodes added per refinement of the convergence check, and the most allowed
P_STEP = 2
P_MAX = 16
#: the longest element, in natural periods of the highest mode
ELEM_PERIODS = 0.5
#: relative depth change between p and p + P_STEP accepted as converged (the target is 1 %)
TOL = 1e-3
#: relative width of the final root bracket
RTOL = 2e-4
#: root-search ladders (multiples of the guess, ascending): first speed of a block, then continuation
LADDER = np.concatenate([np.arange(1, 25) * 0.05, [1.35, 1.5, 1.75, 2.0, 2.5, 3.0]])
LADDER_CONT = np.array([0.35, 0.7, 0.9, 0.98, 1.02, 1.1, 1.25, 1.5, 2.0, 3.0])
#: depths (multiples of a continued boundary point) where the full monodromy must be stable to accept it
CHECKS = np.array([0.7, 0.93, 0.995])
#: the shortest block of the root search (blocks run in parallel; within one, branches continue): a
#: block start costs a full ladder search, so a set is split only to keep the threads busy
BLOCK = 25
#: blocks per thread when the sets alone do not fill the threads (several, for load balance: the
#: low-speed blocks cost more)
BLOCKS_PER_THREAD = 2
#: a multiplier within this angle [rad] of the negative real axis marks a flip boundary
FLIP_ARG = 1e-3

__all__ = ["envelope", "envelope_batch", "envelope_batch_hz", "monodromy", "rho_map", "SpectralEnvelope", "P_NODES", "ELEM_PERIODS", "TOL"]


@dataclass(frozen=True, eq=False)
class SpectralEnvelope(Envelope):
    """:class:`~millstab.stability.zoa.Envelope` plus the lobe type and the critical multiplier.

    Attributes:
        kind: ``"hopf"``, ``"flip"`` or ``"none"`` (no boundary) per speed (S,).
        multiplier: the critical Floquet multiplier e^{iθ} at the boundary (S,) complex (NaN where none).
        nodes: collocation nodes per element the convergence check settled on.
    """

    kind: np.ndarray = None  # type: ignore[assignment]
    multiplier: np.ndarray = None  # type: ignore[assignment]
    nodes: int = P_NODES


def _w_flex(batch: ModalBatch) -> np.ndarray:
    """ωn [rad/s] of each set's most flexible mode (largest 1/(k ζ)): the chatter frequency is taken nearest it."""
    fn = np.concatenate([batch.fn_x, batch.fn_y], axis=1)
    kz = np.concatenate([batch.k_x * batch.zeta_x, batch.k_y * batch.zeta_y], axis=1)
    return np.ascontiguousarray(2 * math.pi * fn[np.arange(batch.size), np.argmin(kz, axis=1)])


def _cut_args(cutting: Cutting) -> tuple:
    return cutting.teeth, cutting.kt, cutting.kr, cutting.entry, cutting.exit


def _elem_len(wn: np.ndarray) -> np.ndarray:
    """Longest element [s] per set: ELEM_PERIODS natural periods of its highest mode."""
    return np.ascontiguousarray(ELEM_PERIODS * 2 * math.pi / wn.max(axis=1))


def _b_ref(batch: ModalBatch, cutting: Cutting, r: np.ndarray) -> np.ndarray:
    """Zero-order depths (B, S) [m] as the search's starting guess (a finite stand-in where it has none)."""
    b_ref = zoa.envelope_batch(batch, cutting, r)
    fallback = np.where(np.isfinite(b_ref), b_ref, np.nan)
    row_max = np.nanmax(np.where(np.isfinite(fallback), fallback, -np.inf), axis=1)
    row_max = np.where(np.isfinite(row_max), row_max, _static_scale(batch, cutting))
    return np.ascontiguousarray(np.where(np.isfinite(b_ref), b_ref, row_max[:, None]))


def _block_len(n_b: int, n_s: int) -> int:
    """Speeds per block: the whole range per set when the sets fill the threads (no restarts), else
    split into about BLOCKS_PER_THREAD blocks per thread, none shorter than BLOCK."""
    want = math.ceil(BLOCKS_PER_THREAD * numba.get_num_threads() / n_b)
    return max(BLOCK, math.ceil(n_s / max(want, 1))) if want > 1 else n_s


def _solve(batch: ModalBatch, cutting: Cutting, rs: np.ndarray, b_ref: np.ndarray, p: int,
           block: int | None = None) -> tuple[np.ndarray, ...]:
    """Depth, multiplier and evaluation counts (B, S) at ascending speeds rs with p nodes per element
    (speeds in blocks of ``block``, default :func:`_block_len`; branches continue within a block)."""
    wn, zeta, mass, act, mdir = _arrays(batch)
    n_b, n_s = batch.size, rs.size
    block = _block_len(n_b, n_s) if block is None else block
    starts = np.unique(np.concatenate([np.arange(0, n_s, block), [n_s]])).astype(np.int64)
    depth = np.empty((n_b, n_s))
    mu = np.empty((n_b, n_s), dtype=np.complex128)
    n_eval = np.empty((n_b, n_s), dtype=np.int64)
    n, kt, kr, ps, pe = _cut_args(cutting)
    with threadpool_limits(1):
        _k.limit_batch(n, kt, kr, ps, pe, rs, starts, b_ref, LADDER, LADDER_CONT, wn, zeta, mass, mdir, act,
                       _elem_len(wn), _k.gauss_nodes(int(p)), RTOL, _w_flex(batch), CHECKS, depth, mu, n_eval)
    if np.any(np.isnan(depth)):
        raise ArithmeticError("spectral engine: root search produced NaN")
    return depth, mu, n_eval


def _moved(batch: ModalBatch, cutting: Cutting, rs: np.ndarray, depth: np.ndarray, mu: np.ndarray,
           p: int) -> tuple[np.ndarray, np.ndarray]:
    """Set 0's boundary points (depth (S,) [m], multiplier (S,)) at speeds rs, moved by Newton to the
    discretisation with p nodes (NaN where Newton fails: not converged; inf stays inf)."""
    wn, zeta, mass, act, mdir = _arrays(batch)
    n, kt, kr, ps, pe = _cut_args(cutting)
    nd = _k.gauss_nodes(int(p))
    el = float(_elem_len(wn)[0])
    d_new = np.full(rs.size, np.nan)
    mu_new = np.full(rs.size, np.nan, dtype=np.complex128)
    for i in range(rs.size):  # a handful of check speeds, not a hot loop
        if not np.isfinite(depth[i]):
            d_new[i], mu_new[i] = depth[i], mu[i]
            continue
        b, th, ok, _ = _k.refine_at(n, kt, kr, ps, pe, float(rs[i]), float(depth[i]), float(abs(np.angle(mu[i]))),
                                    wn[0], zeta[0], mass[0], mdir, act, el, nd)
        if ok:
            d_new[i], mu_new[i] = b, complex(math.cos(th), math.sin(th))
    return d_new, mu_new


def _check_speeds(n_s: int) -> np.ndarray:
    """Indices of the convergence-check speeds: the lowest (longest elements), the middle and the highest."""
    return np.unique([0, n_s // 2, n_s - 1])


def _limit(batch: ModalBatch, cutting: Cutting, r: np.ndarray, nodes: int | None) -> tuple[np.ndarray, np.ndarray, int]:
    """Limiting depths (B, S) [m] and critical multipliers (B, S) at speeds r (any order); the nodes used.

    With ``nodes=None`` the convergence check runs first, on set 0 at the check speeds only: their
    boundary points are moved by Newton to p + P_STEP nodes; while one moves by more than TOL (or Newton
    fails), p grows by P_STEP. Then the whole batch is solved once with that p.
    """
    if nodes is not None and (isinstance(nodes, bool) or not isinstance(nodes, (int, np.integer)) or nodes < 2):
        raise InputError("nodes", nodes, "collocation nodes per element must be an integer >= 2 (or None)")
    # solved once per distinct speed, in increasing order (the continuation from speed to speed needs a
    # step > 0: repeated speeds made the kernel divide by zero), then put back in the caller's order
    rs, inv = np.unique(r, return_inverse=True)
    rs = np.ascontiguousarray(rs)
    b_ref = _b_ref(batch, cutting, rs)
    p = P_NODES if nodes is None else int(nodes)
    if nodes is None:
        p = _check_nodes(batch, cutting, rs, b_ref)
    depth, mu, _ = _solve(batch, cutting, rs, b_ref, p)
    return depth[:, inv], mu[:, inv], p


def _check_nodes(batch: ModalBatch, cutting: Cutting, rs: np.ndarray, b_ref: np.ndarray) -> int:
    """Collocation nodes per element from the convergence check on set 0 at the check speeds of the
    sorted distinct speeds ``rs`` (b_ref: zero-order guesses (B, S) [m]); see :func:`_limit`."""
    p = P_NODES
    idx = _check_speeds(rs.size)
    sub = ModalBatch(*(getattr(batch, f)[:1] for f in ("fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y")))
    # each check speed is its own block: they are far apart, continuation between them only fails
    d_c, mu_c, _ = (a[0] for a in _solve(sub, cutting, rs[idx], b_ref[:1, idx], p, block=1))
    while p < P_MAX:
        d_n, mu_n = _moved(sub, cutting, rs[idx], d_c, mu_c, p + P_STEP)
        with np.errstate(invalid="ignore"):
            moved = np.where(np.isinf(d_c) & np.isinf(d_n), 0.0, d_n / d_c - 1)
        if np.all(np.abs(moved) <= TOL):
            break
        p += P_STEP
        if np.all(np.isfinite(moved)):
            # the moved points are the boundary at p nodes: the next check starts from them (a
            # root search per check speed saved)
            d_c, mu_c = d_n, mu_n
        else:  # Newton failed somewhere: search afresh at p nodes
            d_c, mu_c, _ = (a[0] for a in _solve(sub, cutting, rs[idx], b_ref[:1, idx], p, block=1))
    return p


def split_settings(batch: ModalBatch, cutting: Cutting, rpm) -> dict:
    """Keyword arguments of :func:`envelope_batch` (and ``_hz``) under which any part of ``batch`` gives,
    row for row, the numbers of the whole batch's call: the nodes come from a convergence check on the
    batch's first set, so a part must be given the whole's (used to split a batch over a Dask cluster).
    Costs the check (one set at a few speeds)."""
    rs = np.ascontiguousarray(np.unique(check_rpm(rpm)))
    first = ModalBatch(*(getattr(batch, f)[:1] for f in ("fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y")))
    return {"nodes": _check_nodes(first, cutting, rs, _b_ref(first, cutting, rs))}


def lobe_kind(mu: np.ndarray) -> np.ndarray:
    """``"flip"`` for a multiplier on the negative real axis, ``"hopf"`` otherwise, ``"none"`` if NaN."""
    mu = np.asarray(mu)
    flip = np.abs(np.angle(mu)) > math.pi - FLIP_ARG
    return np.where(~np.isfinite(mu), "none", np.where(flip, "flip", "hopf"))


def envelope(structure: Structure, cutting: Cutting, rpm, nodes: int | None = None) -> SpectralEnvelope:
    """The limiting depth b_lim [m] at each spindle speed [rpm] for one modal structure.

    ``inf`` where no boundary exists up to 1e4 times the reference depth. ``nodes``: collocation
    nodes per element (None: chosen by the convergence check, see the module docstring).

    Raises:
        InputError: for a measured-FRF structure (the time-domain engines need modal parameters).
    """
    _require_modal(structure)
    r = check_rpm(rpm)
    depth, mu, p = _limit(ModalBatch.from_structures([structure]), cutting, r, nodes)
    flex = max(structure.modes, key=lambda m: 1.0 / (m.k * m.zeta))
    T = 60.0 / (cutting.teeth * r)
    ok = np.isfinite(depth[0])
    hz = np.where(ok, _chatter_hz(mu[0], T, flex.fn), np.nan)
    lobe = np.where(ok, np.floor(np.nan_to_num(hz) * T), -1).astype(np.int64)
    kind = np.where(ok, lobe_kind(mu[0]), "none")
    return SpectralEnvelope(r, depth[0], lobe, hz, kind=kind, multiplier=mu[0], nodes=p)


def envelope_batch(batch: ModalBatch, cutting: Cutting, rpm, nodes: int | None = None) -> np.ndarray:
    """Limiting depths (B, S) [m] for B modal parameter sets at S spindle speeds [rpm]."""
    r = check_rpm(rpm)
    return _limit(batch, cutting, r, nodes)[0]


def envelope_batch_hz(batch: ModalBatch, cutting: Cutting, rpm, nodes: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Limiting depths (B, S) [m] and chatter frequencies (B, S) [Hz] for B modal parameter sets at S
    spindle speeds [rpm]: the critical multiplier's frequency nearest each set's most flexible mode
    (largest 1/(kζ), x before y on a tie), as :func:`envelope` reports for one structure; NaN where
    no boundary exists."""
    r = check_rpm(rpm)
    depth, mu, _ = _limit(batch, cutting, r, nodes)
    k = np.concatenate([batch.k_x, batch.k_y], axis=1)
    fn = np.concatenate([batch.fn_x, batch.fn_y], axis=1)
    zeta = np.concatenate([batch.zeta_x, batch.zeta_y], axis=1)
    flex = np.argmax(1.0 / (k * zeta), axis=1)
    f_ref = fn[np.arange(batch.size), flex][:, None]
    hz = np.where(np.isfinite(depth), _chatter_hz(mu, 60.0 / (cutting.teeth * r), f_ref), np.nan)
    return depth, hz


def monodromy(structure: Structure, cutting: Cutting, rpm: float, depth_m: float, nodes: int = P_NODES) -> np.ndarray:
    """The monodromy matrix over one tooth period at one speed [rpm] and depth [m]; its eigenvalues
    are the Floquet multipliers (the cut is stable when all have modulus < 1)."""
    _require_modal(structure)
    wn, zeta, mass, act, mdir = _arrays(ModalBatch.from_structures([structure]))
    r = float(check_rpm([rpm])[0])
    n, kt, kr, ps, pe = _cut_args(cutting)
    x, Dm, lend = _k.gauss_nodes(int(nodes))
    g = _k.setup(n, kr, ps, pe, r, float(_elem_len(wn)[0]), x, wn[0], zeta[0], act)
    return _k.monodromy(float(depth_m), kt, wn[0], zeta[0], mass[0], mdir, act.size, g[0], g[1], g[2], g[3], g[4], Dm,
                        lend)


def rho_map(structure: Structure, cutting: Cutting, rpm, depth_m, nodes: int = P_NODES) -> np.ndarray:
    """Spectral radius ρ of the monodromy matrix on a speed × depth grid, shape (S, D) (depths in m)."""
    r = check_rpm(rpm)
    d = np.atleast_1d(np.asarray(depth_m, dtype=float))
    if d.ndim != 1 or not np.all(np.isfinite(d)) or np.any(d < 0):
        raise InputError("depth_m", depth_m, "depths must be a 1-D list of finite values >= 0 m")
    out = np.empty((r.size, d.size))
    with threadpool_limits(1):
        for i, s in enumerate(r):  # a diagnostic, not a hot path
            for j, b in enumerate(d):
                out[i, j] = np.max(np.abs(np.linalg.eigvals(monodromy(structure, cutting, s, b, nodes))))
    return out


# -- the engine contract (millstab.stability.base.Engine) -----------------------------------------
name = "spectral"
#: the time-domain model keeps the time-varying forces, so the zero-order x↔y exchange is not exact
exact_xy_exchange = False
#: modal structures only (the state-space model needs fn, k, ζ per mode)
accepts_measured_frf = False
#: ``kind`` per speed: hopf / flip / none
reports_lobe_type = True
reports_progress = False
cheap = True
#: :func:`envelope_batch_hz` gives the critical multiplier's frequency beside the depth
reports_chatter_frequency = True
time_averaged = False
#: relative accuracy of a limiting depth (the final root bracket; the node count converges to TOL)
depth_accuracy = RTOL
#: sets per call for callers that stream many sets: as large as the zero-order engine's, because each
#: call runs the node-count convergence check once (on its first set), so fewer calls cost less and
#: give every set the same node count
CALL_ROWS = 16_384


def chunk_rows(n_speeds: int) -> int:
    """Parameter sets per ``envelope_batch`` call for ``n_speeds`` speeds (≤ CALL_ROWS, bounded memory)."""
    return memory_chunk_rows(n_speeds, CALL_ROWS)


import sys as _sys  # noqa: E402

from millstab.stability import register as _register  # noqa: E402

_register(_sys.modules[__name__])
