"""Large studies on a Dask cluster (the optional extra ``millstab[dask]``).

The embarrassingly parallel studies (Monte Carlo, Sobol, Morris; any batch of parameter sets through an
engine's ``envelope_batch``) cut their rows into tasks and run them on ``dask.distributed`` workers:

* :func:`open_client` -- ``--dask ADDRESS`` connects to a running scheduler; ``--workers N`` starts a
  ``LocalCluster`` of N worker processes (one thread each) for the run and closes it afterwards;
  neither: ``None`` and the study runs in this process as before (dask is then never imported).
* :func:`warm` -- numba compiled once per worker, without cache races: the first worker compiles
  alone (and writes the on-disk cache, ``NUMBA_CACHE_DIR``), then the others start together and load
  it. Numba writes each cache file atomically, but the index of a source file is read-modify-written,
  so workers compiling at once all pay the compile and can overwrite each other's entries. The warm
  call also times a small batch, from which :func:`task_rows` sizes the tasks.
* :func:`stream` -- submits tasks a window at a time and hands each result to the caller as it arrives
  (``as_completed``), exactly once, so the caller aggregates into preallocated arrays and the client
  holds only a few tasks' results. A worker lost mid-run is handled by the scheduler: its tasks are run
  again elsewhere; every task is a pure function of its inputs, so a re-run returns the same numbers.

* :func:`depths` -- any batch of parameter sets through an engine (SDM / spectral maps, Sobol, Morris);
  :func:`sample_limits` -- the Bayesian likelihood's sweeps and the P(stable) map by sample rows, sent out
  only where a measured probe says the work pays (:data:`PAYS_SECONDS`). Both hand every task the whole
  batch's pinned settings (``Forward.pinned``: the interrupted-cutting engines choose their discretisation per batch).

Each task runs numba with ONE thread (the parallelism is the cluster's): one worker process per core.
Results do not depend on how the rows are cut (the engines evaluate every row independently, and the
Monte Carlo draws are addressed by path index), so the same seed gives the same numbers, bit for bit,
in this process and on any number of workers.
"""

from __future__ import annotations

import contextlib
import logging
import os
import time
import uuid
from itertools import islice
from typing import Any, Callable, Iterator, Sequence

import numpy as np

from millstab.errors import InputError

#: target CPU seconds of work per task: ≥ 1 s makes dask's per-task cost (~1–10 ms) negligible, while many
#: tasks per worker keep the load balanced and make a lost worker cheap
TASK_SECONDS = 2.0
#: tasks submitted per worker thread before results come back: workers never wait, and the cluster holds
#: at most this many unfetched results per thread (bounded memory, however many tasks the study has)
IN_FLIGHT_PER_THREAD = 3
#: environment of the workers this module starts: BLAS single-threaded (one process per core). Numba's
#: thread count is NOT set here but per task (:func:`one_thread`): a worker imports the caller's main module
#: (numba with it) before Dask applies this environment, and numba refuses a NUMBA_NUM_THREADS that changed
#: after its threads started ("Cannot set NUMBA_NUM_THREADS to a different value once the threads have been
#: launched", at the first compile: a cold cache failed every task); setting it before the spawn instead
#: leaks it into this process for good (Dask's nanny updates os.environ and never restores it), where the
#: same error then hits this process's next compile
WORKER_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
#: dask settings of the local clusters this module starts (docs/cluster.md has the paired measurements):
#: the statistical profiler (a thread sampling every thread's stack every 10 ms, for the dashboard) off:
#: ~3 % of the workers' CPU; the event loops' tick monitor (20 ms, it only warns of a blocked loop) and the
#: memory monitors (100 ms) at 1 s: the idle cluster's CPU falls from ~0.07 to ~0.017 CPU-s per second, which
#: on 2 cores is ~3 % of the machine the engine gets back. The tasks' memory is bounded by the engine's chunk,
#: so a memory check a second is enough.
WORKER_CONFIG = {"distributed.worker.profile.enabled": False, "distributed.admin.tick.interval": "1s",
                 "distributed.worker.memory.monitor-interval": "1s"}
_EXTRA = "needs the optional extra: pip install 'millstab[dask]' (dask[distributed])"


def _distributed(field: str, value: Any):
    try:
        import distributed
    except ImportError:  # pragma: no cover (CI installs the extra)
        raise InputError(field, value, _EXTRA) from None
    return distributed


def check_client(client: Any) -> Any:
    """``client`` if it is a ``distributed.Client``, else InputError naming ``client``."""
    distributed = _distributed("client", type(client).__name__)
    if not isinstance(client, distributed.Client):
        raise InputError("client", type(client).__name__, "need a distributed.Client (or None: run in this process)")
    return client


#: how long a scheduler address may take to answer as a Dask scheduler [s]: a scheduler sends its handshake
#: within milliseconds of a connection; a web server (the dashboard, port 8787) sends nothing until asked
CONNECT_SECONDS = 10.0
#: address schemes of dask.distributed's comms
SCHEMES = ("tcp", "tls", "ucx", "ws", "wss", "inproc")
_EXAMPLE = "e.g. tcp://10.0.0.5:8786 (printed as 'Scheduler at:' by `dask scheduler`)"


def scheduler_address(text: Any, field: str = "--dask") -> str:
    """``--dask`` text as a scheduler address ``SCHEME://HOST:PORT`` (``HOST:PORT`` means tcp).

    Raises:
        InputError: not text, an http(s) address (the dashboard's: the scheduler is usually tcp://HOST:8786),
            an unknown scheme, no host, or no port / a port outside 1..65535.
    """
    if not isinstance(text, str) or not text.strip():
        raise InputError(field, text, f"need a scheduler address, {_EXAMPLE}")
    addr = text.strip()
    scheme, sep, rest = addr.partition("://")
    if not sep:
        scheme, rest = "tcp", addr
    scheme = scheme.lower()
    if scheme in ("http", "https"):
        host = rest.split("/", 1)[0].rsplit(":", 1)[0] or "HOST"
        raise InputError(field, text, f"that is a web address (the Dask dashboard's, usually port 8787); the "
                                      f"scheduler's is usually tcp://{host}:8786")
    if scheme not in SCHEMES:
        raise InputError(field, text, f"unknown scheme {scheme!r} (known: {', '.join(SCHEMES)}); {_EXAMPLE}")
    if scheme == "inproc":
        return addr
    hostport = rest.split("/", 1)[0]
    host, colon, port = hostport.rpartition(":")
    if not colon or not host.strip("[]") or not port.isdigit() or not 0 < int(port) < 65536:
        raise InputError(field, text, f"need HOST:PORT with a port in 1..65535, {_EXAMPLE}")
    return f"{scheme}://{hostport}"


def probe_scheduler(address: str, timeout_s: float = CONNECT_SECONDS, field: str = "--dask",
                    shown: str | None = None) -> None:
    """Check that a Dask scheduler answers at the tcp ``address`` within ``timeout_s``, without dask: connect
    and read the handshake a scheduler sends at once (msgpack naming its ``compression`` and ``python``).
    A closed port, an unknown host or a server of another kind (a web server waits for a request and sends
    nothing) fails here in at most ~``timeout_s`` seconds, where ``distributed.Client`` would wait for ever
    on a server that accepts and never answers. Other schemes (tls, ucx, ...) are left to dask. ``shown``:
    the address as the user wrote it (for the message; default ``address``).

    Raises:
        InputError: naming the address and what answered there.
    """
    import socket

    if not address.startswith("tcp://"):
        return
    given = address if shown is None else shown
    host, _, port = address[len("tcp://"):].rpartition(":")
    host = host.strip("[]")
    advice = "start one with `dask scheduler` (and workers with `dask worker ADDRESS`), or use --workers N"
    try:
        sock = socket.create_connection((host, int(port)), timeout=timeout_s)
    except socket.gaierror:
        raise InputError(field, given, f"unknown host {host!r}; {_EXAMPLE}") from None
    except (socket.timeout, TimeoutError):
        raise InputError(field, given, f"no answer from {host}:{port} in {timeout_s:g} s (a firewall, or no such "
                                         f"machine); {advice}") from None
    except OSError as exc:
        raise InputError(field, given, f"nothing listens there ({exc.strerror or exc}); {advice}") from None
    data = b""
    try:
        sock.settimeout(timeout_s)
        deadline = time.monotonic() + timeout_s
        while len(data) < 256 and time.monotonic() < deadline:
            chunk = sock.recv(256)
            if not chunk:
                break
            data += chunk
            if b"compression" in data or b"pickle-protocol" in data:
                return
    except (socket.timeout, TimeoutError):
        pass
    except OSError:
        pass
    finally:
        sock.close()
    if not data:
        what = (f"something accepts connections there but sent nothing in {timeout_s:g} s: not a Dask scheduler "
                "(a web server, e.g. the dashboard, waits for a request)")
    elif data[:5] in (b"HTTP/", b"<!DOC", b"<html"):
        what = "a web server answers there, not a Dask scheduler"
    else:
        what = f"something that is not a Dask scheduler answers there ({data[:16]!r})"
    raise InputError(field, given, f"{what}; the scheduler's address is usually tcp://HOST:8786")


@contextlib.contextmanager
def open_client(address: str | None = None, workers: int | None = None, *,
                timeout_s: float = CONNECT_SECONDS) -> Iterator[Any]:
    """A ``distributed.Client`` for the run, or None when neither ``address`` nor ``workers`` is given.

    Args:
        address: a running scheduler (``tcp://host:8786``, as printed by ``dask scheduler``; ``host:8786``
            means tcp).
        workers: start a local cluster of this many worker processes (one thread each), closed on exit.
        timeout_s: how long a scheduler at ``address`` may take to answer [s] (:data:`CONNECT_SECONDS`).

    Raises:
        InputError: both given, ``workers`` < 1, a malformed or http address, no scheduler answering at
            ``address`` in ``timeout_s`` (:func:`probe_scheduler`), or dask not installed.
    """
    if address is None and workers is None:
        yield None
        return
    if address is not None and workers is not None:
        raise InputError("--dask", address, "give either --dask ADDRESS (a running scheduler) or --workers N, not both")
    if address is not None:
        addr = scheduler_address(address)
        distributed = _distributed("--dask", address)
        probe_scheduler(addr, timeout_s, shown=address)
        try:
            client = distributed.Client(addr, timeout=timeout_s)
        except (OSError, TimeoutError, ValueError) as exc:
            raise InputError("--dask", address, f"no Dask scheduler answered there ({exc}); start one with "
                             "`dask scheduler` and workers with `dask worker ADDRESS`, or use --workers N") from None
        with client:
            yield client
        return
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise InputError("--workers", workers, "number of local worker processes must be an integer >= 1")
    cores = os.cpu_count() or 1
    if workers > 4 * cores:  # each worker is a process with its own numba and numpy (~200 MB): bound the start
        raise InputError("--workers", workers, f"this machine has {cores} cores: a local cluster takes at most "
                                               f"{4 * cores} worker processes (one per core is best; each is a "
                                               f"Python process of ~200 MB); use --dask ADDRESS for more")
    distributed = _distributed("--workers", workers)
    import dask

    # dask's nanny starts workers with MALLOC_TRIM_THRESHOLD_=65536: glibc then hands freed memory back at once
    # and the engine's arrays page-fault in again on every call (measured: ~16 % more CPU, 4.5x the minor
    # faults); the engine's memory is bounded by its chunk, so the workers keep glibc's default
    with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None, **WORKER_CONFIG}):
        # dashboard on a free port (":0"): the scheduler's HTTP server starts anyway, and the default :8787 may be taken
        with distributed.LocalCluster(n_workers=int(workers), threads_per_worker=1, processes=True,
                                      dashboard_address=":0", env=WORKER_ENV, silence_logs=logging.ERROR) as cluster:
            with distributed.Client(cluster) as client:
                yield client


def one_thread() -> None:
    """Numba single-threaded in the calling thread (numba's thread count is per calling thread, so every
    task sets it): the cluster supplies the parallelism, threads inside a task would oversubscribe."""
    import numba

    numba.set_num_threads(1)


def _warm_task(engine: str, par, cutting, rpm: np.ndarray, probe_rows: int) -> float:
    """On a worker: compile (or load) the engine with one tiny call, then time ``probe_rows`` rows;
    returns CPU seconds per row."""
    from millstab.forward import forward

    one_thread()
    f = forward(par, cutting, engine)
    theta = par.theta0[None, :]
    f(theta, rpm[: min(2, rpm.size)])
    # CPU time of this thread (numba on one thread runs here), not the wall clock: on a crowded machine the
    # wall clock of a few milliseconds is mostly waiting, and tasks sized by it would be far too small
    t0 = time.thread_time()
    f(theta, rpm)
    one = time.thread_time() - t0
    if one * probe_rows > 0.5:  # an expensive engine (sdm: ~1 s per set): one set times it well enough
        return one
    rows = np.repeat(theta, probe_rows, axis=0)
    t0 = time.thread_time()
    f(rows, rpm)
    return (time.thread_time() - t0) / probe_rows


#: how long a study waits for a worker of a cluster that has none at the moment [s] (a nanny restarting a lost one)
WORKER_WAIT_S = 60.0


def live_workers(client: Any) -> list[str]:
    """The addresses of the workers the scheduler holds now, asked of the scheduler itself, waiting up to
    :data:`WORKER_WAIT_S` for one if there is none. Why not ``client.scheduler_info()``: the client refreshes that
    copy every few seconds, so right after a worker was lost (and its nanny started another) it named a dead worker or
    none, and a study failed with "no workers" on a cluster of two (CI, 2026-11-29)."""
    def names(dask_scheduler=None) -> list[str]:
        return sorted(dask_scheduler.workers)

    workers = client.run_on_scheduler(names)
    if not workers:
        try:
            client.wait_for_workers(1, timeout=WORKER_WAIT_S)
        except (TimeoutError, OSError):
            return []
        workers = client.run_on_scheduler(names)
    return list(workers)


def warm(client: Any, engine: str, par, cutting, rpm: np.ndarray, probe_rows: int = 32) -> float:
    """Compile the engine on every worker, the first one alone (see the module docstring), and return
    the median CPU seconds per parameter set (row) at these speeds on one worker thread."""
    workers = live_workers(client)
    if not workers:
        raise InputError("client", str(client), f"the Dask cluster has no workers (waited {WORKER_WAIT_S:g} s)")
    first = client.submit(_warm_task, engine, par, cutting, rpm, probe_rows, workers=workers[:1],
                          allow_other_workers=False, pure=False, key=f"millstab-warm-{uuid.uuid4().hex[:8]}-0")
    times = [first.result()]
    rest = [client.submit(_warm_task, engine, par, cutting, rpm, probe_rows, workers=[w], allow_other_workers=False,
                          pure=False, key=f"millstab-warm-{uuid.uuid4().hex[:8]}-{i}")
            for i, w in enumerate(workers[1:], 1)]
    times += client.gather(rest)
    return float(np.median(times))


def task_rows(seconds_per_row: float, limit: int) -> int:
    """Rows per task for :data:`TASK_SECONDS` of work at ``seconds_per_row``, between 1 and ``limit``
    (the engine's own chunk, which bounds a task's output memory)."""
    if not np.isfinite(seconds_per_row) or seconds_per_row <= 0:
        return int(limit)
    return int(min(limit, max(1, round(TASK_SECONDS / seconds_per_row))))


def rows_into(out: np.ndarray, starts: Sequence[int], progress: Callable[[int, int], None] | None = None):
    """An ``on_result`` for :func:`stream` whose task i returns the rows that begin at ``starts[i]`` of
    ``out``: each block is written in place as it arrives, then ``progress(rows done, rows in all)``."""
    done = [0]

    def take(i: int, rows: np.ndarray) -> None:
        s = starts[i]
        out[s:s + rows.shape[0]] = rows
        done[0] += rows.shape[0]
        if progress:
            progress(done[0], out.shape[0])

    return take


def stream(client: Any, func: Callable[..., Any], tasks: Sequence[tuple], on_result: Callable[[int, Any], None],
           common: tuple = (), name: str = "task") -> None:
    """Run ``func(*common, *tasks[i])`` for every i on the cluster; call ``on_result(i, value)`` once per
    task, in the order results arrive.

    At most :data:`IN_FLIGHT_PER_THREAD` tasks per worker thread are submitted ahead; each result is
    released on the cluster once handed over. A task that fails raises here (the others are cancelled).
    """
    from distributed import as_completed

    threads = max(1, sum(client.nthreads().values()))
    todo = iter(range(len(tasks)))
    tag = f"millstab-{name}-{uuid.uuid4().hex[:8]}"
    index: dict[str, int] = {}
    pending: dict[str, Any] = {}  # key -> future not yet handed over (cancelled if we stop early)
    received = np.zeros(len(tasks), dtype=bool)
    queue = as_completed()

    def submit(i: int) -> None:
        fut = client.submit(func, *common, *tasks[i], key=f"{tag}-{i}", pure=False)
        index[fut.key] = i
        pending[fut.key] = fut
        queue.add(fut)

    try:
        for i in islice(todo, IN_FLIGHT_PER_THREAD * threads):
            submit(i)
        for fut in queue:
            i = index.pop(fut.key)
            del pending[fut.key]
            value = fut.result()
            fut.release()
            if received[i]:  # cannot happen with one future per task; guards the "no path twice" promise
                raise RuntimeError(f"task {i} of {name} returned twice")
            received[i] = True
            on_result(i, value)
            nxt = next(todo, None)
            if nxt is not None:
                submit(nxt)
    finally:
        if pending:  # a task failed (or the caller raised): nothing else of this study should run
            client.cancel(list(pending.values()))
    if not received.all():  # pragma: no cover (as_completed yields every future)
        raise RuntimeError(f"{name}: {int((~received).sum())} tasks never returned")


def _depths_task(pinned, rows: np.ndarray) -> np.ndarray:
    """On a worker: limiting depths (R, S) [m] of parameter rows (R, P) by the pinned forward model (the one
    evaluator, :class:`millstab.forward.Pinned`), numba on one thread."""
    one_thread()
    return pinned(rows)


def depths(client: Any, engine: str, par, cutting, theta_rows: np.ndarray, rpm: np.ndarray,
           progress: Callable[[int, int], None] | None = None, chunk_rows: int | None = None,
           settings: dict | None = None) -> np.ndarray:
    """Limiting depths (R, S) [m] of many parameter rows (R, P) [SI] at speeds ``rpm`` (S,) [rev/min] on
    the cluster: the same numbers as ONE call ``forward(par, cutting, engine)(theta_rows, rpm)`` (every row
    is evaluated alone, under the whole batch's pinned settings, :meth:`millstab.forward.Forward.pinned`), for
    SDM/spectral maps as for the sensitivity studies.

    ``chunk_rows``: rows per task (default: :data:`TASK_SECONDS` of work, timed on the workers).
    ``progress(rows_done, R)`` after each task's result has arrived. ``settings``: the engine's pinned
    discretisation (:meth:`millstab.forward.Forward.pinned`; default: pinned on ``theta_rows``).
    """
    from millstab.forward import Pinned, forward

    check_client(client)
    rpm = np.asarray(rpm, dtype=float)
    theta_rows = np.asarray(theta_rows, dtype=float)
    model = forward(par, cutting, engine)
    # ONE local call chooses at its first row: so does the pinned model the tasks get
    pinned = model.pinned(rpm, theta_rows, at=theta_rows[0]) if settings is None else Pinned(model, rpm, settings)
    return map_pinned(client, pinned, theta_rows, progress, chunk_rows)


def map_pinned(client: Any, pinned, theta_rows: np.ndarray, progress: Callable[[int, int], None] | None = None,
               chunk_rows: int | None = None) -> np.ndarray:
    """Depths (R, S) [m] of parameter rows (R, P) [SI] by the pinned forward model ``pinned``
    (:class:`millstab.forward.Pinned`) as tasks on the Dask cluster of ``client``: each task receives the model
    and calls it on its rows (as emcee's ``pool.map``), so the numbers are those of ``pinned.map(theta_rows)``
    here. ``chunk_rows``, ``progress``: as :func:`depths`."""
    from millstab.stability import get_engine

    check_client(client)
    theta_rows = np.atleast_2d(np.asarray(theta_rows, dtype=float))
    n, f = theta_rows.shape[0], pinned.forward
    sec = warm(client, f.engine, f.par, pinned.conditions, pinned.rpm)
    per = chunk_rows or task_rows(sec, get_engine(f.engine).chunk_rows(pinned.rpm.size))
    starts = range(0, n, per)
    out = np.empty((n, pinned.rpm.size))
    stream(client, _depths_task, [(theta_rows[s:s + per],) for s in starts], rows_into(out, starts, progress),
           common=(pinned,), name="depths")
    return out


# ---- the Bayesian sampler's likelihood and the P(stable) map: rows = posterior samples ----------------------

#: a batch of samples goes to the cluster only when its engine work is estimated at ≥ this many CPU-seconds
#: (timed on a worker, :func:`seconds_per_row`): below, a round trip to the cluster (submitting, pickling the
#: prior, gathering; tens of milliseconds) and the split would cost more than they save. The zero-order
#: engine's sweep of 4 000 samples at a few cut speeds is milliseconds: it stays in this process; the
#: interrupted-cutting engines (sdm, spectral) take seconds per sweep and go out.
PAYS_SECONDS = 1.0
_probed: dict[tuple, float] = {}


def seconds_per_row(client: Any, engine: str, par, cutting, rpm: np.ndarray) -> float:
    """Worker CPU seconds per parameter set at these speeds (one :func:`warm` per client, engine, speed
    count and parameter count; remembered for the client's lifetime)."""
    key = (client.id, engine, int(rpm.size), int(par.size), len(par.base.x), len(par.base.y))
    if key not in _probed:
        _probed[key] = warm(client, engine, par, cutting, rpm, probe_rows=8)
    return _probed[key]


def _samples_task(prior, pinned, with_freq: bool, u: np.ndarray, cap: np.ndarray | None = None,
                  low: np.ndarray | None = None):
    """On a worker: :func:`millstab.update.likelihood.sample_depths` of the sample rows ``u`` by the whole
    batch's pinned forward model (depths [mm], chatter frequencies [Hz] or None; ``cap``, ``low``: these rows'
    ceilings and floors [mm]), numba on one thread."""
    from millstab.update.likelihood import sample_depths  # the local path's own function: one evaluator

    one_thread()
    return sample_depths(pinned, prior, u, with_freq, cap, low)


def sample_limits(client: Any, prior, u: np.ndarray, rpm: np.ndarray, engine: str,
                  with_freq: bool = False, conditions=None,
                  pinned=None, ceiling_mm: np.ndarray | None = None,
                  floor_mm: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None] | None:
    """Limiting depths (B, S) [mm] (and chatter frequencies (B, S) [Hz] or None) of the samples u = ln θ
    (B, P) on the cluster, split by rows into at least one task per worker thread (more for > 2 s each),
    exactly as :func:`millstab.update.likelihood.limits` computes them here (each row is evaluated alone:
    the same numbers; ``pinned``: the caller's pinned forward model of these rows,
    :func:`millstab.update.likelihood.pinned_model`, made here by default; ``ceiling_mm``, ``floor_mm`` (B, S):
    the likelihood's censored and floored search, each task with its rows'). Returns None when it does not pay
    (:data:`PAYS_SECONDS`): the caller runs here."""
    from millstab.stability import check_rpm

    check_client(client)
    rpm = check_rpm(rpm)
    u = np.asarray(u, dtype=float)
    n = u.shape[0]
    work = n * seconds_per_row(client, engine, prior.par, prior.cutting, rpm)
    if work < PAYS_SECONDS:
        return None
    threads = max(1, sum(client.nthreads().values()))
    tasks = min(n, max(threads, int(np.ceil(work / TASK_SECONDS))))
    per = -(-n // tasks)
    starts = range(0, n, per)
    depth = np.empty((n, rpm.size))
    hz: list[np.ndarray | None] = [None]

    def take(i: int, value) -> None:
        d, h = value
        s = starts[i]
        depth[s:s + d.shape[0]] = d
        if h is not None:
            if hz[0] is None:
                hz[0] = np.empty((n, rpm.size))
            hz[0][s:s + h.shape[0]] = h

    if pinned is None:  # the likelihood's own evaluator of these samples (its discretisation, its rows)
        from millstab.update.likelihood import pinned_model

        pinned = pinned_model(prior, u, rpm, engine, conditions)
    # pinned once here: every task's rows give the numbers of ONE local call on all of them
    def rows(a, s):
        return None if a is None else np.asarray(a, float)[s:s + per]

    stream(client, _samples_task, [(u[s:s + per], rows(ceiling_mm, s), rows(floor_mm, s)) for s in starts], take,
           common=(prior, pinned, with_freq), name="samples")
    return depth, hz[0]
