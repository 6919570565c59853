"""The accurate engine in the updating loop (issue 28): one update with the zero-order engine and with the
spectral engine, timed in the same run (the ratio is the figure; target ≤ 10), and whether the accurate
posterior explains every training cut.

Case (the low-immersion shop of docs/updating.md, where the zero-order model is wrong): the seed paper's
Ex.1 structure as the hammer test with the default prior spreads, a/D ``--immersion`` (0.1) down milling;
the truth is the hammer test off by a random factor per parameter (fn ±3 %, k ±20 %, ζ ±30 %, seed
``--seed``); ``--cuts`` cuts at random speeds in ``--rpm``, depths uniform in ±``--spread`` around the
true limit (capped at ``--max-depth``), labelled by the truth's SDM boundary (an engine independent of
both fitted ones) with relative depth noise ``--noise``; relative depth noise ``--sigma-depth-rel`` in
the prior.

Timed (wall and CPU, BLAS pinned to one thread, numba's threads, engines warmed first): ``update`` with
``zoa``; with ``spectral`` and the default sampler (delayed acceptance: the zero-order engine screens each
MH proposal, the spectral engine decides on the survivors, :mod:`millstab.update.sampler`); with
``--plain`` also the spectral update with every proposal through the spectral engine, and the two
spectral posteriors compared (means and 5/50/95 % quantiles of each ln θ in units of its posterior sd:
delayed acceptance must give the same posterior within Monte-Carlo error).

``--proxy-seeds K``: the same check at a cost that allows repeats, in the same 6 parameters and data: the
zero-order likelihood as the "accurate" one and, as its screen, the zero-order likelihood of a model with
Kr 30 % high and Kt 20 % low (lobes moved and reshaped, a model error larger than the spectral/zero-order one
here); K seeds of plain and of delayed-acceptance SMC: the spread of the plain runs' means between seeds is
the Monte-Carlo error that the difference of the two averages is judged by.

"Explains a cut", two readings: strict, the posterior's P(stable) of the cut (fraction of samples whose limit
lies above its depth) is above ½ for a stable cut and below ½ for a chattering one; Bayesian, the posterior
predictive probability of the written label (with the learned label error and depth noise,
:func:`millstab.update.predict.predict_cuts`) is at least 0.1. A cut within one σ_b of the true limit can
fail the strict reading with a correct posterior.

``--fit-nodes``: also the spectral update as before issue 28's sampling node count, in the same run: a fit's
node count (the converged count + 2, not ``purpose="sample"``, :data:`millstab.update.likelihood.SAMPLING`),
chosen at the first row of every call (not once per update by the likelihood's own forward model).

``--surrogate``: also the spectral update with the surrogate sampler (a zero-order pilot posterior, a correction
of the zero-order limits fitted on 200 of its particles evaluated by the spectral engine, tempered SMC on the
corrected limits, the spectral engine once per distinct final particle and importance weights,
:func:`millstab.update.sampler.corrected_smc`), the fit's held-out error, the importance ESS, and its posterior
against the delayed-acceptance one (means and quantiles in sd units); ``--surrogate-kind``: the regression.

``--chatter-hz SIGMA``: every chatter cut carries a frequency reading, as from a microphone (``millstab listen``): the
truth's SDM chatter frequency at its speed + N(0, SIGMA²) Hz (its own generator: the cuts are the same as without).

``--breakdown``: where the spectral update's time goes (issue 28): the spectral engine's calls, the (set, speed)
entries it solved and its ρ / characteristic-function evaluations per entry, CPU in its root search and in its
zero-order starting depths; the proposals, how many passed the screen and were accepted; how many the bounded
second stage decided before all their speeds were evaluated (:meth:`millstab.update.likelihood.Likelihood.bounded`)
and the entries that saved. ``--no-bounded``: also the spectral update with every survivor evaluated at every
speed (the code before), in the same run: the same particles, bit for bit, are checked.

``--anchored``: an estimate, before building it, of a screen anchored at the current particle (the zero-order
limits of the proposal times the particle's own accurate / zero-order ratio per speed column, exact at the
particle; delayed acceptance with a state-dependent screen, Christen & Fox 2005): every proposal of the
delayed-acceptance update is recorded, both engines evaluate every proposal and its particle, and the expected
stage-1 passes and accepted moves of both screens are summed (acceptance probabilities, no random draws; the
plain screen's sums reproduce the run's own counts).

``--screen-stages K[,K2 ...]``: also the spectral update with a screen-tempered start of K stages (the zero-order
screen alone tempered first, the spectral engine at the distinct particles after it, a bridge to its exponent:
:func:`millstab.update.sampler.tempered_smc`'s ``screen_stages``), each against the default sampler (ratio, CPU,
posterior means and quantiles in sd units); with ``--proxy-seeds`` the proxy check runs them too.
``--screen-chain MxS[,...]``: also the spectral update with M moves a stage, each S MH steps on the screen before one
spectral test (``screen_steps``, a surrogate transition), after the first ``--screen-stages`` count's start.

``--seed-study N`` (instead of the timed runs): N seeds of the sampler before the screen-tempered start, of the
default and of each ``--screen-stages`` / ``--screen-chain`` setting, each run's means and quantiles against one
``--study-reference``-sample posterior of the sampler before (seed 1 000), in its sd: single runs cannot tell two
samplers' posteriors apart (a 300-sample mean moves 0.2–0.5 sd between seeds here).

``--tails T``: the prior's tails (:data:`millstab.update.prior.TAILS`) for every run, the seed study's pool included
(the prior is pickled to its workers; default: the package's ``DEFAULT_TAILS``). In the seed study:
``--study-references K`` pools the reference from K runs (seeds 1 000 … 1 000 + K − 1) of each
``--study-reference-sampler`` (``before``, ``plain``: every proposal through the spectral engine, ``default``), each
reference run printed against the pool of the others; ``--study-first S``: seeds S … S + N − 1; ``--study-plain``: a
row of the plain sampler; ``--study-detail``: per run, which quantile of each parameter is off and by how much, and the
share of samples with a kind's common shift beyond ``--study-far`` spreads; every row and reference: the share of
samples in the far modes ``--study-mode KIND:Z`` (the kind's common shift below Z spreads, above Z for Z > 0; default
``any:4``: some kind's |shift| above 4, the far modes of the rival prior, docs/updating-measured.md "The default prior,
again"); ``--study-mode-mass M``: that
mode's posterior mass by importance sampling (M spectral evaluations a side, kernels at the study's particles),
independent of the SMC runs' mode weights; ``--study-save F``: every run's ln samples to an npz file.

``--anchor-compare``: also the spectral update with the anchored screen switched the other way
(:data:`millstab.update.ANCHORED`: the zero-order limits of each proposal times the current particle's own spectral /
zero-order ratio per speed column, :func:`millstab.update.sampler.tempered_smc`'s ``anchored``), in the same run: both
ratios to the zero-order update, CPU and wall, and the two posteriors compared; with ``--seed-study`` the anchored
setting joins the study. With ``--breakdown`` each spectral run prints its accurate sets per phase (the distinct
particles where the spectral engine enters, the bridge's moves, each later stage's moves) and the proposals the
second stage rejected.
``--doors K``: the update as a user calls it (``millstab.api.update`` with the config's cutting and prior, the
default sampler), both engines alternately for seeds 0..K−1, CPU and wall and their ratio (docs/updating-measured.md,
"The ratio through the doors").
``--cold``: no warm-up update first, so the first timed call of each engine also loads its compiled code from the
cache, as in a user's fresh process (with ``--doors``: seed 0's pair is that first call).

``--anchor-moves M[,...]`` and ``--accept-moves T:M[:TOP][,...]`` (with ``--seed-study``): also the anchored screen
with M moves a stage, and with the random walk's acceptance target T (:data:`millstab.update.DELAYED_ACCEPT_TARGET`)
and M moves (and the screen-tempered start's largest exponent TOP, :data:`millstab.update.SCREEN_TOP`). The study's
"now" row is the default (:data:`millstab.update.DELAYED_ACCEPT_TARGET`, :data:`millstab.update.DELAYED_MOVES`); its
reference and "before" row the sampler before the screen-tempered start (target 0.25, 3 moves). ``--jobs J``: the
seed study's runs in a pool of J spawned processes, numba on one thread each, every run seeded by its own index (the
same numbers for any J; its CPU times are one thread's).

``--no-floor``: also the spectral update without the likelihood's floors (:meth:`millstab.update.likelihood.
Likelihood.floors`: every limit below its floor searched to its root), in the same run, the particles compared bit for
bit; ``--floor-gate G[,...]``: also the spectral update with :data:`millstab.stability.spectral.FLOOR_GATE` at G (a
floor tested only where the zero-order depth is at most G × the floor; inf: everywhere). ``--breakdown`` counts the
floor tests and the floored entries. ``--floor-replay R``: the default spectral update's root searches (the
engine's ``_solve`` calls, recorded) solved again without floors and with each ``--floor-gate``, R rounds alternated:
the root search's CPU on one workload, min and median (the shared machine's load moves single runs by ±10 %).
``--zero-order-screen``: every spectral run with the zero-order screen
(:data:`millstab.update.ANCHORED` False), whose particles do not depend on the floors (the anchored screen's anchor is a
particle's depths, which a floor changes: a rung in place of a limit below it).

``--omp-wait active|passive`` (default passive): OpenMP's wait policy for numba's threads (``OMP_WAIT_POLICY``,
set before numba starts its threads). Measured (2026-11-27, load ~22 on the 2 cores): with GOMP's default
(active: idle threads spin), one zero-order engine call of 1 set × 1 speed cost 16 ms CPU and 48 ms wall, with
passive 0.14 ms and 0.7 ms (50 sets × 10 speeds: 16 → 1.6 ms CPU): on a loaded machine the spinning of each
parallel call is most of the zero-order update's CPU time and ~0.5 s of the spectral one's, so CPU ratios
measured with active waiting mix the engines' work with the machine's load.

Run: ``PYTHONPATH=src:benchmarks .venv/bin/python benchmarks/bench_update_accurate.py [--samples 500]
[--cuts 10] [--plain] [--fit-nodes] [--surrogate] [--breakdown] [--no-bounded]``.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import os
import sys
import time

if __name__ == "__main__":  # before numba starts its OpenMP threads (see the module docstring)
    _w = sys.argv[sys.argv.index("--omp-wait") + 1] if "--omp-wait" in sys.argv[:-1] else "passive"
    os.environ["OMP_WAIT_POLICY"] = _w.upper()

import numba as nb
import numpy as np
from threadpoolctl import threadpool_limits

from _machine import describe
from millstab.io import load_config
from millstab.io.config import PriorTable
from millstab.points import PointSet
from millstab.model import Cutting
from millstab.stability import sdm
import millstab.update as upd
from millstab.update import make_prior, update
from millstab.update import likelihood
from millstab.update.likelihood import Evidence, Likelihood
from millstab.update import sampler as smc
from millstab.update.sampler import tempered_smc
from millstab.update.predict import predict_cuts
from millstab.stability import spectral


@contextlib.contextmanager
def spectral_counts(on: bool):
    """With ``on``, count the spectral engine's root searches: calls, entries, evaluations, CPU of the search
    and of its zero-order starting depths (a dict filled while the block runs)."""
    c = {"calls": 0, "entries": 0, "evals": 0, "solve_cpu": 0.0, "b_ref_cpu": 0.0, "rows": 0, "warm_rows": 0,
         "floor_tests": 0, "floored": 0}
    if not on:
        yield c
        return
    solve, b_ref, heads = spectral._solve, spectral._b_ref, spectral._heads

    def counted_heads(*a, **k):  # rows started warm from the row heading their run (within WARM_REL of it)
        follow, head = heads(*a, **k)
        c["rows"] += follow.size
        c["warm_rows"] += int(follow.sum())
        return follow, head

    def counted_solve(*a, **k):
        t = time.process_time()
        out = solve(*a, **k)
        c["solve_cpu"] += time.process_time() - t
        c["calls"] += 1
        c["entries"] += out[2].size
        c["evals"] += int(out[2].sum())
        low = k.get("floor")
        if low is not None:  # the floor's tests (the gate passed; a test needs a rung too: nearly always) and hits
            with np.errstate(invalid="ignore"):  # (inf × 0 where there is no floor)
                c["floor_tests"] += int(((low > 0) & (a[3] <= spectral.FLOOR_GATE * low)).sum())
            c["floored"] += int((out[1] == complex(spectral._k.FLOORED, 0.0)).sum())
        return out

    def counted_b_ref(*a, **k):
        t = time.process_time()
        out = b_ref(*a, **k)
        c["b_ref_cpu"] += time.process_time() - t
        return out

    spectral._solve, spectral._b_ref, spectral._heads = counted_solve, counted_b_ref, counted_heads
    try:
        yield c
    finally:
        spectral._solve, spectral._b_ref, spectral._heads = solve, b_ref, heads


@contextlib.contextmanager
def recorded_moves(on: bool):
    """With ``on``, every delayed-acceptance move's (particles, proposals, β) appended to the yielded list."""
    rec: list = []
    if not on:
        yield rec
        return
    move, anchored = smc._delayed_move, smc._anchored_move

    def recording(u, ll, lp, sll, slp, prop, beta, *a, **k):
        rec.append((u.copy(), prop.copy(), beta))
        return move(u, ll, lp, sll, slp, prop, beta, *a, **k)

    def recording_anchored(u, ll, lp, sll, slp, zd, ad, prop, beta, *a, **k):  # the default screen's moves
        rec.append((u.copy(), prop.copy(), beta))
        return anchored(u, ll, lp, sll, slp, zd, ad, prop, beta, *a, **k)

    smc._delayed_move, smc._anchored_move = recording, recording_anchored
    try:
        yield rec
    finally:
        smc._delayed_move, smc._anchored_move = move, anchored


def anchored_estimate(prior, cuts: PointSet, rec: list) -> None:
    """Expected accurate evaluations and accepted moves of the recorded proposals under the plain zero-order
    screen and under a screen anchored at the current particle (module docstring)."""
    ev = Evidence.from_points(cuts)
    acc, zoa_lik = Likelihood(prior, ev, "spectral"), Likelihood(prior, ev, "zoa")
    x, y = np.vstack([r[0] for r in rec]), np.vstack([r[1] for r in rec])
    beta = np.concatenate([np.full(r[0].shape[0], r[2]) for r in rec])
    (ax, _, wx, okx), (ay, _, wy, oky) = acc._limits(x), acc._limits(y)
    zx, zy = zoa_lik._limits(x)[0], zoa_lik._limits(y)[0]

    def loglik(depth, w, ok):  # the accurate likelihood's form on any limits
        return np.where(ok, acc.from_limits(depth, None, noise=w), -np.inf)

    def prob(log_a):
        return np.exp(np.minimum(0.0, np.nan_to_num(log_a, nan=-np.inf)))

    lpx, lpy = prior.logpdf_full(x), prior.logpdf_full(y)
    pix, piy = lpx + beta * loglik(ax, wx, okx), lpy + beta * loglik(ay, wy, oky)
    sx, sy = lpx + beta * loglik(zx, wx, okx), lpy + beta * loglik(zy, wy, oky)
    with np.errstate(divide="ignore", invalid="ignore"):  # −inf − −inf where both ends are impossible: NaN → 0
        a1 = prob(sy - sx)
        plain_acc = a1 * prob(piy + sx - pix - sy)
        tx_y = lpy + beta * loglik(zy * ax / zx, wy, oky)  # anchored at x, at y
        ty_x = lpx + beta * loglik(zx * ay / zy, wx, okx)  # anchored at y, at x
        b1, b1_back = prob(tx_y - pix), prob(ty_x - piy)
        anc_acc = np.minimum(b1, np.exp(np.minimum(piy - pix, 700.0)) * b1_back)  # b1·α2 = min(b1, π(y)·b1_back/π(x))
        # anchored with a slope: ln(accurate / zero-order) per column, linear in u over each move's particles
        # (least squares on the distinct particles of the move; the slope is fixed within a move, as the step is)
        lx, ly = np.zeros_like(ax), np.zeros_like(ay)
        start = 0
        for r in rec:
            m = r[0].shape[0]
            sl = slice(start, start + m)
            start += m
            ux, keep = np.unique(x[sl], axis=0, return_index=True)
            z = np.log(ax[sl][keep] / zx[sl][keep])
            good = np.isfinite(z).all(axis=1) & okx[sl][keep]
            if good.sum() > x.shape[1] + 2:
                A = np.c_[np.ones(good.sum()), ux[good] - ux[good].mean(axis=0)]
                coef = np.linalg.lstsq(A, z[good], rcond=None)[0][1:]  # (P, S)
            else:
                coef = np.zeros((x.shape[1], ax.shape[1]))
            d = (y[sl] - x[sl]) @ coef
            lx[sl], ly[sl] = d, -d
        sx_y = lpy + beta * loglik(zy * ax / zx * np.exp(lx), wy, oky)
        sy_x = lpx + beta * loglik(zx * ay / zy * np.exp(ly), wx, okx)
        c1, c1_back = prob(sx_y - pix), prob(sy_x - piy)
        slope_acc = np.minimum(c1, np.exp(np.minimum(piy - pix, 700.0)) * c1_back)
    n = x.shape[0]
    print(f"anchored-screen estimate over {n} recorded proposals (plain MH acceptance {prob(piy - pix).mean():.3f}):")
    for name, ev_, ac in (("zero-order screen", a1, plain_acc), ("anchored screen", b1, anc_acc),
                          ("anchored with a slope", c1, slope_acc)):
        print(f"  {name}: expected accurate evaluations {ev_.sum():.0f} ({ev_.mean():.3f} of the proposals), "
              f"accepted {ac.sum():.0f}, evaluations per accepted move {ev_.sum() / ac.sum():.2f}")


@contextlib.contextmanager
def hidden(method: str, on: bool):
    """With ``on``, :class:`millstab.update.likelihood.Likelihood`'s ``method`` (``ceilings`` or ``floors``) returns
    None while the block runs: every limit it would censor or floor is searched to its root."""
    if not on:
        yield
        return
    had = getattr(Likelihood, method)
    setattr(Likelihood, method, lambda self, u, noise: None)
    try:
        yield
    finally:
        setattr(Likelihood, method, had)


def uncensored(on: bool):
    """With ``on``, every limit of the likelihood searched to its root (the code before the censored search)."""
    return hidden("ceilings", on)


@contextlib.contextmanager
def recorded_solves(on: bool):
    """With ``on``, every root search of the spectral engine (``spectral._solve``'s arguments) appended to the
    yielded list, for :func:`floor_replay`."""
    rec: list = []
    if not on:
        yield rec
        return
    solve = spectral._solve

    def recording(*a, **k):
        rec.append((a, dict(k)))
        return solve(*a, **k)

    spectral._solve = recording
    try:
        yield rec
    finally:
        spectral._solve = solve


def floor_replay(rec: list, repeats: int, gates: list[float]) -> None:
    """``--floor-replay R``: the recorded root searches of one update solved again, without floors and with each gate
    (:data:`millstab.stability.spectral.FLOOR_GATE`), the settings alternated R times; CPU of each setting's whole
    set of calls (min and median over the R rounds: the machine is shared) and its evaluations."""
    settings = [("no floors", None)] + [(f"gate {g:g}", g) for g in gates]
    cpu = {name: [] for name, _ in settings}
    evals = {}
    had = spectral.FLOOR_GATE
    try:
        for r in range(repeats):
            for name, g in (settings if r % 2 == 0 else settings[::-1]):
                n = 0
                t = time.process_time()
                for a, k in rec:
                    if g is None:
                        k = {**k, "floor": None}
                    else:
                        spectral.FLOOR_GATE = g
                    n += int(spectral._solve(*a, **k)[2].sum())
                cpu[name].append(time.process_time() - t)
                evals[name] = n
    finally:
        spectral.FLOOR_GATE = had
    base = np.min(cpu["no floors"])
    print(f"floor replay: {len(rec)} root searches, {repeats} rounds alternated:")
    for name, _ in settings:
        lo = np.min(cpu[name])
        print(f"  {name}: CPU min {lo:.3f} s, median {np.median(cpu[name]):.3f} s ({base / lo:.3f}x less than no "
              f"floors, min/min); evaluations {evals[name]}")


def unfloored(on: bool):
    """With ``on``, no floors (every limit below its floor searched to its root: the code before the floor)."""
    return hidden("floors", on)


@contextlib.contextmanager
def floor_gate(gate: float | None):
    """With a number, :data:`millstab.stability.spectral.FLOOR_GATE` set to it while the block runs."""
    if gate is None:
        yield
        return
    had = spectral.FLOOR_GATE
    spectral.FLOOR_GATE = gate
    try:
        yield
    finally:
        spectral.FLOOR_GATE = had


@contextlib.contextmanager
def unbounded(on: bool):
    """With ``on``, the delayed-acceptance second stage evaluates every survivor at every speed (the code before
    the bounded stage): the likelihood's ``bounded`` hidden from the sampler."""
    if not on:
        yield
        return
    had = Likelihood.bounded
    del Likelihood.bounded
    try:
        yield
    finally:
        Likelihood.bounded = had


def timed(f):
    t, c = time.perf_counter(), time.process_time()
    out = f()
    return out, time.perf_counter() - t, time.process_time() - c


def doors(cfg, cuts: PointSet, samples: int, seeds: int) -> None:
    """``--doors K``: the update as a user calls it, ``millstab.api.update(cfg, cuts, engine=..., samples, seed)``
    (the config's cutting and [prior]; no sampler option), the zero-order and the spectral engine alternately for
    seeds 0..K−1 in this one process; CPU and wall of each and their ratio per seed."""
    from millstab import api

    for s in range(seeds):
        (_, zw, zc), (_, sw, sc) = (timed(lambda e=e: api.update(cfg, cuts, engine=e, samples=samples, seed=s))
                                    for e in ("zoa", "spectral"))
        print(f"api.update, {samples} samples, seed {s}: zoa {zc:.2f} s CPU ({zw:.2f} s wall), spectral {sc:.2f} s "
              f"({sw:.2f} s); ratio {sc / zc:.1f} CPU, {sw / zw:.1f} wall (target <= 10)")


def explained(post, cuts: PointSet) -> tuple[int, int, list[str]]:
    """(cuts on the right side of the posterior's median limit, cuts whose written label has posterior
    predictive probability ≥ 0.1, the cuts failing either), see the module docstring."""
    ps, pc = predict_cuts(post, cuts.rpm, cuts.depth_mm)
    chat = cuts.label == "chatter"
    side = np.where(chat, ps < 0.5, ps > 0.5)
    p_label = np.where(chat, pc, 1 - pc)
    bad = [f"{r:.0f} rpm {d:.2f} mm {lab}: P(stable) {p:.2f}, P(label) {q:.2f}" for r, d, lab, p, q, o in
           zip(cuts.rpm, cuts.depth_mm, cuts.label, ps, p_label, side & (p_label >= 0.1)) if not o]
    return int(side.sum()), int((p_label >= 0.1).sum()), bad


def proxy(prior, cuts: PointSet, samples: int, seeds: int, stages: list[int] = (), top: float = 1.0) -> None:
    """Delayed acceptance against plain SMC with a cheap 'accurate' likelihood and a wrong screen (see above);
    with ``stages``, also delayed acceptance after a screen-tempered start of each of these many stages."""
    ev = Evidence.from_points(cuts)
    lik = Likelihood(prior, ev)
    c = prior.cutting
    wrong = dataclasses.replace(prior, cutting=dataclasses.replace(c, kr=1.3 * c.kr, kt=0.8 * c.kt))
    scr = Likelihood(wrong, ev)
    runs = {"plain": [], "delayed": [], "screen alone": []} | {f"screen start {k}": [] for k in stages}
    sets = {k: [] for k in runs}
    for s in range(seeds):
        runs["plain"].append(tempered_smc(prior.sample_full, prior.logpdf_full, lik, samples, seed=s).u)
        res = tempered_smc(prior.sample_full, prior.logpdf_full, lik, samples, seed=s, screen=scr)
        runs["delayed"].append(res.u)
        sets["delayed"].append(res.n_sets)
        for k in stages:
            res = tempered_smc(prior.sample_full, prior.logpdf_full, lik, samples, seed=s, screen=scr, screen_stages=k,
                               screen_top=top)
            runs[f"screen start {k}"].append(res.u)
            sets[f"screen start {k}"].append(res.n_sets)
        runs["screen alone"].append(tempered_smc(prior.sample_full, prior.logpdf_full, scr, samples, seed=s).u)
    m = {k: np.array([u.mean(0) for u in v]) for k, v in runs.items()}
    q = {k: np.array([np.quantile(u, [0.05, 0.95], axis=0) for u in v]) for k, v in runs.items()}
    sd = np.mean([u.std(0) for u in runs["plain"]], axis=0)
    se = m["plain"].std(0, ddof=1) * np.sqrt(2 / seeds)  # of a difference of two K-run averages
    print(f"proxy check, {samples} samples x {seeds} seeds, means and 5/95 % quantiles in units of the posterior sd:")
    for j, nm in enumerate(prior.names):
        d = (m["delayed"][:, j].mean() - m["plain"][:, j].mean()) / sd[j]
        a = (m["screen alone"][:, j].mean() - m["plain"][:, j].mean()) / sd[j]
        dq = (q["delayed"][:, :, j].mean(0) - q["plain"][:, :, j].mean(0)) / sd[j]
        print(f"  ln {nm}: delayed - plain {d:+.3f} (MC error {se[j] / sd[j]:.3f}), quantiles {dq[0]:+.3f} "
              f"{dq[1]:+.3f}; screen alone - plain {a:+.3f}; seed-to-seed sd of a plain mean "
              f"{m['plain'][:, j].std(ddof=1) / sd[j]:.3f}")
        for k in stages:
            key = f"screen start {k}"
            d = (m[key][:, j].mean() - m["plain"][:, j].mean()) / sd[j]
            dq = (q[key][:, :, j].mean(0) - q["plain"][:, :, j].mean(0)) / sd[j]
            print(f"    {key} - plain {d:+.3f} (MC error {se[j] / sd[j]:.3f}), quantiles {dq[0]:+.3f} {dq[1]:+.3f}")
    for k, v in sets.items():
        if v:
            print(f"  {k}: accurate sets {np.mean(v):.0f} per run")


def phases(d: dict, n: int) -> None:
    """Print the spectral update's accurate sets per phase: where the spectral engine entered (every particle, or the
    distinct ones after a screen-tempered start), the bridge's moves (α > 0), each later stage's moves; with the
    proposals that passed the screen and the second stage's rejections."""
    alphas = d.get("screen_start", {}).get("alphas", [0.0] * len(d["betas"]))
    start = d.get("screen_start", {}).get("distinct_rows", n)
    rows = [f"start {start}"]
    tot = [0.0, 0.0, 0.0]
    for k, (b, a, m, p, acc) in enumerate(zip(d["betas"][1:], alphas[1:], d["moves"], d.get("screen_pass", []),
                                              d["acceptance"]), 1):
        if b <= 0 or not m:
            continue
        passed, accepted = p * m * n, acc * m * n
        tot = [tot[0] + passed, tot[1] + accepted, tot[2] + m * n]
        rows.append(f"{'bridge' if a > 0 else 'stage'} {k} (beta {b:.3g}, {m} moves): {passed:.0f} passed, "
                    f"{accepted:.0f} accepted, {passed - accepted:.0f} rejected by stage 2")
    print(f"  phases: {'; '.join(rows)}; moves' proposals {tot[2]:.0f}, passed {tot[0]:.0f} ({tot[0] / tot[2]:.3f}), "
          f"accepted {tot[1]:.0f}, stage 2 rejected {tot[0] - tot[1]:.0f} ({(tot[0] - tot[1]) / max(tot[0], 1):.2f} "
          f"of the passed); accurate sets per accepted move {tot[0] / max(tot[1], 1):.2f}")


def compare(ua: np.ndarray, ub: np.ndarray, names: list[str], what: str, note: str = "") -> None:
    """Print the difference of two posteriors' means and 5/50/95 % quantiles of each ln θ in sd units."""
    for j, nm in enumerate(names):
        sd = 0.5 * (ua[:, j].std() + ub[:, j].std())
        dq = [(np.quantile(ua[:, j], q) - np.quantile(ub[:, j], q)) / sd for q in (0.05, 0.5, 0.95)]
        print(f"  ln {nm}: {what}: mean diff {(ua[:, j].mean() - ub[:, j].mean()) / sd:+.3f} sd, quantile diffs "
              f"{' '.join(f'{x:+.3f}' for x in dq)} sd{note}")


@contextlib.contextmanager
def before_issue_28(on: bool):
    """With ``on``, the likelihood's engine calls as before issue 28's sampling count: a fit's node count
    (converged + 2), chosen at the first row of every call (a fresh forward model per call)."""
    if not on:
        yield
        return
    init = Likelihood.__init__

    def per_call(self, *a, **k):
        init(self, *a, **k)
        self._forwards = [None] * len(self._forwards)

    likelihood.SAMPLING, Likelihood.__init__ = "fit", per_call
    try:
        yield
    finally:
        likelihood.SAMPLING, Likelihood.__init__ = "sample", init


_WARM: list = []  # the seed study's process has run both engines once


def _study_run(task: tuple) -> tuple:
    """One run of the seed study (a process pool's task, or inline): the update of ``task`` = (cfg, cuts, prior,
    engine, (screen stages, top, steps, anchored[, target]), moves, samples, seed, threads[, sampler]) -> (ln samples,
    accurate sets, CPU [s], cuts on the label's side, cuts with predictive probability >= 0.1, the spectral engine's ρ
    evaluations); ``target``: a fresh delayed-acceptance update's (default
    :data:`millstab.update.DELAYED_ACCEPT_TARGET`); ``sampler`` (default ``"auto"``): update()'s, e.g. ``"plain"``
    (every proposal through the engine)."""
    cfg, cuts, prior, engine, setting, moves, n, seed, threads, *rest = task
    sampler = rest[0] if rest else "auto"
    setting, target = (setting[:4], setting[4]) if len(setting) > 4 else (setting, upd.DELAYED_ACCEPT_TARGET)
    base, base_target = (upd.SCREEN_STAGES, upd.SCREEN_TOP, upd.SCREEN_STEPS, upd.ANCHORED), upd.DELAYED_ACCEPT_TARGET
    if threads:
        nb.set_num_threads(threads)
    if not _WARM:  # a fresh worker: load the engines' compiled code outside the timings
        for eng in ("zoa", "spectral"):
            update(cfg, cuts, samples=20, seed=99, engine=eng, moves=1, prior=prior, sampler="plain")
        _WARM.append(True)
    upd.SCREEN_STAGES, upd.SCREEN_TOP, upd.SCREEN_STEPS, upd.ANCHORED = setting
    upd.DELAYED_ACCEPT_TARGET = target  # a fresh delayed-acceptance update's (a zoa update keeps ACCEPT_TARGET)
    try:
        with threadpool_limits(1), spectral_counts(engine == "spectral") as counts:
            post, _, cpu = timed(lambda: update(cfg, cuts, samples=n, seed=seed, engine=engine, prior=prior,
                                                moves=moves, sampler=sampler))
    finally:
        upd.SCREEN_STAGES, upd.SCREEN_TOP, upd.SCREEN_STEPS, upd.ANCHORED = base
        upd.DELAYED_ACCEPT_TARGET = base_target
    n_side, n_label, _ = explained(post, cuts) if engine != "zoa" else (0, 0, [])
    return np.log(post.samples), post.diagnostics.get("engine_sets", 0), cpu, n_side, n_label, counts["evals"]


def kind_shifts(prior, u: np.ndarray) -> np.ndarray:
    """Each kind's common shift of samples u (n, P) [spreads]: the mean over the kind's columns (all fn, all k, all ζ:
    :attr:`millstab.update.prior.Prior.kind_groups`) of z = (u − ln θ_config)/spread (n, kinds)."""
    z = (u[:, :prior.n_modal] - prior.mean_u[:prior.n_modal]) / prior.spread[:prior.n_modal]
    return np.stack([z[:, list(g)].mean(axis=1) for g in prior.kind_groups], axis=1)


QS = (0.05, 0.5, 0.95)


def in_mode(prior, u: np.ndarray, mode: tuple[str, float]) -> np.ndarray:
    """Whether each sample of u (n, P) lies in the region ``mode`` = (kind, z): that kind's common shift
    (:func:`kind_shifts`) below z spreads (z < 0) or above it (z > 0); kind ``any``: some kind's |shift| above |z|
    (n,)."""
    c = kind_shifts(prior, u)
    if mode[0] == "any":
        return (np.abs(c) > abs(mode[1])).any(axis=1)
    c = c[:, [prior.par.kind(prior.names[g[0]]) for g in prior.kind_groups].index(mode[0])]
    return c < mode[1] if mode[1] < 0 else c > mode[1]


def mode_mass(prior, cuts: PointSet, centers: np.ndarray, mode: tuple[str, float], m: int, seed: int = 0,
              h: float = 0.5, diameter_mm: float | None = None) -> tuple[float, float, list[str]]:
    """The posterior mass of the region ``mode`` (:func:`in_mode`) by importance sampling, independent of the SMC
    runs' mode weights: Z_region = E_q[prior · L / q · 1(region)] for the region and its complement, m draws each from
    q = 0.9 · (1/K) Σ_k N(x_k, h² Σ) + 0.1 · prior (x_k: the region's distinct particles ``centers`` of ln θ, at most
    2 000 of them, Σ their covariance, or all particles' with fewer than 2P; the prior alone without any), the noise
    levels drawn from their prior (which cancels), the spectral likelihood (the update's own). Returns (mass, its
    standard error by the delta method, report lines)."""
    from scipy.special import logsumexp

    rng = np.random.default_rng(seed)
    ev = Evidence.from_points(cuts, base_cutting=prior.cutting, diameter_mm=diameter_mm)
    lik = Likelihood(prior, ev, "spectral")
    p = prior.size
    centers = np.unique(centers[:, :p], axis=0)
    inside = in_mode(prior, centers, mode)
    out, lines = {}, []
    for name, sel in (("in", inside), ("out", ~inside)):
        c = centers[sel]
        c = c[rng.choice(c.shape[0], min(c.shape[0], 2000), replace=False)]
        cov = np.cov(c if c.shape[0] > 2 * p else centers, rowvar=False)  # too few: every particle's spread
        chol = np.linalg.cholesky(cov * h * h + 1e-10 * np.eye(p))
        x = c[rng.integers(max(c.shape[0], 1), size=m)] + rng.standard_normal((m, p)) @ chol.T if c.size else None
        nd = m // 10 if c.size else m
        x = prior.sample(m, rng) if x is None else x
        x[m - nd:] = prior.sample(nd, rng)
        log_q = prior.logpdf(x)
        if c.size:
            inv = np.linalg.inv(chol)
            lk = [logsumexp(-0.5 * (((x[i:i + 256, None, :] - c[None]) @ inv.T) ** 2).sum(-1), axis=1)
                  for i in range(0, m, 256)]
            log_k = (np.concatenate(lk) - np.log(c.shape[0]) - np.log(np.diag(chol)).sum()
                     - 0.5 * p * np.log(2 * np.pi))
            log_q = np.logaddexp(np.log(0.9) + log_k, np.log(0.1) + log_q)
        ok = prior.in_support(x) & (in_mode(prior, x, mode) == (name == "in"))
        ll = np.full(m, -np.inf)
        t0 = time.process_time()
        ll[ok] = lik(np.hstack([x[ok], prior.sample_noise(int(ok.sum()), rng)]))
        lw = np.where(ok, prior.logpdf(x) + ll - log_q, -np.inf)
        w = np.exp(lw - lw.max())
        out[name] = (float(logsumexp(lw) - np.log(m)), float(np.sqrt(np.var(w) / m) / np.mean(w)))
        lines.append(f"{name}side: {c.shape[0]} kernel centres, {int(ok.sum())} of {m} draws in it, CPU "
                     f"{time.process_time() - t0:.1f} s, IS ESS {w.sum() ** 2 / (w ** 2).sum():.0f}, log Z "
                     f"{out[name][0]:.3f} +- {out[name][1]:.3f}")
    d = out["in"][0] - out["out"][0]
    mass = 1.0 / (1.0 + np.exp(-d))
    return mass, mass * (1 - mass) * float(np.hypot(out["in"][1], out["out"][1])), lines


def _errors(u: np.ndarray, ref: np.ndarray, sd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(mean error (P,), quantile errors (3, P)) of samples u against the reference samples, in the reference's sd."""
    return (u.mean(0) - ref.mean(0)) / sd, (np.quantile(u, QS, axis=0) - np.quantile(ref, QS, axis=0)) / sd


def _detail(u: np.ndarray, ref: np.ndarray, sd: np.ndarray, names: list[str], prior, far: float, kinds: list[str]
            ) -> str:
    """One run's line of ``--study-detail``: per parameter the quantile furthest off the reference and by how much
    (reference sd), and the share of samples with each kind's common shift beyond ``far`` spreads (either side)."""
    _, dq = _errors(u, ref, sd)
    worst = np.abs(dq).argmax(axis=0)
    per = " ".join(f"{nm}:q{round(100 * QS[w])}{dq[w, j]:+.2f}" for j, (nm, w) in enumerate(zip(names, worst)))
    return f"{per}; {_far_shares(prior, u, far, kinds)}"


def _far_shares(prior, u: np.ndarray, far: float, kinds: list[str]) -> str:
    """The share of samples u whose kind's common shift (:func:`kind_shifts`) is beyond ``far`` spreads, per kind."""
    c = kind_shifts(prior, u)
    return f"|shift| > {far:g}: " + " ".join(f"{k} {np.mean(np.abs(c[:, i]) > far):.3f}" for i, k in enumerate(kinds))


def seed_study(cfg, cuts: PointSet, prior, names: list[str], args, stages: list[int], chains: list[str]) -> None:
    """``--seed-study N``: N seeds of each sampler setting against one reference posterior (the sampler before the
    screen-tempered start, ``--study-reference`` samples, seed 1 000): accurate sets, CPU, and each run's means and
    5/50/95 % quantiles minus the reference's in reference sd (RMS over seeds and parameters; the worst quantile).
    ``--jobs J`` > 1: the runs in a pool of J processes (spawned, each numba on one thread, so each run's CPU is one
    thread's; every run is seeded by its own index: the same numbers for any J but the times).
    ``--study-references K`` and ``--study-reference-sampler S[,S2]``: the reference pooled from K runs (seeds 1 000
    … 1 000 + K − 1) of each sampler S (``before``: no screen stages, not anchored; ``plain``: every proposal through
    the spectral engine; ``default``: the package's), each reference run printed against the pool of the others (its
    own scatter). ``--study-detail``: per run, which quantile of each parameter is off and by how much, and the share
    of samples whose kind's common shift is beyond ``--study-far`` spreads. ``--study-save F``: every run's ln
    samples to the npz file F (for offline reading)."""
    base = (upd.SCREEN_STAGES, upd.SCREEN_TOP, upd.SCREEN_STEPS, upd.ANCHORED)
    top, dm = args.screen_top or base[1], upd.DELAYED_MOVES
    # the sampler before the screen-tempered start: the plain random walk's target and 3 moves (the reference's)
    before = (0, top, 1, False, smc.ACCEPT_TARGET)
    plan = ([] if args.study_skip_before else [("before (0 screen stages, not anchored)", before, 3)]) + (
            [(f"now ({base[0]} stages, top {base[1]:g}, anchored {base[3]}, acceptance target "
              f"{upd.DELAYED_ACCEPT_TARGET:g}, {dm} moves)", base, dm)]
            + ([(f"{base[0]} stages, top {base[1]:g}, anchored {not base[3]}", (*base[:3], not base[3]), dm)]
               if args.anchor_compare else [])
            + [(f"{base[0]} stages, top {base[1]:g}, anchored, {m} moves a stage", (*base[:3], True), m)
               for m in args.anchor_moves]
            + [(f"{base[0]} stages, top {tp:g}, anchored, acceptance target {t:g}, {m} moves a stage",
                (base[0], tp, base[2], True, t), m) for t, m, tp in
               ((a[0], a[1], a[2] if len(a) > 2 else base[1]) for a in args.accept_moves)]
            + [(f"{k} screen stages, top {top:g}", (k, top, 1, base[3]), dm) for k in stages]
            + [(f"{c} (moves x screen steps)", (stages[0] if stages else base[0], top, int(c.split('x')[1]), False),
                int(c.split("x")[0])) for c in chains])
    plan += [("plain (every proposal through the spectral engine)", base, 3, "plain")] if args.study_plain else []
    ref_kinds = {"before": (before, 3, "auto"), "plain": (base, 3, "plain"), "default": (base, dm, "auto")}
    ref_plan = [(k, s) for k in args.study_reference_sampler.split(",")
                for s in range(1000, 1000 + args.study_references)]
    threads = 1 if args.jobs > 1 else 0
    seeds = range(args.study_first, args.study_first + args.seed_study)
    tasks = ([(cfg, cuts, prior, "spectral", ref_kinds[k][0], ref_kinds[k][1], args.study_reference, s, threads,
               ref_kinds[k][2]) for k, s in ref_plan]
             + [(cfg, cuts, prior, "zoa", base, 3, args.samples, s, threads) for s in seeds]
             + [(cfg, cuts, prior, "spectral", p[1], p[2], args.samples, s, threads, *p[3:])
                for p in plan for s in seeds])
    if args.jobs > 1:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(args.jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
            out = list(pool.map(_study_run, tasks))
    else:
        out = [_study_run(t) for t in tasks]
    nr = len(ref_plan)
    refs, out = out[:nr], out[nr - 1:]  # out[0] stands for the reference below (the layout before several)
    ref = np.concatenate([r[0] for r in refs])
    sd = ref.std(0)
    kinds = [prior.par.kind(names[g[0]]) for g in prior.kind_groups]
    zoa = np.mean([o[2] for o in out[1:1 + len(seeds)]])
    what = ", ".join(f"{k} seed {s}" for k, s in ref_plan)
    print(f"seed study (tails {prior.tails}): {args.seed_study} seeds x {args.samples} samples against a "
          f"{ref.shape[0]}-sample reference ({what}; {args.study_reference} samples each); errors in reference sd; the "
          f"zero-order update's CPU {zoa:.3f} s (mean over the seeds); {args.jobs} process(es)")
    for i, ((k, s), r) in enumerate(zip(ref_plan, refs)):
        if nr > 1:  # each reference run against the pool of the others
            rest = np.concatenate([q[0] for j, q in enumerate(refs) if j != i])
            e, dq = _errors(r[0], rest, rest.std(0))
            print(f"  reference {k} seed {s} against the other {nr - 1}: CPU {r[2]:.2f} s, mean error RMS "
                  f"{np.sqrt((e ** 2).mean()):.2f}, worst quantile error {np.abs(dq).max():.2f}"
                  + (f"; {_detail(r[0], rest, rest.std(0), names, prior, args.study_far, kinds)}"
                     if args.study_detail else ""))
        elif args.study_detail:
            print(f"  reference {k} seed {s}: {_far_shares(prior, r[0], args.study_far, kinds)}")
    saved = {f"ref_{k}_{s}": r[0] for (k, s), r in zip(ref_plan, refs)}
    mode = (args.study_mode.split(":")[0], float(args.study_mode.split(":")[1]))
    share = [float(in_mode(prior, r[0], mode).mean()) for r in refs]
    print(f"  share of the mode {args.study_mode} (the kind's common shift beyond it, spreads) in the reference runs: "
          f"{' '.join(f'{x:.4f}' for x in share)}")
    for k, p in enumerate(plan):
        label = p[0]
        rows = []
        for i, (u, sets, cpu, n_side, n_label, evals) in enumerate(out[1 + len(seeds) * (k + 1):
                                                                       1 + len(seeds) * (k + 2)]):
            e, dq = _errors(u, ref, sd)
            rows.append((e, np.abs(dq).max(), sets, cpu, n_side, n_label, evals, u))
            saved[f"run{k}_seed{seeds[i]}"] = u
        err = np.array([r[0] for r in rows])
        per = np.round(np.sqrt((err**2).mean(0)), 2)
        cpu = np.mean([r[3] for r in rows])
        print(f"  {label}: accurate sets {np.mean([r[2] for r in rows]):.0f}, spectral evaluations "
              f"{np.mean([r[6] for r in rows]):.0f}, CPU {cpu:.2f} s (ratio to zero-order {cpu / zoa:.1f}), RMS mean "
              f"error {np.sqrt((err**2).mean()):.2f} (per parameter {per}), "
              f"worst quantile error {np.mean([r[1] for r in rows]):.2f} (mean over seeds), max "
              f"{max(r[1] for r in rows):.2f}; "
              f"cuts explained: label side >= {min(r[4] for r in rows)}/{args.cuts}, predictive >= 0.1 "
              f">= {min(r[5] for r in rows)}/{args.cuts}")
        share = np.array([in_mode(prior, r[7], mode).mean() for r in rows])
        print(f"    the mode {args.study_mode}: share mean {share.mean():.4f}, median {np.median(share):.4f}, max "
              f"{share.max():.4f}, runs above 0.05: {(share > 0.05).sum()}/{share.size}, above 0.02: "
              f"{(share > 0.02).sum()}/{share.size}")
        if args.study_detail:
            for s, r in zip(seeds, rows):
                print(f"    seed {s}: worst {r[1]:.2f}; {_detail(r[7], ref, sd, names, prior, args.study_far, kinds)}")
    if args.study_mode_mass:
        pool = np.concatenate([r[0] for r in refs] + [o[0] for o in out[1 + len(seeds):]])
        with threadpool_limits(1):
            mass, se, lines = mode_mass(prior, cuts, pool, mode, args.study_mode_mass,
                                        diameter_mm=getattr(cfg, "diameter_mm", None))
        print(f"  the mode {args.study_mode}'s posterior mass by importance sampling ({args.study_mode_mass} draws a "
              f"side, kernels at the study's particles): {mass:.4f} +- {se:.4f}; " + "; ".join(lines))
    if args.study_save:
        np.savez_compressed(args.study_save, names=np.array(names), labels=np.array([p[0] for p in plan]),
                            mean_u=prior.mean_u, spread=prior.spread, **saved)
        print(f"  saved every run's ln samples to {args.study_save}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=500)
    ap.add_argument("--cuts", type=int, default=10)
    ap.add_argument("--immersion", type=float, default=0.1)
    ap.add_argument("--rpm", default="5000:12000")
    ap.add_argument("--max-depth", type=float, default=60.0)
    ap.add_argument("--spread", type=float, default=0.3, help="depths uniform in ±spread around the true limit")
    ap.add_argument("--noise", type=float, default=0.03, help="relative depth noise of the labels")
    ap.add_argument("--sigma-depth-rel", type=float, default=0.05)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--plain", action="store_true", help="also the spectral update without delayed acceptance")
    ap.add_argument("--proxy-seeds", type=int, default=0, help="the repeatable proxy check with this many seeds")
    ap.add_argument("--proxy-only", action="store_true", help="only the proxy check (no spectral updates)")
    ap.add_argument("--surrogate", action="store_true", help="also the spectral update with the surrogate sampler "
                    "(zero-order limits times a fitted correction, the spectral engine once per final sample)")
    ap.add_argument("--surrogate-kind", default="linear", help="the correction's regression: linear | quadratic | gp")
    ap.add_argument("--fit-nodes", action="store_true", help="also the spectral update (default sampler) as before "
                    "issue 28's sampling count: a fit's node count (converged + 2), chosen per call")
    ap.add_argument("--breakdown", action="store_true", help="where the spectral update's time goes")
    ap.add_argument("--chatter-hz", type=float, default=None, metavar="SIGMA",
                    help="chatter cuts carry a frequency reading: the truth's SDM chatter frequency + N(0, SIGMA^2) Hz")
    ap.add_argument("--no-bounded", action="store_true", help="also the spectral update without the bounded "
                    "second stage (every survivor at every speed), and the two compared")
    ap.add_argument("--no-censor", action="store_true", help="also the spectral update with every limit searched to "
                    "its root (no ceilings), and the two compared")
    ap.add_argument("--no-floor", action="store_true", help="also the spectral update without floors (every limit "
                    "below its floor searched to its root), and the two compared")
    ap.add_argument("--floor-replay", type=int, default=0, metavar="R", help="the default spectral update's root "
                    "searches solved again without floors and with each --floor-gate (default: FLOOR_GATE), R rounds "
                    "alternated (CPU of the root search alone)")
    ap.add_argument("--zero-order-screen", action="store_true", help="every spectral run with the zero-order screen "
                    "(update.ANCHORED False): floors, ceilings and gates then give the same particles bit for bit, so "
                    "their evaluations compare on one workload")
    ap.add_argument("--floor-gate", type=lambda t: [float(x) for x in t.split(",") if x.strip()], default=[],
                    help="also the spectral update with spectral.FLOOR_GATE at each of these values (comma-separated; "
                    "inf: a floor tested everywhere)")
    ap.add_argument("--anchored", action="store_true", help="estimate a screen anchored at the current particle on "
                    "the delayed-acceptance run's proposals")
    ap.add_argument("--near", type=float, default=None, help="also the spectral update with the refinement near "
                    "rho = 1 at this margin (engine option near; the sampling settings' default is "
                    "spectral.NEAR; 0: off, as before 2026-11-27)")
    ap.add_argument("--screen-stages", default="", help="also the spectral update with a screen-tempered start of "
                    "these many stages (comma-separated counts; tempered_smc's screen_stages), in the same run")
    ap.add_argument("--screen-top", type=float, default=None, help="the screen-tempered start's largest exponent "
                    "(update.SCREEN_TOP) for the --screen-stages and --screen-chain runs and the proxy's")
    ap.add_argument("--screen-chain", default="", help="also the spectral update with MOVESxSTEPS: MOVES moves per "
                    "stage, each STEPS MH steps on the zero-order screen before one spectral test (comma-separated, "
                    "e.g. 2x3,1x6; with the first --screen-stages count, else the default's)")
    ap.add_argument("--seed-study", type=int, default=0, help="instead of the timed runs: this many seeds of the "
                    "sampler before, the default and each --screen-stages / --screen-chain setting against one "
                    "reference")
    ap.add_argument("--study-reference", type=int, default=3000, help="the seed study's reference samples")
    ap.add_argument("--study-first", type=int, default=0, metavar="S", help="the seed study's seeds S ... S+N-1")
    ap.add_argument("--study-references", type=int, default=1, metavar="K", help="the seed study's reference pooled "
                    "from K runs (seeds 1000 ... 1000+K-1) of each --study-reference-sampler")
    ap.add_argument("--study-reference-sampler", default="before", help="the reference runs' sampler(s), "
                    "comma-separated: before (no screen stages, not anchored) | plain | default")
    ap.add_argument("--study-plain", action="store_true", help="the seed study with a row of the plain sampler (every "
                    "proposal through the spectral engine)")
    ap.add_argument("--study-detail", action="store_true", help="the seed study per run: which quantile of each "
                    "parameter is off, by how much, and the share of samples with a kind's common shift beyond "
                    "--study-far spreads")
    ap.add_argument("--study-far", type=float, default=3.0, help="with --study-detail: the common shift [spreads] "
                    "beyond which a sample counts as far out")
    ap.add_argument("--study-mode", default="any:4", metavar="KIND:Z", help="the seed study's far mode: the "
                    "samples whose kind's common shift is below Z spreads (Z < 0; above Z for Z > 0; KIND any: some "
                    "kind's |shift| above |Z|); each run's share in it")
    ap.add_argument("--study-mode-mass", type=int, default=0, metavar="M", help="after the seed study: the far "
                    "mode's posterior mass by importance sampling, M draws on each side (independent of the SMC runs' "
                    "weights)")
    ap.add_argument("--study-save", default="", metavar="F", help="the seed study's ln samples to this npz file")
    ap.add_argument("--tails", default=None, help="the prior's tails (millstab.update.prior.TAILS) for every run, the "
                    "seed study's pool included (default: the package's DEFAULT_TAILS)")
    ap.add_argument("--study-skip-before", action="store_true", help="the seed study without its row of the sampler "
                    "before the screen-tempered start (its reference is still that sampler's)")
    ap.add_argument("--anchor-compare", action="store_true", help="also the spectral update with the anchored "
                    "screen switched the other way (update.ANCHORED), in the same run (and in --seed-study)")
    ap.add_argument("--jobs", type=int, default=1, help="with --seed-study: its runs in a pool of this many processes")
    ap.add_argument("--anchor-moves", type=lambda t: [int(x) for x in t.split(",") if x.strip()], default=[],
                    help="with --seed-study: also the anchored screen with these many moves a stage (comma-separated)")
    ap.add_argument("--cold", action="store_true", help="no warm-up update before the timings: the first timed "
                    "call of each engine loads its compiled code from the cache, as a fresh process of a user does")
    ap.add_argument("--doors", type=int, default=0, metavar="K",
                    help="time millstab.api.update with both engines for seeds 0..K-1 (the config's prior), then stop")
    ap.add_argument("--accept-moves", type=lambda t: [tuple(float(v) if i != 1 else int(v)
                                                            for i, v in enumerate(x.split(":")))
                                                      for x in t.split(",") if x.strip()], default=[],
                    help="with --seed-study: also the anchored screen with the MH acceptance target T and M moves a "
                    "stage, T:M[:TOP] (comma-separated; update.DELAYED_ACCEPT_TARGET; TOP: update.SCREEN_TOP)")
    ap.add_argument("--omp-wait", choices=("active", "passive"), default="passive",
                    help="OpenMP wait policy of numba's threads (set before they start)")
    args = ap.parse_args()
    stages = [int(k) for k in args.screen_stages.split(",") if k.strip()]
    chains = [c.strip() for c in args.screen_chain.split(",") if c.strip()]
    print(describe() + f"; OMP_WAIT_POLICY={os.environ.get('OMP_WAIT_POLICY')}")
    lo, hi = (float(x) for x in args.rpm.split(":"))
    cfg = load_config("example:ex1")
    cut = Cutting.from_immersion(cfg.cutting.teeth, cfg.cutting.kt, cfg.cutting.kr, args.immersion, "down")
    # the config's cutting is not used: update() takes the prior, which holds this cut
    prior = make_prior(cfg.structure, cut, PriorTable({}, sigma_depth_rel=args.sigma_depth_rel, tails=args.tails))
    rng = np.random.default_rng(args.seed)
    names = list(prior.par.free)
    off = {"fn": 0.03, "k": 0.2, "zeta": 0.3}
    fac = np.array([1 + rng.uniform(-off[prior.par.kind(n)], off[prior.par.kind(n)]) for n in names])
    true_struct = prior.par.structure(prior.median * fac)
    rpm = np.sort(rng.uniform(lo, hi, args.cuts))
    env_true = sdm.envelope(true_struct, cut, rpm)
    b_true = env_true.depth_mm
    depth = np.minimum(b_true * rng.uniform(1 - args.spread, 1 + args.spread, rpm.size), args.max_depth)
    chatter = depth > b_true * np.exp(args.noise * rng.standard_normal(rpm.size))
    hz = None
    if args.chatter_hz is not None:  # a microphone's readings: the truth's SDM f_c + noise (its own generator)
        noise_hz = np.random.default_rng(args.seed + 1000).normal(0.0, args.chatter_hz, rpm.size)
        hz = np.where(chatter, env_true.chatter_hz + noise_hz, np.nan)
    cuts = PointSet(rpm, depth, np.where(chatter, "chatter", "stable"), chatter_hz=hz)
    print(f"case (prior tails {prior.tails}): Ex.1 at a/D {args.immersion} down, truth = hammer test x "
          f"{np.round(fac, 3).tolist()} ({names}); "
          f"{args.cuts} cuts, {int(chatter.sum())} chatter"
          + ("" if hz is None else f" ({int(np.isfinite(hz).sum())} with a frequency reading, sigma "
                                    f"{args.chatter_hz:g} Hz)")
          + f"; true SDM limits {np.round(b_true, 1).tolist()} mm")
    with threadpool_limits(1):
        if args.proxy_seeds:
            proxy(prior, cuts, args.samples, args.proxy_seeds, stages, args.screen_top or upd.SCREEN_TOP)
        if args.proxy_only:
            return
        for eng in ("zoa", "spectral") if not args.cold else ():  # compile / load the caches outside the timings
            update(cfg, cuts, samples=20, seed=99, engine=eng, moves=1, prior=prior, sampler="plain")
        _WARM.append(True)
        if args.seed_study:
            seed_study(cfg, cuts, prior, names, args, stages, chains)
            return
        if args.doors:
            doors(dataclasses.replace(cfg, cutting=cut, prior=PriorTable({}, sigma_depth_rel=args.sigma_depth_rel,
                                                                          tails=args.tails)),
                  cuts, args.samples, args.doors)
            return
        runs = {}
        plan = ([("zoa", "auto")] + ([("spectral", "fit-nodes")] if args.fit_nodes else []) + [("spectral", "auto")]
                + ([("spectral", "unbounded")] if args.no_bounded else [])
                + ([("spectral", "uncensored")] if args.no_censor else [])
                + ([("spectral", "unfloored")] if args.no_floor else [])
                + ([("spectral", "zscreen"), ("spectral", "zscreen-unfloored")]
                   if args.no_floor and not args.zero_order_screen else [])
                + [("spectral", f"gate{g:g}") for g in args.floor_gate]
                + ([("spectral", "plain")] if args.plain else [])
                + ([("spectral", "surrogate")] if args.surrogate else [])
                + ([("spectral", "near")] if args.near is not None else [])
                + ([("spectral", "flip-anchor")] if args.anchor_compare else [])
        + [("spectral", f"screen{k}") for k in stages]
                + [("spectral", f"chain{c}") for c in chains])
        upd.SURROGATE_KIND = args.surrogate_kind
        default_stages, default_steps, default_top = upd.SCREEN_STAGES, upd.SCREEN_STEPS, upd.SCREEN_TOP
        default_anchor = False if args.zero_order_screen else upd.ANCHORED
        for eng, smp in plan:
            upd.ANCHORED = (not default_anchor) if smp == "flip-anchor" else (
                False if smp.startswith("zscreen") else default_anchor)
            upd.SCREEN_TOP = args.screen_top if args.screen_top and smp.startswith(("screen", "chain")) else default_top
            upd.SCREEN_STAGES = int(smp[6:]) if smp.startswith("screen") else (
                stages[0] if smp.startswith("chain") and stages else default_stages)
            n_moves, upd.SCREEN_STEPS = (int(x) for x in smp[5:].split("x")) if smp.startswith("chain") else (
                None, default_steps)  # None: update()'s default (DELAYED_MOVES for a fresh delayed update, else 3)
            with before_issue_28(smp == "fit-nodes"), unbounded(smp == "unbounded"), uncensored(smp == "uncensored"), \
                    unfloored(smp in ("unfloored", "zscreen-unfloored")), \
                    floor_gate(float(smp[4:]) if smp.startswith("gate") else None), \
                    spectral_counts(args.breakdown and eng == "spectral") as counts, \
                    recorded_moves(args.anchored and (eng, smp) == ("spectral", "auto")) as moves, \
                    recorded_solves(args.floor_replay and (eng, smp) == ("spectral", "auto")) as solves:
                post, wall, cpu = timed(lambda eng=eng, smp=smp, n_moves=n_moves: update(
                    cfg, cuts, samples=args.samples, seed=args.seed, engine=eng, prior=prior, moves=n_moves,
                    sampler="auto" if smp in ("fit-nodes", "unbounded", "uncensored", "unfloored", "near",
                                              "flip-anchor") or smp.startswith(("screen", "chain", "gate", "zscreen"))
                    else smp,
                    engine_options={"near": args.near} if smp == "near" else None))
            runs[eng, smp] = (post, wall, cpu)
            if solves:
                floor_replay(solves, args.floor_replay, args.floor_gate or [spectral.FLOOR_GATE])
            if moves:
                anchored_estimate(prior, cuts, moves)
            d = post.diagnostics
            n_side, n_label, bad = explained(post, cuts)
            extra = (f", screened by {d['screen_engine']}: {d['screen_sets']} screen sets, pass "
                     f"{np.mean(d['screen_pass']):.2f}" if "screen_pass" in d else "")
            if "correction" in d:
                c, f = d["correction"], d["surrogate"]
                rms = [x for x in f["heldout_rms_ln_b"] if x is not None]
                sd = [x for x in f["delta_sd_ln_b"] if x is not None]
                print(f"  surrogate ({f['kind']}, {f['design']} distinct zero-order posterior particles evaluated by "
                      f"the spectral engine): held-out RMS error of the correction {np.median(rms):.4f} median, "
                      f"{max(rms):.4f} max [ln b] (the correction's own sd {np.median(sd):.4f} median); importance ESS "
                      f"{c['ess']:.0f} ({c['ess_fraction']:.2f} of N), {c['accurate_rows']} distinct final rows "
                      f"evaluated, bridge stages {c['bridge_stages']}")
            if counts["calls"]:
                # the stages with the spectral engine in their target (not the screen-tempered start's: beta 0)
                mv = [m if b > 0 else 0 for b, m in zip(d["betas"][1:], d.get("moves", []))]
                moved = sum(m * args.samples for m in mv)
                passed = sum(p * m * args.samples for p, m in zip(d.get("screen_pass", []), mv))
                accepted = sum(a * m * args.samples for a, m in zip(d.get("acceptance", []), mv))
                print(f"  breakdown: {counts['calls']} spectral calls, {counts['entries']} (set, speed) entries, "
                      f"{counts['evals'] / max(counts['entries'], 1):.2f} evaluations per entry ({counts['evals']}; of "
                      f"the cold searches "
                      f"and warm starts; {counts['warm_rows']} of {counts['rows']} rows started warm from a row within "
                      f"{spectral.WARM_REL:g} of them); CPU root search "
                      f"{counts['solve_cpu']:.2f} s, zero-order starting depths {counts['b_ref_cpu']:.2f} s; "
                      f"proposals {moved:.0f}, passed the screen {passed:.0f}, accepted {accepted:.0f}; decided "
                      f"early {d.get('decided_early', 0)}, entries saved {d.get('entries_saved', 0)}; censored entries "
                      f"{d.get('censored_entries', 0)}; entries below their floor {d.get('floored_entries', 0)}, "
                      f"floor tests {counts['floor_tests']}, floored {counts['floored']}")
            if counts["calls"]:
                phases(d, args.samples)
            if "screen_start" in d:
                st = d["screen_start"]
                print(f"  screen-tempered start: {st['stages']} stages of the zero-order screen to exponent "
                      f"{st['exponent']:.4g}, then the spectral engine at {st['distinct_rows']} distinct particles; "
                      f"betas {np.round(d['betas'], 4).tolist()}, moves {d['moves']}")
            print(f"{eng:8s} {smp:5s}: {wall:7.1f} s wall, {cpu:7.1f} s CPU ({nb.get_num_threads()} threads); "
                  f"{d['stages']} stages, {d['engine_sets']} engine sets{extra}; cuts on the label's side of P(stable) "
                  f"= 1/2: {n_side}/{args.cuts}, written label with predictive probability >= 0.1: "
                  f"{n_label}/{args.cuts}"
                  + (f" (not: {'; '.join(bad)})" if bad else ""))
    z, s = runs["zoa", "auto"], runs["spectral", "auto"]
    print(f"ratio spectral/zoa: {s[1] / z[1]:.1f} wall, {s[2] / z[2]:.1f} CPU (target <= 10)")
    if args.fit_nodes:
        f = runs["spectral", "fit-nodes"]
        print(f"ratio spectral (delayed, a fit's node count per call: before)/zoa: {f[1] / z[1]:.1f} wall, "
              f"{f[2] / z[2]:.1f} CPU; the sampling node count saves {f[1] / s[1]:.2f}x wall, {f[2] / s[2]:.2f}x CPU")
        ua, ub = s[0].u, f[0].u
        for j, nm in enumerate(names):
            sd = 0.5 * (ua[:, j].std() + ub[:, j].std())
            print(f"  ln {nm}: sampling - fit node count: mean diff {(ua[:, j].mean() - ub[:, j].mean()) / sd:+.3f} sd")
    if args.no_bounded:
        o = runs["spectral", "unbounded"]
        same = np.array_equal(o[0].u, s[0].u)
        print(f"bounded second stage vs every survivor at every speed: {o[1] / s[1]:.2f}x wall, {o[2] / s[2]:.2f}x "
              f"CPU; the same particles bit for bit: {same}; ratio without it {o[2] / z[2]:.1f} CPU")
        if not same:  # a decision flipped (the engine's depths depend on the rows sharing a call, docs/updating.md)
            compare(s[0].u, o[0].u, names, "bounded - unbounded")
    if args.no_censor:
        o = runs["spectral", "uncensored"]
        same = np.array_equal(o[0].u, s[0].u)
        print(f"censored limits vs every limit to its root: {o[1] / s[1]:.2f}x wall, {o[2] / s[2]:.2f}x CPU; the same "
              f"particles bit for bit: {same}; ratio without it {o[2] / z[2]:.1f} CPU")
        if not same:
            compare(s[0].u, o[0].u, names, "censored - uncensored")
    if args.no_floor and args.zero_order_screen:
        o = runs["spectral", "unfloored"]
        print(f"floors vs every limit below its floor to its root (zero-order screen): {o[2] / s[2]:.2f}x CPU; the "
              f"same particles bit for bit: {np.array_equal(o[0].u, s[0].u)}; ratio without floors {o[2] / z[2]:.1f} "
              f"CPU")
    elif args.no_floor:
        o = runs["spectral", "unfloored"]
        same = np.array_equal(o[0].u, s[0].u)
        print(f"floors vs every limit below its floor to its root: {o[1] / s[1]:.2f}x wall, {o[2] / s[2]:.2f}x CPU; "
              f"the same particles bit for bit: {same}; ratio without floors {o[1] / z[1]:.1f} wall, {o[2] / z[2]:.1f} "
              f"CPU")
        if not same:
            compare(s[0].u, o[0].u, names, "floored - unfloored")
        a, b = runs["spectral", "zscreen"], runs["spectral", "zscreen-unfloored"]
        print(f"with the zero-order screen (update.ANCHORED False; the anchored screen's anchor is the floored depth, "
              f"so its chain differs): floors {b[2] / a[2]:.2f}x less CPU; the same particles bit for bit: "
              f"{np.array_equal(a[0].u, b[0].u)}; ratio {a[2] / z[2]:.1f} (floors) / {b[2] / z[2]:.1f} CPU")
    for g in args.floor_gate:
        o = runs["spectral", f"gate{g:g}"]
        print(f"floor gate {g:g} (default {spectral.FLOOR_GATE:g}): ratio to zoa {o[1] / z[1]:.1f} wall, "
              f"{o[2] / z[2]:.1f} CPU; the same particles bit for bit: {np.array_equal(o[0].u, s[0].u)}")
    if args.near is not None:
        q = runs["spectral", "near"]
        print(f"refinement near rho = 1 at {args.near:g} against the sampling settings' {spectral.NEAR:g}: "
              f"{q[2] / s[2]:.2f}x CPU; ratio to zoa {q[2] / z[2]:.1f} CPU")
        compare(q[0].u, s[0].u, names, f"near {args.near:g} - near {spectral.NEAR:g}")
    if args.plain:
        p = runs["spectral", "plain"]
        print(f"delayed acceptance vs plain spectral: {p[1] / s[1]:.1f}x faster (wall), {p[2] / s[2]:.1f}x (CPU)")
        ess = min(s[0].diagnostics["ess"][-1], p[0].diagnostics["ess"][-1])
        compare(s[0].u, p[0].u, names, "delayed - plain",
                f" (MC error of a difference ~{np.sqrt(2 / ess):.3f} sd at the last ESS {ess:.0f})")
    if args.surrogate:
        g = runs["spectral", "surrogate"]
        print(f"ratio spectral (surrogate)/zoa: {g[1] / z[1]:.1f} wall, {g[2] / z[2]:.1f} CPU; vs delayed "
              f"{s[1] / g[1]:.2f}x wall, {s[2] / g[2]:.2f}x CPU")
        compare(g[0].u, s[0].u, names, "surrogate - delayed")
    if args.anchor_compare:
        g = runs["spectral", "flip-anchor"]
        new, old = (s, g) if default_anchor else (g, s)
        print(f"anchored screen: ratio to zoa {new[1] / z[1]:.1f} wall, {new[2] / z[2]:.1f} CPU; the sampler before it "
              f"{old[1] / z[1]:.1f} wall, {old[2] / z[2]:.1f} CPU; anchored saves {old[1] / new[1]:.2f}x wall, "
              f"{old[2] / new[2]:.2f}x CPU, accurate sets {old[0].diagnostics['engine_sets']} -> "
              f"{new[0].diagnostics['engine_sets']}")
        compare(new[0].u, old[0].u, names, "anchored - before")
    for k in stages:
        g = runs["spectral", f"screen{k}"]
        print(f"screen-tempered start, {k} stages: ratio to zoa {g[1] / z[1]:.1f} wall, {g[2] / z[2]:.1f} CPU; vs the "
              f"default sampler {s[1] / g[1]:.2f}x wall, {s[2] / g[2]:.2f}x CPU")
        compare(g[0].u, s[0].u, names, f"screen{k} - default")
    for c in chains:
        g = runs["spectral", f"chain{c}"]
        print(f"moves x screen steps {c}: ratio to zoa {g[1] / z[1]:.1f} wall, {g[2] / z[2]:.1f} CPU; vs the default "
              f"sampler {s[1] / g[1]:.2f}x wall, {s[2] / g[2]:.2f}x CPU")
        compare(g[0].u, s[0].u, names, f"chain {c} - default")
    print(f"spectral_over_zoa_wall: {s[1] / z[1]:.2f}")


if __name__ == "__main__":
    main()
