"""The shop database on PostgreSQL (the shared-server case): the same schema by migration, exact round trips,
the stale check between two processes (the campaign row locked by SELECT ... FOR UPDATE), and a campaign
moved from a SQLite file to the server by export/import.

A throwaway server is started for the module with the PostgreSQL binaries on PATH (initdb, pg_ctl) as the
user 'nobody' (postgres refuses root) on a Unix socket in a temporary folder; without the binaries or the
driver (psycopg) the module is skipped."""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("sqlalchemy")
pytest.importorskip("alembic")
psycopg = pytest.importorskip("psycopg")

from millstab.api import shop  # noqa: E402
from millstab.shopdb import open_store  # noqa: E402

from test_shopdb import land, some_cuts  # noqa: E402
from test_shopdb_campaign import race  # noqa: E402

pytestmark = pytest.mark.slow  # initdb and a server start: ~5 s


def _as_user(argv: list[str]) -> list[str]:
    if os.geteuid() == 0:
        return ["runuser", "-u", "nobody", "--", *argv]
    return argv


@pytest.fixture(scope="module")
def server():
    initdb, pg_ctl = shutil.which("initdb"), shutil.which("pg_ctl")
    if not (initdb and pg_ctl) or (os.geteuid() == 0 and not shutil.which("runuser")):
        pytest.skip("no PostgreSQL server binaries (initdb, pg_ctl)")
    d = Path(tempfile.mkdtemp(prefix="millstab-pg-"))
    if os.geteuid() == 0:
        shutil.chown(d, "nobody")
    port = str(55000 + os.getpid() % 1000)
    try:
        subprocess.run(_as_user([initdb, "-D", str(d / "data"), "-A", "trust", "-U", "shop"]), check=True,
                       capture_output=True, timeout=120, cwd="/")
        subprocess.run(_as_user([pg_ctl, "-D", str(d / "data"), "-l", str(d / "log"), "-w", "-o",
                                 f"-k {d} -p {port} -c listen_addresses='' -c fsync=off", "start"]),
                       check=True, capture_output=True, timeout=120, cwd="/")
    except (subprocess.SubprocessError, OSError) as exc:
        shutil.rmtree(d, ignore_errors=True)
        pytest.skip(f"cannot start a PostgreSQL server: {exc}")
    yield f"host={d} port={port} user=shop", f"postgresql+psycopg://shop@/{{db}}?host={d}&port={port}"
    subprocess.run(_as_user([pg_ctl, "-D", str(d / "data"), "-m", "immediate", "stop"]), capture_output=True,
                   timeout=120, cwd="/")
    shutil.rmtree(d, ignore_errors=True)


@pytest.fixture
def url(server, request):
    """A new database on the server for each test."""
    dsn, template = server
    name = "t_" + request.node.name.lower().replace("[", "_").replace("]", "")[:50]
    with psycopg.connect(dsn + " dbname=postgres", autocommit=True) as conn:
        conn.execute(f'DROP DATABASE IF EXISTS "{name}"')
        conn.execute(f'CREATE DATABASE "{name}"')
    return template.format(db=name)


def test_schema_and_exact_round_trip_on_postgresql(url):
    from alembic.autogenerate import compare_metadata
    from alembic.migration import MigrationContext

    from millstab.shopdb import schema

    store = open_store(url, user="ann")
    with store.engine.connect() as conn:
        ctx = MigrationContext.configure(conn)
        assert ctx.get_current_revision() == schema.HEAD and compare_metadata(ctx, schema.metadata) == []
    a, b = some_cuts(4, 1), some_cuts(3, 2)
    land(store, "t12-m1", a, 1, machine="m1", tool="t12")
    land(store, "t12-m1", b, 2)
    got, want = store.cuts("t12-m1"), shop._join(a, b)
    for f in ("rpm", "depth_mm", "weight", "chatter_hz", "grade"):
        np.testing.assert_array_equal(getattr(got, f), getattr(want, f), err_msg=f)
    assert [e.action for e in store.history("t12-m1")] == ["update", "update", "create"]
    assert store.check() == [] and open_store(url).head("t12-m1").revision == 2


def test_two_concurrent_updates_on_postgresql(url, tmp_path):
    first = land(open_store(url, user="ann"), "c", some_cuts(3), 1)
    outs = race(url, tmp_path)
    assert "re-run to start from it" in next(o for o in outs if o.startswith("stale"))
    head = open_store(url).head("c")
    assert head.posterior_id == first + 1 and head.n_rows == 5 and head.revision == 2


def test_a_campaign_moves_from_sqlite_to_the_server(url, tmp_path):
    local = open_store(tmp_path / "shop.db", user="ann")
    land(local, "t12-m1", some_cuts(5), 1, raters=list("abcde"))
    land(local, "t12-m1", some_cuts(2, 3), 2)
    shop.export_campaign(local, "t12-m1", tmp_path / "exp")
    server = open_store(url, user="bob")
    assert shop.import_campaign(server, tmp_path / "exp") == "t12-m1"
    x, y = local.export_bundle("t12-m1"), server.export_bundle("t12-m1")
    assert y["events"].pop()["action"] == "import" and x == y and server.check() == []


def test_upgrade_from_0002_and_cuts_with_conditions_on_postgresql(url):
    """A server database at 0002 holding a cut is upgraded (ALTER TABLE ... ADD COLUMN, not SQLite's batch copy):
    the old cut keeps NULL (the config's condition and stickout), and cuts with their own read back exactly."""
    from alembic.autogenerate import compare_metadata
    from alembic.migration import MigrationContext

    from millstab import api
    from millstab.shopdb import schema
    from millstab.shopdb.store import cut_settings
    from test_shopdb_shops import MIXED, database_at

    database_at(url, "0002", cut=True)
    store = open_store(url, user="bob")
    with store.engine.connect() as conn:
        ctx = MigrationContext.configure(conn)
        assert ctx.get_current_revision() == schema.HEAD and compare_metadata(ctx, schema.metadata) == []
    mixed = api.points_from_text(MIXED)
    store.add_cuts("old", mixed)
    got = store.cuts("old")
    assert cut_settings(got) == [{}] + cut_settings(mixed) and got.rpm[0] == 9000.5 and store.check() == []
