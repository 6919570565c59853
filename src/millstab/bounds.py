"""Plausibility bounds on inputs that set how much work a command does: spindle speeds, chatter
frequencies and random seeds. One place, one set of messages, for the command line, Python and the web.

Why a speed floor. The work of every engine grows without bound as the speed falls: the semi-discretization
(``sdm``) takes ~12 steps per natural period of the highest mode in each tooth period, so its steps grow like
1/Ω (fn = 1 kHz, 2 teeth: 72 steps at 5 000 rpm, 36 000 at 10 rpm, 3.6·10⁸ at 0.001 rpm); the time-domain
simulation's steps per tooth period and the spectral engine's collocation grow the same way, and the
zero-order engine's lobe count f/(NΩ) too. Below :data:`MIN_RPM` no milling spindle turns a cutter (a 1 m
face mill at 30 m/min is ~10 rev/min) while a single speed costs ~500 times one at 5 000 rpm: a speed
below it is a typing slip (0.01 for 10 000?), not a process, and is refused before any work.

Why a ceiling. The fastest spindles that carry milling cutters, air-bearing micro-milling spindles, reach
~400 000 rev/min; :data:`MAX_RPM` leaves room above them. 5 000 000 rev/min is a slip (an extra zero, or Hz).

Chatter frequencies are vibrations of the tool, holder and spindle (modes from ~100 Hz to ~20 kHz on micro
tools), recorded by microphones and accelerometers whose bandwidth ends below ~50 kHz; :data:`MAX_CHATTER_HZ`
(100 kHz) is far above any of them.
"""

from __future__ import annotations

import operator

import numpy as np

from millstab.errors import InputError

#: the slowest accepted spindle speed [rev/min] (module docstring: why)
MIN_RPM = 10.0
#: the fastest accepted spindle speed [rev/min]
MAX_RPM = 500_000.0
#: the highest accepted chatter frequency [Hz]
MAX_CHATTER_HZ = 100_000.0
#: the most posterior samples (SMC particles) an update takes: 250x the default 4 000; the posterior JSON of
#: 10^6 samples is ~130 MB and the zero-order update of 40 000 took ~1 min (2 shared cores), so 10^6 is ~half
#: an hour, more never pays (the sampling error of a probability falls like 1/sqrt(n): 0.0005 at 10^6)
MAX_SAMPLES = 1_000_000
#: the updating's peak memory per sample [bytes]: measured 1 300 (peak RSS 241 MB at 2 000 samples, 291 MB at
#: 40 000; example ex1, 6 cuts, 6 free parameters: the particles, their proposals and the likelihood's
#: samples x cuts arrays), rounded up for more cuts and parameters
BYTES_PER_SAMPLE = 2_000
#: the highest natural frequency of a tool-tip mode [Hz]: as a chatter frequency (above); a mode above it is a slip
#: (rad/s, rpm or an extra zero) and costs without bound (the zero-order sweep's lobes and sdm's steps grow with it:
#: a mode of 10^12 Hz held a web server's one thread for minutes)
MAX_MODE_HZ = MAX_CHATTER_HZ
#: the most modes per direction of a structure: a tap test's fit uses a few (millstab fit-modes: up to 6), a tool
#: tip model's up to ~10; more is a slip that makes every engine call and the app's form (a field per value) slow
MAX_MODES = 20
#: the most teeth of a cutter: the largest face mills carry ~100 inserts; a tooth count beyond this is a slip
MAX_TEETH = 500
#: the most labelled cuts (and points) one update takes: its arrays hold samples x cuts values (~100 bytes a pair
#: at the default 4 000 samples: 8 000 cuts took 0.8 GB and 79 s, 260 000 a 4.9 MB file exhausted a 24 GB machine);
#: a shop's campaigns hold tens to hundreds
MAX_CUTS = 5_000
#: seeds are numpy's 32-bit unsigned integers (``default_rng``, ``RandomState`` and SALib all accept them)
SEED_LIMIT = 2**32


def check_cuts(n: int, field: str = "cuts") -> None:
    """Refuse more than :data:`MAX_CUTS` cuts (and points) in one update, prediction or validation, before any work.

    Raises:
        InputError: naming ``field``, the count and the bound with its reason.
    """
    if n > MAX_CUTS:
        raise InputError(field, f"{n:,} rows", f"at most {MAX_CUTS:,} cuts and points at once (the work holds samples "
                                              "x cuts values: 8 000 cuts took 0.8 GB; a shop's campaign holds tens to "
                                              "hundreds); split the file")


def speed_rule() -> str:
    return (f"spindle speeds must lie in {MIN_RPM:g}..{MAX_RPM:,.0f} rev/min (below {MIN_RPM:g} no milling "
            f"spindle turns and the engines' work grows like 1/speed; above {MAX_RPM:,.0f} no spindle turns)")


def check_speeds(rpm, field: str = "rpm", shown: object = None) -> np.ndarray:
    """``rpm`` as a float array when every speed is finite and within [MIN_RPM, MAX_RPM] [rev/min].

    Raises:
        InputError: naming ``field``, ``shown`` (the text as written; default: the first speed out of
            range) and the bounds with their reason.
    """
    r = np.atleast_1d(np.asarray(rpm, dtype=float))
    bad = ~np.isfinite(r) | (r < MIN_RPM) | (r > MAX_RPM)
    if bad.any():
        value = shown if shown is not None else float(r[bad][0])
        fin = r[np.isfinite(r) & (r > 0)]
        slow = fin[fin < MIN_RPM]
        hint = (f" (at {slow.min():g} rev/min one revolution takes {_duration(60.0 / slow.min())})"
                if slow.size else " (an extra zero? speeds are rev/min, not rad/s)" if np.any(fin > MAX_RPM) else "")
        raise InputError(field, value, speed_rule() + hint)
    return r


def _duration(seconds: float) -> str:
    for unit, size in (("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"


def seed(value, field: str = "--seed") -> int | None:
    """A random seed as an int in [0, 2**32) (None passes: no seed given).

    Raises:
        InputError: a negative, too large or non-integer seed.
    """
    if value is None:
        return None
    try:
        if isinstance(value, bool):
            raise TypeError
        s = operator.index(value)
    except TypeError:
        raise InputError(field, value, f"a seed is a whole number in 0..{SEED_LIMIT - 1}") from None
    if not 0 <= s < SEED_LIMIT:
        raise InputError(field, value, f"a seed is a whole number in 0..{SEED_LIMIT - 1} (numpy's 32-bit seeds)")
    return int(s)


def available_memory() -> float | None:
    """Memory this process could still take [bytes] (``MemAvailable`` of the OS), or None when unknown."""
    try:
        import psutil

        return float(psutil.virtual_memory().available)
    except Exception:  # psutil missing (it comes with dask, not with the core install)
        pass
    try:
        import os

        return float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


#: the share of the available memory (:func:`available_memory`) one command's arrays may take
MEMORY_SHARE = 0.8


def memory_room(per_item: float) -> float:
    """How many items of ``per_item`` bytes fit in :data:`MEMORY_SHARE` of the available memory (0 when unknown)."""
    return MEMORY_SHARE * (available_memory() or 0.0) / per_item


def check_memory(field: str, value: int, nbytes: float, what: str, largest: int) -> None:
    """Refuse, before any work, a run whose arrays would not fit in the memory this machine has available.

    ``nbytes`` [bytes] is what the run keeps at once (``what`` says which arrays), ``largest`` the largest
    ``value`` that would fit (:func:`memory_room`); a run that would only fail on its allocation after minutes of
    sampling (or swap the machine) fails here with the field, the need and the limit instead.

    Raises:
        InputError: naming ``field`` and ``value``, the memory needed and available, and ``largest``.
    """
    avail = available_memory()
    if avail is not None and nbytes > MEMORY_SHARE * avail:
        raise InputError(field, value, f"needs ~{_gb(nbytes)} of memory ({what}), this machine has "
                                       f"{_gb(avail)} available; use at most {largest:,}")


def samples(n, field: str = "--samples", minimum: int = 100) -> int:
    """A sample count in [``minimum``, :data:`MAX_SAMPLES`] whose memory (:data:`BYTES_PER_SAMPLE` each) fits
    in this machine's available memory, checked before anything is allocated.

    Raises:
        InputError: too few, too many (with the memory they would need), or more than the memory holds
            (saying how much is needed and how much there is).
    """
    try:
        if isinstance(n, bool):
            raise TypeError
        k = operator.index(n)
    except TypeError:
        raise InputError(field, n, "a whole number of samples, e.g. 4000") from None
    if k < minimum:
        raise InputError(field, n, f"need at least {minimum} samples")
    need = k * BYTES_PER_SAMPLE
    avail = available_memory()
    has = f", this machine has {_gb(avail)} available" if avail is not None else ""
    if k > MAX_SAMPLES:
        raise InputError(field, n, f"at most {MAX_SAMPLES:,} samples: this many needs ~{_gb(need)} of memory{has} "
                                   f"(the default 4 000 is usually plenty)")
    if avail is not None and need > MEMORY_SHARE * avail:
        raise InputError(field, n, f"needs ~{_gb(need)} of memory, this machine has {_gb(avail)} available; "
                                   f"use at most ~{int(memory_room(BYTES_PER_SAMPLE)):,} samples")
    return int(k)


def _gb(nbytes: float) -> str:
    return f"{nbytes / 1e9:.3g} GB" if nbytes < 1e12 else f"{nbytes / 1e12:,.0f} TB"


__all__ = ["BYTES_PER_SAMPLE", "MAX_CHATTER_HZ", "MAX_RPM", "MAX_SAMPLES", "MEMORY_SHARE", "MIN_RPM", "SEED_LIMIT",
           "available_memory", "check_memory", "check_speeds", "memory_room", "samples", "seed", "speed_rule"]
