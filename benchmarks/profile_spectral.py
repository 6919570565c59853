"""Where the spectral engine's time goes (issue 28), on the two workloads that matter.

1. ``update``: the updating loop's call, the limits of ``--samples`` prior samples of the docs/updating.md
   low-immersion case (Ex.1, a/D 0.1, down milling) at 10 cut speeds (uniform 5 000–12 000 rpm, seed 0), with
   the sampler's settings (``purpose="sample"``: the converged node count, ``near`` 0).
2. ``envelope``: benchmarks/bench_spectral.py's envelope (x = y one mode each, a/D 0.05, 200 speeds
   5 000–25 000 rpm), nodes by the per-call convergence check.

For each: CPU time of the whole call and of its parts (zero-order starting depths, the node-count check, the
compiled root search), the evaluations per speed, and, from compiled timing loops, the CPU time of one ρ
evaluation (its monodromy build, from the per-speed low-rank factors and as before element by element, and its
eigenvalues) and of one characteristic-function evaluation with its
derivative (a Newton step), at the case's own speeds and depths. The ρ evaluations of the search from below
are counted exactly where they are deterministic: the ladder rungs below the accepted root (the acceptance
evaluates each, whatever found the root). One thread, BLAS pinned: CPU time is the figure on a shared machine.

Run: ``PYTHONPATH=src:benchmarks .venv/bin/python benchmarks/profile_spectral.py [--samples 100]``.
"""

from __future__ import annotations

import argparse
import math
import time

import numba as nb
import numpy as np
from _machine import describe
from threadpoolctl import threadpool_limits

from millstab.frf import ModalBatch
from millstab.io import load_config
from millstab.io.config import PriorTable
from millstab.model import Cutting, Mode, Structure
from millstab.stability import _spectral_kernel as _k
from millstab.stability import spectral
from millstab.stability.sdm import _arrays
from millstab.update import make_prior


@nb.njit(cache=True)
def _loop_rho(reps, bs, kt, wn, zeta, mass, mdir, D, g, nd):
    s = 0.0
    for _ in range(reps):
        for b in bs:
            s += _k.rho(b, kt, wn, zeta, mass, mdir, D, g, nd)[0]
    return s


@nb.njit(cache=True)
def _loop_below(reps, bs, level, kt, wn, zeta, mass, mdir, D, g, nd):
    s = 0.0
    for _ in range(reps):
        for b in bs:
            s += _k.rho_below(b, level, kt, wn, zeta, mass, mdir, D, g, nd)[0]
    return s


@nb.njit(cache=True)
def _loop_build(reps, bs, kt, wn, zeta, mass, mdir, g, nd):
    s = 0.0
    for _ in range(reps):
        for b in bs:
            s += _k._build_lr(b, kt, g, g[8], g[9])[0, 0]  # into the speed's workspace, as the search builds
    return s


@nb.njit(cache=True)
def _loop_small(reps, bs, kt, wn, zeta, mass, mdir, g, nd):
    """The element-by-element build before issue 28's low-rank factors (for the comparison)."""
    s = 0.0
    for _ in range(reps):
        for b in bs:
            U = _k.monodromy_small(b, kt, wn, zeta, mass, mdir, g[0], g[1], g[2], g[4], g[5], g[6], g[7], nd[1], nd[2])
            s += U[0, 0]
    return s


@nb.njit(cache=True)
def _loop_char(reps, bs, th, kt, wn, zeta, mass, mdir, g, nd):
    s = 0.0
    for _ in range(reps):
        for b in bs:
            s += abs(_k.char_d(b, th, kt, wn, zeta, mass, mdir, g, nd)[0])
    return s


@nb.njit(cache=True)
def _loop_setup(reps, n_teeth, kr, ps, pe, rpm, el, x, wn, zeta, act):
    s = 0.0
    for _ in range(reps):
        for r in rpm:
            s += _k.setup(n_teeth, kr, ps, pe, r, el, x, wn, zeta, act)[1][0]
    return s


@nb.njit(cache=True)
def _loop_factors(reps, n_teeth, kr, ps, pe, rpm, el, nd, wn, zeta, mass, mdir, act):
    s = 0.0
    for _ in range(reps):
        for r in rpm:
            s += _k.with_factors(_k.setup(n_teeth, kr, ps, pe, r, el, nd[0], wn, zeta, act), wn, zeta, mass, mdir,
                                 nd)[1][0]
    return s


@nb.njit(cache=True)
def _loop_parts(reps, bs, level, kt, g, part):
    """The rung test by its parts at depths bs (one speed's layout g): 0 the monodromy build (into the speed's
    workspace), 1 the build and a full balance (the certificate's similarity before issue 28's reuse of the
    scaling), 2 the build, that balance and one squaring with its norms, 3 the whole rung test, 4 the build and the
    exact ρ (balance, Hessenberg, QR)."""
    s = 0.0
    ws = g[9]
    for _ in range(reps):
        for b in bs:
            if part == 3:
                s += _k.rho_test(b, level, _k.CERT_SQUARINGS, kt, g)[0]
                continue
            U = _k._build_lr(b, kt, g, g[8], ws)
            if part == 4:
                s += _k._rho_exact(U, ws)[0]
                continue
            if part >= 1:
                ws[14][:] = 1.0
                _k._balance(U, ws[14])
            if part >= 2:
                np.dot(U, U, ws[8])
                s += _k._norms(ws[8])[0]
            s += U[0, 0]
    return s


def rung_parts(batch: ModalBatch, cut: Cutting, rs: np.ndarray, depth: np.ndarray, b_ref: np.ndarray, p: int,
               near: float, rows: int = 5, reps: int = 20) -> dict:
    """CPU seconds per rung of each part of :func:`_loop_parts` on the rungs under the accepted roots (first
    ``rows`` sets), and the rows K of their monodromies."""
    tot = np.zeros(5)
    n_r = k_sum = 0
    for g, bs in rungs_by_speed(batch, cut, rs, depth, b_ref, p, rows):
        if bs.size == 0:
            continue
        for part in range(5):
            _loop_parts(0, bs, 1.0 - near, cut.kt, g, part)  # compile / cache load
            tot[part] += cpu(_loop_parts, reps, bs, 1.0 - near, cut.kt, g, part)[1]
        n_r += bs.size
        k_sum += bs.size * g[9][0].shape[0]
    return {"parts": tot / max(n_r * reps, 1), "K": k_sum / max(n_r, 1)}


def cpu(f, *args):
    """(f(*args), CPU seconds it took)."""
    c = time.process_time()
    out = f(*args)
    return out, time.process_time() - c


def unit_costs(batch: ModalBatch, cut: Cutting, rs: np.ndarray, depth: np.ndarray, p: int, level: float,
               reps: int = 20) -> dict:
    """CPU seconds per ρ evaluation, per monodromy build, per characteristic function + derivative and per
    speed setup, averaged over the rows of ``batch`` (up to 5) at speeds rs and depths 0.3–1.0 × the row's limit;
    the rung test (:func:`rho_below`) at ``level``."""
    wn, zeta, mass, act, mdir = _arrays(batch)
    n, kt, kr, ps, pe = cut.teeth, cut.kt, cut.kr, cut.entry, cut.exit
    nd = _k.gauss_nodes(p)
    el = spectral._elem_len(wn)
    keys = ("rho", "below", "build", "small", "char", "setup", "factors")
    tot = dict.fromkeys(keys, 0.0)
    cnt = dict.fromkeys(keys, 0)
    rows = range(min(batch.size, 5))
    g0 = _k.with_factors(_k.setup(n, kr, ps, pe, rs[0], el[0], nd[0], wn[0], zeta[0], act), wn[0], zeta[0], mass[0],
                         mdir, nd)
    # compile / cache load first (reps 0: same types), so the timed loops hold no compile time
    _loop_setup(0, n, kr, ps, pe, rs, el[0], nd[0], wn[0], zeta[0], act)
    _loop_rho(0, rs, kt, wn[0], zeta[0], mass[0], mdir, act.size, g0, nd)
    _loop_build(0, rs, kt, wn[0], zeta[0], mass[0], mdir, g0, nd)
    _loop_below(0, rs, 1.0, kt, wn[0], zeta[0], mass[0], mdir, act.size, g0, nd)
    _loop_small(0, rs, kt, wn[0], zeta[0], mass[0], mdir, g0, nd)
    _loop_factors(0, n, kr, ps, pe, rs, el[0], nd, wn[0], zeta[0], mass[0], mdir, act)
    _loop_char(0, rs, 1.0, kt, wn[0], zeta[0], mass[0], mdir, g0, nd)
    for i in rows:
        _, c = cpu(_loop_setup, reps, n, kr, ps, pe, rs, el[i], nd[0], wn[i], zeta[i], act)
        tot["setup"] += c
        cnt["setup"] += reps * rs.size
        _, c = cpu(_loop_factors, reps, n, kr, ps, pe, rs, el[i], nd, wn[i], zeta[i], mass[i], mdir, act)
        tot["factors"] += c
        cnt["factors"] += reps * rs.size
        for s, r in enumerate(rs):
            if not np.isfinite(depth[i, s]):
                continue
            g = _k.with_factors(_k.setup(n, kr, ps, pe, r, el[i], nd[0], wn[i], zeta[i], act), wn[i], zeta[i], mass[i],
                                mdir, nd)
            bs = depth[i, s] * np.linspace(0.3, 1.0, 8)
            common = (kt, wn[i], zeta[i], mass[i], mdir)
            for key, f, args in (("rho", _loop_rho, (reps, bs, *common, act.size, g, nd)),
                                 ("below", _loop_below, (reps, bs, level, *common, act.size, g, nd)),
                                 ("build", _loop_build, (reps, bs, *common, g, nd)),
                                 ("small", _loop_small, (reps, bs, *common, g, nd)),
                                 ("char", _loop_char, (reps, bs, 1.0, *common, g, nd))):
                _, c = cpu(f, *args)
                tot[key] += c
                cnt[key] += reps * bs.size
    return {k: tot[k] / max(cnt[k], 1) for k in tot}


def rungs_below(depth: np.ndarray, b_ref: np.ndarray) -> np.ndarray:
    """ρ evaluations the acceptance of each root makes at least: the ladder rungs below depth·(1 − 2e-3),
    plus ρ at that depth itself (:func:`millstab.stability._spectral_kernel.check_root`)."""
    out = np.zeros(depth.shape, np.int64)
    for idx in np.ndindex(depth.shape):
        d, b = depth[idx], b_ref[idx]
        if not np.isfinite(d):
            continue
        k = 0
        while _k.ladder_depth(b, spectral.LADDER, k) < d * (1 - 2e-3):
            k += 1
        out[idx] = k + 1
    return out


def rungs_by_speed(batch: ModalBatch, cut: Cutting, rs: np.ndarray, depth: np.ndarray, b_ref: np.ndarray, p: int,
                   rows: int = 5):
    """For each (set, speed) of the first ``rows`` sets with a finite limit: (its layout with factors and workspace,
    the ladder depths (R,) under its accepted root)."""
    wn, zeta, mass, act, mdir = _arrays(batch)
    nd = _k.gauss_nodes(p)
    el = spectral._elem_len(wn)
    for i in range(min(batch.size, rows)):
        for s, r in enumerate(rs):
            if not np.isfinite(depth[i, s]):
                continue
            g = _k.with_factors(_k.setup(cut.teeth, cut.kr, cut.entry, cut.exit, r, el[i], nd[0], wn[i], zeta[i], act),
                                wn[i], zeta[i], mass[i], mdir, nd)
            bs = []
            while _k.ladder_depth(b_ref[i, s], spectral.LADDER, len(bs)) < depth[i, s] * (1 - 2e-3):
                bs.append(_k.ladder_depth(b_ref[i, s], spectral.LADDER, len(bs)))
            yield g, np.array(bs)


def rung_census(batch: ModalBatch, cut: Cutting, rs: np.ndarray, depth: np.ndarray, b_ref: np.ndarray, p: int,
                near: float, rows: int = 5) -> dict:
    """How the rungs under the accepted roots are decided (first ``rows`` sets): the rung test at 1 − near with the
    full squaring budget (``_k.rho_test``, CERT_SQUARINGS) certifies them (and with how many squarings) or needs
    the eigenvalues; and how many have ρ above the level (the refinement's triggers, eigenvalues in any case)."""
    level = 1.0 - near
    out = {"rungs": 0, "certified": 0, "squarings": 0, "above": 0}
    for g, bs in rungs_by_speed(batch, cut, rs, depth, b_ref, p, rows):
        for x in bs:
            out["rungs"] += 1
            for sq in range(1, _k.CERT_SQUARINGS + 1):  # the fewest squarings that certify
                if not _k.rho_test(x, level, sq, cut.kt, g)[2]:
                    out["certified"] += 1
                    out["squarings"] += sq
                    break
            else:
                out["above"] += int(_k.rho_test(x, level, 0, cut.kt, g)[0] > level)
    return out


def profile(label: str, batch: ModalBatch, cut: Cutting, rpm: np.ndarray, nodes, near: float) -> None:
    rs = np.ascontiguousarray(np.unique(rpm))
    spectral.envelope_batch(ModalBatch(*(getattr(batch, f)[:1]
                                         for f in ("fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y"))),
                            cut, rs[:2], nodes=nodes, near=near)  # compile / cache load
    _, t_all = cpu(lambda: spectral.envelope_batch(batch, cut, rs, nodes=nodes, near=near))
    b_ref, t_ref = cpu(spectral._b_ref, batch, cut, rs)
    if nodes is None:
        p, t_chk = cpu(spectral._converged_nodes, batch, cut, rs, b_ref)
    else:
        p, t_chk = int(nodes), 0.0
    (depth, _mu, n_eval), t_solve = cpu(lambda: spectral._solve_warm(batch, cut, rs, b_ref, p, near=near))
    n_pairs = depth.size
    n_rho = rungs_below(depth, b_ref)
    u = unit_costs(batch, cut, rs, depth, p, 1.0 - near)
    other = t_all - t_ref - t_chk - t_solve
    print(f"{label}: {batch.size} sets x {rs.size} speeds, nodes {p}, near {near}")
    print(f"  CPU per call {t_all:.3f} s = zero-order start {t_ref:.3f} + node check {t_chk:.3f} + root search "
          f"{t_solve:.3f} + Python/other {other:.3f}; per (set, speed) {1e3 * t_solve / n_pairs:.3f} ms in the search")
    print(f"  evaluations per (set, speed) {n_eval.mean():.1f} (rho + characteristic); of them rho on the rungs under "
          f"the accepted root (a floor) {n_rho.mean():.1f}")
    print(f"  unit CPU: rho {1e6 * u['rho']:.1f} us (monodromy build {1e6 * u['build']:.1f} us from the low-rank "
          f"factors, {1e6 * u['small']:.1f} us element by element as before; eigenvalues "
          f"{1e6 * (u['rho'] - u['build']):.1f} us); the rung test with its certificate (rho_below) "
          f"{1e6 * u['below']:.1f} us; characteristic fn + derivative {1e6 * u['char']:.1f} us, speed setup "
          f"{1e6 * u['setup']:.1f} us (with the low-rank factors {1e6 * u['factors']:.1f} us)")
    cen = rung_census(batch, cut, rs, depth, b_ref, p, near)
    n_r = max(cen["rungs"], 1)
    print(f"  rungs under the roots (first {min(batch.size, 5)} sets): {cen['rungs']}, certified below 1 - near by "
          f"squarings {100 * cen['certified'] / n_r:.1f} % (mean {cen['squarings'] / max(cen['certified'], 1):.2f} "
          f"squarings), eigenvalues needed {100 * (1 - cen['certified'] / n_r):.1f} % (rho above 1 - near at "
          f"{100 * cen['above'] / n_r:.1f} %: those steps are refined)")
    parts = rung_parts(batch, cut, rs, depth, b_ref, p, near)
    t = 1e6 * parts["parts"]
    print(f"  a rung under the root by its parts (first {min(batch.size, 5)} sets, K = {parts['K']:.1f} rows): the "
          f"whole test {t[3]:.2f} us = monodromy build {t[0]:.2f} us + the certificate {t[3] - t[0]:.2f} us; for "
          f"comparison a full balance {t[1] - t[0]:.2f} us, one squaring with its norms {t[2] - t[1]:.2f} us, the "
          f"exact rho (balance, Hessenberg, QR) {t[4] - t[0]:.2f} us")
    rung_t = n_rho.sum() * parts["parts"][3]
    set_t = u["factors"] * n_pairs
    n_other = np.maximum(n_eval - n_rho, 0).sum()
    each = 1e6 * (t_solve - rung_t - set_t) / max(n_other, 1)
    print(f"  the search's {t_solve:.3f} s: rungs under the root ~{rung_t:.3f} s ({100 * rung_t / t_solve:.0f} %, at "
          f"the measured whole test); speed setups {set_t:.3f} s ({100 * set_t / t_solve:.0f} %); the other "
          f"{n_other / n_pairs:.1f} evaluations per pair (the refinement near rho = 1, the bracket's ends, Newton, "
          f"the check at a root's top: mostly exact rho) the rest, ~{each:.1f} us each")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    print(describe())
    nb.set_num_threads(1)
    with threadpool_limits(1):
        cfg = load_config("example:ex1")
        cut = Cutting.from_immersion(cfg.cutting.teeth, cfg.cutting.kt, cfg.cutting.kr, 0.1, "down")
        prior = make_prior(cfg.structure, cut, PriorTable({}, sigma_depth_rel=0.05))
        rng = np.random.default_rng(args.seed)
        rpm = np.sort(rng.uniform(5000, 12000, 10))
        theta, _ = prior.split(prior.sample_full(args.samples, rng))
        batch = prior.par.batch(theta)
        st = spectral.settings(prior.par.batch(prior.median[None]), cut, rpm, purpose="sample")
        profile("update (prior samples at the cut speeds)", batch, cut, rpm, st["nodes"], st["near"])
        m, fn, z = 0.03993, 922.0, 0.011
        k = m * (2 * math.pi * fn) ** 2
        xy = Structure(x=(Mode(fn, k, z),), y=(Mode(fn, k, z),))
        profile("envelope (x = y, a/D 0.05, 200 speeds)", ModalBatch.from_structures([xy]),
                Cutting.from_immersion(2, 6e8, 1 / 3, 0.05, "down"), np.linspace(5000, 25000, 200), None, spectral.NEAR)


if __name__ == "__main__":
    main()
