"""The target-condition options of the doors as a user test found them: ``recommend --radial-width`` names the
condition the decision is made for (with the tool diameter), a/D as written in results (no angle round trip), the
P(stable) map's title names its condition, ``lobes --rpm`` takes one speed, and lobes' own help texts."""

from __future__ import annotations

import json

import numpy as np
import pytest

from millstab.errors import InputError
from millstab.io.config import parse_config
from millstab.points import condition_of, condition_text, describe_condition
from millstab.update import Posterior, make_prior
from configs import TWO_MODE_TOML

CFG = parse_config(TWO_MODE_TOML + '[prior]\nfixed = ["zeta_x", "fn_y", "k_y", "zeta_y"]\n')
SLOT = CFG.cutting
HALF_DOWN = condition_of(SLOT, radial_immersion=0.5, milling="down")


def _posterior(diameter_mm: float | None = 12.0, n: int = 120) -> Posterior:
    """A posterior of prior draws deciding at a/D 0.5 down (a 12 mm tool unless ``diameter_mm`` says otherwise)."""
    prior = make_prior(CFG.structure, CFG.cutting, CFG.prior)
    post = Posterior(prior, np.exp(prior.sample(n, np.random.default_rng(5))), "zoa", cuts={"rpm": [5000.0, 9000.0]},
                     diameter_mm=diameter_mm)
    return post.for_condition(HALF_DOWN)


def _aod(c) -> float:
    return describe_condition(c)["radial_immersion"]


# --- 1. --radial-width names the decision's condition where the diameter is known ----------------------------
def test_a_width_sets_the_decisions_immersion_with_the_diameter_and_is_checked_against_the_other_options():
    """Fails on the old code: a width wider than the tool was accepted, a width alone kept a/D 0.5, and a width
    contradicting --radial-immersion (or the angles) was refused only as 'not both' (or not at all)."""
    from millstab import api

    post = _posterior()
    with pytest.raises(InputError) as e:
        api.for_condition(post, radial_width_mm=14.0)
    assert str(e.value).startswith("--radial-width = 14") and "(0, 12]" in str(e.value)
    quarter = api.for_condition(post, radial_width_mm=3.0)  # the posterior's direction (down) at a/D 3/12
    assert (_aod(quarter.condition), describe_condition(quarter.condition)["milling"]) == (0.25, "down")
    up = api.for_condition(post, radial_width_mm=3.0, milling="up")
    assert condition_text(up.condition) == "a/D 0.25 up milling, 2 teeth"
    # with --radial-immersion: the width must agree (a/D 0.25 of 12 mm is 3 mm), and the a/D decides
    agreed = api.for_condition(post, radial_immersion=0.25, milling="up", radial_width_mm=3.0)
    assert agreed.condition == up.condition
    with pytest.raises(InputError) as e:
        api.for_condition(post, radial_immersion=0.25, milling="up", radial_width_mm=6.0)
    msg = str(e.value)
    assert msg.startswith("--radial-width = 6") and "--radial-immersion 0.25" in msg and "3 mm" in msg
    # with entry/exit angles: the engaged width D/2 (cos entry − cos exit)
    assert api.for_condition(post, entry_deg=0, exit_deg=90, radial_width_mm=6.0).condition.exit == pytest.approx(
        np.pi / 2)
    with pytest.raises(InputError) as e:
        api.for_condition(post, entry_deg=0, exit_deg=90, radial_width_mm=3.0)
    assert msg != str(e.value) and "--entry-deg 0/--exit-deg 90" in str(e.value) and "6 mm" in str(e.value)
    # without a diameter a width names no condition (a rate in cm³/min only): today's meaning
    plain = _posterior(None)
    assert api.for_condition(plain, radial_width_mm=14.0) is plain
    assert api.for_condition(plain, radial_immersion=0.25, milling="up", radial_width_mm=6.0).condition == up.condition


@pytest.mark.filterwarnings("ignore:the zoa engine averages")  # 0.5 teeth in the cut: not what is tested here
def test_a_recommendation_refuses_a_rate_width_that_is_not_its_conditions():
    """The library's own guard (any door): with a known diameter the removal rate's width is the decision's; fails
    on the old code (a 14 mm rate for a 6 mm cut)."""
    from millstab.update import recommend

    post = _posterior()
    with pytest.raises(InputError) as e:
        recommend(post, 0.05, (5000, 9000), width_mm=14.0, feed_mm=0.1)
    assert str(e.value).startswith("--radial-width = 14") and "a/D 0.5 down milling" in str(e.value)
    rec = recommend(post, 0.05, (5000, 9000), width_mm=6.0, feed_mm=0.1)
    assert rec.mrr_cm3_per_min == pytest.approx(rec.depth_mm * rec.rpm * 6.0 * 0.1 * 2 / 1000)
    # a width alone (no feed) named the condition: no rate, no error
    assert recommend(post, 0.05, (5000, 9000), width_mm=6.0).mrr_cm3_per_min is None
    # a feed alone takes the condition's width from the diameter (an exploratory test: `--radial-immersion 0.25
    # --feed-per-tooth 0.1` asked for --radial-width; fails on the old code)
    rec = recommend(post, 0.05, (5000, 9000), feed_mm=0.1)
    assert rec.mrr_cm3_per_min == pytest.approx(rec.depth_mm * rec.rpm * 6.0 * 0.1 * 2 / 1000)


def test_recommend_command_decides_for_the_width_or_names_the_contradiction(tmp_path, capsys):
    from millstab.cli import main

    (tmp_path / "post.json").write_text(json.dumps(_posterior().to_json()))
    base = ["recommend", str(tmp_path / "post.json"), "--rpm", "5000:9000", "--feed-per-tooth", "0.1"]
    for extra, named in ((["--radial-width", "14"], "(0, 12]"),
                         (["--radial-width", "6", "--radial-immersion", "0.25", "--milling", "up"],
                          "--radial-immersion 0.25")):
        capsys.readouterr()
        assert main([*base, *extra, "--out", str(tmp_path / "bad.json")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "--radial-width = " in err[0] and named in err[0]
        assert not (tmp_path / "bad.json").exists()
    assert main([*base, "--radial-width", "3", "--out", str(tmp_path / "r.json")]) == 0
    rec = json.loads((tmp_path / "r.json").read_text())
    assert rec["computed_for"]["radial_immersion"] == 0.25 and rec["computed_for"]["milling"] == "down"
    assert rec["mrr_cm3_per_min"] == pytest.approx(rec["depth_mm"] * rec["rpm"] * 3 * 0.1 * 2 / 1000)
    assert "computed for a/D 0.25 down milling" in " ".join(capsys.readouterr().out.split())


def _help(capsys, monkeypatch, *argv) -> str:
    """A command's help as one line of words (rich wraps it in boxed panels)."""
    from millstab.cli import main

    monkeypatch.setenv("COLUMNS", "300")
    capsys.readouterr()
    assert main([*argv, "--help"]) == 0
    return " ".join(capsys.readouterr().out.replace("│", " ").split())


def test_recommend_help_says_what_the_width_does(capsys, monkeypatch):
    out = _help(capsys, monkeypatch, "recommend")
    assert "sets the decision's a/D" in out and "without a diameter" in out


# --- 2. a/D as written, not as an angle round trip --------------------------------------------------------
def test_the_immersion_written_for_users_is_the_one_given():
    """Fails on the old code: a/D 0.5 up milling came back as 0.49999999999999994 (1 − cos(acos(0)))/2)."""
    for ri in (0.5, 0.25, 0.1, 0.3, 0.75):
        for mill in ("up", "down"):
            d = describe_condition(condition_of(SLOT, radial_immersion=ri, milling=mill))
            assert d["radial_immersion"] == ri, (ri, mill, d)
    half_up = describe_condition(condition_of(SLOT, radial_immersion=0.5, milling="up"))
    assert half_up["exit_deg"] == 90.0 and half_up["entry_deg"] == 0.0


# --- 3. the P(stable) map's title names its condition ------------------------------------------------------
def test_the_map_title_names_the_condition(tmp_path):
    pytest.importorskip("matplotlib")
    import matplotlib.pyplot as plt

    from millstab import api

    post = _posterior()
    fig = api.map_figure(post, np.linspace(5000, 9000, 5), np.linspace(0.5, 5, 4), np.full((5, 4), 0.5),
                         title="P(stable) from post.json")
    assert fig.axes[0].get_title() == "P(stable) from post.json: a/D 0.5 down milling, 2 teeth"
    plt.close(fig)


# --- 4. lobes --rpm with one speed --------------------------------------------------------------------------
def test_a_speed_range_of_one_speed_is_that_speed(tmp_path, capsys):
    """START = STOP gives that one speed, as --rpm-file with one line does (refused before); the range rules stay."""
    from millstab import api
    from millstab.cli import main

    np.testing.assert_array_equal(api.speeds("12984:12984:1"), [12984.0])
    (tmp_path / "one.txt").write_text("12984\n")
    np.testing.assert_array_equal(api.speeds(rpm_file=tmp_path / "one.txt"), [12984.0])
    for bad, why in (("12984:12000:1", "START = STOP: that one value"), ("12984:12984:0", "STEP > 0"),
                     ("5:5:1", "10")):  # (the speeds' bounds: 10 to 500 000 rev/min)
        with pytest.raises(InputError, match="--rpm") as e:
            api.speeds(bad)
        assert why in str(e.value), (bad, str(e.value))
    with pytest.raises(InputError, match="START < STOP"):  # map and design keep their rule: a range
        api.parse_rpm_range("12984:12984:1")
    assert main(["lobes", "example:ex1", "--rpm", "12984:12984:1", "--out", str(tmp_path / "one.csv")]) == 0
    rows = (tmp_path / "one.csv").read_text().strip().splitlines()
    assert len(rows) == 2 and rows[1].startswith("12984")


# --- 5. lobes' own help for the condition options -----------------------------------------------------------
def test_lobes_help_speaks_of_the_lobes_not_of_a_posterior(capsys, monkeypatch):
    out = _help(capsys, monkeypatch, "lobes")
    assert "posterior" not in out and "Decide" not in out
    for text in ("Draw the lobes for this radial immersion a/D", "Draw the lobes for up or down milling",
                 "Draw the lobes for this entry angle", "Draw the lobes for this exit angle",
                 "START = STOP is that one speed"):
        assert text in out, text
    rec = _help(capsys, monkeypatch, "recommend")
    assert "(or draw lobes)" not in rec and "Decide for this radial immersion" in rec


# --- simulate takes the same condition options (a user had to write a config per condition) ------------------
def test_simulate_runs_a_cut_in_the_condition_its_options_name(tmp_path, capsys):
    """``simulate CONFIG --radial-immersion 0.5 --milling up`` is the simulation of the config written in that
    condition (the same cut: identical trace), says which condition it ran, and the cuts mode takes the options as
    the config's condition for empty cells (a cell of the file still decides its row)."""
    from millstab.cli import main

    up = TWO_MODE_TOML.replace('entry = "0 deg"', 'radial_immersion = 0.5\nmilling = "up"').replace(
        'exit = "180 deg"\n', '')
    (tmp_path / "slot.toml").write_text(TWO_MODE_TOML)
    (tmp_path / "up.toml").write_text(up)
    args = ["--rpm", "6000", "--depth", "1.5", "--revs", "20"]
    assert main(["simulate", str(tmp_path / "slot.toml"), *args, "--radial-immersion", "0.5", "--milling", "up",
                 "--out", str(tmp_path / "a.csv")]) == 0
    said = capsys.readouterr().out
    assert "computed for a/D 0.5 up milling" in said and "the config's: slot" in said
    assert main(["simulate", str(tmp_path / "up.toml"), *args, "--out", str(tmp_path / "b.csv")]) == 0
    assert (tmp_path / "a.csv").read_text() == (tmp_path / "b.csv").read_text()
    assert main(["simulate", str(tmp_path / "slot.toml"), *args, "--out", str(tmp_path / "c.csv")]) == 0
    assert (tmp_path / "c.csv").read_text() != (tmp_path / "a.csv").read_text()  # the slot is another cut
    (tmp_path / "cuts.csv").write_text("rpm,depth_mm,radial_immersion,milling\n6000,1.5,,\n6000,1.5,1,\n")
    assert main(["simulate", str(tmp_path / "slot.toml"), "--cuts", str(tmp_path / "cuts.csv"), "--revs", "20",
                 "--radial-immersion", "0.5", "--milling", "up", "--out", str(tmp_path / "l.csv")]) == 0
    assert main(["simulate", str(tmp_path / "up.toml"), "--cuts", str(tmp_path / "cuts.csv"), "--revs", "20",
                 "--out", str(tmp_path / "m.csv")]) == 0
    assert (tmp_path / "l.csv").read_text() == (tmp_path / "m.csv").read_text()
    with pytest.raises(InputError, match="climb = down"):
        from millstab import api

        api.config_in_condition(CFG, radial_immersion=0.5, milling="sideways")


@pytest.mark.filterwarnings("ignore:the zoa engine averages")
def test_map_and_predict_take_a_radial_width_as_recommend_does(tmp_path, capsys):
    """map --radial-width 3 and predict --radial-width 3 on a 12 mm tool decide for a/D 0.25 (an exploratory test:
    map refused the option recommend takes); their numbers are those of --radial-immersion 0.25."""
    from millstab.cli import main

    (tmp_path / "post.json").write_text(json.dumps(_posterior().to_json()))
    (tmp_path / "cuts.csv").write_text("rpm,depth_mm\n6000,1.0\n8000,2.5\n")
    post = str(tmp_path / "post.json")
    for i, target in enumerate((["--radial-width", "3"], ["--radial-immersion", "0.25"])):
        assert main(["map", post, "--rpm", "5000:9000:500", "--depth", "0:4:1", *target, "--milling", "down",
                     "--out", str(tmp_path / f"m{i}.csv")]) == 0
        assert main(["predict", post, str(tmp_path / "cuts.csv"), *target, "--milling", "down",
                     "--out", str(tmp_path / f"p{i}.csv")]) == 0
    assert "computed for a/D 0.25 down milling" in " ".join(capsys.readouterr().out.split())
    for name in ("m", "p"):
        assert (tmp_path / f"{name}0.csv").read_text() == (tmp_path / f"{name}1.csv").read_text()
    assert main(["map", post, "--rpm", "5000:9000:500", "--depth", "0:4:1", "--radial-width", "14",
                 "--out", str(tmp_path / "bad.csv")]) == 2
    assert "--radial-width = 14" in capsys.readouterr().err and not (tmp_path / "bad.csv").exists()


def test_an_immersion_written_as_a_percentage_is_named_so():
    """--radial-immersion 25 (a/D in percent) is refused with the fraction it likely meant; 150 just with the range."""
    from millstab.api.update import target_condition

    base = parse_config(TWO_MODE_TOML).cutting
    with pytest.raises(InputError) as e:
        target_condition(base, radial_immersion=25.0, milling="down")
    assert str(e.value) == ("--radial-immersion = 25 is invalid: the radial immersion a/D, in (0, 1] (1 = slot); "
                            "a percentage? 25 % is 0.25")
    with pytest.raises(InputError) as e:
        target_condition(base, radial_immersion=150.0, milling="down")
    assert str(e.value).endswith("in (0, 1] (1 = slot)")
