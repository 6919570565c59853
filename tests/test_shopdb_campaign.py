"""The shop database under real use: a 10-round campaign through the database equals the file workflow bit
for bit; a process killed (SIGKILL) inside an update leaves the previous posterior current and the file
consistent; two concurrent updates lose nothing (one lands, the other is stale or re-runs from it)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("sqlalchemy")
pytest.importorskip("alembic")

from millstab import api  # noqa: E402
from millstab.api import shop  # noqa: E402
from millstab.cli import main  # noqa: E402
from millstab.io import write_points  # noqa: E402
from millstab.points import PointSet  # noqa: E402
from millstab.shopdb import open_store  # noqa: E402
from millstab.shopdb.store import StaleError  # noqa: E402
from millstab.stability import get_engine  # noqa: E402

from test_shopdb import land, some_cuts  # noqa: E402

TESTS = Path(__file__).resolve().parent
SRC = TESTS.parent / "src"


def labelled_cuts(n: int, seed: int) -> PointSet:
    """Cuts labelled by the ex1 tap-test structure's own zero-order limit (stable below it, chatter above)."""
    cfg = api.config("example:ex1")
    rng = np.random.default_rng(seed)
    rpm = rng.uniform(5000, 12000, n)
    lim = get_engine("zoa").envelope(cfg.structure, cfg.cutting, rpm).depth_mm
    depth = lim * rng.uniform(0.6, 1.4, n)
    lab = np.where(depth > lim, "chatter", "stable")
    return PointSet(rpm, depth, lab)


@pytest.mark.slow
def test_a_campaign_through_the_database_equals_the_file_workflow(tmp_path, capsys):
    """20 cuts in 10 rounds: `update --start post.json` file by file, and update_in_db round by round, with the
    same seeds, give the same samples bit for bit in every round."""
    cuts = labelled_cuts(20, 7)
    db = tmp_path / "shop.db"
    prev = None
    for r in range(10):
        now = cuts.subset(np.arange(2 * r + 2))
        write_points(tmp_path / f"cuts{r}.csv", now)
        argv = ["update", "example:ex1", str(tmp_path / f"cuts{r}.csv"), "--samples", "200", "--seed", str(r),
                "--out", str(tmp_path / f"post{r}.json")]
        assert main(argv + (["--start", str(prev)] if prev else [])) == 0
        prev = tmp_path / f"post{r}.json"
        # the new cuts only, or (odd rounds) the whole file as in the file workflow: recorded rows are not repeated
        given = now if r % 2 else cuts.subset(np.arange(2 * r, 2 * r + 2))
        got = shop.update_in_db(db, "t12-m1", api.config("example:ex1"), given, samples=200, seed=r, user="ann",
                                machine="m1", tool="t12")
        assert got.new_cuts == 2 and (("adding the 2 after them" in got.notes[0]) if r % 2 else not got.notes)
        want = api.posterior_from_json(json.loads(prev.read_text()))
        assert np.array_equal(got.posterior.samples, want.samples), f"round {r}"
        assert got.parent_id == (None if r == 0 else got.posterior_id - 1) and got.cuts == 2 * r + 2
    capsys.readouterr()
    store = open_store(db)
    np.testing.assert_array_equal(store.latest_posterior("t12-m1").samples, want.samples)
    np.testing.assert_array_equal(store.cuts("t12-m1").depth_mm, cuts.depth_mm)
    assert store.head("t12-m1").revision == 10 and store.check() == []
    # recommend continues from the newest posterior with no file in hand, and is remembered
    rec, rid, pid = shop.recommend_from_db(db, "t12-m1", 0.05, (5000, 12000), max_depth_mm=6)
    assert pid == store.head("t12-m1").posterior_id and rec.p_chatter <= 0.05
    assert [e.action for e in store.history("t12-m1", limit=2)] == ["recommend", "update"]


def _python(code: str, *args: str, **kw) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(SRC), str(TESTS), os.environ.get("PYTHONPATH", "")])}
    return subprocess.Popen([sys.executable, "-c", textwrap.dedent(code), *args], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kw)


KILL_BEFORE_COMMIT = """
    import os, signal, sys
    import sqlalchemy as sa
    from millstab.shopdb import open_store
    from millstab.shopdb.store import Store
    from test_shopdb import land, some_cuts

    store = open_store(sys.argv[1], user="bob")
    write_event = Store._event

    def event_then_die(conn, cid, user, at, action, detail, *a, **k):
        write_event(conn, cid, user, at, action, detail, *a, **k)
        if action == "update":  # the update's last write, inside its open transaction, before the commit
            n_cuts = conn.execute(sa.text("SELECT count(*) FROM cut")).scalar()
            head = conn.execute(sa.text("SELECT head_posterior_id FROM campaign")).scalar()
            print(n_cuts, head, flush=True)
            os.kill(os.getpid(), signal.SIGKILL)

    Store._event = staticmethod(event_then_die)
    land(store, "c", some_cuts(4, 3), 2)
    print("not killed")
"""


@pytest.mark.slow
def test_sigkill_before_commit_keeps_the_previous_posterior(tmp_path):
    db = tmp_path / "shop.db"
    store = open_store(db, user="ann")
    first = land(store, "c", some_cuts(3), 1)
    before = store.export_bundle("c")
    p = _python(KILL_BEFORE_COMMIT, str(db))
    out, err = p.communicate(timeout=120)
    assert p.returncode == -signal.SIGKILL, err
    assert out.split() == ["7", str(first + 1)]  # the killed transaction had written its cuts and moved the head
    assert main(["campaign", "check", "--db", str(db)]) == 0
    store = open_store(db, user="ann")
    assert store.check() == []  # integrity_check, foreign keys, head = newest posterior, cut seq
    assert store.export_bundle("c") == before  # nothing of the killed update, the previous posterior current
    assert store.head("c").posterior_id == first
    assert land(store, "c", some_cuts(4, 3), 2) == first + 1  # no lock or journal left behind


KILL_ANYWHERE = """
    import sys
    from millstab.shopdb import open_store
    from test_shopdb import fake_posterior, land, some_cuts

    store = open_store(sys.argv[1])
    i = 0
    while True:
        i += 1
        land(store, "c", some_cuts(5, i), i)
        print("landed", i, flush=True)
"""


@pytest.mark.slow
def test_sigkill_at_random_moments_leaves_a_consistent_database(tmp_path):
    db = tmp_path / "shop.db"
    rng = np.random.default_rng(0)
    for k in range(3):
        p = _python(KILL_ANYWHERE, str(db))
        assert p.stdout.readline().startswith("landed")  # the writer is in its loop
        time.sleep(rng.uniform(0.05, 1.0))
        p.send_signal(signal.SIGKILL)
        p.communicate(timeout=60)
        store = open_store(db)
        assert store.check() == [], f"kill {k}"
        head = store.head("c")
        doc = store.posterior_doc(head.posterior_id)
        assert len(doc["cuts"]["rpm"]) == head.n_rows  # the current posterior is over exactly the stored cuts
        store.close()


RACE = """
    import os, sys, time
    from pathlib import Path
    from millstab.shopdb import open_store
    from millstab.shopdb.store import StaleError
    from test_shopdb import fake_posterior, some_cuts
    import millstab.api.shop as shop

    db, who, gate = sys.argv[1], sys.argv[2], Path(sys.argv[3])
    store = open_store(db, user=who)
    head = store.head("c")  # both start from the same head ...
    new = some_cuts(2, ord(who[0]))
    every = shop._join(store.cuts("c"), new)
    (gate / who).touch()
    while not (gate / "go").exists():  # ... and record at the same moment
        time.sleep(0.001)
    try:
        pid = store.record_update("c", "x", new, fake_posterior(every, 5), expected_head=head.posterior_id,
                                  expected_rows=head.n_rows, parent=head.posterior_id, all_cuts=every)
        print("landed", pid)
    except StaleError as exc:
        print("stale", exc)
"""


def race(db: str, gate: Path) -> list[str]:
    """Two processes (ann, bob) read the same head, wait at a gate, then record at once; their outputs."""
    procs = [_python(RACE, db, who, str(gate)) for who in ("ann", "bob")]
    t0 = time.monotonic()
    while not ((gate / "ann").exists() and (gate / "bob").exists()):
        assert time.monotonic() - t0 < 120 and all(p.poll() is None for p in procs)
        time.sleep(0.01)
    (gate / "go").touch()
    outs = [p.communicate(timeout=120)[0].strip() for p in procs]
    assert all(p.returncode == 0 for p in procs), outs
    assert sorted(o.split()[0] for o in outs) == ["landed", "stale"], outs
    return outs


@pytest.mark.slow  # two fresh Python processes: ~3 s idle, 20 s on a loaded 2-core machine
def test_two_concurrent_updates_one_lands_the_other_is_stale(tmp_path):
    db = tmp_path / "shop.db"
    first = land(open_store(db, user="ann"), "c", some_cuts(3), 1)
    outs = race(str(db), tmp_path)
    winner = next(o for o in outs if o.startswith("landed"))
    loser = next(o for o in outs if o.startswith("stale"))
    by = "ann" if outs.index(winner) == 0 else "bob"
    assert f"by {by} at" in loser and "re-run to start from it" in loser
    store = open_store(db)
    head = store.head("c")
    assert head.posterior_id == int(winner.split()[1]) == first + 1 and head.n_rows == 5 and head.revision == 2
    assert store.check() == []


@pytest.mark.slow
def test_a_stale_update_reruns_from_the_one_that_landed(tmp_path):
    """update_in_db reads the campaign; another update lands while it samples; it re-runs from that one, and the
    result is exactly the sequential file workflow's: the old cuts, then the other's, then its own."""
    cfg = api.config("example:ex1")
    db = tmp_path / "shop.db"
    cuts = labelled_cuts(10, 3)
    a, b1, b2, c = (cuts.subset(np.arange(i, j)) for i, j in ((0, 4), (4, 6), (6, 8), (8, 10)))
    shop.update_in_db(db, "c", cfg, a, samples=100, seed=1, user="ann")
    ann, bob = open_store(db, user="ann"), open_store(db, user="bob")
    real = ann.snapshot
    pending, landed = [b1, b2], []

    def snapshot_then_bob_lands(name, with_posterior=True):
        snap = real(name, with_posterior)
        if with_posterior and armed:  # the snapshot an update starts from; then bob lands, once per ann call
            armed.clear()
            landed.append(shop.update_in_db(bob, "c", cfg, pending.pop(0), samples=100, seed=2))
        return snap

    ann.snapshot = snapshot_then_bob_lands
    armed = [True]
    with pytest.raises(StaleError, match="by bob"):
        shop.update_in_db(ann, "c", cfg, c, samples=100, seed=3, retries=0)
    assert ann.head("c").n_rows == 6 and ann.check() == []  # bob's update is there, ann's is not
    armed.append(True)
    got = shop.update_in_db(ann, "c", cfg, c, samples=100, seed=3)
    assert got.attempts == 2 and got.parent_id == landed[1].posterior_id and "re-ran" in got.notes[0]
    want = api.update(cfg, cuts, samples=100, seed=3, start=landed[1].posterior)
    np.testing.assert_array_equal(got.posterior.samples, want.samples)
    np.testing.assert_array_equal(ann.cuts("c").rpm, cuts.rpm)
    assert ann.check() == [] and ann.head("c").revision == 4  # ann, bob, bob, ann
