"""Zero-order (Altintas–Budak) stability: directional coefficients, lobes and the lower envelope.

The milling forces are averaged over the tooth period into the constant directional matrix
[A0] = (N/2π)[α]. With ν an eigenvalue of [α][G(iω)], the chatter boundary (Altintas 2012, ch. 3) is

    b_lim(ω) = 2π / (N Kt Re ν(ω))      (Re ν > 0),   ε = π + 2 arg ν,   Ω = 60 ω / (N (ε + 2kπ)).

:func:`envelope` and :func:`envelope_batch` return the lower envelope at arbitrary spindle speeds,
each value the exact (root-found) minimum over all lobes k and both eigenvalue branches; see
:mod:`millstab.stability._zoa_kernel` for the algorithm. :func:`lobes` returns the raw lobes for plots.

Units: spindle speed in rpm, depth in m (``depth_mm`` for mm), chatter frequency in Hz.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterator

import numpy as np

from millstab.frf import ModalBatch, structure_receptance  # noqa: F401  (re-exported for tests)
from millstab.model import Conditions, Cutting, Structure
from millstab.stability import _zoa_kernel as _k
from millstab.stability.base import Envelope  # noqa: F401  (moved to the contract; re-exported)
# shared helpers of the contract, re-exported where they used to live
from millstab.stability.base import check_ceiling, check_kr, check_rpm, directional_matrix  # noqa: F401
from millstab.stability.process_damping import reject as reject_process_damping

#: log-spaced background points of the per-set frequency grid (mode clusters come on top)
N_BASE = 160
_OFFSETS = _k.cluster_offsets()
#: outputs (sets × speeds) per chunk of the batched engine: depth, lobe and chatter frequency take
#: 24 bytes each, so a chunk holds at most ~100 MB whatever the number of speeds
CHUNK_CELLS = 4_000_000
#: the most parameter sets per chunk (larger chunks amortise the per-call overhead; ~5 % faster than 4096)
CHUNK = 16_384


_NO_STATS = np.zeros(0, dtype=np.int64)
_NO_MODES = np.zeros((2, 3, 0))
_NO_STATS_2D = np.zeros((0, _k.N_STATS), dtype=np.int64)
_NO_CEILING = np.zeros(0)
_NO_CEILING_2D = np.zeros((0, 0))


def chunk_rows(n_speeds: int) -> int:
    """Parameter sets per chunk for ``n_speeds`` speeds: ≤ CHUNK and ≤ CHUNK_CELLS / n_speeds."""
    return max(64, min(CHUNK, CHUNK_CELLS // max(n_speeds, 1)))


@dataclass(frozen=True, eq=False)
class Lobe:
    """One raw lobe (one branch, one k) for plotting: speed and depth along the chatter frequency."""

    k: int
    branch: int
    rpm: np.ndarray
    depth: np.ndarray
    chatter_hz: np.ndarray


def _sorted(rpm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    order = np.argsort(rpm, kind="stable")
    return np.ascontiguousarray(rpm[order]), order


def envelope(structure: Structure, cutting: Cutting, rpm) -> Envelope:
    """The limiting depth b_lim at each spindle speed for one structure (modal or measured FRF).

    Args:
        structure: tool-tip dynamics; a measured FRF uses its full 2×2 matrix when cross terms exist.
        cutting: cutting conditions.
        rpm: spindle speeds [rev/min], any order.
    """
    reject_process_damping(cutting, name)
    r = check_rpm(rpm)
    if structure.is_modal:
        batch = ModalBatch.from_structures([structure])
        depth, lobe, wc = _run_modal(batch, cutting, r)
        return Envelope(r, depth[0], lobe[0], wc[0] / (2 * math.pi))
    rs, order = _sorted(r)
    frf = structure.frf
    w = 2 * math.pi * frf.freq_hz
    g = frf.matrix()
    G = np.ascontiguousarray(np.stack([g[:, 0, 0], g[:, 0, 1], g[:, 1, 0], g[:, 1, 1]]))
    a = _k.directional_brackets(cutting.kr, cutting.entry, cutting.exit)
    n_s = rs.size
    depth, lobe, wc = np.empty(n_s), np.empty(n_s, dtype=np.int64), np.empty(n_s)
    _k.envelope_on_grid(w, G, a, cutting.teeth, cutting.kt, rs, _NO_MODES, True, depth, lobe, wc, _NO_STATS,
                        _NO_CEILING)
    inv = np.empty_like(order)
    inv[order] = np.arange(order.size)
    return Envelope(r, depth[inv], lobe[inv], wc[inv] / (2 * math.pi))


def _run_modal(batch: ModalBatch, cutting: Cutting | Conditions, rpm: np.ndarray,
               stats: np.ndarray | None = None,
               kr: np.ndarray | None = None,
               ceiling: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Run the compiled batch kernel on one chunk; returns depth [m], lobe, ωc [rad/s], each (B, S).

    ``cutting``: one Cutting, or Conditions (one per speed column); ``kr``: a Kr per set (B,) or None.
    ``stats``: optional (B, N_STATS) int64 zeros that receive the kernel's work counts per set.
    ``ceiling``: (B, S) [m] checked by :func:`check_ceiling`, or None (:func:`envelope_batch`).
    """
    reject_process_damping(cutting, name)
    if isinstance(cutting, Conditions) or kr is not None or ceiling is not None:
        return _run_conditions(batch, Conditions.coerce(cutting, rpm.size), rpm, stats, kr, ceiling)
    rs, order = _sorted(rpm)
    n_b, n_s = batch.size, rs.size
    depth = np.empty((n_b, n_s))
    lobe = np.empty((n_b, n_s), dtype=np.int64)
    wc = np.empty((n_b, n_s))
    a = _k.directional_brackets(cutting.kr, cutting.entry, cutting.exit)
    _k.envelope_modal_batch(_packed(batch), a, cutting.teeth, cutting.kt, rs, N_BASE, _OFFSETS, depth, lobe, wc,
                            _NO_STATS_2D if stats is None else stats)
    return _unsorted(order, depth, lobe, wc)


def _packed(batch: ModalBatch) -> np.ndarray:
    two_pi = 2 * math.pi
    return _k.pack_modes(two_pi * batch.fn_x, batch.k_x, batch.zeta_x, two_pi * batch.fn_y, batch.k_y, batch.zeta_y)


def _unsorted(order: np.ndarray, depth, lobe, wc):
    """The kernel's columns (sorted by ``order``) back in the caller's order."""
    n_s = order.size
    if np.array_equal(order, np.arange(n_s)):
        return depth, lobe, wc
    inv = np.empty_like(order)
    inv[order] = np.arange(n_s)
    return depth[:, inv], lobe[:, inv], wc[:, inv]


def _run_conditions(batch: ModalBatch, cond: Conditions, rpm: np.ndarray, stats: np.ndarray | None,
                    kr: np.ndarray | None,
                    ceiling: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_run_modal` under per-column conditions: ONE compiled call (:func:`_k.envelope_modal_conditions`)
    with the columns sorted by condition, then speed; each set's grid is shared by the conditions."""
    cuts, inverse = cond.unique()
    order = np.lexsort((rpm, inverse))
    rs = np.ascontiguousarray(rpm[order])
    starts = np.searchsorted(inverse[order], np.arange(len(cuts) + 1)).astype(np.int64)
    n_b, n_s = batch.size, rs.size
    depth = np.empty((n_b, n_s))
    lobe = np.empty((n_b, n_s), dtype=np.int64)
    wc = np.empty((n_b, n_s))
    col = {f: np.array([getattr(c, f) for c in cuts], dtype=np.int64 if f == "teeth" else float)
           for f in ("teeth", "kt", "kr", "entry", "exit")}
    kr_set = np.zeros(0) if kr is None else np.ascontiguousarray(kr, dtype=float)
    cap = _NO_CEILING_2D if ceiling is None else np.ascontiguousarray(ceiling[:, order], dtype=float)
    _k.envelope_modal_conditions(_packed(batch), kr_set, col["teeth"], col["kt"], col["kr"], col["entry"], col["exit"],
                                 rs, starts, N_BASE, _OFFSETS, depth, lobe, wc,
                                 _NO_STATS_2D if stats is None else stats, cap)
    return _unsorted(order, depth, lobe, wc)


def _rows(batch: ModalBatch, rows: slice) -> ModalBatch:
    return ModalBatch(*(getattr(batch, f)[rows] for f in ("fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y")))


def iter_envelope_chunks(batch: ModalBatch, cutting: Cutting | Conditions, rpm, chunk: int | None = None,
                         kr=None, ceiling=None) -> Iterator[tuple[slice, np.ndarray]]:
    """Yield ``(rows, depth)`` chunk by chunk, depth (rows, S) [m], so huge batches stream in bounded
    memory (``chunk`` sets at a time; default :func:`chunk_rows`). ``cutting``, ``kr`` and ``ceiling`` as
    :func:`envelope_batch`."""
    r = check_rpm(rpm)
    if isinstance(cutting, Conditions):
        cutting.check_columns(r.size)
    k = check_kr(kr, batch.size)
    cap = check_ceiling(ceiling, batch.size, r.size)
    chunk = chunk or chunk_rows(r.size)
    for start in range(0, batch.size, chunk):
        rows = slice(start, min(start + chunk, batch.size))
        yield rows, _run_modal(_rows(batch, rows), cutting, r, kr=None if k is None else k[rows],
                               ceiling=None if cap is None else cap[rows])[0]


def envelope_batch(batch: ModalBatch, cutting: Cutting | Conditions, rpm, chunk: int | None = None,
                   kr=None, ceiling=None) -> np.ndarray:
    """The hot path: limiting depths (B, S) [m] for B modal parameter sets at S spindle speeds [rpm].

    ``cutting``: one :class:`Cutting` for every column, or :class:`Conditions` with one condition per
    speed column (depth[b, s] is set b's limit under condition s at rpm[s]; each set's frequency grid is
    shared by all conditions). ``kr``: a radial-to-tangential ratio per set (B,), overriding the
    conditions' Kr (the ``per_set_kr`` capability). Compiled, parallel over sets, streamed in chunks of
    ``chunk`` sets. For reductions over very large B (Monte Carlo) use :func:`iter_envelope_chunks`.
    ``ceiling`` (B, S) [m] (inf: none): a censored search (:func:`_zoa_kernel.envelope_on_grid`): where the limit
    is at or below the ceiling it is returned as without one; where it is above, the ceiling itself, a lower
    bound of the limit, and the scan certifies only down to it (issue 27; the ``likelihood_ceiling`` capability: the
    updating's likelihood censors with it, in one condition and in several, docs/updating.md, "Several cutting
    conditions").
    """
    r = check_rpm(rpm)
    out = np.empty((batch.size, r.size))
    for rows, depth in iter_envelope_chunks(batch, cutting, r, chunk, kr, ceiling):
        out[rows] = depth
    return out


def envelope_batch_hz(batch: ModalBatch, cutting: Cutting | Conditions, rpm, kr=None) -> tuple[np.ndarray, np.ndarray]:
    """Limiting depths (B, S) [m] and the limiting lobes' chatter frequencies (B, S) [Hz] of B modal
    parameter sets at S spindle speeds [rpm], streamed in chunks of :func:`chunk_rows` sets; ``cutting``
    and ``kr`` as :func:`envelope_batch`."""
    r = check_rpm(rpm)
    if isinstance(cutting, Conditions):
        cutting.check_columns(r.size)
    k = check_kr(kr, batch.size)
    depth = np.empty((batch.size, r.size))
    hz = np.empty((batch.size, r.size))
    step = chunk_rows(r.size)
    for start in range(0, batch.size, step):  # chunks bound the memory; each chunk is one compiled call
        rows = slice(start, min(start + step, batch.size))
        d, _, wc = _run_modal(_rows(batch, rows), cutting, r, kr=None if k is None else k[rows])
        depth[rows], hz[rows] = d, wc / (2 * math.pi)
    return depth, hz


def lobes(structure: Structure, cutting: Cutting, rpm_min: float, rpm_max: float, n_freq: int = 4000) -> list[Lobe]:
    """Raw lobes reaching [rpm_min, rpm_max], for plotting (not for accurate envelopes).

    Each lobe is a curve (Ω_k(ω), b(ω)) over the frequencies where Re ν > 0, per eigenvalue branch.
    """
    reject_process_damping(cutting, name)
    r = check_rpm([rpm_min, rpm_max])
    if structure.is_modal:
        fns = np.array([m.fn for m in structure.modes])
        zs = np.array([m.zeta for m in structure.modes])
        f_top = cutting.teeth * r.max() / 60.0
        f_lo, f_hi = 0.3 * fns.min(), max(3.0 * fns.max(), 1.05 * f_top)
        f = np.unique(np.concatenate([np.geomspace(f_lo, f_hi, n_freq)] +
                                     [fn * (1 + z * _OFFSETS) for fn, z in zip(fns, zs)]))
        f = f[(f >= f_lo) & (f <= f_hi)]
    else:
        f = structure.frf.freq_hz
    g = structure_receptance(structure, f)
    a = _k.directional_brackets(cutting.kr, cutting.entry, cutting.exit)
    G = np.ascontiguousarray(np.stack([g[:, 0, 0], g[:, 0, 1], g[:, 1, 0], g[:, 1, 1]]))
    nu = _k._branches(a, G[0], G[1], G[2], G[3])
    out: list[Lobe] = []
    n, kt = cutting.teeth, cutting.kt
    w = 2 * math.pi * f
    for br in range(2):
        v = nu[br]
        ok = v.real > 0
        if not ok.any():
            continue
        eps = math.pi + 2 * np.angle(v)
        depth = np.where(ok, 2 * math.pi / (n * kt * np.where(ok, v.real, 1.0)), np.nan)
        wv = w[ok]
        k_max = int(np.ceil((wv * 60.0 / (n * r.min())).max() / (2 * math.pi)))
        for k in range(0, k_max + 1):
            speed = np.where(ok, 60.0 * w / (n * (eps + 2 * math.pi * k)), np.nan)
            inside = ok & (speed >= r.min()) & (speed <= r.max())
            if inside.sum() < 2:
                continue
            out.append(Lobe(k, br, speed, depth, f))
    return out


# -- the engine contract (millstab.stability.base.Engine) -----------------------------------------
name = "zoa"
#: the zero-order boundary depends only on tr and det of [α][G], so the x↔y exchange is exact
exact_xy_exchange = True
#: a measured FRF is used directly (full 2×2 matrix when cross terms exist)
accepts_measured_frf = True
#: lobe numbers only, no flip/Hopf distinction (the averaged model has no flip lobes)
reports_lobe_type = False
reports_progress = False
cheap = True
#: the process-damping term is not carried (a time-averaged depth-independent model cannot hold a
#: damping that grows with depth): a cut with it is an InputError naming the engines that do
process_damping = False
#: the compiled batch kernel returns the limiting lobe's ωc beside the depth (:func:`envelope_batch_hz`)
reports_chatter_frequency = True
#: the directional matrix averaged over the tooth period (the zero-order model)
time_averaged = True
#: relative accuracy of a limiting depth (root polish of the compiled kernel)
depth_accuracy = 1e-6
#: ``envelope_batch(..., kr=(B,))``: the directional brackets are recomputed per set in the kernel (cheap)
per_set_kr = True
#: ``envelope_batch(..., ceiling=(B, S))`` is a censored search (below the ceiling the same bits as without one, above
#: it the ceiling itself, with one Cutting or per-column conditions), and the updating's likelihood uses it (issue 27:
#: the same particles, 0.93-0.97x the CPU of an update over cuts in four conditions, docs/updating.md). Not
#: ``takes_ceiling``, which also censors the decisions (maps, recommendations): for this cheap engine they read
#: each (sample, speed) limit once from their memo (tests/test_decide_columns.py), and a map censored at its top
#: depth would be searched again by the next decision; not measured to pay
likelihood_ceiling = True

import sys as _sys  # noqa: E402

from millstab.stability import register as _register  # noqa: E402

_register(_sys.modules[__name__])
