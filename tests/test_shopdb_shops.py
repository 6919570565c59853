"""Per-shop visibility in the service layer (issue 31.4): a campaign belongs to a shop, a user of the app
sees and writes only their shops' campaigns, and the rule holds in millstab.api.shop (not only in the page).
Another shop's campaign is refused with the same words as a name that does not exist. Fast: no sampler
runs (posteriors are recorded through the store as in test_shopdb.py, and refused updates stop before
sampling)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("sqlalchemy")
pytest.importorskip("alembic")

import sqlalchemy as sa  # noqa: E402

from millstab import api  # noqa: E402
from millstab.api import shop  # noqa: E402
from millstab.errors import InputError  # noqa: E402
from millstab.shopdb import open_store, schema  # noqa: E402

from test_shopdb import land, some_cuts  # noqa: E402


@pytest.fixture
def db(tmp_path):
    """Campaign a1 of shop acme (two updates and cuts after them), b1 of shop bolt, c1 made by the command
    line (no shop named: the default shop)."""
    path = tmp_path / "shop.db"
    with open_store(path, user="ann") as s:
        land(s, "a1", some_cuts(4, 1), 1, shop="acme")
        land(s, "a1", some_cuts(3, 2), 2)
        s.add_cuts("a1", some_cuts(2, 3))
        land(s, "b1", some_cuts(5, 4), 4, shop="bolt", user="bob")
        land(s, "c1", some_cuts(3, 5), 5)
    return path


def message(exc: InputError, name: str) -> str:
    return str(exc.value).replace(name, "NAME") + " | " + exc.allowed


def test_a_user_lists_and_opens_only_their_shops_campaigns(db):
    assert [c["name"] for c in shop.campaigns(db)] == ["a1", "b1", "c1"]  # no rule: every campaign
    assert [(c["name"], c["shop"]) for c in shop.campaigns(db, ["acme"])] == [("a1", "acme")]
    assert [c["name"] for c in shop.campaigns(db, ["bolt", schema.DEFAULT_SHOP])] == ["b1", "c1"]
    ann = shop.ShopView(db, "ann", ["acme"])
    a1 = ann.open("a1")
    assert (a1.shop, a1.revision, len(a1.cuts), a1.posterior_rows) == ("acme", 2, 9, 7)
    assert a1.cuts.rpm.tolist() == (some_cuts(4, 1).rpm.tolist() + some_cuts(3, 2).rpm.tolist()
                                    + some_cuts(2, 3).rpm.tolist())
    assert a1.config_toml == "name = 'ex1'\n" and a1.posterior is not None
    assert [e.action for e in a1.events] == ["cuts", "update", "update", "create"]
    # history of "all campaigns" is of the user's shops only
    assert {e.campaign for e in ann.history()} == {"a1"}
    assert {e.campaign for e in shop.history(db)} == {"a1", "b1", "c1"}


def test_another_shops_campaign_reads_as_no_such_campaign(db):
    """Guessing a name of another shop tells nothing: the same error as a name that does not exist, and its
    name is not among the campaigns the error lists."""
    ann = shop.ShopView(db, "ann", ["acme"])
    with pytest.raises(InputError) as none:
        ann.open("zz9")
    for call in (lambda: ann.open("b1"), lambda: ann.history("b1"),
                 lambda: shop.posterior_from_db(db, "b1", shops=["acme"]),
                 lambda: ann.recommend("b1", 0.05, (5000, 12000))):
        with pytest.raises(InputError) as other:
            call()
        assert message(other.value, "b1") == message(none.value, "zz9")
        assert "b1" not in other.value.allowed and "a1" in other.value.allowed
    with open_store(db) as s:
        assert len(s.history("b1")) == 2  # nothing recorded by the refused recommendation


def test_writes_into_another_shop_are_refused_before_any_work(db, monkeypatch):
    """An update or new cuts aimed at another shop's campaign are refused before sampling (the name is
    taken, nothing of the campaign is shown), and nothing is recorded; a new campaign takes the user's shop, or one they
    name among theirs."""
    import sys

    monkeypatch.setattr(sys.modules["millstab.api.update"], "update",
                        lambda *a, **k: pytest.fail("sampled for a refused update"))
    ann = shop.ShopView(db, "ann", ["acme"])
    cfg = api.config("example:ex1")
    for call in (lambda: ann.update("b1", cfg, some_cuts(2, 9), samples=100),
                 lambda: ann.add_cuts("b1", some_cuts(2, 9))):
        with pytest.raises(InputError, match="taken by a campaign you cannot see"):
            call()
    with open_store(db) as s:
        assert s.head("b1").n_rows == 5 and s.head("b1").revision == 1
    assert ann.add_cuts("a2", some_cuts(2, 9)) == 2  # a new campaign: in ann's only shop
    assert shop.ShopView(db, "x", ["acme"]).open("a2").shop == "acme"
    both = shop.ShopView(db, "cy", ["acme", "bolt"])
    with pytest.raises(InputError, match="needs its shop: one of acme, bolt"):
        both.add_cuts("n1", some_cuts(1, 9))
    with pytest.raises(InputError, match="one of your shops"):
        both.add_cuts("n1", some_cuts(1, 9), shop="other")
    assert both.add_cuts("n1", some_cuts(1, 9), shop="bolt") == 1
    assert both.add_cuts("b1", some_cuts(1, 9)) == 6  # an existing campaign of one of cy's shops
    # a name taken in another shop: refused without saying whose
    with pytest.raises(InputError, match="taken by a campaign you cannot see"):
        ann.add_cuts("n1", some_cuts(1, 9))


def test_the_writers_transaction_checks_the_shop_again(db):
    """Between the service's check and the write another shop may create the same name: the store refuses
    a write whose shop is not the campaign's (the transaction is the last word)."""
    with open_store(db) as s:
        with pytest.raises(InputError, match="taken by a campaign you cannot see"):
            s.add_cuts("b1", some_cuts(1, 9), shop="acme")
        with pytest.raises(InputError, match="taken by a campaign you cannot see"):
            land(s, "b1", some_cuts(1, 9), 9, shop="acme")
        assert s.head("b1").n_rows == 5 and s.campaign_shop("b1") == "bolt"


def database_at(url: str, revision: str, cut: bool = False) -> None:
    """A database built by the migrations up to ``revision`` only (an older millstab's), holding campaign 'old'
    (from 0002 in shop acme) and, with ``cut``, one cut of it."""
    from alembic import command

    from millstab.shopdb.store import alembic_config

    at, shop_col = "'2026-01-01T00:00:00Z'", revision >= "0002"
    eng = sa.create_engine(url)
    with eng.begin() as conn:
        command.upgrade(alembic_config(conn), revision)
        conn.execute(sa.text("INSERT INTO campaign (name, note, created_at, created_by, updated_at, revision"
                             + (", shop" if shop_col else "") + f") VALUES ('old', '', {at}, 'ann', {at}, 0"
                             + (", 'acme'" if shop_col else "") + ")"))
        if cut:
            conn.execute(sa.text("INSERT INTO cut (campaign_id, seq, rpm, depth_mm, label, grade, weight, batch, "
                                 "rater, recording, created_at, created_by) SELECT id, 0, 9000.5, 1.25, 'chatter', "
                                 f"1.0, 2.0, 'mon', 'ann', '', {at}, 'ann' FROM campaign"))
    eng.dispose()


def test_a_database_of_the_first_schema_is_migrated_into_the_default_shop(tmp_path):
    path = tmp_path / "old.db"
    database_at(f"sqlite:///{path}", "0001")
    with open_store(path) as s:
        assert s.campaigns()[0]["shop"] == schema.DEFAULT_SHOP == "default"
        assert s.check() == []
    assert [c["name"] for c in shop.ShopView(path, "u", ["default"]).campaigns()] == ["old"]


def test_export_import_keeps_the_shop(db, tmp_path):
    shop.export_campaign(db, "b1", tmp_path / "b1")
    shop.import_campaign(db, tmp_path / "b1", "b1-copy")
    assert shop.ShopView(db, "bob", ["bolt"]).open("b1-copy").shop == "bolt"
    # the way to hand a command-line campaign (shop default) to a shop: export, import --shop
    from millstab.cli import main

    shop.export_campaign(db, "c1", tmp_path / "c1")
    assert main(["campaign", "import", str(tmp_path / "c1"), "--db", str(db), "--as", "c1-acme", "--shop", "acme"]) == 0
    assert [c["name"] for c in shop.campaigns(db, ["acme"])] == ["a1", "c1-acme"]
    assert main(["campaign", "import", str(tmp_path / "c1"), "--db", str(db), "--as", "x", "--shop", "a b"]) == 2


def test_a_retry_after_another_shop_took_the_name_reads_none_of_its_cuts(db, monkeypatch):
    """Two shops start a campaign of the same name at once: the one that lands second is stale, and its
    re-run stops at the shop check, before reading or sampling the other shop's cuts."""
    import sys

    ann = shop.ShopView(db, "ann", ["acme"])
    sampled = []

    def fake_update(cfg, cuts, points, **kw):
        sampled.append(len(cuts))
        if len(sampled) == 1:  # bolt's campaign of the same name lands while acme's first attempt samples
            with open_store(db) as s:
                land(s, "same", some_cuts(5, 6), 6, shop="bolt")
        from test_shopdb import fake_posterior

        return fake_posterior(cuts, 0)

    monkeypatch.setattr(sys.modules["millstab.api.update"], "update", fake_update)
    with pytest.raises(InputError, match="taken by a campaign you cannot see"):
        ann.update("same", api.config("example:ex1"), some_cuts(2, 9), samples=100)
    assert sampled == [2]  # only acme's own two cuts were ever sampled (without the re-check: [2, 7], then refused)
    with open_store(db) as s:
        assert s.campaign_shop("same") == "bolt" and s.head("same").n_rows == 5


MIXED = ("rpm,depth_mm,label,batch,radial_immersion,milling,entry_deg,exit_deg,teeth,feed_per_tooth_mm,stickout_mm\n"
         "9000,1.0,stable,mon,0.5,up,,,,0.05,45\n"
         "9500,2.0,chatter,mon,,,,,,,\n"
         "10000,1.5,marginal,tue,,,30,150,3,,60.25\n"
         "10500,0.7,stable,tue,0.1,down,,,4,0.1,0.1\n")


def test_cuts_with_conditions_and_stickouts_are_stored_as_given(tmp_path):
    """Each cut's own condition cells and stickout are recorded (NULL: an empty cell, the config's value) and
    read back as the file gave them, bit for bit, also through export/import. Fails on the old code: such cuts
    were refused (the database had no columns for them)."""
    from millstab.io import read_points, write_points
    from millstab.io.stickout import stickouts_mm
    from millstab.shopdb.store import cut_settings

    (tmp_path / "mixed.csv").write_text(MIXED)
    cuts = read_points(tmp_path / "mixed.csv")
    assert cuts.has_conditions
    db = tmp_path / "shop.db"
    assert shop.record_cuts(db, "c1", cuts, user="ann") == 4
    with open_store(db) as s:
        rows = s.cut_rows("c1")
        got = s.cuts("c1")
    assert [r["milling"] for r in rows] == ["up", None, None, "down"] and rows[2]["teeth"] == 3
    assert [r["stickout_mm"] for r in rows] == [45.0, None, 60.25, 0.1] and rows[1]["radial_immersion"] is None
    assert set(got.conditions) == {"radial_immersion", "milling", "entry_deg", "exit_deg", "teeth", "feed_per_tooth_mm"}
    for k, col in cuts.conditions.items():
        assert got.conditions[k].tolist() == col.tolist() if k == "milling" else \
            np.array_equal(got.conditions[k], col, equal_nan=True), k
    np.testing.assert_array_equal(stickouts_mm(got), stickouts_mm(cuts))
    assert got.batch.tolist() == ["mon", "mon", "tue", "tue"]  # the test day, stored since the first schema
    write_points(tmp_path / "back.csv", got)  # the campaign's cuts as a file: the same cuts file again
    assert cut_settings(read_points(tmp_path / "back.csv")) == cut_settings(cuts)
    shop.export_campaign(db, "c1", tmp_path / "c1")
    shop.import_campaign(db, tmp_path / "c1", "c1-copy")
    with open_store(db) as s:
        assert cut_settings(s.cuts("c1-copy")) == cut_settings(cuts) and s.check() == []
    # the app's cuts table: the condition and stickout columns some cut fills, an empty cell the config's value
    header, body = shop.cut_table(shop.ShopView(db, "ann").open("c1").rows)
    assert header == ["seq", "rpm", "depth_mm", "label", "batch", "radial_immersion", "milling", "entry_deg",
                      "exit_deg", "feed_per_tooth_mm", "teeth", "stickout_mm", "created_by"]
    assert body[1] == [2, 9500.0, 2.0, "chatter", "mon"] + [None] * 7 + ["ann"]
    assert body[2][header.index("entry_deg")] == 30.0 and body[3][header.index("stickout_mm")] == 0.1
    # the whole file again, as the file workflow passes it: its recorded rows are recognised, conditions too
    assert shop.already_recorded(got, cuts)[0].rpm.size == 0
    moved = read_points(tmp_path / "mixed.csv")
    moved.extra["stickout_mm"][0] = "46"  # the same cut at another stickout is another cut
    assert len(shop.already_recorded(got, moved)[0]) == 4


def test_a_database_of_schema_0002_is_migrated_and_keeps_its_cuts(tmp_path):
    """Upgrading from 0002: the cut table gains the condition and stickout columns, NULL (the config's) for
    every existing cut, which read back unchanged; the schema is then the code's tables."""
    from alembic.autogenerate import compare_metadata
    from alembic.migration import MigrationContext

    path = tmp_path / "old.db"
    database_at(f"sqlite:///{path}", "0002", cut=True)
    with open_store(path) as s:
        with s.engine.connect() as conn:
            assert MigrationContext.configure(conn).get_current_revision() == schema.HEAD == "0003"
            assert compare_metadata(MigrationContext.configure(conn), schema.metadata) == []
        (row,) = s.cut_rows("old")
        assert all(row[k] is None for k in ("radial_immersion", "milling", "teeth", "stickout_mm"))
        got = s.cuts("old")
        assert (got.rpm[0], got.depth_mm[0], got.weight[0], got.batch[0]) == (9000.5, 1.25, 2.0, "mon")
        assert not got.has_conditions and "stickout_mm" not in got.extra and s.check() == []
        s.add_cuts("old", api.points_from_text(MIXED))  # and the migrated campaign takes cuts with their own conditions
        assert [r["stickout_mm"] for r in s.cut_rows("old")] == [None, 45.0, None, 60.25, 0.1]


def test_update_shop_names_the_shop_of_a_command_line_campaign(tmp_path, monkeypatch):
    """`update --db --campaign --shop NAME` creates the campaign in shop NAME (the command line's campaigns went
    to 'default' only); a campaign's shop cannot change; a bad name and --shop without --db are one-line errors."""
    import sys

    from millstab.cli import main

    def fake_update(cfg, cuts, points, **kw):  # the shop is the point here, not the sampler
        import dataclasses

        from test_shopdb import fake_posterior

        diag = {"stages": 1, "acceptance": [0.5], "loglik_calls": 1, "time_s": 0.0}
        return dataclasses.replace(fake_posterior(cuts, 0), diagnostics=diag)

    import millstab.api.update  # noqa: F401 (loaded, to be patched)

    monkeypatch.setattr(sys.modules["millstab.api.update"], "update", fake_update)
    (tmp_path / "c.csv").write_text("rpm,depth_mm,label\n9000,1.0,stable\n9500,3.0,chatter\n")
    db = tmp_path / "shop.db"
    base = ["update", "example:ex1", str(tmp_path / "c.csv"), "--db", str(db), "--campaign", "t1", "--samples", "100"]
    assert main(base + ["--shop", "acme"]) == 0
    assert (shop.campaigns(db, ["acme"])[0]["name"] == "t1"
            and shop.ShopView(db, "ann", ["acme"]).open("t1").revision == 1)
    (tmp_path / "c.csv").write_text("rpm,depth_mm,label\n9000,1.0,stable\n9500,3.0,chatter\n10000,1.0,stable\n")
    assert main(base + ["--shop", "acme"]) == 0  # its own shop again (one more cut): fine
    assert main(base + ["--shop", "bolt"]) == 2
    assert main(base + ["--shop", "a b"]) == 2
    assert main(["update", "example:ex1", str(tmp_path / "c.csv"), "--out", str(tmp_path / "p.json"),
                 "--shop", "acme"]) == 2
    assert main(base[:6] + ["t2"] + base[7:]) == 0
    assert shop.campaigns(db, ["default"])[0]["name"] == "t2"
