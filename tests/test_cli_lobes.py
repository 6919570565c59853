"""`millstab lobes`: outputs, overlays, and one-line errors with exit status 2."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from millstab.cli import main
from millstab.io import load_config
from millstab.stability import zoa


def test_lobes_writes_csv_and_plot(tmp_path, capsys):
    out, fig = tmp_path / "sld.csv", tmp_path / "sld.png"
    assert main(["lobes", "example:ex1", "--rpm", "3000:6000:100", "--out", str(out), "--plot", str(fig)]) == 0
    rows = list(csv.DictReader(out.open()))
    assert list(rows[0])[:2] == ["rpm", "blim_mm"]
    rpm = np.array([float(r["rpm"]) for r in rows])
    np.testing.assert_allclose(rpm, np.arange(3000, 6001, 100))
    cfg = load_config("example:ex1")
    expect = zoa.envelope(cfg.structure, cfg.cutting, rpm).depth_mm
    np.testing.assert_allclose([float(r["blim_mm"]) for r in rows], expect, rtol=1e-9)
    assert fig.stat().st_size > 10_000 and fig.read_bytes()[:4] == b"\x89PNG"
    assert "minimum limit" in capsys.readouterr().out


def test_lobes_with_points_rpm_file_svg(tmp_path):
    pts = tmp_path / "p.csv"
    pts.write_text("rpm,depth_mm,label\n4000,1.0,stable\n4000,3.0,chatter\n5000,2.0,\n")
    speeds = tmp_path / "speeds.txt"
    speeds.write_text("3000\n4000\n5000\n")
    fig = tmp_path / "sld.svg"
    assert main(["lobes", "example:ex1", "--rpm-file", str(speeds), "--points", str(pts), "--plot", str(fig)]) == 0
    assert fig.read_text().lstrip().startswith(("<?xml", "<svg"))


def test_lobes_draws_only_the_points_cut_in_the_configs_condition(tmp_path, capsys, monkeypatch):
    """The SLD is the config's condition (Ex.1: a slot); a point cut at a/D 0.25 up milling belongs to another
    boundary: it is left out of the figure and the console says so (it was drawn before)."""
    from millstab import api

    pts = tmp_path / "p.csv"
    pts.write_text("rpm,depth_mm,label,radial_immersion,milling\n4000,1.0,stable,,\n4000,3.0,chatter,,\n"
                   "5000,9.0,chatter,0.25,up\n")
    seen = []
    draw = api.lobes_figure
    monkeypatch.setattr(api, "lobes_figure", lambda result, points=None, **k: (seen.append(points),
                                                                               draw(result, points=points, **k))[1])
    fig = tmp_path / "sld.png"
    assert main(["lobes", "example:ex1", "--rpm", "3000:6000:500", "--points", str(pts), "--plot", str(fig)]) == 0
    assert list(seen[0].rpm) == [4000.0, 4000.0] and list(seen[0].label) == ["stable", "chatter"]
    assert "1 of the 3 points were cut in other conditions than the config's: not drawn" in capsys.readouterr().out


@pytest.mark.parametrize("args,needle", [
    (["lobes", "example:nope"], "example"),
    (["lobes", "example:ex1", "--rpm", "5000:100:10"], "--rpm"),
    (["lobes", "example:ex1", "--rpm", "a:b:c"], "--rpm"),
    (["lobes", "example:ex1", "--engine", "fem"], "engine"),
    (["lobes", "example:ex1", "--plot", "x.bmp"], "plot file"),
    (["lobes", "missing.toml"], "missing.toml"),
])
def test_lobes_bad_input_is_one_line_exit_2(args, needle, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and needle in err and "Traceback" not in err


def test_lobes_refuses_to_overwrite_its_input(tmp_path, capsys):
    cfg = tmp_path / "tool.toml"
    cfg.write_text('[cutting]\nteeth = 2\nkt = "600 MPa"\nkr = 0.3\nentry = "0 deg"\nexit = "180 deg"\n'
                   '[[structure.x]]\nfn = "900 Hz"\nk = "10 N/um"\nzeta = 0.02\n')
    before = cfg.read_text()
    assert main(["lobes", str(cfg), "--rpm", "3000:4000:100", "--out", str(cfg)]) == 2
    assert cfg.read_text() == before
    assert "overwrite" in capsys.readouterr().err


def test_stiffness_in_wrong_units_warns_on_one_line(tmp_path, capsys):
    cfg = tmp_path / "tool.toml"
    cfg.write_text('[cutting]\nteeth = 2\nkt = "600 MPa"\nkr = 0.3\nentry = "0 deg"\nexit = "180 deg"\n'
                   '[[structure.x]]\nfn = 900\nk = 12.53\nzeta = 0.02\n')
    assert main(["lobes", str(cfg), "--rpm", "3000:4000:500"]) == 0
    err = capsys.readouterr().err
    assert "N/um" in err and "warning" in err


def test_lobes_from_measured_frf_config_matches_modal(tmp_path):
    """A config whose structure is measured FRF files (CSV freq_hz,real,imag built from the
    example's modes on a fine grid) gives the modal SLD to the table's interpolation accuracy."""
    from millstab.frf import structure_receptance
    from millstab.io import write_frf_csv

    cfg = load_config("example:ex3")
    f = np.linspace(90.0, 4000.0, 40001)
    g = structure_receptance(cfg.structure, f)
    write_frf_csv(tmp_path / "xx.csv", f, g[:, 0, 0])
    write_frf_csv(tmp_path / "yy.csv", f, g[:, 1, 1])
    (tmp_path / "tool.toml").write_text(
        '[cutting]\nteeth = 3\nkt = "2173 MPa"\nkr = 0.268\nradial_immersion = 0.2\nmilling = "down"\n'
        '[structure.frf]\nxx = "xx.csv"\nyy = "yy.csv"\n')
    out = tmp_path / "sld.csv"
    assert main(["lobes", str(tmp_path / "tool.toml"), "--rpm", "3000:12000:250", "--out", str(out)]) == 0
    rows = list(csv.DictReader(out.open()))
    rpm = np.array([float(r["rpm"]) for r in rows])
    modal_cut = load_config("example:ex3").cutting
    # radial immersion 0.2 gives entry 126.87°, the config 126.9°: compare at the same cutting
    from millstab.model import Cutting

    cut = Cutting.from_immersion(3, modal_cut.kt, modal_cut.kr, 0.2, "down")
    expect = zoa.envelope(cfg.structure, cut, rpm).depth_mm
    np.testing.assert_allclose([float(r["blim_mm"]) for r in rows], expect, rtol=2e-4)


def test_rpm_file_errors_name_the_real_line(tmp_path, capsys):
    """Blank and comment lines are skipped but counted: the error names the file's own line number,
    and a row too short for the 'rpm' column is an error, not a crash."""
    f = tmp_path / "speeds.csv"
    f.write_text("# speeds for the test\nrpm,note\n3000,a\n\n4000,b\nabc,c\n")
    assert main(["lobes", "example:ex1", "--rpm-file", str(f)]) == 2
    assert "line 6" in capsys.readouterr().err
    f.write_text("note,rpm\nx,3000\ny\n")
    assert main(["lobes", "example:ex1", "--rpm-file", str(f)]) == 2
    err = capsys.readouterr().err
    assert "line 3" in err and "Traceback" not in err


def test_a_zero_order_sld_where_less_than_one_tooth_cuts_is_warned_unless_the_time_domain_is_beside_it():
    """Ex.3 cuts with 0.44 teeth on average (3 teeth, a/D 0.2): its zero-order SLD is warned, pointing to --compare
    sdm; with the SDM limit drawn beside it, or for Ex.1's slot (one tooth in the cut), nothing."""
    import warnings

    from millstab import api

    rpm = np.array([6000.0, 9000.0])
    with pytest.warns(UserWarning, match=r"in ex3's cut \(a/D 0.1998 down milling, 3 teeth\) no tooth cuts for 56% .*"
                                         r"--compare sdm"):
        api.lobes(load_config("example:ex3"), rpm)
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        api.lobes(load_config("example:ex3"), rpm, compare="sdm")
        api.lobes(load_config("example:ex1"), rpm)
    assert not [x for x in w if "averages the cutting force" in str(x.message)]


def test_lobes_for_another_condition_is_the_sld_of_that_conditions_config(tmp_path, capsys, monkeypatch):
    """``--radial-immersion``/``--milling`` (the options of map, recommend and predict) draw the same tool's SLD in
    another condition: the same depths as a config whose [cutting] is that condition, built independently (entry
    and exit angles of a/D 0.25 down milling: arccos(1 − 2·0.25) = 120° to 180°); the points drawn are the ones cut
    in it."""
    monkeypatch.setenv("COLUMNS", "200")
    from millstab.model import Cutting

    out, fig = tmp_path / "sld.csv", tmp_path / "sld.png"
    pts = tmp_path / "p.csv"
    pts.write_text("rpm,depth_mm,label,radial_immersion,milling\n4000,1.0,stable,,\n4000,3.0,chatter,0.25,down\n"
                   "4500,2.0,stable,0.25,up\n")
    assert main(["lobes", "example:ex1", "--rpm", "3000:6000:100", "--radial-immersion", "0.25", "--milling", "down",
                 "--out", str(out), "--points", str(pts), "--plot", str(fig)]) == 0
    text = capsys.readouterr().out
    assert "computed for a/D 0.25 down milling" in text and "(the config's: slot" in text
    assert "2 of the 3 points were cut in other conditions than the target's: not drawn" in text
    cfg = load_config("example:ex1")
    c = cfg.cutting
    down = Cutting(teeth=c.teeth, kt=c.kt, kr=c.kr, entry=np.radians(120.0), exit=np.pi)
    rows = list(csv.DictReader(out.open()))
    rpm = np.array([float(r["rpm"]) for r in rows])
    expect = zoa.envelope(cfg.structure, down, rpm).depth_mm
    np.testing.assert_allclose([float(r["blim_mm"]) for r in rows], expect, rtol=1e-9)
    slot = zoa.envelope(cfg.structure, c, rpm).depth_mm
    assert np.median(expect / slot) > 1.5  # a quarter immersion is not the slot's SLD


@pytest.mark.parametrize("args, needle", [
    (["--radial-immersion", "1.5"], "--radial-immersion"),
    (["--milling", "sideways"], "--milling"),
    (["--entry-deg", "30"], "--exit-deg"),
])
def test_lobes_target_condition_errors_name_the_option(args, needle, capsys):
    assert main(["lobes", "example:ex1", "--rpm", "3000:4000:100", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and needle in err
