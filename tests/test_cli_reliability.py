"""Issue 25, the command line under bad input and faults: speeds that would make the work unbounded, seeds,
sample counts beyond the machine's memory, Dask addresses that are no scheduler, the last-resort handler,
the FRF kind of a tap-test file (receptance / mobility / accelerance), and the compile notice.

Each error is one line on stderr and exit status 2, raised before any work (the commands are given inputs
that would take hours or fail later, and must answer at once)."""

from __future__ import annotations

import http.server
import json
import os
import socket
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from millstab import bounds
from millstab.cli import main
from millstab.errors import InputError

CUTS = "rpm,depth_mm,label,chatter_hz\n5000,1.0,stable,\n5500,4.0,chatter,1010\n6000,2.0,stable,\n"


def run(capsys, args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def one_line_error(code, err, *needles):
    assert code == 2, err
    assert err.count("\n") == 1 and err.startswith("millstab: error: "), err
    for n in needles:
        assert n in err, (n, err)


# ---- speeds: a floor and a ceiling, from every door --------------------------------------------------------

@pytest.mark.parametrize("args, shown", [
    (["lobes", "example:ex1", "--rpm", "0.01:2:0.01"], "'0.01:2:0.01'"),
    (["lobes", "example:ex1", "--rpm", "5000000:5000100:50"], "'5000000:5000100:50'"),
    (["sensitivity", "oat", "example:ex1", "--rpm", "0.01:2:0.01"], "'0.01:2:0.01'"),
    (["map", "{tmp}/no-posterior.json", "--rpm", "0.01:2:0.01", "--depth", "0:1:0.1", "--out", "{tmp}/m.csv"],
     "'0.01:2:0.01'"),
    (["recommend", "{tmp}/no-posterior.json", "--rpm", "0.001:0.002", "--out", "{tmp}/r.json"], "'0.001:0.002'"),
    (["simulate", "example:ex1", "--rpm", "0.001", "--depth", "1"], "0.001"),
])
def test_speeds_beyond_the_bounds_are_refused_before_any_work(capsys, tmp_path, args, shown):
    """Today these run for hours (0.01 rpm: the engines' work grows like 1/speed) or fail on the missing
    posterior after the speeds were taken."""
    args = [a.format(tmp=tmp_path) for a in args]
    code, _, err = run(capsys, args)
    one_line_error(code, err, "--rpm", shown, "10..500,000 rev/min")


def test_the_bounds_themselves_are_accepted_and_the_hint_names_the_revolution_time():
    assert bounds.check_speeds([bounds.MIN_RPM, bounds.MAX_RPM]).tolist() == [10.0, 500_000.0]
    with pytest.raises(InputError, match=r"at 0\.001 rev/min one revolution takes 16\.7 h"):
        bounds.check_speeds([0.001, 5000.0], "--rpm")
    with pytest.raises(InputError, match="extra zero"):
        bounds.check_speeds([5e6], "--rpm")
    with pytest.raises(InputError, match="10..500,000"):
        bounds.check_speeds([float("nan")], "--rpm")


def test_a_cut_at_a_thousandth_of_a_rpm_names_file_row_and_column(capsys, tmp_path):
    path = tmp_path / "cuts.csv"
    path.write_text("rpm,depth_mm,label\n# a comment line\n5000,1,stable\n0.001,1,chatter\n")
    from millstab import api

    with pytest.raises(InputError) as exc:  # every door reads cuts through PointSet
        api.points(path)
    assert exc.value.field == "cuts.csv data row 2, column rpm" and exc.value.value == 0.001
    for args in (["update", "example:ex1", path, "--out", tmp_path / "post.json"],
                 ["simulate", "example:ex1", "--cuts", path]):
        code, _, err = run(capsys, args)
        one_line_error(code, err, "cuts.csv data row 2, column rpm = 0.001", "10..500,000 rev/min")
    assert not (tmp_path / "post.json").exists()


def test_a_chatter_frequency_of_ten_megahertz_is_refused(capsys, tmp_path):
    path = tmp_path / "cuts.csv"
    path.write_text(CUTS.replace("1010", "1e7"))
    code, _, err = run(capsys, ["update", "example:ex1", path, "--out", tmp_path / "post.json"])
    one_line_error(code, err, "cuts.csv data row 2, column chatter_hz = 10000000", "at most 100,000 Hz")
    from millstab.points import PointSet

    PointSet([5000.0], [1.0], ["chatter"], chatter_hz=[bounds.MAX_CHATTER_HZ])  # the bound itself passes


def test_a_config_whose_speeds_table_crawls_is_refused(capsys, tmp_path):
    from millstab.io.examples import example_path

    text = example_path("ex1").read_text()
    cfg = tmp_path / "slow.toml"
    cfg.write_text(text.split("[speeds]")[0] + '\n[speeds]\nstart = 0.01\nstop = 2\nstep = 0.01\n'
                   if "[speeds]" in text else text + '\n[speeds]\nstart = 0.01\nstop = 2\nstep = 0.01\n')
    code, _, err = run(capsys, ["lobes", cfg])
    one_line_error(code, err, "slow.toml [speeds]", "10..500,000 rev/min")


def test_a_speeds_file_and_an_uploaded_config_are_bounded_too(capsys, tmp_path):
    (tmp_path / "speeds.txt").write_text("5000\n0.5\n")
    for cmd in (["lobes", "example:ex1"], ["sensitivity", "oat", "example:ex1"]):
        code, _, err = run(capsys, cmd + ["--rpm-file", tmp_path / "speeds.txt"])
        one_line_error(code, err, "--rpm-file speeds.txt = 0.5", "one revolution takes 2 min")
    from millstab import api

    text = api.config_toml(api.config("example:ex1")).split("[speeds]")[0] + "[speeds]\nstart = 1\nstop = 5\nstep = 1\n"
    with pytest.raises(InputError, match=r"\[speeds\] = 1 is invalid"):
        api.config_from_text(text, "upload.toml")


# ---- seeds ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("command", [
    ["update", "example:ex1", "{cuts}", "--out", "{tmp}/p.json"],
    ["recommend", "{tmp}/no-posterior.json", "--rpm", "5000:9000", "--out", "{tmp}/r.json"],
    ["simulate", "example:ex1", "--cuts", "{cuts}", "--label-noise", "0.1"],
    ["design", "example:ex1"],
    ["identify", "example:ex3", "example:ex3_points"],
    ["sensitivity", "mc", "example:ex1", "--n", "10"],
    ["reproduce", "--out", "{tmp}/rep"],
])
@pytest.mark.parametrize("seed", ["-1", str(2**32), "-99999999999"])
def test_every_seed_is_checked_once_the_same_way(capsys, tmp_path, command, seed):
    """A negative seed was a numpy traceback after the work began (update, recommend, simulate)."""
    (tmp_path / "cuts.csv").write_text(CUTS)
    args = [a.format(tmp=tmp_path, cuts=tmp_path / "cuts.csv") for a in command] + ["--seed", seed]
    code, _, err = run(capsys, args)
    one_line_error(code, err, f"--seed = {seed}", "0..4294967295")
    assert not (tmp_path / "p.json").exists() and not (tmp_path / "rep").exists()


def test_the_python_doors_check_the_seed_too():
    from millstab import api
    from millstab.points import PointSet

    cfg, cuts = api.config("example:ex1"), PointSet([5000.0], [1.0], ["stable"])
    for call in (lambda: api.update(cfg, cuts, samples=200, seed=-1),
                 lambda: api.label_cuts(cfg, cuts, seed=-1, label_noise=0.1)):
        with pytest.raises(InputError, match="--seed = -1"):
            call()


def test_seed_rule():
    assert bounds.seed(0) == 0 and bounds.seed(2**32 - 1) == 2**32 - 1 and bounds.seed(None) is None
    assert bounds.seed(np.int64(7)) == 7
    for bad in (-1, 2**32, 1.5, "3", True):
        with pytest.raises(InputError, match="seed"):
            bounds.seed(bad)


# ---- samples -------------------------------------------------------------------------------------------

@pytest.mark.parametrize("text", ["100000000", "1e8", "1E8"])
def test_samples_beyond_the_cap_say_how_much_memory_they_would_need(capsys, tmp_path, text):
    """Today --samples 100000000 starts and dies of a MemoryError traceback (and 1e8 is a usage panel)."""
    code, _, err = run(capsys, ["update", "example:ex1", tmp_path / "none.csv", "--samples", text,
                                "--out", tmp_path / "p.json"])
    one_line_error(code, err, "--samples = 100000000", "at most 1,000,000 samples: this many needs ~200 GB of memory")


@pytest.mark.parametrize("text", ["abc", "1.5", "-5", "99"])
def test_samples_that_are_no_count_or_too_few(capsys, tmp_path, text):
    code, _, err = run(capsys, ["update", "example:ex1", tmp_path / "none.csv", "--samples", text,
                                "--out", tmp_path / "p.json"])
    one_line_error(code, err, "--samples = ")


def test_samples_beyond_the_memory_say_how_much_there_is(capsys, tmp_path, monkeypatch):
    monkeypatch.setattr(bounds, "available_memory", lambda: 100e6)
    code, _, err = run(capsys, ["update", "example:ex1", tmp_path / "none.csv", "--samples", "200000",
                                "--out", tmp_path / "p.json"])
    one_line_error(code, err, "needs ~0.4 GB of memory, this machine has 0.1 GB available", "at most ~40,000")
    from millstab import api
    from millstab.points import PointSet

    with pytest.raises(InputError, match="needs ~0.4 GB"):  # the Python door too, before any allocation
        api.update(api.config("example:ex1"), PointSet([5000.0], [1.0], ["stable"]), samples=200_000)


def test_available_memory_is_the_machines():
    avail = bounds.available_memory()
    assert avail is None or 1e7 < avail < 1e14


# ---- Dask addresses ------------------------------------------------------------------------------------

def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def web_server():
    """A plain HTTP server on a loopback port (what the dashboard is)."""
    srv = http.server.ThreadingHTTPServer(("127.0.0.1", 0), http.server.SimpleHTTPRequestHandler)
    t = threading.Thread(target=srv.serve_forever, daemon=True)
    t.start()
    yield srv.server_address[1]
    srv.shutdown()
    srv.server_close()


def _open(address, timeout_s=1.0):
    """open_client in a thread: the error it raised (or None), and whether it ended within 15 s."""
    from millstab.cluster import open_client

    box = {}

    def go():
        try:
            with open_client(address, timeout_s=timeout_s):
                pass
            box["exc"] = None
        except BaseException as exc:  # noqa: BLE001 (reported to the test)
            box["exc"] = exc

    t = threading.Thread(target=go, daemon=True)
    t.start()
    t.join(15)
    return box.get("exc"), not t.is_alive()


@pytest.mark.parametrize("address, needle", [
    ("http://127.0.0.1:8787/status", "the scheduler's is usually tcp://127.0.0.1:8786"),
    ("garbage", "need HOST:PORT"),
    ("tcp://10.0.0.5", "need HOST:PORT"),
    ("ftp://10.0.0.5:21", "unknown scheme 'ftp'"),
    ("", "need a scheduler address"),
])
def test_malformed_dask_addresses_are_named(address, needle):
    from millstab.cluster import scheduler_address

    with pytest.raises(InputError, match="--dask") as exc:
        scheduler_address(address)
    assert needle in str(exc.value)


def test_host_port_means_tcp():
    from millstab.cluster import scheduler_address

    assert scheduler_address(" 10.0.0.5:8786 ") == "tcp://10.0.0.5:8786"
    assert scheduler_address("TCP://head:9000") == "tcp://head:9000"


def test_a_web_server_at_the_address_is_an_error_within_the_timeout(web_server):
    """Today distributed.Client waits for ever on a server that accepts and never answers."""
    t0 = time.monotonic()
    exc, ended = _open(f"tcp://127.0.0.1:{web_server}", timeout_s=1.0)
    assert ended, "open_client still waiting after 15 s"
    assert isinstance(exc, InputError) and "not a Dask scheduler" in str(exc), exc
    assert time.monotonic() - t0 < 10


def test_a_closed_port_and_an_unknown_host_are_errors():
    exc, ended = _open(f"127.0.0.1:{_free_port()}")
    assert ended and isinstance(exc, InputError) and "nothing listens there" in str(exc), exc
    exc, ended = _open("no-such-host.invalid:8786")
    assert ended and isinstance(exc, InputError) and "unknown host" in str(exc), exc


def test_a_server_of_another_kind_is_named():
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(1)

    def greet():
        conn, _ = srv.accept()
        conn.sendall(b"SSH-2.0-OpenSSH_9.6\r\n")
        time.sleep(0.5)
        conn.close()

    threading.Thread(target=greet, daemon=True).start()
    exc, ended = _open(f"tcp://127.0.0.1:{srv.getsockname()[1]}")
    srv.close()
    assert ended and isinstance(exc, InputError) and "not a Dask scheduler answers there" in str(exc), exc


def test_a_local_cluster_beyond_four_workers_per_core_is_refused(monkeypatch):
    pytest.importorskip("distributed")
    from millstab.cluster import open_client

    monkeypatch.setattr(os, "cpu_count", lambda: 1)  # a 1-core machine: 5 workers is beyond 4 per core
    with pytest.raises(InputError, match="--workers = 5 is invalid: this machine has 1 cores"):
        with open_client(workers=5):
            pass


@pytest.mark.parametrize("address", ["garbage", "http://localhost:8787"])
def test_dask_garbage_on_the_command_line_is_one_line(capsys, address):
    pytest.importorskip("distributed")
    code, _, err = run(capsys, ["sensitivity", "mc", "example:ex1", "--n", "10", "--dask", address])
    one_line_error(code, err, "--dask")


# ---- the last resort -----------------------------------------------------------------------------------

def test_an_unexpected_exception_is_one_line_and_a_log(capsys, tmp_path, monkeypatch):
    import millstab.api

    def broken(*args, **kwargs):
        raise RuntimeError("engine exploded\n  at step 3")

    monkeypatch.setattr(millstab.api, "lobes", broken)
    monkeypatch.setenv("MILLSTAB_LOG_DIR", str(tmp_path / "logs"))
    code, out, err = run(capsys, ["lobes", "example:ex1", "--rpm", "5000:5100:50"])
    assert code == 1 and err.count("\n") == 1, err
    assert err.startswith("millstab: internal error: RuntimeError: engine exploded at step 3 (traceback in ")
    log = err.rsplit("(traceback in ", 1)[1].rstrip().rstrip(")")
    text = open(log, encoding="utf-8").read()
    assert os.path.dirname(log) == str(tmp_path / "logs")
    assert "Traceback (most recent call last)" in text and "RuntimeError: engine exploded" in text
    assert "command: millstab lobes example:ex1 --rpm 5000:5100:50" in text


def test_out_of_memory_says_so(capsys, tmp_path, monkeypatch):
    import millstab.api

    def greedy(*args, **kwargs):
        raise MemoryError("Unable to allocate 75 GiB for an array")

    monkeypatch.setattr(millstab.api, "lobes", greedy)
    monkeypatch.setenv("MILLSTAB_LOG_DIR", str(tmp_path))
    code, _, err = run(capsys, ["lobes", "example:ex1", "--rpm", "5000:5100:50"])
    assert code == 1 and err.count("\n") == 1 and "out of memory: Unable to allocate 75 GiB" in err, err


def test_an_unwritable_log_folder_falls_back_to_the_temporary_one(tmp_path, monkeypatch):
    from millstab.io.errorlog import write_error_log

    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv("MILLSTAB_LOG_DIR", str(blocker / "logs"))  # under a file: cannot be made
    try:
        raise ValueError("x")
    except ValueError as exc:
        path = write_error_log(exc, ["lobes"])
    assert path is not None and path.is_file() and "millstab-logs" in str(path)
    path.unlink()


# ---- the FRF kind of a tap-test file -------------------------------------------------------------------

F = np.linspace(100.0, 3000.0, 600)
MODES = (np.array([900.0, 1700.0]), np.array([2e7, 5e7]), np.array([0.03, 0.02]))


def _frf(kind, f=F, modes=MODES, noise=0.0, seed=0):
    from millstab.frf import modal_receptance

    g = np.asarray(modal_receptance(f, *modes)).reshape(-1)
    w = 2 * np.pi * f
    h = {"receptance": g, "mobility": 1j * w * g, "accelerance": -w**2 * g}[kind]
    if noise:
        rng = np.random.default_rng(seed)
        h = h + noise * np.abs(h).max() * (rng.standard_normal(h.size) + 1j * rng.standard_normal(h.size)) / np.sqrt(2)
    return h


BANDS = {"around": np.linspace(100, 5000, 2000), "below": np.linspace(100, 1000, 900),
         "above": np.linspace(500, 5000, 900), "narrow": np.linspace(700, 1100, 400)}


@pytest.mark.parametrize("band", list(BANDS))
@pytest.mark.parametrize("kind", ["receptance", "mobility", "accelerance"])
@pytest.mark.parametrize("conj", [False, True])
def test_the_kind_is_told_from_phase_and_slope(band, kind, conj):
    from millstab.frfkind import frf_kind

    f = BANDS[band]
    one = (np.array([900.0]), np.array([2e7]), np.array([0.03]))
    h = _frf(kind, f, one)
    seen = frf_kind(f, np.conj(h) if conj else h)
    assert (seen.kind, seen.conjugated) == (kind, conj)


@pytest.mark.parametrize("kind", ["receptance", "mobility", "accelerance"])
@pytest.mark.parametrize("seed", [1, 2])
def test_the_kind_survives_two_percent_noise(kind, seed):
    from millstab.frfkind import frf_kind

    f = np.linspace(0.5, 2000.0, 4000)  # a hammer test's lines, 0.5 Hz up
    seen = frf_kind(f, _frf(kind, f, noise=0.02, seed=seed))
    assert (seen.kind, seen.conjugated) == (kind, False)


def test_a_cross_frf_is_no_kind():
    from millstab.frf import modal_receptance
    from millstab.frfkind import frf_kind

    g = np.asarray(modal_receptance(F, *MODES)).reshape(-1)
    g2 = np.asarray(modal_receptance(F, MODES[0][:1], MODES[1][:1], MODES[2][:1])).reshape(-1)
    assert frf_kind(F, g - 2 * g2).kind is None  # modes of both signs


@pytest.fixture
def frf_files(tmp_path):
    from millstab.io import write_frf_csv

    out = {}
    for kind in ("receptance", "mobility", "accelerance"):
        out[kind] = write_frf_csv(tmp_path / f"{kind}.csv", F, _frf(kind))
    out["negated"] = write_frf_csv(tmp_path / "negated.csv", F, np.conj(_frf("accelerance")))
    return out


@pytest.mark.parametrize("kind, needle", [
    ("mobility", "integrate once: G = H/(iω), or pass --frf-type mobility"),
    ("accelerance", "integrate twice: G = −H/ω², or pass --frf-type accelerance"),
    ("negated", "accelerance ((m/s²)/N) with its imaginary part negated"),
])
def test_modal_names_mobility_and_accelerance_instead_of_advising_to_negate(capsys, tmp_path, frf_files, kind,
                                                                             needle):
    """Today: 'negate the imaginary column' for an accelerance, then the opposite advice once negated."""
    code, _, err = run(capsys, ["modal", frf_files[kind], "--out", tmp_path / "s.toml"])
    one_line_error(code, err, "FRF_X", needle)
    assert "negate the imaginary" not in err and "overflow" not in err
    assert not (tmp_path / "s.toml").exists()


@pytest.mark.parametrize("kind", ["mobility", "accelerance"])
def test_modal_converts_with_frf_type(capsys, tmp_path, frf_files, kind):
    out = tmp_path / "s.toml"
    code, stdout, err = run(capsys, ["modal", frf_files[kind], "--frf-type", kind, "--out", out, "--json",
                                     tmp_path / "q.json"])
    assert code == 0, err
    assert "warning" not in err  # the raw file's sign and unit warnings do not apply to the converted data
    doc = json.loads((tmp_path / "q.json").read_text())
    modes = doc["directions"]["x"]["modes"]
    fn = sorted(m["fn_hz"] for m in modes)
    k = [m["k_n_per_m"] for m in sorted(modes, key=lambda m: m["fn_hz"])]
    np.testing.assert_allclose(fn, MODES[0], rtol=1e-4)
    np.testing.assert_allclose(k, MODES[1], rtol=1e-3)


def test_modal_refuses_a_frf_type_the_data_contradict(capsys, tmp_path, frf_files):
    code, _, err = run(capsys, ["modal", frf_files["receptance"], "--frf-type", "accelerance",
                                "--out", tmp_path / "s.toml"])
    one_line_error(code, err, "--frf-type accelerance was given but the file looks like receptance (m/N)")
    code, _, err = run(capsys, ["modal", frf_files["receptance"], "--frf-type", "volts", "--out", tmp_path / "s.toml"])
    one_line_error(code, err, "--frf-type = 'volts'")


def test_the_same_file_for_x_and_y_is_warned_about(capsys, tmp_path, frf_files):
    import shutil

    copy = shutil.copy(frf_files["receptance"], tmp_path / "y_copy.csv")
    for y, name in ((frf_files["receptance"], "(receptance.csv)"), (copy, "(receptance.csv, y_copy.csv)")):
        out = tmp_path / f"s{len(name)}.toml"
        code, _, err = run(capsys, ["modal", frf_files["receptance"], y, "--out", out])
        assert code == 0 and "FRF_Y is the same measurement as FRF_X " + name in err, err


# ---- the compile notice and the warm-up ----------------------------------------------------------------

@pytest.mark.slow
def test_a_cold_cache_is_announced_once_and_a_warm_one_not(tmp_path):
    """numba's compile event fires only on a cache miss: the first run says so once, the second is silent."""
    (tmp_path / "millstab_probe_kernel.py").write_text(
        "from numba import njit\n\n@njit(cache=True)\ndef twice(x):\n    return 2 * x\n\n"
        "@njit(cache=True)\ndef thrice(x):\n    return 3 * x\n")
    script = ("import sys\nfrom millstab.cli.notices import install_compile_notice\ninstall_compile_notice()\n"
              "import millstab_probe_kernel as k\nprint(k.twice(2), k.thrice(2.5))\n")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"),
           "PYTHONPATH": os.pathsep.join([str(tmp_path), os.path.join(os.path.dirname(__file__), "..", "src")])}
    first = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=120)
    second = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=120)
    assert first.returncode == 0 and second.returncode == 0, first.stderr + second.stderr
    assert first.stdout == second.stdout == "4 7.5\n"
    assert first.stderr.count("compiling the engines (first run only") == 1, first.stderr
    assert "compiling" not in second.stderr, second.stderr


def test_the_notice_goes_to_a_real_stderr_once_and_not_into_a_capture(tmp_path, monkeypatch):
    import io
    import types

    from millstab.cli import notices

    def event(module):
        return types.SimpleNamespace(data={"dispatcher": types.SimpleNamespace(py_func=types.SimpleNamespace(
            __module__=module))})

    monkeypatch.setattr(notices, "_said", [False])
    with open(tmp_path / "stderr.txt", "w+", encoding="utf-8") as real:
        monkeypatch.setattr(sys, "stderr", real)
        notices._on_compile(event("numpy.linalg"))  # not ours: no notice
        notices._on_compile(event("millstab.stability._zoa_kernel"))
        notices._on_compile(event("millstab.stability._sdm_kernel"))
        real.seek(0)
        assert real.read() == notices.COMPILE_NOTICE + "\n"
    monkeypatch.setattr(notices, "_said", [False])
    captured = io.StringIO()
    monkeypatch.setattr(sys, "stderr", captured)
    notices._on_compile(event("millstab.stability._zoa_kernel"))
    assert captured.getvalue() == ""


def test_warmup_refuses_an_unknown_target(capsys):
    code, _, err = run(capsys, ["warmup", "zoa", "nope"])
    one_line_error(code, err, "TARGET = 'nope'", "zoa, sdm, spectral, simulate")


def test_warmup_refuses_no_processes(capsys):
    code, _, err = run(capsys, ["warmup", "zoa", "--jobs", "0"])
    one_line_error(code, err, "--jobs = 0", "≥ 1")


@pytest.mark.parametrize("jobs", [1, 2, 3, 4, 9])
def test_warmup_deals_every_target_once_and_balances_the_compile(jobs):
    """Every target lands in exactly one process, and no other dealing of the targets to that many
    processes has a shorter longest process (brute force over all assignments)."""
    import itertools

    from millstab.api.warmup import COMPILE_S, TARGETS, groups

    dealt = groups(list(TARGETS) + ["zoa"], jobs)  # a repeated target is compiled once
    assert sorted(t for g in dealt for t in g) == sorted(TARGETS)
    assert len(dealt) == min(jobs, len(TARGETS)) and all(dealt)
    longest = max(sum(COMPILE_S[t] for t in g) for g in dealt)
    best = min(max(sum(COMPILE_S[t] for t, k in zip(TARGETS, a) if k == i) for i in range(len(dealt)))
               for a in itertools.product(range(len(dealt)), repeat=len(TARGETS)))
    assert longest == best


@pytest.mark.slow
def test_warmup_compiles_zoa(capsys):
    code, out, err = run(capsys, ["warmup", "zoa"])
    assert code == 0 and out.startswith("zoa: ready ("), out + err


def test_warmup_reaches_the_kernel_of_cuts_in_several_conditions(monkeypatch):
    """`make demo`'s report compiled the zero-order kernel of per-column conditions after `millstab warmup` (a numba
    compile listener named `_zoa_kernel.envelope_modal_conditions`, 2026-11-29): the warm-up now runs an envelope
    batch in two conditions, which reaches it (fails on the warm-up before: no such call)."""
    from millstab.api.warmup import warm
    from millstab.stability import zoa

    seen = []
    run = zoa._run_conditions
    monkeypatch.setattr(zoa, "_run_conditions", lambda *a, **k: seen.append(a[1]) or run(*a, **k))
    warm("zoa")
    assert seen and len(seen[0].cuttings) == 2


def test_speeds_reach_the_kernels_contiguous_so_warmup_covers_them():
    """A strided speed list (rpm[::2]) reached the SDM kernel as layout 'A', a second compile after
    `millstab warmup` (seen in `make demo`); check_rpm hands every engine a C-contiguous copy."""
    from millstab.stability.base import check_rpm

    r = check_rpm(np.arange(1000.0, 9000.0, 500.0)[::2])
    assert r.flags.c_contiguous and r.tolist() == list(np.arange(1000.0, 9000.0, 1000.0))


def test_the_next_tests_information_has_one_numba_signature():
    """One ε for all samples or one per sample: the same kernel signature (a read-only broadcast view was a
    second one, compiled after `millstab warmup`); the result equals a per-sample ε of equal values."""
    from millstab.update._bald import _bald, label_information

    b = np.array([[1.0, 2.0], [1.5, np.inf], [0.8, 2.5]])
    d, s = np.array([0.5, 1.2, 2.0]), np.full(3, 0.05)
    one = label_information(b, d, s, 0.02)
    per = label_information(b, d, s, np.full(3, 0.02), np.ones(3))
    assert all(np.array_equal(x, y) for x, y in zip(one, per))
    assert len(set(_bald.signatures)) == 1, _bald.signatures


# --- inputs that set the work without bound, refused before any (an exploratory test of the app: a mode of 10^12 Hz
# held the server's one thread for minutes, a 4.9 MB cuts file exhausted 24 GB, sdm steps=10^8 grew past 12 GB) ------
def test_work_bounds_refuse_a_slip_before_any_work(tmp_path):
    import numpy as np

    from millstab import api
    from millstab.bounds import MAX_CUTS, MAX_MODE_HZ, MAX_MODES, MAX_TEETH
    from millstab.forward import MAX_NODES, MAX_STEPS, engine_options
    from millstab.io.config import parse_config
    from millstab.points import PointSet
    from configs import TWO_MODE_TOML

    cfg = parse_config(TWO_MODE_TOML)
    mode = '[[structure.x]]\nfn = "{}"\nk = "10 N/um"\nzeta = 0.03\n'
    head = TWO_MODE_TOML.split("[[structure.x]]")[0]
    with pytest.raises(InputError, match="at most 100,000 Hz .rad/s") as e:
        parse_config(head + mode.format("1e12 Hz"))
    assert e.value.field == "structure.x[0].fn" and e.value.value == "1e12 Hz"
    assert parse_config(head + mode.format(f"{MAX_MODE_HZ:g} Hz")).structure.x[0].fn == MAX_MODE_HZ
    with pytest.raises(InputError, match=f"at most {MAX_MODES} modes per direction"):
        parse_config(head + mode.format("1000 Hz") * (MAX_MODES + 1))
    assert len(parse_config(head + mode.format("1000 Hz") * MAX_MODES).structure.x) == MAX_MODES
    with pytest.raises(InputError, match=f"at most {MAX_TEETH}"):
        parse_config(TWO_MODE_TOML.replace("teeth = 2", "teeth = 99999999999999999999"))
    assert parse_config(TWO_MODE_TOML.replace("teeth = 2", f"teeth = {MAX_TEETH}")).cutting.teeth == MAX_TEETH
    for engine, key, top in (("sdm", "steps", MAX_STEPS), ("spectral", "nodes", MAX_NODES)):
        assert dict(engine_options(engine, {key: top})) == {key: top}
        with pytest.raises(InputError, match=f"in .*{top:,}"):
            engine_options(engine, {key: top + 1})
    many = PointSet(np.full(MAX_CUTS + 1, 6000.0), np.ones(MAX_CUTS + 1), np.array(["stable"] * (MAX_CUTS + 1)))
    for call in (lambda: api.update(cfg, many, samples=100), lambda: api.validate(cfg, many, samples=100)):
        with pytest.raises(InputError, match=f"at most {MAX_CUTS:,} cuts") as e:
            call()
        assert e.value.value == f"{MAX_CUTS + 1:,} rows"
