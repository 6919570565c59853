"""Compiling the engines ahead of the first real run (``millstab warmup``, ``make demo``, ``make test``).

A fresh install compiles each engine at its first use (~1 min for zoa, ~4 min for spectral on one core).
Every kernel a command reaches is touched with a tiny problem (two speeds of example ex1): the single
structure's envelope, the batched forward function of the studies, the chatter-frequency path of the
updating, cuts in two conditions, the next test's information (with zoa: the decisions use it whatever the
engine), and the time-domain simulation of one short cut.
"""

from __future__ import annotations

import dataclasses

import numpy as np

#: what ``millstab warmup`` compiles by default (every engine and the simulation)
TARGETS = ("zoa", "sdm", "spectral", "simulate")
#: compile seconds of each target on one core of the 2-core CI machine (fresh clone, `make demo`, 2026-11-26);
#: only their order and rough ratios matter: they balance the groups of :func:`groups`
COMPILE_S = {"zoa": 31.0, "sdm": 31.0, "spectral": 81.0, "simulate": 23.0}


def warm(target: str) -> None:
    """Compile (or load from the cache) every kernel of one engine or of ``simulate``."""
    from millstab.api.inputs import config, points_from_text
    from millstab.api.lobes import envelope
    from millstab.api.studies import label_cuts, simulate_cut

    cfg = config("example:ex1")
    rpm = np.array([5000.0, 5200.0])
    if target == "simulate":
        simulate_cut(cfg, 5000.0, 0.5, revs=4)
        label_cuts(cfg, points_from_text("rpm,depth_mm\n5000,0.5\n"), revs=4)
        return
    from millstab.forward import forward
    from millstab.model import Conditions
    from millstab.params import Parameterization
    from millstab.stability import get_engine

    envelope(cfg, rpm, engine=target)
    par = Parameterization(cfg.structure)
    theta = np.repeat(par.theta0[None, :], 2, axis=0)
    forward(par, cfg.cutting, target)(theta, rpm)
    eng = get_engine(target)
    # cuts in two conditions (an update's cuts at two widths; the zero-order engine has a kernel of its own for it,
    # which `make demo`'s report compiled after the warm-up, 2026-11-29)
    half = dataclasses.replace(cfg.cutting, exit=0.5 * (cfg.cutting.entry + cfg.cutting.exit))
    eng.envelope_batch(par.batch(theta), Conditions.of((cfg.cutting, half)), rpm)
    if eng.reports_chatter_frequency:
        eng.envelope_batch_hz(par.batch(theta), cfg.cutting, rpm)
    if target == TARGETS[0]:  # the next test's information (recommend, map), whatever the engine
        from millstab.update._bald import label_information

        label_information(np.ones((2, 2)), np.ones(2), np.ones(2), np.full(2, 0.02), np.ones(2))


def groups(targets, jobs: int) -> list[list[str]]:
    """The targets dealt to at most ``jobs`` processes, longest compile first onto the least-loaded group.

    Why processes: numba compiles on one core, and every process that meets an uncompiled kernel compiles
    it itself (two pytest-xdist workers on a cold cache spent 253 s CPU on what one process did in 141 s,
    spectral tests, 2026-11-27), so compiling each engine once, side by side, before the test workers start
    saves the duplicate.
    """
    order = sorted(dict.fromkeys(targets), key=lambda t: -COMPILE_S.get(t, 0.0))
    out: list[list[str]] = [[] for _ in range(max(1, min(int(jobs), len(order))))]
    load = [0.0] * len(out)
    for t in order:
        i = load.index(min(load))
        out[i].append(t)
        load[i] += COMPILE_S.get(t, 0.0)
    return out


def warm_group(targets: list[str]) -> list[tuple[str, float]]:
    """Warm each target in turn (one process); (target, seconds) each."""
    import time

    done = []
    for t in targets:
        t0 = time.perf_counter()
        warm(t)
        done.append((t, time.perf_counter() - t0))
    return done
