"""`millstab update`, `map` and `recommend` end to end, and their one-line errors."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from millstab.cli import main

CUTS = """rpm,depth_mm,label,chatter_hz
5000,1.0,stable,
5500,4.0,chatter,1010
6000,2.0,stable,
7000,3.0,marginal,
8000,5.0,chatter,
9000,2.5,stable,
"""


@pytest.fixture(scope="module")
def shop(tmp_path_factory):
    d = tmp_path_factory.mktemp("upd")
    (d / "cuts.csv").write_text(CUTS)
    assert main(["update", "example:ex1", str(d / "cuts.csv"), "--samples", "300", "--seed", "3",
                 "--out", str(d / "post.json"), "--plot", str(d / "corner.png")]) == 0
    return d


def test_update_writes_the_posterior(shop):
    doc = json.loads((shop / "post.json").read_text())
    assert doc["schema"] == "millstab.posterior/3"
    assert doc["names"] == ["fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y"]
    s = np.array(doc["samples"])
    assert s.shape == (300, 6) and (s > 0).all()
    p = doc["parameters"]["fn_x"]
    assert p["q05"] <= p["q50"] <= p["q95"] and p["sd"] > 0
    assert doc["diagnostics"]["stages"] >= 1 and doc["diagnostics"]["frequency_term"] is True
    assert doc["prior"]["cutting"]["teeth"] == 2 and len(doc["cuts"]["rpm"]) == 6
    assert (shop / "corner.png").stat().st_size > 1000
    # the config's name is the posterior's own (issue 26: the CLI added it after to_json, so the web app's
    # posterior.json lacked it and a posterior read back dropped it): the file round-trips whole
    from millstab.update import Posterior

    assert doc["config"] == "ex1" and Posterior.from_json(doc, "post.json").to_json() == doc


def test_map_and_recommend_from_the_json_alone(shop, capsys):
    assert main(["map", str(shop / "post.json"), "--rpm", "5000:9000:500", "--depth", "0:6:0.5",
                 "--out", str(shop / "pmap.csv"), "--plot", str(shop / "pmap.png")]) == 0
    rows = list(csv.DictReader((shop / "pmap.csv").open()))
    assert len(rows) == 9 * 13 and set(rows[0]) == {"rpm", "depth_mm", "p_stable"}
    p = np.array([float(r["p_stable"]) for r in rows]).reshape(9, 13)
    assert (np.diff(p, axis=1) <= 0).all() and (p[:, 0] == 1).all()
    assert main(["recommend", str(shop / "post.json"), "--risk", "0.05", "--rpm", "5000:9000", "--max-depth", "3",
                 "--radial-width", "5", "--feed-per-tooth", "0.1", "--out", str(shop / "rec.json")]) == 0
    rec = json.loads((shop / "rec.json").read_text())
    assert rec["p_chatter"] <= 0.05 and rec["depth_mm"] <= 3 and 5000 <= rec["rpm"] <= 9000
    assert rec["mrr_cm3_per_min"] == pytest.approx(rec["depth_mm"] * rec["rpm"] * 5 * 0.1 * 2 / 1000)
    assert {"rpm", "depth_mm", "why"} <= set(rec["next_test"])


def test_map_samples_option_states_the_error_and_refuses_a_bad_value(shop, capsys):
    """``map --samples``: auto (every sample of this zero-order posterior), a number (its error printed), or a one-line
    error naming --samples. Fails on the old code (an integer option: "auto" refused)."""
    args = ["map", str(shop / "post.json"), "--rpm", "5000:9000:1000", "--depth", "0:4:1", "--out"]
    assert main([*args, str(shop / "auto.csv"), "--samples", "auto"]) == 0
    assert "300 samples;" in " ".join(capsys.readouterr().out.split())  # (rich wraps the line)
    assert main([*args, str(shop / "sub.csv"), "--samples", "100"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "100 of 300 samples (Monte Carlo standard error ≤ 0.050 per cell)" in out
    assert main([*args, str(shop / "bad.csv"), "--samples", "many"]) == 2
    assert "--samples" in capsys.readouterr().err and not (shop / "bad.csv").exists()


def test_recommend_rule_options_reach_the_library(shop):
    """--confidence none --speed-tolerance 0 is the plain rule of millstab.update.recommend (the same cut),
    and the default rule is at least as cautious (its depth never deeper at the same risk)."""
    from millstab.update import recommend
    from millstab.update.posterior import Posterior

    post = Posterior.from_json(json.loads((shop / "post.json").read_text()))
    assert main(["recommend", str(shop / "post.json"), "--rpm", "5000:9000", "--max-depth", "3", "--confidence", "none",
                 "--speed-tolerance", "0", "--out", str(shop / "plain.json")]) == 0
    plain = json.loads((shop / "plain.json").read_text())
    lib = recommend(post, 0.05, (5000, 9000), max_depth_mm=3, confidence=None, speed_tolerance=0.0)
    assert (plain["rpm"] == pytest.approx(lib.rpm, rel=1e-12)
            and plain["depth_mm"] == pytest.approx(lib.depth_mm, rel=1e-12))
    assert main(["recommend", str(shop / "post.json"), "--rpm", "5000:9000", "--max-depth", "3",
                 "--out", str(shop / "safe.json")]) == 0
    safe = json.loads((shop / "safe.json").read_text())
    assert safe["confidence"] == 0.9 and safe["speed_tolerance"] == 0.0025
    # the default rule's cuts are a subset of the plain rule's, so its best removal rate is no higher
    assert safe["depth_mm"] * safe["rpm"] <= plain["depth_mm"] * plain["rpm"] * (1 + 1e-3)


@pytest.mark.parametrize("args, text", [
    (["recommend", "{d}/post.json", "--risk", "0", "--rpm", "5000:9000", "--out", "{d}/r.json"], "--risk"),
    (["recommend", "{d}/post.json", "--rpm", "9000:5000", "--out", "{d}/r.json"], "--rpm"),
    (["recommend", "{d}/post.json", "--rpm", "5000:9000", "--radial-width", "5", "--out", "{d}/r.json"],
     "--feed-per-tooth"),
    (["map", "{d}/cuts.csv", "--rpm", "5000:9000:100", "--depth", "0:5:0.1", "--out", "{d}/m.csv"], "not valid JSON"),
    (["map", "{d}/post.json", "--rpm", "5000:9000:100", "--depth", "0:5", "--out", "{d}/m.csv"], "--depth"),
    (["update", "example:ex1", "{d}/bad.csv", "--out", "{d}/p.json"], "label"),
    (["update", "example:ex1", "{d}/marg.csv", "--out", "{d}/p.json"], "stable or chatter"),
    (["update", "example:ex1", "{d}/cuts.csv", "--out", "{d}/cuts.csv"], "--out"),
    (["update", "{d}/neg.toml", "{d}/cuts.csv", "--out", "{d}/p.json"], "prior.fn"),
    (["recommend", "{d}/post.json", "--rpm", "5000:9000", "--confidence", "1", "--out", "{d}/r.json"], "--confidence"),
    (["recommend", "{d}/post.json", "--rpm", "5000:9000", "--confidence", "high", "--out", "{d}/r.json"],
     "--confidence"),
    (["recommend", "{d}/post.json", "--rpm", "5000:9000", "--speed-tolerance", "0.2", "--out", "{d}/r.json"],
     "--speed-tolerance"),
])
def test_bad_input_is_one_line_exit_2(shop, args, text, capsys):
    (shop / "bad.csv").write_text("rpm,depth_mm,label\n5000,1,wobbly\n")
    (shop / "marg.csv").write_text("rpm,depth_mm,label\n5000,1,marginal\n")
    from millstab.datasets import example_path

    (shop / "neg.toml").write_text(example_path("ex1").read_text() + '\n[prior]\nfn = "-5 %"\n')
    capsys.readouterr()
    assert main([a.format(d=shop) for a in args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("millstab: error:") and text in err[0]


@pytest.mark.parametrize("args, text", [
    (["recommend", "{d}/post.json", "--risk", "1.5", "--rpm", "5000:9000", "--out", "{d}/r.json"], "--risk"),
    (["recommend", "{d}/post.json", "--risk", "-0.1", "--rpm", "5000:9000", "--out", "{d}/r.json"], "--risk"),
    (["update", "{d}/zero.toml", "{d}/cuts.csv", "--out", "{d}/p.json"], "prior.k_x"),
])
def test_more_bad_input_is_one_line_exit_2(shop, args, text, capsys):
    from millstab.datasets import example_path

    (shop / "zero.toml").write_text(example_path("ex1").read_text() + "\n[prior]\nk_x = 0\n")
    capsys.readouterr()
    assert main([a.format(d=shop) for a in args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("millstab: error:") and text in err[0]


def test_weak_but_valid_answers_warn_in_one_line(shop, capsys):
    """All cuts stable: the update runs and says the map leans on the prior; speeds beyond the tested
    ones: map and recommend run and say so."""
    (shop / "stable.csv").write_text("rpm,depth_mm,label\n6000,1.0,stable\n7000,1.2,stable\n")
    capsys.readouterr()
    assert main(["update", "example:ex1", str(shop / "stable.csv"), "--samples", "200", "--out",
                 str(shop / "post_st.json")]) == 0
    out, err = capsys.readouterr()
    err = [x for x in err.splitlines() if x.strip()]
    assert len(err) == 1 and err[0].startswith("millstab: warning:") and "every cut" in err[0] and "stable" in err[0]
    assert "lean on the prior" in err[0]
    assert "every cut" not in out  # said once, as it happened (the table's warnings repeated it)
    assert "every cut" in json.loads((shop / "post_st.json").read_text())["warnings"][0]  # and kept in the file
    (shop / "marginal.csv").write_text("rpm,depth_mm,label\n6000,1.0,marginal\n7000,1.2,chatter\n")
    assert main(["update", "example:ex1", str(shop / "marginal.csv"), "--samples", "200", "--out",
                 str(shop / "post_mg.json")]) == 0
    assert "every cut" not in "".join(capsys.readouterr())  # a marginal cut lies at the limit: not one-sided
    assert main(["map", str(shop / "post.json"), "--rpm", "2000:20000:2000", "--depth", "0:4:1",
                 "--out", str(shop / "far.csv")]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("millstab: warning:") and "beyond the tested speeds" in err[0]
    assert main(["recommend", str(shop / "post.json"), "--rpm", "2000:20000", "--out", str(shop / "far.json")]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("millstab: warning:") and "beyond the tested speeds" in err[0]
    assert err[0].removeprefix("millstab: warning: ") in json.loads((shop / "far.json").read_text())["warnings"]


def test_kt_freed_by_the_prior_table_end_to_end(tmp_path):
    """[prior] kt = 0.3 frees Kt: the posterior carries it (N/m²), map and recommend read it back from the
    JSON, and cuts made with a 25 % larger true Kt pull it up (the limit scales as Kt₀/Kt exactly)."""
    from millstab.datasets import example_path
    from millstab.io import load_config
    from millstab.stability import get_engine

    cfg_text = example_path("ex1").read_text() + ('\n[prior]\nkt = 0.3\nzeta_x = 0.02\n'
                                                  'fixed = ["fn_x", "k_x", "fn_y", "k_y", "zeta_y"]\n')
    (tmp_path / "kt.toml").write_text(cfg_text)
    cfg = load_config(str(tmp_path / "kt.toml"))
    rpm = np.linspace(5000, 12000, 8)
    b_true = get_engine("zoa").envelope(cfg.structure, cfg.cutting, rpm).depth_mm / 1.25
    depth = b_true * np.where(np.arange(8) % 2, 1.15, 0.85)
    rows = "".join(f"{r},{d},{'chatter' if d > b else 'stable'}\n" for r, d, b in zip(rpm, depth, b_true))
    (tmp_path / "cuts.csv").write_text("rpm,depth_mm,label\n" + rows)
    assert main(["update", str(tmp_path / "kt.toml"), str(tmp_path / "cuts.csv"), "--samples", "1000", "--seed", "1",
                 "--out", str(tmp_path / "post.json")]) == 0
    doc = json.loads((tmp_path / "post.json").read_text())
    assert doc["names"] == ["zeta_x", "kt"] and doc["units"][-1] == "N/m^2"
    kt = doc["parameters"]["kt"]
    assert kt["q05"] < 1.25 * cfg.cutting.kt < kt["q95"]
    assert kt["q50"] > 1.1 * cfg.cutting.kt  # pulled up from the prior median Kt₀
    assert np.std(np.log(np.array(doc["samples"])[:, 1])) < 0.5 * 0.3  # narrower than the prior
    assert main(["map", str(tmp_path / "post.json"), "--rpm", "5000:12000:1000", "--depth", "0:4:1",
                 "--out", str(tmp_path / "m.csv")]) == 0
    assert main(["recommend", str(tmp_path / "post.json"), "--rpm", "5000:12000",
                 "--out", str(tmp_path / "r.json")]) == 0
    rec = json.loads((tmp_path / "r.json").read_text())
    assert rec["p_chatter"] <= 0.05


def test_update_from_an_earlier_posterior(shop, capsys):
    """--start: the posterior of the first cuts starts the update of all of them; a start of other cuts
    is refused in one line."""
    first = "".join(CUTS.splitlines(keepends=True)[:4])
    (shop / "first.csv").write_text(first)
    assert main(["update", "example:ex1", str(shop / "first.csv"), "--samples", "300", "--seed", "1",
                 "--out", str(shop / "early.json")]) == 0
    assert main(["update", "example:ex1", str(shop / "cuts.csv"), "--samples", "300", "--seed", "2",
                 "--start", str(shop / "early.json"), "--out", str(shop / "seq.json")]) == 0
    seq = json.loads((shop / "seq.json").read_text())
    fresh = json.loads((shop / "post.json").read_text())
    # only the new cuts are tempered in: never more stages than the fresh update (fewer is typical, not certain:
    # with the lobe-jump moves' random stream both took 2 stages here)
    assert len(seq["cuts"]["rpm"]) == 6 and seq["diagnostics"]["stages"] <= fresh["diagnostics"]["stages"]
    assert seq["diagnostics"]["started_from_cuts"] == 3 and fresh["diagnostics"]["started_from_cuts"] == 0
    (shop / "other.csv").write_text(CUTS.replace("6000,2.0", "6100,2.0"))
    capsys.readouterr()
    assert main(["update", "example:ex1", str(shop / "other.csv"), "--start", str(shop / "early.json"),
                 "--out", str(shop / "x.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("millstab: error:") and "start" in err[0]


def test_recommend_prints_without_a_file_and_map_needs_somewhere_to_write(shop, capsys, tmp_path, monkeypatch):
    """``recommend`` without ``--out`` prints the same cut it writes with it (a shop asking "where do I cut?" needs
    no file); ``map`` with neither ``--out`` nor ``--plot`` is refused before any work, naming both."""
    monkeypatch.setenv("COLUMNS", "200")
    args = ["recommend", str(shop / "post.json"), "--rpm", "5000:9000", "--max-depth", "3"]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert main([*args, "--out", str(tmp_path / "r.json")]) == 0
    with_file = capsys.readouterr().out
    rec = json.loads((tmp_path / "r.json").read_text())
    assert f"{rec['rpm']:.0f} rpm" in printed and "wrote" not in printed
    assert printed.replace("\n", "") in with_file.replace("\n", "")
    monkeypatch.chdir(tmp_path)
    assert main(["map", str(shop / "post.json"), "--rpm", "5000:9000:500", "--depth", "0:6:0.5"]) == 2
    err = capsys.readouterr().err
    assert "--out" in err and "--plot" in err and len(err.strip().splitlines()) == 1
    assert main(["map", str(shop / "post.json"), "--rpm", "5000:9000:500", "--depth", "0:6:0.5",
                 "--plot", "m.png"]) == 0
    assert (tmp_path / "m.png").stat().st_size > 1000 and not list(tmp_path.glob("*.csv"))


@pytest.mark.parametrize("field", ["--risk", "risk P(chatter)"])
def test_one_risk_rule_for_every_door(field):
    """recommend, the API's decision_rule and the app's field share parsing.check_risk: a probability strictly
    inside (0, 1), given as a number or its text; 0, 1, NaN, a boolean, text and None are refused naming the field
    (the library took a numpy float32 and refused '0.1'; the app's own copy said something else)."""
    import math

    from millstab.errors import InputError
    from millstab.parsing import check_risk
    from millstab.update.decide import recommend

    assert check_risk(np.float32(0.25), field) == 0.25 and check_risk("0.1", field) == 0.1
    for bad in (0, 1, 1.5, -0.1, math.nan, math.inf, True, "x", None, [0.1]):
        with pytest.raises(InputError) as exc:
            check_risk(bad, field)
        assert exc.value.field == field and "(0, 1)" in str(exc.value)
    with pytest.raises(InputError, match="--risk"):
        recommend(None, math.nan, (5000, 9000))  # refused before the posterior is read


def test_speeds_in_hz_are_warned_and_kept_with_the_posterior(tmp_path, capsys):
    """A cuts file whose rpm column holds rev/s (Hz: 83-150 for 5 000-9 000 rpm) was fitted 60 times too slow
    without a word naming the speeds; the warning names the column, the value, its reading in rpm and the config's
    speeds, and post.json keeps it. Speeds within the config's range raise none."""
    from millstab.io import load_config
    from millstab.update import warn_speeds_in_hz
    from millstab.points import PointSet

    rows = CUTS.splitlines()
    hz = [rows[0]] + [",".join([f"{float(r.split(',')[0]) / 60:.2f}"] + r.split(",")[1:]) for r in rows[1:]]
    (tmp_path / "cuts.csv").write_text("\n".join(hz) + "\n")
    assert main(["update", "example:ex1", str(tmp_path / "cuts.csv"), "--samples", "100", "--seed", "3",
                 "--out", str(tmp_path / "post.json")]) == 0
    said = ("rpm: the fastest cut is 150 rpm, below a tenth of the config's speeds (3000-15000 rpm): are the speeds "
            "in Hz (rev/s)? 150 rev/s is 9000 rpm; the column rpm is in rev/min")
    assert said in json.loads((tmp_path / "post.json").read_text())["warnings"]
    assert said in " ".join(capsys.readouterr().err.split())
    cfg = load_config("example:ex1")
    assert warn_speeds_in_hz(cfg, PointSet([5000, 9000], [1, 2], ["stable", "chatter"])) is None
    assert warn_speeds_in_hz(cfg, PointSet([10, 20], [1, 2], ["stable", "chatter"])) is None  # 60× is no speed of it
