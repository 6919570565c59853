"""``millstab sensitivity``: JSON contract, figures, and one-line errors with exit status 2."""

from __future__ import annotations

import json

import pytest

from millstab.cli import main

PARAMS = ("fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y")
SPEEDS = ["--rpm", "4000:12000:400"]


def test_mc_json_contract_and_table(tmp_path, capsys):
    out, fig = tmp_path / "r.json", tmp_path / "mc.png"
    code = main(["sensitivity", "mc", "example:ex1", *SPEEDS, "--n", "16", "--seed", "5", "--preset", "paper",
                 "--out", str(out), "--plot", str(fig)])
    text = capsys.readouterr().out
    assert code == 0
    data = json.loads(out.read_text())
    for p in PARAMS:
        assert isinstance(data[p]["mean"], float) and isinstance(data[p]["sd"], float)
        assert data[p]["sd"] >= 0 and "sem" in data[p]
    assert data["n"] == 16 and data["seed"] == 5 and data["t"] == 0.1 and data["eps"] == 0.01
    assert data["paper"]["fn_x"]["mean"] == 0.0661 and data["paper_example"] == "ex1"
    assert data["centre"]["fn_x"] == 910.4 and data["speeds"]["count"] == 21
    assert "mean (paper Table 6)" in text and "fn_x/k_x" in text
    assert fig.stat().st_size > 0
    # same seed, same table
    out2 = tmp_path / "r2.json"
    assert main(["sensitivity", "mc", "example:ex1", *SPEEDS, "--n", "16", "--seed", "5", "--preset", "paper",
                 "--out", str(out2)]) == 0
    assert all(json.loads(out2.read_text())[p] == data[p] for p in PARAMS)


def test_oat_sobol_morris_run(tmp_path, capsys):
    assert main(["sensitivity", "oat", "example:ex1", *SPEEDS, "--preset", "paper", "--plot", str(tmp_path / "o.png"),
                 "--out", str(tmp_path / "o.json")]) == 0
    d = json.loads((tmp_path / "o.json").read_text())
    assert len(d["eps"]) == 9 and set(d["mse_mm2"]) == set(PARAMS)
    assert main(["sensitivity", "sobol", "example:ex1", *SPEEDS, "--n", "16", "--plot", str(tmp_path / "s.png"),
                 "--out", str(tmp_path / "s.json"), "--bound", "fn_x=850:950"]) == 0
    s = json.loads((tmp_path / "s.json").read_text())
    assert s["bounds"]["fn_x"] == [850.0, 950.0] and len(s["blim"]["ST"]["fn_y"]) == 21
    assert main(["sensitivity", "morris", "example:ex1", *SPEEDS, "--n", "4", "--plot", str(tmp_path / "m.png")]) == 0
    assert (tmp_path / "s.png").exists() and (tmp_path / "m.png").exists()


@pytest.mark.parametrize("args", [
    ["sensitivity", "bogus", "example:ex1"],
    ["sensitivity", "mc", "example:ex1", "--t", "1.0"],
    ["sensitivity", "mc", "example:ex1", "--eps", "40", "--n", "10"],
    ["sensitivity", "mc", "example:ex1", "--eps", "abc"],
    ["sensitivity", "mc", "example:ex1", "--n", "1"],
    ["sensitivity", "mc", "example:ex1", "--rpm", "100:50:1"],
    ["sensitivity", "sobol", "example:ex1", "--n", "100"],
    ["sensitivity", "sobol", "example:ex1", "--n", "16", "--bound", "zeta_x=0.5:1.5"],
    ["sensitivity", "sobol", "example:ex1", "--bound", "fn_x"],
    ["sensitivity", "oat", "example:ex1", "--eps", "0.2:-0.2:0.05"],
    ["sensitivity", "oat", "example:ex1", "--preset", "nope"],
    ["sensitivity", "oat", "example:ex1", "--plot", "fig.gif"],
    ["sensitivity", "oat", "example:nosuch"],
    ["sensitivity", "mc", "example:ex1", "--engine", "fem"],
])
def test_bad_input_one_line_exit_2(args, capsys):
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("millstab: error:") and "\n" not in err


def test_a_time_averaged_study_below_one_tooth_in_the_cut_says_so(capsys):
    """As `lobes` does: with the zero-order engine and less than one tooth in the cut on average (example ex3: a/D 0.2,
    3 teeth, 0.44 teeth) the study warns in one line that these are the averaged model's sensitivities and names the
    time-domain engines; with Ex.1's slot (two teeth, one in the cut on average) it says nothing."""
    for example, warned in (("example:ex3", True), ("example:ex1", False)):
        assert main(["sensitivity", "oat", example, "--rpm", "5000:9000:1000"]) == 0
        err = [x for x in capsys.readouterr().err.splitlines() if x.strip()]
        if warned:
            assert len(err) == 1 and "0.44 teeth in the cut" in err[0] and "--engine spectral" in err[0], err
        else:
            assert not err, err
