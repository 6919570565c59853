"""The shop database (millstab.shopdb): schema by migration, exact round trips of cuts and posteriors, the
stale check, faults as one clear error, export/import, and the `history` / `campaign` commands.

Posteriors here are prior draws wrapped as a Posterior (no sampler run), so these tests are fast; the
sampler-backed campaign, SIGKILL and concurrency tests are in test_shopdb_campaign.py."""

from __future__ import annotations

import ast
import dataclasses
import json
import os
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("sqlalchemy")
pytest.importorskip("alembic")

import sqlalchemy as sa  # noqa: E402

from millstab import api  # noqa: E402
from millstab.api import shop  # noqa: E402
from millstab.cli import main  # noqa: E402
from millstab.errors import InputError  # noqa: E402
from millstab.points import PointSet  # noqa: E402
from millstab.shopdb import open_store, schema  # noqa: E402
from millstab.shopdb.store import StaleError, alembic_config  # noqa: E402
from millstab.update import Posterior, make_prior  # noqa: E402

SRC = Path(__file__).resolve().parents[1] / "src" / "millstab"


def cfg():
    return api.config("example:ex1")


def fake_posterior(cuts: PointSet, seed: int, n: int = 50) -> Posterior:
    """A posterior-shaped object from prior draws (the store does not care how the samples were made)."""
    c = cfg()
    pr = make_prior(c.structure, c.cutting, c.prior)
    u = pr.sample(n, np.random.default_rng(seed))
    data = {"rpm": cuts.rpm.tolist(), "depth_mm": cuts.depth_mm.tolist(), "label": cuts.label.tolist(),
            "chatter_hz": [None if np.isnan(h) else float(h) for h in cuts.chatter_hz]}
    return Posterior(pr, np.exp(u), "zoa", {"stages": 1}, data)


def some_cuts(n: int, seed: int = 0) -> PointSet:
    rng = np.random.default_rng(seed)
    d = rng.uniform(0.5, 5, n)
    lab = np.where(d > 2.5, "chatter", "stable")
    hz = np.where(lab == "chatter", rng.uniform(900, 1100, n), np.nan)
    return PointSet(rng.uniform(5000, 12000, n), d, lab, rng.uniform(0.5, 2, n), None, hz, None,
                    np.array([f"day{i // 3}" for i in range(n)]))


def land(store, name: str, new: PointSet, seed: int, shop: str | None = None, **by) -> int:
    """Record one update of ``new`` cuts on the current head (what update_in_db does, minus the sampler); ``by``:
    the fields of :class:`millstab.shopdb.CutsBy` (user, machine, tool, raters, recordings)."""
    from millstab.api.shop import _join
    from millstab.shopdb import CutsBy

    head = store.head(name)
    old = store.cuts(name) if head is not None else None
    every = new if old is None else _join(old, new)
    return store.record_update(name, "name = 'ex1'\n", new, fake_posterior(every, seed), seed=seed,
                               expected_head=head.posterior_id if head else None,
                               expected_rows=head.n_rows if head else 0, parent=head.posterior_id if head else None,
                               by=CutsBy(**by), all_cuts=every, shop=shop)


@pytest.fixture
def store(tmp_path):
    s = open_store(tmp_path / "shop.db", user="ann")
    yield s
    s.close()


def test_schema_is_created_by_the_migration_and_matches_the_tables(store):
    from alembic.autogenerate import compare_metadata
    from alembic.migration import MigrationContext
    from alembic.script import ScriptDirectory

    head = ScriptDirectory.from_config(alembic_config()).get_current_head()
    with store.engine.connect() as conn:
        ctx = MigrationContext.configure(conn)
        assert ctx.get_current_revision() == head == schema.HEAD
        # what the migrations built is what the code's table definitions say (no drift between them)
        assert compare_metadata(ctx, schema.metadata) == []
        mode = conn.exec_driver_sql("PRAGMA journal_mode").scalar()
        fk = conn.exec_driver_sql("PRAGMA foreign_keys").scalar()
    assert mode == "wal" and fk == 1


def test_a_new_database_file_is_private_and_an_existing_one_keeps_its_mode(tmp_path):
    """Security review: a new shop database was made 0644 (the umask's), with its -wal and -shm files: every
    account of the machine could read every shop's campaigns, which the app's accounts keep apart (fails on the
    old code: 0o644). A new file is 0600 like the users file; an existing file's mode is not changed."""
    import stat

    def mode(p):
        return stat.S_IMODE(os.stat(p).st_mode)

    cuts = some_cuts(4, 1)
    with open_store(tmp_path / "shop.db", user="bob") as st:
        st.record_update("a1", "x = 1\n", cuts, fake_posterior(cuts, 1), expected_head=None, expected_rows=0)
        assert {p.name: mode(p) for p in tmp_path.iterdir()} == {"shop.db": 0o600, "shop.db-wal": 0o600,
                                                                 "shop.db-shm": 0o600}
    os.chmod(tmp_path / "shop.db", 0o640)  # a shop that shares it with a group
    with open_store(tmp_path / "shop.db", user="bob") as st:
        assert [c["name"] for c in st.campaigns()] == ["a1"]
    assert mode(tmp_path / "shop.db") == 0o640


def test_cuts_and_posteriors_read_back_bit_identical(store):
    a, b = some_cuts(4, 1), some_cuts(3, 2)
    b = PointSet(b.rpm, b.depth_mm, ["marginal", "", "stable"], b.weight, None, [np.nan] * 3, [0.3, np.nan, 0.1],
                 ["tue", "tue", "tue"])  # a graded label and a boundary point
    land(store, "t12-m1", a, 1, machine="m1", tool="t12", raters=["ann"] * 4,
         recordings=[f"r{i}.wav" for i in range(4)])
    pid = land(store, "t12-m1", b, 2)
    got = store.cuts("t12-m1")
    want = shop._join(a, b)
    for f in ("rpm", "depth_mm", "weight", "chatter_hz", "grade"):
        np.testing.assert_array_equal(getattr(got, f), getattr(want, f), err_msg=f)
    assert got.label.tolist() == want.label.tolist() and got.batch.tolist() == want.batch.tolist()
    rows = store.cut_rows("t12-m1")
    assert [r["seq"] for r in rows] == list(range(7)) and rows[0]["rater"] == "ann" and rows[3]["recording"] == "r3.wav"
    post = store.latest_posterior("t12-m1")
    np.testing.assert_array_equal(post.samples, fake_posterior(want, 2).samples)
    head = store.head("t12-m1")
    assert (head.posterior_id, head.n_rows, head.revision) == (pid, 7, 2)
    assert store.check() == []


def test_a_stale_update_records_nothing_and_names_who_landed_first(tmp_path):
    one = open_store(tmp_path / "shop.db", user="ann")
    two = open_store(tmp_path / "shop.db", user="bob")
    land(one, "c", some_cuts(3), 1)
    head = two.head("c")  # bob starts from posterior 1 ...
    land(one, "c", some_cuts(2, 5), 2)  # ... ann lands posterior 2 meanwhile
    events = len(two.history("c"))
    with pytest.raises(StaleError, match=r"stale: another update \(by ann at .*\) landed first.*re-run"):
        two.record_update("c", "x", some_cuts(1, 9), fake_posterior(some_cuts(6), 3),
                          expected_head=head.posterior_id, expected_rows=head.n_rows)
    assert len(two.history("c")) == events and two.head("c").n_rows == 5 and two.head("c").posterior_id == 2
    assert two.check() == []
    # added cuts make an update stale too (its posterior would not be over the stored rows)
    h = one.head("c")
    two.add_cuts("c", some_cuts(1, 7))
    with pytest.raises(StaleError):
        one.record_update("c", "x", some_cuts(1), fake_posterior(some_cuts(6), 4), expected_head=h.posterior_id,
                          expected_rows=h.n_rows)
    assert one.check() == []


def test_history_newest_first_paged_and_per_campaign(store):
    for i in range(3):
        land(store, f"c{i}", some_cuts(2, i), i)
    store.record_recommendation("c1", {"rpm": 9000.0, "depth_mm": 2.0, "risk": 0.05}, store.head("c1").posterior_id)
    ev = store.history()
    assert [e.id for e in ev] == sorted((e.id for e in ev), reverse=True) and ev[0].action == "recommend"
    assert [e.action for e in store.history("c1")] == ["recommend", "update", "create"]
    page = store.history(limit=2)
    assert [e.id for e in store.history(limit=2, before=page[-1].id)] == [page[-1].id - 1, page[-1].id - 2]
    assert all(e.user == "ann" and e.at.endswith("Z") for e in ev)
    with pytest.raises(InputError, match="did you mean 'c1'"):
        store.history("C1 ")


def test_export_import_round_trip(store, tmp_path):
    a, b = some_cuts(4, 1), some_cuts(2, 2)
    land(store, "t12-m1", a, 1, machine="m1", tool="t12", raters=list("abcd"))
    pid = land(store, "t12-m1", b, 2)
    store.record_recommendation("t12-m1", {"schema": "millstab.recommendation/1", "rpm": 9e3, "depth_mm": 1.5}, pid)
    out = shop.export_campaign(store, "t12-m1", tmp_path / "exp")
    assert {p.name for p in out.iterdir()} == {"campaign.json", "config.toml", "configs", "cuts.csv", "cuts_meta.csv",
                                               "posteriors", "recommendations"}
    # the exported files are millstab's own formats: the file workflow reads them as they are
    from millstab.io import read_json, read_points

    np.testing.assert_array_equal(read_points(out / "cuts.csv").rpm, shop._join(a, b).rpm)
    np.testing.assert_array_equal(api.posterior_from_json(read_json(out / "posteriors" / "0002.json")).samples,
                                  store.latest_posterior("t12-m1").samples)
    other = open_store(tmp_path / "other.db", user="bob")
    assert shop.import_campaign(other, out) == "t12-m1"
    x, y = store.export_bundle("t12-m1"), other.export_bundle("t12-m1")
    assert y["events"][-1]["action"] == "import" and y["events"][-1]["detail"].startswith("import: campaign t12-m1")
    y["events"] = y["events"][:-1]
    assert x == y  # every row, time, user, float and JSON document as it was
    assert other.check() == []
    with pytest.raises(InputError, match="exists"):
        shop.import_campaign(other, out)
    with pytest.raises(InputError, match="new or empty folder"):
        shop.export_campaign(store, "t12-m1", out)


def test_read_only_database_is_one_clear_error(store, tmp_path):
    land(store, "c", some_cuts(2), 1)
    path = tmp_path / "shop.db"
    ro = open_store(f"sqlite:///file:{path}?mode=ro&uri=true")
    assert ro.head("c").n_rows == 2  # reading works
    with pytest.raises(InputError, match=r"--db .*read-only.*nothing was recorded"):
        land(ro, "c", some_cuts(1), 2)
    assert store.check() == [] and store.head("c").n_rows == 2


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root writes through file permissions")
def test_unwritable_file_and_folder(store, tmp_path):
    land(store, "c", some_cuts(2), 1)
    store.close()
    path = tmp_path / "shop.db"
    for p in tmp_path.iterdir():
        p.chmod(0o444)
    tmp_path.chmod(0o555)
    try:
        with pytest.raises(InputError, match="--db"):
            land(open_store(path), "c", some_cuts(1), 2)
        with pytest.raises(InputError, match="--db"):
            open_store(tmp_path / "new.db")
    finally:
        tmp_path.chmod(0o755)


def test_full_disk_is_one_clear_error_and_keeps_the_head(store):
    land(store, "c", some_cuts(2), 1)
    store.engine.dispose()
    pages = store.engine.connect().exec_driver_sql("PRAGMA page_count").scalar()
    store.engine.dispose()
    # SQLite's own "disk full" (SQLITE_FULL): the file may not grow past its present size
    sa.event.listen(store.engine, "connect", lambda c, _: c.execute(f"PRAGMA max_page_count = {pages}"))
    with pytest.raises(InputError, match=r"--db .*disk is full.*nothing was recorded"):
        land(store, "c", some_cuts(3), 2)
    assert store.head("c").posterior_id == 1 and store.check() == []


def test_bad_targets_are_one_clear_error(tmp_path):
    (tmp_path / "notes.txt").write_text("not a database\n" * 100)
    with pytest.raises(InputError, match="not a millstab shop database"):
        open_store(tmp_path / "notes.txt")
    with pytest.raises(InputError, match="does not exist"):
        open_store(tmp_path / "missing" / "shop.db")
    with pytest.raises(InputError, match="a folder"):
        open_store(tmp_path)
    other = sa.create_engine(f"sqlite:///{tmp_path / 'other.db'}")
    with other.begin() as conn:
        conn.exec_driver_sql("CREATE TABLE parts (id INTEGER)")
    with pytest.raises(InputError, match="something else"):
        open_store(tmp_path / "other.db")
    s = open_store(tmp_path / "new.db")
    with s.engine.begin() as conn:
        conn.exec_driver_sql("UPDATE alembic_version SET version_num = '9999'")
    with pytest.raises(InputError, match="newer"):
        open_store(tmp_path / "new.db")
    with pytest.raises(InputError, match="--campaign"):
        land(open_store(tmp_path / "a.db"), "bad\nname", some_cuts(1), 1)
    with pytest.raises(InputError, match="postgresql"):
        open_store("postgres://u@host/shop")
    with pytest.raises(InputError, match="in-memory"):
        open_store("sqlite://")


def test_without_the_extra_one_line_names_it(monkeypatch):
    import millstab.shopdb as sdb

    monkeypatch.setattr(sdb, "available", lambda: False)
    with pytest.raises(InputError, match=r"millstab\[db\]"):
        sdb.open_store("shop.db")


def test_only_shopdb_imports_sqlalchemy_and_alembic():
    bad = []
    for path in SRC.rglob("*.py"):
        if path.is_relative_to(SRC / "shopdb"):
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else (
                [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            if any(n.split(".")[0] in ("sqlalchemy", "alembic") for n in names):
                bad.append(f"{path.relative_to(SRC)}:{node.lineno}")
    assert bad == []


def test_history_and_campaign_commands(store, tmp_path, capsys):
    land(store, "t12-m1", some_cuts(3), 1, machine="m1")
    db = str(tmp_path / "shop.db")
    assert main(["history", "--db", db, "--out", str(tmp_path / "h.csv")]) == 0
    out = capsys.readouterr().out
    assert "t12-m1" in out and "update" in out and "create" in out
    assert (tmp_path / "h.csv").read_text().splitlines()[0] == "id,at,user,campaign,action,detail"
    assert main(["campaign", "list", "--db", db]) == 0 and "m1" in capsys.readouterr().out
    assert main(["campaign", "check", "--db", db]) == 0 and "consistent" in capsys.readouterr().out
    assert main(["campaign", "export", "--db", db, "--campaign", "t12-m1", "--out", str(tmp_path / "e")]) == 0
    assert json.loads((tmp_path / "e" / "campaign.json").read_text())["name"] == "t12-m1"
    assert main(["campaign", "import", str(tmp_path / "e"), "--db", db, "--as", "copy", "--user", "bob"]) == 0
    capsys.readouterr()
    assert main(["history", "--db", db, "--campaign", "copy", "--limit", "1"]) == 0
    out = capsys.readouterr().out
    assert "import" in out and "bob" in out and "--before" in out
    assert main(["history", "--db", db, "--campaign", "nope"]) == 2
    assert "millstab: error: --campaign = 'nope'" in capsys.readouterr().err
    assert main(["history", "--db", str(tmp_path / "typo.db")]) == 2  # a reading command creates no file
    assert "no such database file" in capsys.readouterr().err and not (tmp_path / "typo.db").exists()


def test_check_finds_what_a_half_written_update_would_leave(store):
    """check() is not vacuous: each kind of damage a torn update could leave is reported."""
    land(store, "c", some_cuts(3), 1)
    land(store, "c", some_cuts(2, 2), 2)
    assert store.check() == []
    with store.engine.begin() as conn:
        conn.exec_driver_sql("UPDATE campaign SET head_posterior_id = 1")  # a head that did not move
        conn.exec_driver_sql("DELETE FROM cut WHERE seq = 1")  # a lost cut row
    problems = store.check()
    assert any("head posterior 1, newest posterior 2" in p for p in problems)
    assert any("cut seq not 0..3" in p for p in problems)
    assert any("posterior 2 uses more cut rows than stored" in p for p in problems)


def test_shop_options_go_together():
    from millstab.cli.history import shop_target

    assert shop_target(None, None) is False and shop_target("shop.db", "t12-m1") is True
    with pytest.raises(InputError, match="--campaign .*go together"):
        shop_target("shop.db", None)
    with pytest.raises(InputError, match="--db .*go together"):
        shop_target(None, "t12-m1")


def test_update_in_db_takes_its_settings_and_recorder_as_objects_or_keywords(tmp_path):
    """update_in_db's options grouped: UpdateSettings (api.update's own keywords, same names and defaults) and
    CutsBy (who and what recorded the cuts). The objects and the keyword form record the same posterior, bit for
    bit, with the same machine, tool, raters and user; a keyword overrides its object's field; a keyword that is a
    field of neither is a TypeError before the database is touched."""
    import inspect

    from millstab.shopdb import CutsBy

    sig = inspect.signature(api.update).parameters
    for f in dataclasses.fields(api.UpdateSettings):  # the update's own keywords, with their defaults
        assert sig[f.name].kind is inspect.Parameter.KEYWORD_ONLY and sig[f.name].default == f.default, f.name
    cfg = api.config("example:ex1")
    cuts = some_cuts(4)
    raters = list("abcd")
    kw = shop.update_in_db(tmp_path / "kw.db", "c", cfg, cuts, samples=100, seed=3, user="ann", machine="m1",
                           tool="t12", raters=raters)
    obj = shop.update_in_db(tmp_path / "obj.db", "c", cfg, cuts, settings=api.UpdateSettings(samples=100, seed=9),
                            by=CutsBy(user="bob", machine="m1", tool="t12", raters=raters), seed=3, user="ann")
    np.testing.assert_array_equal(obj.posterior.samples, kw.posterior.samples)
    for name in ("kw.db", "obj.db"):
        store = open_store(tmp_path / name)
        (row,) = store.campaigns()
        assert (row["machine"], row["tool"]) == ("m1", "t12")
        assert [r["rater"] for r in store.snapshot("c").rows] == raters
        assert store.history("c")[0].user == "ann"
        store.close()
    with pytest.raises(TypeError, match="'sampels'"):
        shop.update_in_db(tmp_path / "never.db", "c", cfg, cuts, sampels=100)
    assert not (tmp_path / "never.db").exists()
