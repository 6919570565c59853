"""Packaged datasets: the paper's examples load, agree with the paper's tables, and the published values."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from millstab.datasets import example_path, list_examples, load_example, paper_values
from millstab.errors import InputError
from millstab.io.config import load_config


def test_list_examples():
    assert list_examples() == ["ex1", "ex2", "ex3", "fourflute"]


@pytest.mark.parametrize("name", ["ex1", "ex2", "ex3", "fourflute"])
def test_examples_load_cleanly(name):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no unit warnings: the files state their units
        c = load_example(name)
    assert c.name == name and c.path == example_path(name) and c.path.is_file()
    assert c.rpm is not None and c.rpm.size > 100 and np.all(np.diff(c.rpm) > 0)
    assert load_config(f"example:{name}").cutting == c.cutting


@pytest.mark.parametrize("name", ["ex1", "ex2", "ex3"])
def test_synthetic_examples_match_table_1(name):
    t = paper_values()["input_values"][name]
    c = load_example(name)
    assert c.cutting.teeth == t["teeth"]
    assert c.cutting.kt == pytest.approx(t["kt"], rel=1e-14)
    assert c.cutting.kr == t["kr"]
    assert math.degrees(c.cutting.entry) == pytest.approx(t["entry_deg"], abs=1e-12)
    assert math.degrees(c.cutting.exit) == pytest.approx(t["exit_deg"], abs=1e-12)
    for d in ("x", "y"):
        (m,) = getattr(c.structure, d)
        assert (m.fn, m.k, m.zeta) == pytest.approx((t[f"fn_{d}"], t[f"k_{d}"], t[f"zeta_{d}"]), rel=1e-14)


def test_ex3_is_20_percent_down_milling():
    c = load_example("ex3").cutting
    # Table 1 prints 126.9 deg, the rounded arccos(2 * 0.2 - 1) = 126.87 deg
    assert math.degrees(c.entry) == pytest.approx(math.degrees(math.acos(2 * 0.2 - 1)), abs=0.05)
    assert c.exit == math.pi


def test_fourflute_matches_table_4():
    t = paper_values()["modal"]
    c = load_example("fourflute")
    for d in ("x", "y"):
        modes = getattr(c.structure, d)
        assert [m.fn for m in modes] == t[f"fn_{d}"]
        assert [m.k for m in modes] == pytest.approx(t[f"k_{d}"], rel=1e-14)
        assert [m.zeta for m in modes] == t[f"zeta_{d}"]
    e = paper_values()["experiment"]
    assert c.cutting.teeth == e["teeth"] == 4 and c.cutting.is_slotting
    assert c.cutting.kt == pytest.approx(e["kt"], rel=1e-14) and c.cutting.kr == e["kr"]
    assert c.rpm[0] == 5000 and c.rpm[-1] == 7000


def test_unknown_example():
    with pytest.raises(InputError, match="available: ex1, ex2, ex3, fourflute"):
        load_example("ex4")
    with pytest.raises(InputError):
        example_path("paper_values")  # a data file, not an example config


def test_paper_values_groups_cite_their_tables():
    v = paper_values()
    for group in ("input_values", "results_fourier", "modal", "experimental_results", "experiment", "mc"):
        assert "tab:" in v[group]["cite"] or "Section" in v[group]["cite"], group
    assert v["experiment"]["cite"].startswith("Section")


def test_paper_values_numbers():
    v = paper_values()
    assert v["results_fourier"]["ex3"]["predicted"]["fn_y"] == 947.7
    assert v["results_fourier"]["ex1"]["predicted"]["k_x"] == 13.44e6
    assert v["results_fourier"]["iterations"] == 60
    for ex in ("ex1", "ex2", "ex3"):  # Table 3 targets are Table 1 inputs
        tgt = v["results_fourier"][ex]["target"]
        assert all(tgt[k] == pytest.approx(v["input_values"][ex][k], rel=1e-12) for k in tgt)
    er = v["experimental_results"]
    assert (er["newton_raphson"]["fn"], er["newton_raphson"]["k"],
            er["newton_raphson"]["zeta"]) == (4103.4, 11.65e6, 0.0269)
    assert (er["method1_two_point"]["fn"], er["method1_two_point"]["k"],
            er["method1_two_point"]["zeta"]) == (4124.0, 10.63e6, 0.0307)
    assert (er["method2_regression"]["fn"], er["method2_regression"]["k"],
            er["method2_regression"]["zeta"]) == (4103.0, 8.90e6, 0.0379)
    e = v["experiment"]
    assert (e["chatter_tests"], e["operation"], e["rpm_min"], e["rpm_max"]) == (21, "slotting", 5500.0, 6500.0)
    mc = v["mc"]
    assert mc["params"] == ["fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y"]
    assert mc["mean"] == [0.06610, 0.00080, 0.00025, 0.06798, 0.00078, 0.00026]
    assert mc["sd"] == [0.03202, 0.00029, 0.00012, 0.03174, 0.00026, 0.00013]
    assert (mc["paths"], mc["width_t"], mc["eps"]) == (10000, 0.1, 0.01)


def test_paper_values_is_a_fresh_copy():
    v = paper_values()
    v["mc"]["mean"][0] = -1.0
    assert paper_values()["mc"]["mean"][0] == 0.06610


# The seed paper's tables as printed (typed from /work/shared/seed/000_3b9ad6736ed734e3.txt, not read from
# paper_values.toml): stiffness in N/um = MN/m and Kt in N/mm^2, so the stored SI values are these × 1e6.
_TABLE_1 = {  # tab:Input_values, columns Ex.1, Ex.2, Ex.3
    "fn_x": (903.0, 500.0, 900.0), "k_x": (12.53, 8.00, 9.000), "zeta_x": (0.0300, 0.0200, 0.0200),
    "fn_y": (903.0, 500.0, 950.0), "k_y": (12.53, 8.00, 10.00), "zeta_y": (0.0300, 0.0200, 0.0100),
    "kt": (556.31, 695, 2173), "kr": (0.404, 0.404, 0.268), "entry_deg": (0.000, 0.000, 126.9),
    "exit_deg": (180.0, 180.0, 180.0), "teeth": (2, 4, 3),
}
_TABLE_2_PREDICTED = {  # tab:results_fourier, the Predicted rows: fn_x k_x zeta_x fn_y k_y zeta_y
    "ex1": (910.4, 13.44, 0.0287, 910.4, 13.44, 0.0286),
    "ex2": (503.5, 8.66, 0.0196, 503.5, 8.66, 0.0196),
    "ex3": (906.8, 9.49, 0.0183, 947.7, 9.56, 0.0104),
}
_TABLE_MODAL = {  # tab:modal, Mode.1 and Mode.2
    "fn_x": (3890.0, 4182.0), "k_x": (22.60, 15.40), "zeta_x": (0.0196, 0.0170),
    "fn_y": (3872.0, 4127.0), "k_y": (23.40, 25.10), "zeta_y": (0.0220, 0.0177),
}
_MEGA = {"k_x", "k_y", "kt"}


def _si(name, printed):
    return printed * 1e6 if name in _MEGA else printed


def test_paper_values_equal_the_printed_tables():
    """Every number of Tables 1, 2 (Predicted) and the modal table, as printed in the paper, equals the
    packaged value (× 1e6 for stiffness and Kt)."""
    v = paper_values()
    for name, cols in _TABLE_1.items():
        for ex, printed in zip(("ex1", "ex2", "ex3"), cols):
            assert v["input_values"][ex][name] == pytest.approx(_si(name, printed), rel=1e-12), (ex, name)
    names = ("fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y")
    for ex, row in _TABLE_2_PREDICTED.items():
        got = v["results_fourier"][ex]["predicted"]
        assert set(got) == set(names)
        for name, printed in zip(names, row):
            assert got[name] == pytest.approx(_si(name, printed), rel=1e-12), (ex, name)
    for name, cols in _TABLE_MODAL.items():
        assert v["modal"][name] == pytest.approx([_si(name, c) for c in cols], rel=1e-12), name


@pytest.mark.parametrize("name,min_lobes", [("ex1", 6), ("ex2", 4), ("ex3", 4), ("fourflute", 3)])
def test_default_speeds_show_several_lobes(name, min_lobes):
    """The [speeds] comments promise several lobes; count the distinct limiting lobes on that range."""
    from millstab.stability import zoa  # imported, not importorskip'd: a broken engine must fail here

    c = load_example(name)
    env = zoa.envelope(c.structure, c.cutting, c.rpm)
    assert np.all(np.isfinite(env.depth))
    assert len(set(env.lobe.tolist())) >= min_lobes


# --- the example points file ------------------------------------------------------------------------

def _generating_command() -> str:
    """The python -c command quoted in the example points file's comment lines."""
    from millstab.datasets import points_path

    lines = points_path("ex3_points").read_text(encoding="utf-8").splitlines()
    (cmd,) = [ln for ln in lines if ln.startswith('# python -c "')]
    return cmd[len('# python -c "'):-1]


def test_example_points_file_is_what_its_comment_says():
    """Running the command in the file's comment prints exactly the file's data lines."""
    import contextlib
    import io

    from millstab.datasets import points_path

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(_generating_command(), {})
    data = [ln for ln in points_path("ex3_points").read_text(encoding="utf-8").splitlines() if not ln.startswith("#")]
    assert out.getvalue().splitlines() == data


def test_example_points_file_holds_example_3_boundary_with_2_percent_noise():
    """Independent of the comment: the points lie on Example 3's SLD within a 2 % noise band."""
    from millstab.io.points import read_points
    from millstab.stability import zoa

    pts = read_points("example:ex3_points")
    assert len(pts) == 40 and pts.boundary.all()
    c = load_example("ex3")
    assert pts.rpm[0] == c.rpm[0] and pts.rpm[-1] == pytest.approx(c.rpm[-1])
    rel = pts.depth_mm / zoa.envelope(c.structure, c.cutting, pts.rpm).depth_mm - 1
    assert 0.01 < rel.std() < 0.03 and np.abs(rel).max() < 4 * 0.02


def test_example_points_resolve_like_configs():
    from millstab.datasets import list_example_points, points_path
    from millstab.io.points import read_points

    assert list_example_points() == ["ex3_points"]
    assert points_path("ex3_points.csv") == points_path(" EX3_points ") == example_path("ex3").parent / "ex3_points.csv"
    assert read_points("example:ex3_points.csv").source == points_path("ex3_points")
    with pytest.raises(InputError, match="available: ex3_points"):
        read_points("example:ex4_points")
    with pytest.raises(InputError, match="example points file"):  # a points file given as the config
        load_config("example:ex3_points")


def test_identify_example_points_recovers_example_3(tmp_path):
    """`millstab identify example:ex3 example:ex3_points` from a start 30 % off every parameter recovers
    Table 1's Example 3 within 3 standard errors (and 5 %) of every parameter."""
    import json

    from millstab.cli import main

    truth = paper_values()["input_values"]["ex3"]
    names = ("fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y")
    start = ",".join(f"{n}={truth[n] * f:.6g}" for n, f in zip(names, (1.3, 0.7, 1.3, 0.7, 1.3, 0.7)))
    out = tmp_path / "fit.json"
    assert main(["identify", "example:ex3", "example:ex3_points", "--initial", start, "--quiet", "--out",
                 str(out)]) == 0
    fit = json.loads(out.read_text())
    for n in names:
        est, se = fit["parameters"][n], fit["std_errors"][n]
        assert abs(est - truth[n]) < 3 * se, n
        assert est == pytest.approx(truth[n], rel=0.05), n
