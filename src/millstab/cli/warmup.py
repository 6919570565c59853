"""``millstab warmup``: compile the engines into numba's on-disk cache once, ahead of the first real run.

A fresh install compiles each engine at its first use (~1 min for zoa, ~4 min for spectral on one core);
``make demo``/``make test`` call this right after installing, so a newcomer's first command starts at once.
Every kernel a command reaches is touched with a tiny problem (two speeds of example ex1): the single
structure's envelope, the batched forward function of the studies, the chatter-frequency path of the
updating, and the time-domain simulation of one short cut.
"""

from __future__ import annotations

import time
from typing import List, Optional

import typer

from millstab.api.warmup import TARGETS, groups, warm_group
from millstab.cli.app import app
from millstab.errors import InputError


@app.command("warmup")
def warmup_cmd(
    targets: Optional[List[str]] = typer.Argument(None, help=f"What to compile: {', '.join(TARGETS)} (default: all)."),
    jobs: int = typer.Option(1, "--jobs", help="Processes compiling side by side (each compiles on one core)."),
) -> None:
    """Compile the engines into the cache once (first run after installing: minutes), so later runs start at once."""
    chosen = list(targets) if targets else list(TARGETS)
    for t in chosen:
        if t not in TARGETS:
            raise InputError("TARGET", t, f"must be one of {', '.join(TARGETS)}")
    if jobs < 1:
        raise InputError("--jobs", jobs, "need an integer ≥ 1")
    if jobs == 1:
        for t, seconds in warm_group(chosen):
            typer.echo(f"{t}: ready ({seconds:.1f} s)")
        return
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    t0 = time.perf_counter()
    dealt = groups(chosen, jobs)
    # spawn: a fresh interpreter per process (no forked numba or BLAS threads)
    with ProcessPoolExecutor(len(dealt), mp_context=multiprocessing.get_context("spawn")) as pool:
        for done in pool.map(warm_group, dealt):
            for t, seconds in done:
                typer.echo(f"{t}: ready ({seconds:.1f} s)")
    typer.echo(f"all ready in {time.perf_counter() - t0:.1f} s ({len(dealt)} processes)")
