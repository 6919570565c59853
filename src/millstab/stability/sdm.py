"""Semi-discretization (Insperger & Stépán): time-domain stability of the milling model.

Same interface as :mod:`millstab.stability.zoa` (``envelope``, ``envelope_batch``), plus the ρ map.
Modal structures only: every mode is a 1-DOF oscillator in x (feed) or y (cross-feed), the tool-tip
displacement in a direction is the sum of its modal coordinates; a direction without modes is rigid.

Force model (Altintas' notation, the one whose tooth-period average is the zero-order matrix):

    F(t) = ½ b Kt [A(t)] Δ(t),   Δ = u(t) − u(t − T),   u = (x, y),   T = 60 / (N Ω),
    mean over a tooth period of [A(t)] = (N / 2π) [α],   [α] = :func:`zoa.directional_matrix`,

with the screen function g(φ) = 1 for φst ≤ φ ≤ φex (Cutting.entry / Cutting.exit, φ measured from
+y), N equally spaced straight teeth. See :mod:`millstab.stability._sdm_kernel` for the equations.

Discretization. First-order semi-discretization: on each step the periodic matrix is replaced by its
exact average over the step, the delayed displacement by the straight line between grid nodes, and
the resulting linear ODE is solved exactly (matrix functions e^{Ah}, ∫e^{A(h−s)}ds, ∫e^{A(h−s)}s ds
in closed form for one mode, by eigendecomposition otherwise). The grid is aligned with the tooth
entry/exit instants, so no step straddles a jump of g(φ), and a stretch with no tooth in the cut is a
single exact step (free vibration). Unused history nodes are dropped, so the monodromy matrix of a
low-immersion cut is small.

Step size (accuracy control). The error of the scheme is O(h²), governed by the step measured in
natural periods of the highest mode (40 steps per tooth period is only ~7 per natural period at
5 000 rpm in the classic benchmark: ≈ 8 % error in depth). With ``steps=None`` (the default) the base
grid has

    steps per tooth period = max(STEPS_MIN, ceil(STEPS_PER_NATURAL_PERIOD · fn_max · T))   (20, 12)

and every ρ is evaluated on that grid and on the grid with every step halved, and the Floquet
multipliers are Richardson-extrapolated one by one, μ = (4 μ_fine − μ_coarse)/3, each fine multiplier
paired with the nearest coarse one (only the 8 largest). Extrapolating per multiplier, not ρ or the
depth, matters: where a flip and a Hopf multiplier compete for the largest modulus the dominant one
can differ between the two grids (seen at 5 500 rpm in slotting). Measured on the benchmark (81
speeds 5 000–25 000 rpm, slotting and a/D = 0.05, against a Richardson extrapolation of 200 and 400
uniform steps): max error 0.23 % (slotting) and 0.11 % (a/D = 0.05); 40 fixed steps: 5.7 % at a/D =
0.05 and, in slotting at 18 750 rpm, a thin unstable band is missed altogether. An explicit ``steps``
(per tooth period) uses that one grid without extrapolation, e.g. the customary 40.

Root search for the limiting depth at each speed (compiled, parallel over speeds). ρ(0) = max
e^{−ζ ωn T} < 1. ρ is evaluated on the depths b_ref · FACTORS (b_ref = the zero-order limiting depth
at that speed, or a static scale where the zero-order method finds no boundary), ascending, stopping
at the first unstable depth; beyond the last factor the depth grows geometrically (×1.5) up to
1e4 · b_ref (then ``inf``: no boundary). With the default steps ρ is the extrapolated one throughout,
so a thin band that only the converged solution has is seen too. The bracket [last stable, first unstable]
is refined by the Illinois method on ρ − 1 to a relative width of ``RTOL``. ρ(b) is not monotone: the answer is the
first crossing from 0 upward provided no unstable band is thinner than the bracket grid spacing
(0.05 · b_ref); flip lobes at low immersion, where the zero-order depth is several times too high,
are wide bands on that scale and are found.

Chatter frequency: the dominant multiplier μ = |μ| e^{iθ} at the boundary fixes the chatter
frequency only modulo the tooth-passing frequency, ω = (±θ + 2πk)/T; ``envelope`` reports the
candidate nearest the natural frequency of the most flexible mode (largest 1/(k ζ)), and lobe = −1.
A multiplier μ ≈ −1 is a period-doubling (flip) boundary, complex μ a Hopf boundary.

Interruptible, with progress. A compiled call cannot be interrupted (Ctrl-C waits for it), so the
speeds (× structures) are run in chunks from Python: each chunk is sized from the rate of the one
before to take about ``CHUNK_SECONDS`` (a multiple of the thread count, growing at most 4× per chunk),
and between chunks KeyboardInterrupt is seen and ``progress(stage, done, total)`` is called (an
exception it raises stops the run). Every (structure, speed) pair is computed alone, so the chunking
changes no bit of the result.

Process damping (``Cutting.process_damping`` C > 0, :mod:`millstab.stability.process_damping`): each
tooth in the cut adds −(C b / V)(n·u̇) n; its exact step average enters every cutting step's
current-state matrix next to the cutting force's, so the term is carried instantaneously per tooth
with the scheme's own accuracy (four-tooth slotting, where the model is a constant-coefficient delay
equation: within 3.4e-4 of its closed form). The monodromy matrix is rebuilt at every depth anyway
(the cutting force is ∝ b); the reference depth is the zero-order one without the term, and the
bracket grid goes on in 10 % steps to ~30 b_ref (``FACTORS_PD``) since the low-speed limits rise to
many times it. Measured cost (benchmarks/bench_sdm.py --process-damping): ×1.16 CPU time.

Units: rpm at the interface, depth in m (``Envelope.depth_mm`` for mm), frequencies in Hz.
"""

from __future__ import annotations

import math
import time
from typing import Callable

import numba as nb
import numpy as np
from threadpoolctl import threadpool_limits

from millstab.errors import InputError
from millstab.frf import ModalBatch
from millstab.model import Cutting, Structure
from millstab.progress import Progress, cancel_point
from millstab.stability import _sdm_kernel as _k
from millstab.stability import zoa
from millstab.stability.base import Envelope, memory_chunk_rows
from millstab.stability.base import by_condition, check_kr, check_process_damping, check_rpm, kr_sets

#: smallest number of steps per tooth period for the accuracy-controlled default
STEPS_MIN = 20
#: steps per natural period of the highest mode for the accuracy-controlled default
STEPS_PER_NATURAL_PERIOD = 12.0
#: relative width of the final root bracket
RTOL = 1e-4
#: bracket grid of the root search, in units of the reference depth (ascending)
FACTORS = np.concatenate([np.arange(1, 25) * 0.05, [1.35, 1.5, 1.75, 2.0, 2.5, 3.0]])
#: the bracket grid with process damping: the reference depth is the zero-order one without it, and
#: process damping lifts the low-speed limits to many times that, so the grid goes on in steps of 10 %
#: to ~30 b_ref before the geometric ×1.5 growth (a band of instability is only missed when thinner
#: than the step it falls in)
FACTORS_PD = np.concatenate([FACTORS, 3.0 * 1.1 ** np.arange(1, 25)])
#: target wall time of one compiled call [s]: Ctrl-C and the progress callback are seen between calls;
#: None runs everything in one call
CHUNK_SECONDS: float | None = 0.25



def _chunked(run: Callable[[int, int], None], total: int, stage: str, progress: Progress | None) -> None:
    """Call ``run(first, last)`` over the tasks 0..total-1 in chunks of about CHUNK_SECONDS each; the thread's
    cancel point (:func:`millstab.progress.cancel_point`) is checked between chunks.

    The first chunk has one task per thread; each next one as many as the previous chunk's rate gives
    for CHUNK_SECONDS (a multiple of the thread count, at most 4× the previous, so a run whose tasks
    grow dearer stays responsive).
    """
    threads = max(1, nb.get_num_threads())
    done, size = 0, threads if CHUNK_SECONDS is not None else total
    if progress is not None:
        progress(stage, 0, total)
    while done < total:
        last = min(total, done + size)
        t0 = time.perf_counter()
        run(done, last)
        elapsed = time.perf_counter() - t0
        n, done = last - done, last
        if progress is not None:
            progress(stage, done, total)
        if done < total:  # a caller without progress (a map, the likelihood) is cancelled here too
            cancel_point()
        if CHUNK_SECONDS is not None:
            fit = int(n * CHUNK_SECONDS / max(elapsed, 1e-9)) // threads * threads
            size = max(threads, min(4 * n, fit))

__all__ = ["envelope", "envelope_batch", "rho_map", "monodromy", "critical_multipliers", "default_steps",
           "step_matrices", "STEPS_MIN", "STEPS_PER_NATURAL_PERIOD"]


def _require_modal(structure: Structure) -> None:
    if not structure.is_modal:
        raise InputError("structure", "measured FRF",
                         "the semi-discretization engine needs modal parameters (fn, k, zeta per mode); "
                         "use the zero-order engine (engine 'zoa') for a measured FRF")


def _layout(n_x: int, n_y: int) -> tuple[np.ndarray, np.ndarray]:
    """Active directions (0 = x, 1 = y, only those with modes) and each mode's index into them."""
    act = [d for d, n in ((0, n_x), (1, n_y)) if n > 0]
    mdir = [0] * n_x + [act.index(1)] * n_y if n_y else [0] * n_x
    return np.array(act, dtype=np.int64), np.array(mdir, dtype=np.int64)


def _arrays(batch: ModalBatch) -> tuple[np.ndarray, ...]:
    """wn [rad/s], zeta, mass [kg] (B, M) with x modes first, plus act and mdir."""
    fn = np.concatenate([batch.fn_x, batch.fn_y], axis=1)
    k = np.concatenate([batch.k_x, batch.k_y], axis=1)
    zeta = np.ascontiguousarray(np.concatenate([batch.zeta_x, batch.zeta_y], axis=1))
    wn = np.ascontiguousarray(2 * math.pi * fn)
    mass = np.ascontiguousarray(k / wn**2)
    act, mdir = _layout(batch.fn_x.shape[1], batch.fn_y.shape[1])
    return wn, zeta, mass, act, mdir


def default_steps(fn_max_hz: float, cutting: Cutting, rpm) -> np.ndarray:
    """Accuracy-controlled steps per tooth period at each speed (see the module docstring)."""
    r = check_rpm(rpm)
    T = 60.0 / (cutting.teeth * r)
    return np.maximum(STEPS_MIN, np.ceil(STEPS_PER_NATURAL_PERIOD * fn_max_hz * T)).astype(np.int64)


def _steps(steps, fn_max_hz: float, cutting: Cutting, r: np.ndarray) -> np.ndarray:
    if steps is None:
        return default_steps(fn_max_hz, cutting, r)
    st = np.broadcast_to(np.asarray(steps), r.shape)
    if not np.all(np.isfinite(st.astype(float))) or np.any(st < 1) or np.any(st != np.round(st)):
        raise InputError("steps", steps, "steps per tooth period must be a positive integer (or None)")
    return np.ascontiguousarray(st, dtype=np.int64)


def _cut_args(cutting: Cutting) -> tuple:
    return cutting.teeth, cutting.kt, cutting.kr, cutting.entry, cutting.exit


def step_matrices(cutting: Cutting, rpm: float, steps: int,
                  contact: bool = False) -> tuple[np.ndarray, ...]:
    """The step grid of one tooth period as the engine uses it (tooth 0 enters at t = 0).

    Returns the step lengths h (m,) [s], whether a tooth cuts in each step (m,), and the step
    averages of the directional matrix [A(t)] (m, 2, 2) [-]; with ``contact`` also the step averages
    of Σ_teeth g n nᵀ (m, 2, 2) [-], the directions of the process damping.
    """
    r = float(check_rpm([rpm])[0])
    T = 60.0 / (cutting.teeth * r)
    n, _, kr, ps, pe = _cut_args(cutting)
    grid = _k.period_grid(n, kr, ps, pe, r, T / int(steps), 1)
    return grid if contact else grid[:3]


def monodromy(structure: Structure, cutting: Cutting, rpm: float, depth_m: float,
              steps: int | None = None) -> np.ndarray:
    """The (reduced) monodromy matrix over one tooth period at one speed [rpm] and depth [m].

    Its eigenvalues are the Floquet multipliers (apart from zero multipliers of dropped history
    nodes); the cut is stable when all have modulus < 1.
    """
    _require_modal(structure)
    batch = ModalBatch.from_structures([structure])
    wn, zeta, mass, act, mdir = _arrays(batch)
    r = check_rpm([rpm])
    st = _steps(steps, float(np.max(wn) / (2 * math.pi)), cutting, r)
    n, kt, kr, ps, pe = _cut_args(cutting)
    h, cut, abar_d, phi_free, hpos, n_used, pbar_d = _k._setup(n, kr, ps, pe, float(r[0]), int(st[0]), 1, wn[0],
                                                               zeta[0], act)
    cpd = float(cutting.process_damping_per_depth(r)[0]) * float(depth_m)
    return _k.monodromy(float(depth_m), kt, wn[0], zeta[0], mass[0], mdir, act.size, h, cut, abar_d, phi_free,
                        hpos, n_used, cpd, pbar_d)


def rho_map(structure: Structure, cutting: Cutting, rpm, depth_m, steps: int | None = None,
            progress: Progress | None = None) -> np.ndarray:
    """Spectral radius ρ of the monodromy matrix on a speed × depth grid, shape (S, D).

    Args:
        rpm: spindle speeds (S,) [rev/min]; depth_m: axial depths (D,) [m], ≥ 0;
        steps: steps per tooth period (int), or None for the accuracy-controlled default;
        progress: ``progress(stage, done, total)`` in speeds, see the module docstring.

    The default's accuracy control is set for the boundary (ρ = 1, where the limits are read); far inside a band
    ρ can be off by a few %: Example 1 at a/D 0.05 down, 12 500 rpm, 145 mm gives 0.912 against 0.953 at 400
    steps (and the spectral engine's converged value). Pass a fixed ``steps`` for ρ values deep inside a band.
    """
    _require_modal(structure)
    r = check_rpm(rpm)
    d = np.atleast_1d(np.asarray(depth_m, dtype=float))
    if d.ndim != 1 or not np.all(np.isfinite(d)) or np.any(d < 0):
        raise InputError("depth_m", depth_m, "depths must be a 1-D list of finite values >= 0 m")
    wn, zeta, mass, act, mdir = _arrays(ModalBatch.from_structures([structure]))
    st = _steps(steps, float(np.max(wn) / (2 * math.pi)), cutting, r)
    out = np.empty((r.size, d.size))
    n, kt, kr, ps, pe = _cut_args(cutting)
    d = np.ascontiguousarray(d)
    cv = np.ascontiguousarray(cutting.process_damping_per_depth(r))

    def run(first: int, last: int) -> None:
        _k.rho_grid(n, kt, kr, ps, pe, r, st, steps is None, d, wn[0], zeta[0], mass[0], mdir, act, first, last, out,
                    cv)

    with threadpool_limits(1):
        _chunked(run, r.size, "sdm: spectral radius map", progress)
    if not np.all(np.isfinite(out)):
        raise ArithmeticError("semi-discretization: eigenvalue solver failed (non-finite spectral radius)")
    return out


def _static_scale(batch: ModalBatch, cutting: Cutting) -> np.ndarray:
    """A depth scale [m] per set where the zero-order method has no boundary: 8 k ζ / (N Kt)."""
    kz = np.concatenate([batch.k_x * batch.zeta_x, batch.k_y * batch.zeta_y], axis=1)
    return 8.0 * kz.min(axis=1) / (cutting.teeth * cutting.kt)


def _limit(batch: ModalBatch, cutting: Cutting, r: np.ndarray, steps,
           progress: Progress | None = None, fn_max_hz: float | None = None,
           kr=None, process_damping=None) -> tuple[np.ndarray, np.ndarray]:
    """Limiting depths (B, S) [m] and dominant multipliers (B, S) at the boundary; the default steps
    follow ``fn_max_hz`` [Hz] (default: the batch's highest natural frequency, :func:`split_settings`); ``kr`` (B,)
    or None: each set's Kr; ``process_damping`` (B,) [N/m] or None: each set's C (:func:`envelope_batch`)."""
    wn, zeta, mass, act, mdir = _arrays(batch)
    st = _steps(steps, _fn_max_hz(wn) if fn_max_hz is None else float(fn_max_hz), cutting, r)
    kr = check_kr(kr, batch.size)
    cv = _per_depth(cutting, check_process_damping(process_damping, batch.size), batch.size, r)
    # the reference depth is the zero-order one without process damping (that model has none)
    b_ref = zoa.envelope_batch(batch, cutting.without_process_damping(), r, kr=kr)
    fallback = np.where(np.isfinite(b_ref), b_ref, np.nan)
    # where the zero-order method finds no boundary, take the largest finite one of that set (or a static scale)
    row_max = np.nanmax(np.where(np.isfinite(fallback), fallback, -np.inf), axis=1)
    row_max = np.where(np.isfinite(row_max), row_max, _static_scale(batch, cutting))
    b_ref = np.ascontiguousarray(np.where(np.isfinite(b_ref), b_ref, row_max[:, None]))
    n_b, n_s = batch.size, r.size
    depth = np.empty((n_b, n_s))
    mu = np.empty((n_b, n_s), dtype=np.complex128)
    n_eval = np.empty((n_b, n_s), dtype=np.int64)
    n, kt, _, ps, pe = _cut_args(cutting)
    krs = kr_sets(cutting, kr, n_b)
    factors = FACTORS_PD if (cv > 0).any() else FACTORS

    def run(first: int, last: int) -> None:
        _k.limit_batch(n, kt, krs, ps, pe, r, st, steps is None, b_ref, factors, wn, zeta, mass, mdir, act, RTOL,
                       first, last, depth, mu, n_eval, cv)

    with threadpool_limits(1):
        _chunked(run, n_b * n_s, "sdm: limiting depths", progress)
    if np.any(np.isnan(depth)):
        raise ArithmeticError("semi-discretization: root search produced NaN")
    return depth, mu


def _per_depth(cutting: Cutting, pd: np.ndarray | None, n_sets: int, r: np.ndarray) -> np.ndarray:
    """C / V [N·s/m²] of each set at each speed (B, S): the cutting's own C (zeros for none), or each set's C ``pd``
    (B,) [N/m] at the cutting's tool diameter (InputError where a C > 0 has no diameter to give the speed V)."""
    if pd is None:
        # a writable copy: a read-only one (one set, one speed) would compile the kernel for another signature
        return np.array(np.broadcast_to(cutting.process_damping_per_depth(r), (n_sets, r.size)))
    if not (pd > 0).any():
        return np.zeros((n_sets, r.size))
    if not (cutting.diameter or 0) > 0:
        raise InputError("cutting.diameter", cutting.diameter, "a tool diameter [m] > 0: the process damping C / V "
                                                               "needs the cutting speed V = π D Ω / 60")
    # the same division as Cutting.process_damping_per_depth (the same bits as a Cutting of that C; C = 0 gives 0)
    speed = math.pi * float(cutting.diameter) * r / 60.0
    return np.ascontiguousarray(pd[:, None] / speed[None, :])


def _chatter_hz(mu: np.ndarray, T: np.ndarray, f_ref: float) -> np.ndarray:
    """Frequency [Hz] of the multiplier's candidates (±θ + 2πk)/T nearest f_ref [Hz]."""
    theta = np.abs(np.angle(mu))
    w_ref = 2 * math.pi * f_ref
    best = np.full(mu.shape, np.nan)
    for sign in (1.0, -1.0):
        k = np.round((w_ref * T - sign * theta) / (2 * math.pi))
        w = (sign * theta + 2 * math.pi * k) / T
        w = np.where(w < 0, w + 2 * math.pi / T, w)
        better = np.isnan(best) | (np.abs(w - w_ref) < np.abs(best - w_ref))
        best = np.where(better, w, best)
    return np.where(np.isfinite(mu), best / (2 * math.pi), np.nan)


def envelope(structure: Structure, cutting: Cutting, rpm, steps: int | None = None,
             progress: Progress | None = None, fn_max_hz: float | None = None) -> Envelope:
    """The limiting depth b_lim [m] at each spindle speed [rpm] for one modal structure.

    ``inf`` where no boundary exists up to 1e4 times the reference depth. ``chatter_hz`` is the
    dominant multiplier's frequency nearest the most flexible mode (see module docstring); lobe = −1.
    ``progress(stage, done, total)`` is called between chunks of speeds (an exception it raises
    stops the run). ``fn_max_hz`` [Hz]: the default accuracy control as if the highest natural frequency were
    this (:func:`envelope_batch`; 1: 20 and 40 steps per tooth period at every speed, extrapolated).

    Raises:
        InputError: for a measured-FRF structure (semi-discretization needs modal parameters).
    """
    _require_modal(structure)
    r = check_rpm(rpm)
    batch = ModalBatch.from_structures([structure])
    depth, mu = _limit(batch, cutting, r, steps, progress, fn_max_hz)
    flex = max(structure.modes, key=lambda m: 1.0 / (m.k * m.zeta))
    T = 60.0 / (cutting.teeth * r)
    hz = np.where(np.isfinite(depth[0]), _chatter_hz(mu[0], T, flex.fn), np.nan)
    return Envelope(r, depth[0], np.full(r.size, -1, dtype=np.int64), hz)


def critical_multipliers(structure: Structure, cutting: Cutting, rpm, steps: int | None = None,
                         progress: Progress | None = None) -> np.ndarray:
    """The dominant Floquet multiplier at the limiting depth (just on the unstable side), (S,) complex.

    |μ| ≈ 1; μ ≈ −1 marks a period-doubling (flip) boundary, a complex pair a Hopf boundary.
    """
    _require_modal(structure)
    r = check_rpm(rpm)
    return _limit(ModalBatch.from_structures([structure]), cutting, r, steps, progress)[1][0]


@by_condition
def envelope_batch(batch: ModalBatch, cutting: Cutting, rpm, steps: int | None = None,
                   progress: Progress | None = None, fn_max_hz: float | None = None, kr=None,
                   process_damping=None) -> np.ndarray:
    """Limiting depths (B, S) [m] for B modal parameter sets at S spindle speeds [rpm];
    ``progress(stage, done, total)`` counts (structure, speed) pairs; ``fn_max_hz``: see :func:`split_settings`.
    ``kr`` (B,) (None: the cutting's): each set's radial-to-tangential ratio, overriding the cutting's Kr (the
    ``per_set_kr`` capability: a sampler that learns Kr); each (set, speed) builds its step matrices anyway, so the
    depths are those of one call per set with its own Kr, bit for bit. ``process_damping`` (B,) [N/m] (None: the
    cutting's): each set's process-damping coefficient C at the cutting's tool diameter (the
    ``per_set_process_damping`` capability: a sampler that learns C); the same depths as one call per set with a
    Cutting of that C, bit for bit (where every set has a C > 0, or none has)."""
    r = check_rpm(rpm)
    return _limit(batch, cutting, r, steps, progress, fn_max_hz, kr, process_damping)[0]


def _fn_max_hz(wn: np.ndarray) -> float:
    return float(np.max(wn) / (2 * math.pi))


@by_condition
def split_settings(batch: ModalBatch, cutting: Cutting, rpm) -> dict:
    """Keyword arguments of :func:`envelope_batch` under which any part of ``batch`` gives, row for row,
    the numbers of the whole batch's call: the default steps per period follow the batch's highest
    natural frequency, so a part must be told the whole's (used to split a batch over a Dask cluster)."""
    return {"fn_max_hz": _fn_max_hz(_arrays(batch)[0])}


# -- the engine contract (millstab.stability.base.Engine) -----------------------------------------
name = "sdm"
#: the time-domain model keeps the time-varying forces, so the zero-order x↔y exchange is not exact
exact_xy_exchange = False
#: modal structures only (the state-space model needs fn, k, ζ per mode)
accepts_measured_frf = False
#: flip and Hopf boundaries are both found, but not told apart
reports_lobe_type = False
#: optional capability: :func:`critical_multipliers` (millstab.stability.base.Engine)
reports_multipliers = True
#: carries process damping (Cutting.process_damping), instantaneous per tooth, rebuilt per depth
process_damping = True
reports_progress = True
cheap = False
#: ``envelope_batch(..., kr=(B,))``: each (set, speed)'s step matrices are built in the kernel anyway
per_set_kr = True
#: ``envelope_batch(..., process_damping=(B,))``: the kernel reads each (set, speed)'s C / V
per_set_process_damping = True
#: the batched path returns depths only (``envelope`` reports the chatter frequency of one structure)
reports_chatter_frequency = False
time_averaged = False
#: relative accuracy of a limiting depth (discretisation and root bracket)
depth_accuracy = 1e-4
#: sets per call for callers that stream many sets: small, since each set costs ms per speed, so a
#: caller's progress and cancellation are seen often
CALL_ROWS = 256


def chunk_rows(n_speeds: int) -> int:
    """Parameter sets per ``envelope_batch`` call for ``n_speeds`` speeds (≤ CALL_ROWS, bounded memory)."""
    return memory_chunk_rows(n_speeds, CALL_ROWS)


import sys as _sys  # noqa: E402

from millstab.stability import register as _register  # noqa: E402

_register(_sys.modules[__name__])
