"""What a benchmark ran on, printed at its top so figures can be compared honestly."""

from __future__ import annotations

import os
import platform


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
