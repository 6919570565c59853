"""Output files: never over an input of the run, checked before the work, one clear line on a bad
path, figures with the same permissions as every other output."""

from __future__ import annotations

import json
import os
import stat

import numpy as np
import pytest

from millstab.cli import main
from millstab.errors import InputError
from millstab.io import load_config

CUT = '[cutting]\nteeth = 2\nkt = "600 MPa"\nkr = 0.3\nentry = "0 deg"\nexit = "180 deg"\n'
MODES = ('[[structure.x]]\nfn = "900 Hz"\nk = "10 N/um"\nzeta = 0.02\n'
         '[[structure.y]]\nfn = "950 Hz"\nk = "12 N/um"\nzeta = 0.03\n')
SPEEDS = ["--rpm", "3000:6000:500"]


@pytest.fixture
def shop(tmp_path):
    """A shop folder: a modal config, a measured-FRF config (xx CSV + yy UFF record), points, speeds."""
    from millstab.frf import structure_receptance
    from millstab.io import write_frf_csv

    (tmp_path / "modal.toml").write_text(CUT + MODES)
    f = np.linspace(200.0, 2000.0, 1801)
    g = structure_receptance(load_config(str(tmp_path / "modal.toml")).structure, f)
    (tmp_path / "meas").mkdir()
    write_frf_csv(tmp_path / "meas" / "xx.csv", f, g[:, 0, 0])
    write_frf_csv(tmp_path / "meas" / "yy.csv", f, g[:, 1, 1])
    (tmp_path / "shop.toml").write_text(CUT + '[structure.frf]\nxx = "meas/xx.csv"\nyy = { file = "meas/yy.csv" }\n')
    (tmp_path / "pts.csv").write_text("rpm,depth_mm\n3000,1.0\n3500,1.2\n4000,0.9\n4500,1.5\n5000,1.1\n5500,0.8\n"
                                      "6000,1.3\n6500,1.0\n")
    (tmp_path / "speeds.txt").write_text("3000\n4000\n5000\n")
    return tmp_path


def _snapshot(folder):
    return {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()}


def test_config_inputs_names_the_frf_files(shop):
    from millstab.io.outputs import config_inputs

    files = config_inputs(load_config(str(shop / "shop.toml")))
    assert files == {"config": shop / "shop.toml", "structure.frf.xx": shop / "meas" / "xx.csv",
                     "structure.frf.yy": shop / "meas" / "yy.csv"}
    assert config_inputs(load_config(str(shop / "modal.toml"))) == {"config": shop / "modal.toml"}


@pytest.mark.parametrize("args", [
    # the case: the measured FRF the config reads
    ["lobes", "{shop}/shop.toml", *SPEEDS, "--out", "{shop}/meas/xx.csv"],
    ["lobes", "{shop}/shop.toml", *SPEEDS, "--out", "{shop}/meas/../meas/yy.csv"],
    ["lobes", "{shop}/modal.toml", "--rpm-file", "{shop}/speeds.txt", "--out", "{shop}/speeds.txt"],
    ["lobes", "{shop}/modal.toml", *SPEEDS, "--points", "{shop}/pts.csv", "--out", "{shop}/pts.csv"],
    ["identify", "{shop}/shop.toml", "{shop}/pts.csv", "--out", "{shop}/meas/xx.csv"],
    ["identify", "{shop}/modal.toml", "{shop}/pts.csv", "--out", "{shop}/pts.csv"],
    ["design", "{shop}/shop.toml", "--out", "{shop}/meas/yy.csv"],
    ["design", "{shop}/modal.toml", "--points", "{shop}/pts.csv", "--out", "{shop}/pts.csv"],
    ["sensitivity", "oat", "{shop}/shop.toml", *SPEEDS, "--out", "{shop}/meas/xx.csv"],
    ["sensitivity", "mc", "{shop}/modal.toml", "--rpm-file", "{shop}/speeds.txt", "--out", "{shop}/speeds.txt"],
    ["sensitivity", "sobol", "{shop}/modal.toml", *SPEEDS, "--out", "{shop}/modal.toml"],
    ["sensitivity", "morris", "{shop}/modal.toml", *SPEEDS, "--out", "{shop}/modal.toml"],
])
def test_no_output_over_an_input(shop, args, capsys):
    before = _snapshot(shop)
    assert main([a.format(shop=shop) for a in args]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "overwrite" in err and "--out" in err
    assert _snapshot(shop) == before


def test_frf_input_through_a_symlink_is_protected(shop, capsys):
    (shop / "link.csv").symlink_to(shop / "meas" / "xx.csv")
    before = (shop / "meas" / "xx.csv").read_bytes()
    assert main(["lobes", str(shop / "shop.toml"), *SPEEDS, "--out", str(shop / "link.csv")]) == 2
    assert (shop / "meas" / "xx.csv").read_bytes() == before and "overwrite" in capsys.readouterr().err


@pytest.mark.parametrize("cmd", [
    ["lobes", "{shop}/modal.toml", *SPEEDS],
    ["identify", "{shop}/modal.toml", "{shop}/pts.csv"],
    ["design", "{shop}/modal.toml", "--rpm", "3000:6000:100"],
    ["sensitivity", "oat", "{shop}/modal.toml", *SPEEDS],
])
def test_same_path_for_two_outputs_is_refused(shop, cmd, capsys):
    out = shop / "same.png"
    assert main([a.format(shop=shop) for a in cmd] + ["--out", str(out), "--plot", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "same file" in err and not out.exists()


def test_history_plot_over_plot_is_refused(shop, capsys):
    args = ["identify", str(shop / "modal.toml"), str(shop / "pts.csv"), "--plot", str(shop / "a.png"),
            "--history-plot", str(shop / "sub" / ".." / "a.png")]
    assert main(args) == 2
    assert "same file" in capsys.readouterr().err


@pytest.mark.parametrize("cmd", [
    ["lobes", "{shop}/modal.toml", *SPEEDS, "--plot", "{shop}/afile/a.png"],
    ["lobes", "{shop}/modal.toml", *SPEEDS, "--out", "{shop}/afile/deeper/a.csv"],
    ["identify", "{shop}/modal.toml", "{shop}/pts.csv", "--plot", "{shop}/afile/a.png"],
    ["identify", "{shop}/modal.toml", "{shop}/pts.csv", "--history-plot", "{shop}/afile/a.png"],
    ["design", "{shop}/modal.toml", "--rpm", "3000:6000:100", "--plot", "{shop}/afile/a.png"],
    ["sensitivity", "mc", "{shop}/modal.toml", *SPEEDS, "--plot", "{shop}/afile/a.png"],
    ["sensitivity", "morris", "{shop}/modal.toml", *SPEEDS, "--out", "{shop}/afile/a.json"],
    ["reproduce", "--out", "{shop}/afile/report"],
    ["reproduce", "--out", "{shop}/afile"],
    ["lobes", "{shop}/modal.toml", *SPEEDS, "--out", "{shop}/meas"],
])
def test_output_below_a_file_or_onto_a_folder_is_one_line(shop, cmd, capsys):
    (shop / "afile").write_text("not a folder\n")
    assert main([a.format(shop=shop) for a in cmd]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("millstab: error:") and "Traceback" not in err
    assert (shop / "afile").read_text() == "not a folder\n"


def _unwritable_folder(tmp_path):
    """A folder nobody may write in: a chmod'ed one, or for root (who ignores modes) a read-only
    system folder; None where neither exists."""
    if os.geteuid() != 0:
        d = tmp_path / "locked"
        d.mkdir()
        d.chmod(0o555)
        return d
    for d in ("/sys", "/proc/sys"):
        try:
            probe = os.path.join(d, ".millstab-test-probe")
            os.close(os.open(probe, os.O_CREAT | os.O_WRONLY, 0o600))
            os.unlink(probe)
        except OSError:
            return type(tmp_path)(d)
    return None


def test_unwritable_out_fails_before_the_monte_carlo(shop, monkeypatch, capsys):
    locked = _unwritable_folder(shop)
    if locked is None:
        pytest.skip("no unwritable folder on this machine")
    import millstab.sensitivity

    def work(*a, **k):
        raise AssertionError("the Monte Carlo ran before the output was checked")

    monkeypatch.setattr(millstab.sensitivity, "monte_carlo", work)
    try:
        for target in (locked / "mc.json", locked / "new" / "mc.json"):
            assert main(["sensitivity", "mc", str(shop / "modal.toml"), *SPEEDS, "--out", str(target)]) == 2
            err = capsys.readouterr().err.strip()
            assert len(err.splitlines()) == 1 and "cannot write" in err and "--out" in err
    finally:
        if locked.is_relative_to(shop):
            locked.chmod(0o755)


def test_outputs_checked_before_the_work(shop, monkeypatch, capsys):
    """A bad output path costs nothing: the engines, the fit and the report never start."""
    import millstab.identify
    import millstab.reproduce
    from millstab.stability import zoa

    def work(*a, **k):
        raise AssertionError("work started before the outputs were checked")

    monkeypatch.setattr(zoa, "envelope", work)
    monkeypatch.setattr(millstab.identify, "identify", work)
    monkeypatch.setattr(millstab.reproduce, "run", work)
    (shop / "afile").write_text("x")
    cases = [["lobes", str(shop / "modal.toml"), *SPEEDS, "--plot", str(shop / "afile" / "a.png")],
             ["identify", str(shop / "modal.toml"), str(shop / "pts.csv"), "--out", str(shop)],
             ["reproduce", "--out", str(shop / "afile")],
             ["reproduce", "--out", str(shop), "--points", str(shop / "pts.csv")]]
    for args in cases:
        assert main(args) == 2, args
        assert "work started" not in capsys.readouterr().err


def test_reproduce_keeps_points_out_of_the_report_folder(shop, monkeypatch, capsys):
    import millstab.reproduce

    monkeypatch.setattr(millstab.reproduce, "run", lambda *a, **k: (_ for _ in ()).throw(AssertionError("ran")))
    before = _snapshot(shop)
    assert main(["reproduce", "--out", str(shop), "--points", str(shop / "pts.csv")]) == 2
    err = capsys.readouterr().err
    assert "pts.csv" in err and "folder" in err and _snapshot(shop) == before
    # a bad points file is reported before the run, not after the first steps
    (shop / "bad.csv").write_text("rpm,depth_mm\nabc,1\n")
    assert main(["reproduce", "--out", str(shop / "rep"), "--points", str(shop / "bad.csv")]) == 2
    assert "ran" not in capsys.readouterr().err and not (shop / "rep").exists()


@pytest.mark.parametrize("umask,mode", [(0o022, 0o644), (0o027, 0o640)])
def test_figures_get_the_permissions_of_other_outputs(shop, umask, mode):
    old = os.umask(umask)
    try:
        out, png, svg = shop / "sld.csv", shop / "sld.png", shop / "sub" / "sld.svg"
        assert main(["lobes", str(shop / "modal.toml"), *SPEEDS, "--out", str(out), "--plot", str(png)]) == 0
        assert main(["lobes", str(shop / "modal.toml"), *SPEEDS, "--plot", str(svg)]) == 0
    finally:
        os.umask(old)
    for p in (out, png, svg):
        assert stat.S_IMODE(p.stat().st_mode) == mode, p
    assert png.read_bytes()[:4] == b"\x89PNG"
    # a figure written over an existing file keeps that file's mode, as CSV and JSON do
    png.chmod(0o664)
    assert main(["lobes", str(shop / "modal.toml"), *SPEEDS, "--plot", str(png)]) == 0
    assert stat.S_IMODE(png.stat().st_mode) == 0o664


def test_save_figure_leaves_no_temporary_file(shop):
    import matplotlib.pyplot as plt

    from millstab.io.figures import save_figure

    fig = plt.figure()
    save_figure(fig, shop / "f.pdf")
    assert sorted(p.name for p in shop.iterdir() if p.name.startswith(".")) == []
    with pytest.raises(InputError):
        save_figure(plt.figure(), shop / "pts.csv.png", protect=[shop / "pts.csv.png"])


def test_check_outputs_rules(shop):
    from millstab.io.outputs import check_outputs, config_inputs

    cfg = load_config(str(shop / "shop.toml"))
    ins = config_inputs(cfg)
    ok = check_outputs(ins, {"--out": shop / "new" / "x.csv", "--plot": None}, figures=("--plot",))
    assert ok == {"--out": shop / "new" / "x.csv"} and not (shop / "new").exists()  # nothing created
    with pytest.raises(InputError, match="structure.frf.xx"):
        check_outputs(ins, {"--out": shop / "meas" / "xx.csv"})
    with pytest.raises(InputError, match="plot file"):
        check_outputs(ins, {"--plot": shop / "a.gif"}, figures=("--plot",))
    with pytest.raises(InputError, match="folder"):
        check_outputs(ins, {"--out": shop / "meas"})
    with pytest.raises(InputError, match="is a file"):
        check_outputs([], {"--out": shop / "pts.csv"}, folders={"--out": (".md",)})
    with pytest.raises(InputError, match="same file"):
        check_outputs([], {"--out": shop / "a.json", "--plot": shop / "." / "a.json"})


def test_sensitivity_subcommands_have_their_own_help(capsys):
    helps = {}
    for method in ("oat", "mc", "sobol", "morris"):
        assert main(["sensitivity", method, "--help"]) == 0
        helps[method] = capsys.readouterr().out
    assert len(set(helps.values())) == 4
    assert "--levels" in helps["morris"] and "--levels" not in helps["mc"]
    assert "--bound" in helps["sobol"] and "--bound" not in helps["oat"]
    assert "--seed" not in helps["oat"] and "--n" in helps["mc"] and "--n " not in helps["oat"]
    assert "Monte Carlo" in helps["mc"] and "Sobol" in helps["sobol"] and "Morris" in helps["morris"]
    for text in helps.values():
        assert "tab:" not in text and "results_fourier" not in text  # no LaTeX labels
        assert "Table 3" in text  # --preset names the paper's table a reader can find


def test_sensitivity_json_names_the_paper_table(shop, tmp_path):
    out = tmp_path / "o.json"
    assert main(["sensitivity", "oat", "example:ex1", *SPEEDS, "--preset", "paper", "--eps", "0.1", "--out",
                 str(out)]) == 0
    assert "tab:" not in json.loads(out.read_text())["centre_source"]


def test_ctrl_c_exits_130_without_a_traceback(monkeypatch, capsys):
    from millstab.stability import zoa

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(zoa, "envelope", interrupted)
    assert main(["lobes", "example:ex1", *SPEEDS]) == 130
    assert "Traceback" not in capsys.readouterr().err


def test_files_in_each_others_place_are_named(tmp_path, capsys):
    """Arguments swapped (CUTS for CONFIG, a config for the posterior, a posterior for the cuts) say what the file
    looks like; it was "TOML syntax error: Expected '=' after a key ..." or "not valid JSON: Expecting value"."""
    cuts = tmp_path / "cuts.csv"
    cuts.write_text("rpm,depth_mm,label\n9000,1.0,stable\n9000,4.0,chatter\n", encoding="utf-8")
    config = tmp_path / "tool.toml"
    config.write_text('[cutting]\nteeth = 2\nkt = "600 MPa"\nkr = 0.3\nradial_immersion = 1\n', encoding="utf-8")
    post = tmp_path / "post.json"
    post.write_text('{"schema": "millstab.posterior/3"}\n', encoding="utf-8")
    runs = [(["update", str(cuts), str(config), "--out", str(tmp_path / "p.json")],
             "cuts.csv = 'TOML syntax error' is invalid: Expected '=' after a key in a key/value pair (at line 1, "
             "column 4); the file looks like a points or cuts CSV (header 'rpm,depth_mm,label'), not a TOML config: "
             "is it in the config's place?"),
            (["recommend", str(config), "--risk", "0.05", "--rpm", "3000:15000"],
             "tool.toml = 'line 1, column 2' is invalid: not valid JSON: Expecting value; the file looks like a TOML "
             "config ([cutting] table), not JSON: is it in the JSON file's place?"),
            (["update", "example:ex1", str(post), "--out", str(tmp_path / "p.json")],
             "post.json = 'JSON (a posterior, fit or result file)' is invalid: not a points or cuts CSV (header "
             "rpm,depth_mm,...): is the file in the CSV's place? (the config or posterior comes first)")]
    for argv, said in runs:
        assert main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("millstab: error: ") and err.endswith(said), err  # the file named with or without folder
