"""What a benchmark ran on, printed at its top so figures can be compared honestly."""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import platform
from concurrent.futures import ProcessPoolExecutor
from itertools import repeat


def describe() -> str:
    """One line: CPU model, core count, Python, numpy, numba and its thread count."""
    import numba
    import numpy

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return (f"machine: {cpu}; {os.cpu_count()} CPUs; Python {platform.python_version()}; numpy {numpy.__version__}; "
            f"numba {numba.__version__} with {numba.get_num_threads()} threads; BLAS pinned to 1 thread")


def _one_thread() -> None:
    """A pool worker's start: numba on one thread (the pool is the parallelism)."""
    import numba

    numba.set_num_threads(1)


def pool_of(jobs: int):
    """A process pool of ``jobs`` workers (spawned: numba's OpenMP forbids fork after use; one numba
    thread each), or, for ``jobs`` ≤ 1, a null context (``None``: run in this process)."""
    if jobs <= 1:
        return contextlib.nullcontext()
    return ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn"), initializer=_one_thread)


def run_campaigns(run_one, args, todo) -> tuple[list, list]:
    """(rows, records) of ``run_one(args, c)`` -> (row, printed lines, record) for each c in ``todo``, in
    ``args.jobs`` processes (:func:`pool_of`); each campaign's lines are printed in campaign order."""
    rows, records = [], []
    with pool_of(args.jobs) as pool:
        results = pool.map(run_one, repeat(args), todo) if pool else (run_one(args, c) for c in todo)
        for row, lines, rec in results:  # in campaign order, whatever finished first
            rows.append(row)
            records.append(rec)
            print("\n".join(lines), flush=True)
    return rows, records
