"""The commands on a shop database (issue 31): `update`, `map`, `recommend` and `predict` with --db/--campaign
give the numbers of the file workflow (update --start post.json, same seeds), and record what they did."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("sqlalchemy")

from millstab.cli import main  # noqa: E402
from millstab.io import read_json  # noqa: E402

FIRST = "rpm,depth_mm,label\n5000,1.0,stable\n5500,4.0,chatter\n6000,2.0,stable\n"
MORE = "rpm,depth_mm,label\n7000,3.0,chatter\n7400,1.2,stable\n"


def run(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    assert code == 0, err
    return out


def test_db_workflow_equals_the_file_workflow(tmp_path, capsys):
    (tmp_path / "first.csv").write_text(FIRST)
    (tmp_path / "all.csv").write_text(FIRST + MORE.split("\n", 1)[1])
    (tmp_path / "more.csv").write_text(MORE)
    db, common = tmp_path / "shop.db", ["--samples", 200, "--seed", 3]
    # files: the first cuts, then all cuts starting from the first posterior
    run(capsys, "update", "example:ex1", tmp_path / "first.csv", "--out", tmp_path / "p1.json", *common)
    run(capsys, "update", "example:ex1", tmp_path / "all.csv", "--start", tmp_path / "p1.json", "--out",
        tmp_path / "p2.json", *common)
    # the database: the same cuts in two rounds, no posterior file in hand
    run(capsys, "update", "example:ex1", tmp_path / "first.csv", "--db", db, "--campaign", "t12", *common)
    out = run(capsys, "update", "example:ex1", tmp_path / "more.csv", "--db", db, "--campaign", "t12", *common,
              "--out", tmp_path / "d2.json")
    np.testing.assert_array_equal(read_json(tmp_path / "d2.json")["samples"],
                                  read_json(tmp_path / "p2.json")["samples"])
    rec = ["--risk", 0.1, "--rpm", "4000:9000"]
    run(capsys, "recommend", tmp_path / "p2.json", *rec, "--out", tmp_path / "r_file.json")
    run(capsys, "recommend", "--db", db, "--campaign", "t12", *rec, "--out", tmp_path / "r_db.json")
    a, b = (json.loads((tmp_path / f).read_text()) for f in ("r_file.json", "r_db.json"))
    assert (a["rpm"], a["depth_mm"]) == (b["rpm"], b["depth_mm"])
    run(capsys, "map", "--db", db, "--campaign", "t12", "--rpm", "4000:9000:500", "--depth", "0.5:3:0.5",
        "--out", tmp_path / "m_db.csv")
    run(capsys, "map", tmp_path / "p2.json", "--rpm", "4000:9000:500", "--depth", "0.5:3:0.5", "--out",
        tmp_path / "m.csv")
    assert (tmp_path / "m_db.csv").read_text() == (tmp_path / "m.csv").read_text()
    run(capsys, "predict", "--db", db, "--campaign", "t12", tmp_path / "more.csv", "--out", tmp_path / "pr_db.csv")
    run(capsys, "predict", tmp_path / "p2.json", tmp_path / "more.csv", "--out", tmp_path / "pr.csv")
    assert (tmp_path / "pr_db.csv").read_text() == (tmp_path / "pr.csv").read_text()
    hist = run(capsys, "history", "--db", db, "--campaign", "t12")
    assert hist.count("update") >= 2 and "recommend" in hist


def test_db_options_and_files_are_checked_before_work(tmp_path, capsys):
    (tmp_path / "c.csv").write_text(FIRST)
    for args, needle in (
        (["update", "example:ex1", tmp_path / "c.csv"], "--out"),
        (["update", "example:ex1", tmp_path / "c.csv", "--db", tmp_path / "s.db"], "--campaign"),
        (["update", "example:ex1", tmp_path / "c.csv", "--db", tmp_path / "s.db", "--campaign", "x", "--start",
          tmp_path / "c.csv"], "--start"),
        (["map", "--rpm", "4000:5000:500", "--depth", "0.5:1:0.5", "--out", tmp_path / "m.csv"], "POSTERIOR"),
        (["recommend", "--rpm", "4000:5000", "--out", tmp_path / "r.json"], "POSTERIOR"),
    ):
        code = main([str(a) for a in args])
        err = capsys.readouterr().err
        assert code == 2 and needle in err and err.count("\n") == 1, err


def test_listen_records_the_cut_with_the_label_heard(tmp_path, capsys):
    """Issue 31.2: `listen REC --db --campaign --depth` records the cut in the campaign with the label and chatter
    frequency heard in the recording, the rater `listen` and the recording by reference; once the campaign has
    a posterior, the suggestion is recommend's from it (as with --post). Fails on the old code: no --db."""
    import math

    from listen_synth import milling_sound
    from test_shopdb import land, some_cuts

    from millstab.io.recordings import write_recording
    from millstab.shopdb import open_store

    db, fs = tmp_path / "shop.db", 48000
    chat, calm = tmp_path / "cut 1.wav", tmp_path / "cut2.wav"
    write_recording(chat, fs, milling_sound(teeth=2, rpm=14000.0, chatter_hz=1000.0, ratio=0.5))
    write_recording(calm, fs, milling_sound(teeth=2, rpm=9000.0))
    out = run(capsys, "listen", chat, "--rpm", 14000, "--teeth", 2, "--db", db, "--campaign", "t1", "--depth", 2.5,
              "--user", "ann")
    assert "chatter at 1000.0 Hz" in out and "recorded in campaign t1 as cut 1: 14000 rpm, 2.5 mm, chatter" in out
    with open_store(db) as s:
        land(s, "t1", some_cuts(3, 1), 1)  # an update lands: the campaign now has a posterior
    out = run(capsys, "listen", calm, "--rpm", 9000, "--teeth", 2, "--db", db, "--campaign", "t1", "--depth", 1.0,
              "--rpm-range", "5000:12000", "--user", "bob")
    assert "stable" in out and "recommend: the fastest cut" in out and "as cut 5: 9000 rpm, 1 mm, stable" in out
    with open_store(db) as s:
        rows = s.cut_rows("t1")
    first, last = rows[0], rows[-1]
    assert (first["rpm"], first["depth_mm"], first["label"], first["rater"], first["created_by"]) == \
        (14000.0, 2.5, "chatter", "listen", "ann")
    assert abs(first["chatter_hz"] - 1000.0) < 2 and first["recording"] == str(chat.resolve())
    assert (last["rpm"], last["depth_mm"], last["label"], last["created_by"]) == (9000.0, 1.0, "stable", "bob")
    assert last["chatter_hz"] is None or math.isnan(last["chatter_hz"])
    # the depth is needed to record the cut; --post and --db do not go together
    assert main(["listen", str(calm), "--rpm", "9000", "--teeth", "2", "--db", str(db), "--campaign", "t1"]) == 2
    assert "--depth" in capsys.readouterr().err
    assert main(["listen", str(calm), "--rpm", "9000", "--teeth", "2", "--db", str(db)]) == 2  # --campaign missing


def test_update_from_the_cuts_listen_recorded_needs_no_file(tmp_path, capsys):
    """`listen --db` says "the next `millstab update --db` uses it": an update with --db/--campaign and no CUTS file
    tempers in the cuts recorded since the campaign's posterior (it demanded a CUTS argument until 2026-11-29); with
    none recorded it is refused in one line (it re-ran the sampler on nothing and recorded the same posterior as a
    new one); a changed engine refits from the prior; without --db the missing CUTS is named."""
    from listen_synth import milling_sound

    from millstab.io.recordings import write_recording
    from millstab.shopdb import open_store

    (tmp_path / "first.csv").write_text(FIRST)
    db, common = tmp_path / "shop.db", ["--samples", 200, "--seed", 3]
    run(capsys, "update", "example:ex1", tmp_path / "first.csv", "--db", db, "--campaign", "t1", *common)
    wav = tmp_path / "cut.wav"
    write_recording(wav, 48000, milling_sound(teeth=2, rpm=9000.0, chatter_hz=1000.0, ratio=0.5))
    run(capsys, "listen", wav, "--rpm", 9000, "--teeth", 2, "--db", db, "--campaign", "t1", "--depth", 3.5)
    out = run(capsys, "update", "example:ex1", "--db", db, "--campaign", "t1", *common, "--out", tmp_path / "p.json")
    assert "wrote" in out
    post = read_json(tmp_path / "p.json")
    cuts = post["cuts"]
    assert len(cuts["rpm"]) == 4 and cuts["rpm"][-1] == 9000.0 and cuts["label"][-1] == "chatter"
    with open_store(db) as s:
        n_posteriors = s.head("t1").posterior_id
    code = main([str(a) for a in ["update", "example:ex1", "--db", db, "--campaign", "t1", *common]])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "already holds all 4 recorded cuts" in err, err
    with open_store(db) as s:
        assert s.head("t1").posterior_id == n_posteriors  # nothing recorded
    out = run(capsys, "update", "example:ex1", "--db", db, "--campaign", "t1", "--engine", "sdm", "--samples", 100,
              "--engine-option", "steps=20")
    assert "updating from the prior over all 4 cuts" in out
    code = main(["update", "example:ex1", "--out", str(tmp_path / "q.json")])
    err = capsys.readouterr().err
    assert code == 2 and "CUTS" in err and err.count("\n") == 1, err


#: cuts in several conditions (a/D, direction, teeth, feed) and at several stickouts, on two test days
MIXED_FIRST = ("rpm,depth_mm,label,batch,radial_immersion,milling,teeth,feed_per_tooth_mm,stickout_mm\n"
               "9000,0.4,stable,mon,,,,,\n"
               "12000,1.5,chatter,mon,0.25,up,,0.08,60\n"
               "15000,0.8,stable,mon,,,,,60\n")
MIXED_MORE = ("rpm,depth_mm,label,batch,radial_immersion,milling,teeth,feed_per_tooth_mm,stickout_mm\n"
              "11000,1.0,stable,tue,0.25,up,,,45\n"
              "14000,2.5,chatter,tue,,,4,,75\n")


@pytest.mark.slow
def test_db_workflow_of_mixed_conditions_and_stickouts_equals_the_file_workflow(tmp_path, capsys):
    """A [tool] + [holder] config (one posterior over the holder) and cuts each in its own condition and at its
    own stickout: the database in two rounds gives the file workflow's samples bit for bit (same seed), and
    map / recommend at a target condition and stickout from the campaign equal those from the posterior file.
    Fails on the old code: the database refused such cuts."""
    from test_update_stickout import CONFIG

    cfg = tmp_path / "holder.toml"
    cfg.write_text(CONFIG)
    (tmp_path / "first.csv").write_text(MIXED_FIRST)
    (tmp_path / "all.csv").write_text(MIXED_FIRST + MIXED_MORE.split("\n", 1)[1])
    (tmp_path / "more.csv").write_text(MIXED_MORE)
    db, common = tmp_path / "shop.db", ["--samples", 200, "--seed", 5]
    run(capsys, "update", cfg, tmp_path / "first.csv", "--out", tmp_path / "p1.json", *common)
    run(capsys, "update", cfg, tmp_path / "all.csv", "--start", tmp_path / "p1.json", "--out", tmp_path / "p2.json",
        *common)
    run(capsys, "update", cfg, tmp_path / "first.csv", "--db", db, "--campaign", "t12", *common)
    run(capsys, "update", cfg, tmp_path / "more.csv", "--db", db, "--campaign", "t12", *common, "--out",
        tmp_path / "d2.json")
    want, got = read_json(tmp_path / "p2.json"), read_json(tmp_path / "d2.json")
    np.testing.assert_array_equal(got["samples"], want["samples"])
    assert got["cuts"]["condition"] == want["cuts"]["condition"] and len(set(want["cuts"]["condition"])) == 3
    assert got["cuts"]["stickout_mm"] == want["cuts"]["stickout_mm"] == [None, 60.0, 60.0, 45.0, 75.0]
    target = ["--stickout", 55, "--radial-immersion", 0.3, "--milling", "up"]  # never cut: decided from the holder
    grid = ["--rpm", "8000:16000:1000", "--depth", "0.25:3:0.25"]
    run(capsys, "map", "--db", db, "--campaign", "t12", *grid, *target, "--out", tmp_path / "m_db.csv")
    run(capsys, "map", tmp_path / "p2.json", *grid, *target, "--out", tmp_path / "m.csv")
    assert (tmp_path / "m_db.csv").read_text() == (tmp_path / "m.csv").read_text()
    run(capsys, "map", tmp_path / "p2.json", *grid, "--out", tmp_path / "m_config.csv")
    assert (tmp_path / "m_config.csv").read_text() != (tmp_path / "m.csv").read_text()  # the target moved the map
    rec = ["--risk", 0.1, "--rpm", "8000:16000", *target]
    run(capsys, "recommend", "--db", db, "--campaign", "t12", *rec, "--out", tmp_path / "r_db.json")
    run(capsys, "recommend", tmp_path / "p2.json", *rec, "--out", tmp_path / "r.json")
    a, b = (json.loads((tmp_path / f).read_text()) for f in ("r.json", "r_db.json"))
    assert (a["rpm"], a["depth_mm"]) == (b["rpm"], b["depth_mm"])


def _sounds(tmp_path):
    """Two recorded cuts of ex1 (2 teeth): one chattering at 1000 Hz at 9000 rpm, one stable at 7000 rpm."""
    from listen_synth import milling_sound

    from millstab.io.recordings import write_recording

    write_recording(tmp_path / "chat.wav", 48000, milling_sound(teeth=2, rpm=9000.0, chatter_hz=1000.0, ratio=0.5,
                                                                seconds=2.0))
    write_recording(tmp_path / "calm.wav", 48000, milling_sound(teeth=2, rpm=7000.0, seconds=2.0))


HEARD = "rpm,depth_mm,label,recording\n9000,3.0,,chat.wav\n7000,1.0,,calm.wav\n12000,1.0,stable,\n"


def test_the_whole_cuts_file_again_after_a_listen_adds_only_its_new_row(tmp_path, capsys):
    """Exploratory test item 1 (HIGH): a cuts file with a `recording` column, recorded by `update --db`, then a cut
    heard by `listen --db`, then the same file plus one row: the campaign holds 3 + 1 + 1 cuts, not 3 + 1 + 4 (every
    old row was added again: the file no longer began with *every* recorded cut, the listen cut missing from it).
    Item 3: the heard cuts keep their recording and rater `listen`, in the database and in the export's
    cuts_meta.csv (both were empty). Fails on the old code."""
    import csv

    from millstab.shopdb import open_store

    _sounds(tmp_path)
    (tmp_path / "cuts.csv").write_text(HEARD)
    (tmp_path / "cuts_b.csv").write_text(HEARD + "12000,3.0,chatter,\n")
    db, common = tmp_path / "shop.db", ["--samples", 200, "--seed", 3]
    run(capsys, "update", "example:ex1", tmp_path / "cuts.csv", "--db", db, "--campaign", "a", *common)
    run(capsys, "listen", tmp_path / "chat.wav", "--rpm", 9000, "--teeth", 2, "--db", db, "--campaign", "a",
        "--depth", 4.5)
    out = run(capsys, "update", "example:ex1", tmp_path / "cuts_b.csv", "--db", db, "--campaign", "a", *common)
    assert "the first 3 rows of the cuts are cuts the campaign holds" in out and "adding the 1 after them" in out
    with open_store(db) as s:
        rows = s.cut_rows("a")
    assert [(r["rpm"], r["depth_mm"], r["label"]) for r in rows] == [
        (9000.0, 3.0, "chatter"), (7000.0, 1.0, "stable"), (12000.0, 1.0, "stable"), (9000.0, 4.5, "chatter"),
        (12000.0, 3.0, "chatter")]
    assert [(r["rater"], r["recording"]) for r in rows] == [
        ("listen", str((tmp_path / "chat.wav").resolve())), ("listen", str((tmp_path / "calm.wav").resolve())),
        ("", ""), ("listen", str((tmp_path / "chat.wav").resolve())), ("", "")]
    run(capsys, "campaign", "export", "--db", db, "--campaign", "a", "--out", tmp_path / "exp")
    with open(tmp_path / "exp" / "cuts_meta.csv", newline="") as f:
        meta = list(csv.DictReader(f))
    assert [m["rater"] for m in meta] == ["listen", "listen", "", "listen", ""]
    assert meta[1]["recording"] == str((tmp_path / "calm.wav").resolve())
    # the exported cuts file is the cuts as labelled (no recording column: update does not listen again)
    assert "recording" not in (tmp_path / "exp" / "cuts.csv").read_text().splitlines()[0]


def test_a_cut_heard_again_with_another_chatter_frequency_is_the_same_cut():
    """Exploratory test item 1: after a config change a recording's chatter was heard at 300.00 Hz, recorded at
    300.13 Hz; the cut is the one recorded (what the user wrote: speed, depth, recording), kept as recorded and
    said in a note, not added again (9 -> 18 cuts). A cut written in the file is another cut when its written
    label differs. Fails on the old code (every row counted as new)."""
    from millstab.api import shop
    from millstab.points import PointSet

    def cuts(label, hz, rec):
        return PointSet(np.array([9000.0, 7000.0]), np.array([1.5, 1.0]), np.array(label, dtype=object),
                        chatter_hz=np.array(hz), extra={"recording": np.array(rec, dtype=object)})

    old = cuts(["chatter", "stable"], [300.13, np.nan], ["/r/late.wav", ""])
    rows = [{"recording": "/r/late.wav"}, {"recording": ""}]
    again = cuts(["chatter", "stable"], [300.0, np.nan], ["/r/late.wav", ""])
    new, notes = shop.already_recorded(old, again, rows)
    assert len(new) == 0 and "adding the 0 after them" in notes[0]
    assert "cut 1 (9000 rpm, 1.5 mm, late.wav) is heard as chatter at 300.00 Hz now, recorded as chatter at " \
           "300.13 Hz" in notes[1] and len(notes) == 2
    relabelled = cuts(["chatter", "chatter"], [300.0, np.nan], ["/r/late.wav", ""])
    new, notes = shop.already_recorded(old, relabelled, rows)
    assert len(new) == 1 and new.label[0] == "chatter" and "adding the 1 after them" in notes[0]
    # a cut recorded by listen, missing from the file, does not stop the file's recorded rows being recognised
    new, _ = shop.already_recorded(old.subset(np.array([1, 0])), again.subset(np.array([1])), rows[::-1])
    assert len(new) == 0


def test_listen_records_the_stickout_and_checks_campaign_and_teeth(tmp_path, capsys):
    """Exploratory test items 2 and 6: `listen --db` had no --stickout (a 60 mm cut was stored at the config's
    stickout), a misspelt --campaign silently started a new campaign, and --teeth 3 went into a 2-tooth campaign
    without comment. And `update` with a `recording` column dropped the cuts' stickout_mm column (every heard cut
    at the config's stickout; its notes printed "8500 rpm, 2 mm: chatter" twice for two stickouts). Fails on the
    old code."""
    from listen_synth import milling_sound
    from test_update_stickout import CONFIG

    from millstab.io.recordings import write_recording
    from millstab.shopdb import open_store

    cfg, db, common = tmp_path / "holder.toml", tmp_path / "shop.db", ["--samples", 200, "--seed", 3]
    cfg.write_text(CONFIG)  # 3 teeth, a 12 mm end mill at 45 mm, fluted length 26 mm
    write_recording(tmp_path / "c.wav", 48000, milling_sound(teeth=3, rpm=8500.0, chatter_hz=1000.0, ratio=0.5,
                                                             seconds=2.0))
    (tmp_path / "cuts.csv").write_text("rpm,depth_mm,label,stickout_mm,recording\n9000,0.3,stable,45,\n"
                                       "8500,2.0,,60,c.wav\n8500,2.0,,40,c.wav\n")
    out = run(capsys, "update", cfg, tmp_path / "cuts.csv", "--db", db, "--campaign", "em12", *common)
    assert "8500 rpm, 2 mm (stickout 60 mm): chatter" in out and "8500 rpm, 2 mm (stickout 40 mm): chatter" in out
    listen = ["listen", tmp_path / "c.wav", "--rpm", 8500, "--depth", 2, "--db", db]
    run(capsys, *listen, "--teeth", 3, "--campaign", "em12", "--stickout", 55)
    with open_store(db) as s:
        assert [r["stickout_mm"] for r in s.cut_rows("em12")] == [45.0, 60.0, 40.0, 55.0]
    for extra, needle in ((["--teeth", 2, "--campaign", "em12"], "--teeth = 2 is invalid: the tool of campaign "
                                                                  "'em12' has 3 teeth"),
                          (["--teeth", 3, "--campaign", "em21"], "no such campaign"),
                          (["--teeth", 3, "--campaign", "em12", "--stickout", 0.06], "0.06 looks like metres"),
                          (["--teeth", 3, "--campaign", "em12", "--stickout", 20], "at least the tool's fluted "
                                                                                    "length (26 mm)")):
        assert main([str(a) for a in listen + extra]) == 2
        err = capsys.readouterr().err
        assert needle in err and err.count("\n") == 1, err
    run(capsys, *listen, "--teeth", 3, "--campaign", "em21", "--new-campaign")  # a new campaign when asked for
    with open_store(db) as s:
        assert len(s.cut_rows("em12")) == 4 and len(s.cut_rows("em21")) == 1


def test_update_records_the_cuts_file_and_says_a_campaign_is_new(tmp_path, capsys):
    """A cut is traced to the file it came from (the update's event names it), and an update of a campaign the
    database does not hold, while it holds others, says so (a misspelt --campaign: a campaign of one cut)."""
    (tmp_path / "mon.csv").write_text(FIRST)
    (tmp_path / "tue.csv").write_text(MORE)
    db, common = tmp_path / "shop.db", ["--samples", 200, "--seed", 3]
    run(capsys, "update", "example:ex1", tmp_path / "mon.csv", "--db", db, "--campaign", "t12-m1", *common)
    out = run(capsys, "update", "example:ex1", tmp_path / "tue.csv", "--db", db, "--campaign", "t12-m2", *common)
    said = ("new campaign 't12-m2' in " f"{db} (it holds 1 campaign(s): t12-m1); did you mean 't12-m1'? "
            "(a misspelt --campaign starts a campaign of its own)")
    assert said in " ".join(out.split())
    from millstab.api import shop

    details = {e.campaign: e.detail for e in shop.history(db) if e.action == "update"}
    assert details["t12-m1"].startswith(f"update: +3 cut(s) from {tmp_path / 'mon.csv'}, 3 in all;")
    assert details["t12-m2"].startswith(f"update: +2 cut(s) from {tmp_path / 'tue.csv'}, 2 in all;")
    assert said in details["t12-m2"]
