"""Large studies on a Dask cluster (millstab.cluster): the same numbers as in this process, bit for bit,
with a LocalCluster of 2 worker processes; a worker killed mid-run loses and duplicates no path; and
without a cluster dask is never imported."""

from __future__ import annotations

import importlib.util
import json
import os
import signal
import subprocess
import sys

import numpy as np
import pytest

from millstab.datasets import load_example
from millstab.errors import InputError
from millstab.forward import forward
from millstab.params import Parameterization
from millstab.sensitivity import monte_carlo, morris, mse_mm2, predicted_theta, sobol
from millstab.sensitivity.montecarlo import draws
from configs import TWO_MODE_TOML

CFG = load_example("ex1")
THETA = predicted_theta("ex1")
RPM = np.linspace(2000.0, 12000.0, 60)


def test_draws_are_rows_of_the_plain_stream():
    """Each block jumps to its first path: the rows equal those of one sequential default_rng stream."""
    full = np.random.default_rng(11).random((500, 6))
    for start, count in ((0, 500), (0, 1), (1, 7), (137, 200), (499, 1)):
        np.testing.assert_array_equal(draws(11, start, count, 6), full[start:start + count])


@pytest.mark.slow
def test_without_a_cluster_dask_is_not_imported():
    """No millstab code imports dask or distributed without a cluster. (pint itself imports ``dask.base``
    when dask is installed, for its dask-array support; those modules are the baseline, taken after
    ``import pint`` alone.)"""
    code = (
        "import sys\n"
        "def ours(): return {m for m in sys.modules if m.split('.')[0] in ('dask', 'distributed')}\n"
        "import pint\n"
        "baseline = ours()\n"
        "import numpy as np\n"
        "import millstab.cli, millstab.cluster, millstab.sensitivity as s\n"
        "from millstab.cli import main\n"
        "from millstab.datasets import load_example\n"
        "c = load_example('ex1'); r = np.linspace(3000, 9000, 8)\n"
        "s.monte_carlo(c.structure, c.cutting, r, n=3)\n"
        "s.sobol(c.structure, c.cutting, r, n=2)\n"
        "assert main(['sensitivity', 'mc', 'example:ex1', '--n', '3', '--rpm', '3000:9000:1000']) == 0\n"
        "extra = sorted(ours() - baseline)\n"
        "assert not extra, extra\n"
        "assert 'distributed' not in sys.modules\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=os.environ.copy())
    assert proc.returncode == 0, proc.stderr[-2000:]


def test_client_arguments_are_checked():
    from millstab.cluster import open_client

    with pytest.raises(InputError, match="--dask"):
        with open_client("tcp://127.0.0.1:8786", 2):
            pass
    with pytest.raises(InputError, match="--workers"):
        with open_client(workers=0):
            pass
    with open_client() as client:
        assert client is None


#: the cluster tests need dask[distributed] (the millstab[dask] extra; `make test` and CI install it)
needs_distributed = pytest.mark.skipif(importlib.util.find_spec("distributed") is None,
                                       reason="dask[distributed] is not installed (pip install 'millstab[dask]')")


@pytest.fixture(scope="module")
def client():
    from millstab.cluster import open_client

    with open_client(workers=2) as c:
        yield c


def _mc_by_hand(n, t, eps, seed, rpm):
    """Algorithm 2 written out: every path's draws from one plain stream, ONE engine call on all rows."""
    par = Parameterization(CFG.structure)
    star = THETA * (1.0 + t * (2.0 * np.random.default_rng(seed).random((n, 6)) - 1.0))
    rows = [star]
    for j in range(6):
        r = star.copy()
        r[:, j] *= 1.0 + eps
        rows.append(r)
    d = forward(par, CFG.cutting)(np.concatenate(rows), rpm).reshape(7, n, rpm.size)
    return np.stack([mse_mm2(d[0], d[1 + j]) for j in range(6)], axis=1)


@needs_distributed
def test_bad_client_is_rejected_before_any_work():
    with pytest.raises(InputError, match="client"):
        monte_carlo(CFG.structure, CFG.cutting, RPM, n=4, client="tcp://127.0.0.1:8786")
    with pytest.raises(InputError, match="client"):
        sobol(CFG.structure, CFG.cutting, RPM, n=4, client=object())


@needs_distributed
@pytest.mark.slow
def test_mc_on_cluster_equals_local_bit_for_bit(client):
    kw = dict(n=65, t=0.1, eps=0.01, seed=7, theta=THETA)
    here = monte_carlo(CFG.structure, CFG.cutting, RPM, **kw)
    there = monte_carlo(CFG.structure, CFG.cutting, RPM, chunk_paths=13, client=client, **kw)  # 5 tasks
    auto = monte_carlo(CFG.structure, CFG.cutting, RPM, client=client, **kw)  # tasks sized on the workers
    np.testing.assert_array_equal(there.mse_mm2, here.mse_mm2)
    np.testing.assert_array_equal(auto.mse_mm2, here.mse_mm2)
    np.testing.assert_array_equal(there.mse_mm2, _mc_by_hand(65, 0.1, 0.01, 7, RPM))
    assert there.mean.tolist() == here.mean.tolist() and there.sd.tolist() == here.sd.tolist()


@needs_distributed
def test_sobol_and_morris_on_cluster_equal_local_bit_for_bit(client):
    kw = dict(t=0.1, seed=3, theta=THETA)
    a = sobol(CFG.structure, CFG.cutting, RPM, n=16, **kw)
    b = sobol(CFG.structure, CFG.cutting, RPM, n=16, client=client, chunk_rows=23, **kw)
    for out in ("mse", "minimum", "blim"):
        for key in ("S1", "S1_conf", "ST", "ST_conf"):
            np.testing.assert_array_equal(getattr(b, out)[key], getattr(a, out)[key])
    m1 = morris(CFG.structure, CFG.cutting, RPM, trajectories=6, **kw)
    m2 = morris(CFG.structure, CFG.cutting, RPM, trajectories=6, client=client, chunk_rows=9, **kw)
    for out in ("mse", "minimum"):
        for key, v in m1.outputs[out].items():
            np.testing.assert_array_equal(m2.outputs[out][key], v)


@needs_distributed
def test_cli_dask_address_gives_the_local_numbers(client, tmp_path):
    """``--dask ADDRESS`` (here the fixture's scheduler; ``--workers N`` starts the same LocalCluster as the
    fixture, through the same open_client) prints and writes the local run's numbers."""
    from millstab.cli import main

    args = ["sensitivity", "mc", "example:ex1", "--n", "30", "--rpm", "2000:12000:500", "--seed", "5"]
    assert main(args + ["--out", str(tmp_path / "here.json")]) == 0
    assert main(args + ["--dask", client.scheduler.address, "--out", str(tmp_path / "there.json")]) == 0
    here, there = (json.loads((tmp_path / f).read_text()) for f in ("here.json", "there.json"))
    assert here == there
    assert main(args + ["--workers", "2", "--dask", client.scheduler.address]) == 2


@needs_distributed
def test_worker_killed_mid_run_loses_and_duplicates_no_path(client):
    """One of the 2 workers dies (SIGKILL) after the first block has arrived; the scheduler re-runs its
    tasks elsewhere. Every path arrives exactly once and the table is the local one, bit for bit."""
    n, chunk = 400, 10
    kw = dict(n=n, t=0.1, eps=0.01, seed=21, theta=THETA)
    here = monte_carlo(CFG.structure, CFG.cutting, RPM, **kw)
    victim = sorted(client.scheduler_info()["workers"])[0]
    pid = client.run(os.getpid, workers=[victim])[victim]
    seen = []

    def progress(done, total):
        seen.append(done)
        if len(seen) == 1:
            os.kill(pid, signal.SIGKILL)  # a hard loss, as of a node: no goodbye to the scheduler

    there = monte_carlo(CFG.structure, CFG.cutting, RPM, chunk_paths=chunk, client=client, progress=progress, **kw)
    from millstab.cluster import live_workers

    assert victim not in live_workers(client)  # it did die (the nanny restarts a new one)
    client.wait_for_workers(2, timeout=120)  # the module's other tests want both workers back
    steps = np.diff([0] + seen)
    assert seen[-1] == n and len(seen) == n // chunk and (steps == chunk).all()  # each block once, none lost
    np.testing.assert_array_equal(there.mse_mm2, here.mse_mm2)


@needs_distributed
@pytest.mark.slow
def test_workers_compile_when_the_main_module_imports_numba(tmp_path):
    """A worker process imports the caller's main module before the nanny applies its ``env``; with numba
    imported there, the workers' first compile (a cold cache) failed ("Cannot set NUMBA_NUM_THREADS to a
    different value once the threads have been launched"). Numba's thread count is now set per task only:
    a fresh function compiles on the worker after :func:`one_thread`, and in this process after the
    cluster (a NUMBA_NUM_THREADS set before the spawn stayed in this process's environment and broke it)."""
    script = tmp_path / "main_with_numba.py"
    script.write_text(
        "import numba\n"
        "def task():\n"
        "    from millstab.cluster import one_thread\n"
        "    one_thread()\n"
        "    return numba.njit(lambda x: x + 1)(41), numba.get_num_threads()\n"
        "if __name__ == '__main__':\n"
        "    from millstab.cluster import open_client\n"
        "    numba.njit(lambda x: x)(0), numba.get_num_threads()  # this process's threads started\n"
        "    with open_client(workers=1) as c:\n"
        "        print(c.submit(task, pure=False).result())\n"
        "        numba.njit(lambda x: x - 1)(1)\n"
        "    print(numba.njit(lambda x: x * 2)(21))\n")
    proc = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=os.environ.copy(),
                          cwd=tmp_path, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.split() == ["(42,", "1)", "42"]


@needs_distributed
@pytest.mark.parametrize("engine", ["spectral", "sdm"])
@pytest.mark.slow
def test_interrupted_engine_depths_on_cluster_equal_one_local_call(client, engine):
    """SDM / spectral maps on the cluster: the rows split over tasks give the numbers of ONE local call on
    all rows. These engines choose their discretisation from the whole batch (sdm: steps from the highest
    natural frequency; spectral: nodes from a check on the first set), so each task is told the whole
    batch's choice (``split_settings``); without it the parts differed (sdm ~1e-6, spectral ~0.4 %)."""
    from millstab import cluster

    par = Parameterization(CFG.structure)
    rng = np.random.default_rng(4)
    rows = THETA * (1 + 0.1 * (2 * rng.random((2 if engine == "sdm" else 7, 6)) - 1))  # sdm: ~1 s per set
    rows[1, 3] *= 1.15  # the highest mode is not the first row's (sdm's steps follow the batch maximum)
    rpm = np.array([4000.0, 10500.0]) if engine == "sdm" else np.array([4000.0, 7000.0, 10500.0])
    here = forward(par, CFG.cutting, engine)(rows, rpm)
    there = cluster.depths(client, engine, par, CFG.cutting, rows, rpm, chunk_rows=1 if engine == "sdm" else 2)
    np.testing.assert_array_equal(there, here)


TOML = TWO_MODE_TOML


@needs_distributed
@pytest.mark.slow
def test_update_and_map_on_cluster_give_the_local_posterior(client, monkeypatch, tmp_path):
    """Same seed, same posterior with and without a client (spectral engine, a measured chatter frequency:
    depths and frequencies come back from the workers), and the same P(stable) map through the CLI's
    ``map --dask``; the cluster forced (PAYS_SECONDS = 0) since this small case would stay here."""
    from millstab import cluster
    from millstab.cli import main
    from millstab.io.config import parse_config
    from millstab.points import PointSet
    from millstab.update import update

    cfg = parse_config(TOML)
    cuts = PointSet([6000.0, 8000.0], [3.0, 1.0], ["chatter", "stable"], chatter_hz=[1010.0, float("nan")])
    here = update(cfg, cuts, engine="spectral", samples=16, seed=3, moves=1)
    calls = []
    stream = cluster.stream
    monkeypatch.setattr(cluster, "stream", lambda *a, **k: calls.append(1) or stream(*a, **k))
    monkeypatch.setattr(cluster, "PAYS_SECONDS", 0.0)
    there = update(cfg, cuts, engine="spectral", samples=16, seed=3, moves=1, client=client)
    # every engine call went out: the spectral ones and the zero-order screen's (delayed acceptance)
    d = there.diagnostics
    assert len(calls) == d["loglik_calls"] + d["screen_calls"] and d["loglik_calls"] > 1 and d["frequency_term"]
    np.testing.assert_array_equal(there.samples, here.samples)
    post = tmp_path / "post.json"
    post.write_text(json.dumps(here.to_json()))
    args = ["map", str(post), "--rpm", "5000:9000:1000", "--depth", "0.5:4:0.5"]
    assert main(args + ["--out", str(tmp_path / "here.csv")]) == 0
    n = len(calls)
    assert main(args + ["--out", str(tmp_path / "there.csv"), "--dask", client.scheduler.address]) == 0
    assert len(calls) == n + 1
    assert (tmp_path / "here.csv").read_text() == (tmp_path / "there.csv").read_text()


@needs_distributed
def test_zoa_likelihood_stays_in_this_process(client):
    """Where it pays: a zoa sweep of 4 000 samples at the cut speeds is milliseconds (measured on a worker):
    no round trip; the rule (PAYS_SECONDS of estimated work) sends it out only when forced, then with the
    local numbers."""
    from millstab import cluster
    from millstab.update import make_prior
    from millstab.update.likelihood import limits

    prior = make_prior(CFG.structure, CFG.cutting)
    u = prior.sample(4000, np.random.default_rng(0))
    rpm = np.array([5000.0, 6500.0, 9000.0])
    assert cluster.sample_limits(client, prior, u, rpm, "zoa") is None
    old = cluster.PAYS_SECONDS
    try:
        cluster.PAYS_SECONDS = 0.0
        depth, hz = cluster.sample_limits(client, prior, u, rpm, "zoa", True)
    finally:
        cluster.PAYS_SECONDS = old
    d0, h0 = limits(prior, u, rpm, "zoa", True)
    np.testing.assert_array_equal(depth, d0)
    np.testing.assert_array_equal(hz, h0)


@needs_distributed
@pytest.mark.slow
def test_mixed_conditions_and_free_kr_on_cluster_give_the_local_limits(client):
    """Per-column conditions and a Kr per sample travel with the tasks: the forced cluster sweep is the local one."""
    from millstab import cluster
    from millstab.config import PriorTable
    from millstab.model import Conditions, Cutting
    from millstab.update import make_prior
    from millstab.update.likelihood import limits

    c = CFG.cutting
    prior = make_prior(CFG.structure, c, PriorTable(spreads={"kr": 0.2}))
    cond = Conditions.of([c, Cutting.from_immersion(c.teeth, c.kt, c.kr, 0.3, "up")], [0, 1, 1, 0])
    u = prior.sample(200, np.random.default_rng(0))
    rpm = np.array([5000.0, 5000.0, 9000.0, 9000.0])
    old = cluster.PAYS_SECONDS
    try:
        cluster.PAYS_SECONDS = 0.0
        depth, hz = cluster.sample_limits(client, prior, u, rpm, "zoa", True, cond)
    finally:
        cluster.PAYS_SECONDS = old
    d0, h0 = limits(prior, u, rpm, "zoa", True, conditions=cond)
    np.testing.assert_array_equal(depth, d0)
    np.testing.assert_array_equal(hz, h0)


@needs_distributed
@pytest.mark.slow
@pytest.mark.parametrize("engine", ["spectral", "sdm"])
def test_interrupted_engine_study_is_the_same_local_chunked_and_on_cluster(client, engine):
    """Issue 26 ("what it must reach"): a spectral or SDM study gives the same numbers in one local call, in
    chunks of one row and as cluster tasks (each task calls the study's pinned model: ``cluster.map_pinned``),
    bit for bit. Morris over fn_x and k_x, 2 trajectories (6 structures) at 2 speeds."""
    par = Parameterization(CFG.structure, ("fn_x", "k_x"))
    rpm = np.array([6000.0, 11000.0])
    kw = {"trajectories": 2, "t": 0.2, "seed": 7, "engine": engine}
    runs = [morris(par, CFG.cutting, rpm, **kw), morris(par, CFG.cutting, rpm, chunk_rows=1, **kw),
            morris(par, CFG.cutting, rpm, client=client, chunk_rows=2, **kw)]
    for out in ("mse", "minimum"):
        for key, v in runs[0].outputs[out].items():
            assert np.all(np.isfinite(v)), (out, key)
            for other in runs[1:]:
                np.testing.assert_array_equal(other.outputs[out][key], v)
