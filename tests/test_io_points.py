"""Point-set CSVs and the results writers (atomic, protected)."""

from __future__ import annotations

import json
import os
import stat
from dataclasses import dataclass

import numpy as np
import pytest

from millstab.errors import InputError
from millstab.io.points import check_enough, read_points, write_points
from millstab.points import PointSet
from millstab.io.results import read_json, write_csv, write_json

GOOD = """rpm,depth_mm,label,weight
5500,1.20,,
5600,1.50,chatter,2
5600,1.00,Stable,
# a comment line
5700,0.95,,0.5
"""


def points_file(tmp_path, text, name="pts.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def err(tmp_path, text) -> InputError:
    with pytest.raises(InputError) as info:
        read_points(points_file(tmp_path, text))
    return info.value


def test_read_points(tmp_path):
    ps = read_points(points_file(tmp_path, GOOD))
    np.testing.assert_array_equal(ps.rpm, [5500, 5600, 5600, 5700])
    np.testing.assert_array_equal(ps.depth_mm, [1.2, 1.5, 1.0, 0.95])
    np.testing.assert_array_equal(ps.depth_m, [1.2e-3, 1.5e-3, 1.0e-3, 0.95e-3])
    assert list(ps.label) == ["", "chatter", "stable", ""]
    np.testing.assert_array_equal(ps.weight, [1, 2, 1, 0.5])
    np.testing.assert_array_equal(ps.boundary, [True, False, False, True])
    np.testing.assert_array_equal(ps.chatter, [False, True, False, False])
    assert len(ps) == 4 and ps.source == tmp_path / "pts.csv"


def test_minimal_columns_any_order(tmp_path):
    ps = read_points(points_file(tmp_path, "depth_mm , RPM\n2.0, 6000\n3.0,6100\n"))
    np.testing.assert_array_equal(ps.rpm, [6000, 6100])
    np.testing.assert_array_equal(ps.depth_mm, [2.0, 3.0])
    assert ps.boundary.all() and (ps.weight == 1).all()


def test_subset(tmp_path):
    ps = read_points(points_file(tmp_path, GOOD))
    b = ps.subset(ps.boundary)
    np.testing.assert_array_equal(b.rpm, [5500, 5700])
    assert list(b.label) == ["", ""] and b.weight.tolist() == [1.0, 0.5]
    with pytest.raises(InputError):
        ps.subset(np.array([True, False]))


def test_round_trip_exact(tmp_path):
    rng = np.random.default_rng(1)
    ps = PointSet(rng.uniform(5000, 7000, 50), rng.uniform(0.1, 3, 50),
                  rng.choice(["", "stable", "chatter"], 50), rng.uniform(0.1, 5, 50))
    out = write_points(tmp_path / "sub" / "p.csv", ps)
    back = read_points(out)
    np.testing.assert_array_equal(back.rpm, ps.rpm)
    np.testing.assert_array_equal(back.depth_mm, ps.depth_mm)
    np.testing.assert_array_equal(back.label, ps.label)
    np.testing.assert_array_equal(back.weight, ps.weight)


@pytest.mark.parametrize("text,field,words", [
    ("", "points file", "empty"),
    ("# only a comment\n\n", "points file", "empty"),
    ("rpm,depth_mm\n", "points file", "no points"),
    ("rpm,depth\n5000,1\n", "pts.csv header", "depth_mm"),
    ("speed,depth_mm\n5000,1\n", "pts.csv header", "rpm"),
    ("rpm\n5000\n", "pts.csv header", "missing column 'depth_mm'"),
    ("rpm,depth_mm,lable\n5000,1,stable\n", "pts.csv header", "allowed columns"),
    ("rpm,depth_mm\n5000,1\n5100,abc\n", "pts.csv line 3, depth_mm", "number"),
    ("rpm,depth_mm\n5000,1\n\n5,1e\n", "pts.csv line 4, depth_mm", "number"),
    ("rpm,depth_mm\nnan,1\n", "pts.csv line 2, rpm", "finite"),
    ("rpm,depth_mm\n0,1\n", "pts.csv line 2, rpm", "> 0"),
    ("rpm,depth_mm\n5000,-1\n", "pts.csv line 2, depth_mm", "> 0"),
    ("rpm,depth_mm,label\n5000,1,chatty\n", "pts.csv line 2, label", "stable"),
    ("rpm,depth_mm,weight\n5000,1,0\n", "pts.csv line 2, weight", "> 0"),
    ("rpm,depth_mm\n5000,1,3\n", "pts.csv line 2", "cells"),
    ("rpm,rpm,depth_mm\n5000,1,3\n", "pts.csv header", "twice"),
])
def test_bad_point_files(tmp_path, text, field, words):
    e = err(tmp_path, text)
    assert e.field == field
    assert words in str(e)


def test_missing_points_file(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        read_points(tmp_path / "none.csv")


def test_pointset_validates_arrays():
    with pytest.raises(InputError, match=r"points\.depth_mm\[1\]"):
        PointSet([5000, 6000], [1.0, -1.0])
    with pytest.raises(InputError, match="points.label"):
        PointSet([5000], [1.0], ["maybe"])
    with pytest.raises(InputError, match="points.weight"):
        PointSet([5000, 6000], [1.0, 2.0], weight=[1.0])


@pytest.mark.parametrize("kwargs, field, value", [
    ({"rpm": ["5000", "6000x"], "depth_mm": [1.0, 2.0]}, "points.rpm[1]", "6000x"),
    ({"rpm": [5000], "depth_mm": [{"mm": 1}]}, "points.depth_mm[0]", {"mm": 1}),
    ({"rpm": [5000], "depth_mm": [1.0], "label": ["chatter"], "chatter_hz": ["high"]}, "points.chatter_hz[0]", "high"),
    ({"rpm": [5000], "depth_mm": [1.0], "weight": ["heavy"]}, "points.weight[0]", "heavy")])
def test_pointset_names_a_value_that_is_no_number(kwargs, field, value):
    """A notebook's cuts built by hand: a typo in one cell is an InputError naming the array and the entry, not
    numpy's "could not convert string to float"."""
    with pytest.raises(InputError) as exc:
        PointSet(**kwargs)
    assert exc.value.field == field and exc.value.value == value and "must be a number" in exc.value.allowed


def test_check_enough(tmp_path):
    ps = read_points(points_file(tmp_path, GOOD))  # two boundary points
    assert check_enough(ps, 2) == 2
    with pytest.raises(InputError, match="at least 3 boundary points") as info:
        check_enough(ps, 3)
    assert "pts.csv" in str(info.value)


# ------------------------------------------------------------------------------------ results

def test_write_json_numpy_and_dataclasses(tmp_path):
    @dataclass(frozen=True)
    class R:
        x: np.ndarray
        n: int

    obj = {"a": np.arange(3), "b": np.float64(0.5), "c": np.int32(7), "d": R(np.array([[1.0, np.nan]]), 2),
           "e": 1 + 2j, "f": np.bool_(True), "g": (1, 2), "h": tmp_path, "inf": np.inf}
    p = write_json(tmp_path / "deep" / "dir" / "r.json", obj)
    back = read_json(p)
    assert back == {"a": [0, 1, 2], "b": 0.5, "c": 7, "d": {"x": [[1.0, None]], "n": 2},
                    "e": {"real": 1.0, "imag": 2.0}, "f": True, "g": [1, 2], "h": str(tmp_path), "inf": None}
    json.loads(p.read_text())  # strict JSON (no NaN tokens)
    assert "NaN" not in p.read_text()


def test_write_json_rejects_unknown_types(tmp_path):
    with pytest.raises(TypeError, match="object"):
        write_json(tmp_path / "x.json", {"a": object()})
    assert not (tmp_path / "x.json").exists()


def test_writers_refuse_to_overwrite_inputs(tmp_path):
    inp = points_file(tmp_path, GOOD)
    before = inp.read_text()
    for call in (lambda p: write_json(p, {"a": 1}, protect=[inp]),
                 lambda p: write_csv(p, ["a"], [[1.0]], protect=[inp]),
                 lambda p: write_points(p, read_points(inp), protect=[inp])):
        with pytest.raises(InputError, match="overwrite the input file"):
            call(inp)
        # also through another spelling of the same path
        with pytest.raises(InputError):
            call(tmp_path / "." / "pts.csv")
    assert inp.read_text() == before
    link = tmp_path / "link.csv"
    link.symlink_to(inp)
    with pytest.raises(InputError):
        write_json(link, {}, protect=[inp])


def test_atomic_replace_keeps_old_file_on_failure(tmp_path):
    p = write_json(tmp_path / "r.json", {"v": 1})
    with pytest.raises(TypeError):
        write_json(p, {"v": object()})
    assert read_json(p) == {"v": 1}
    write_json(p, {"v": 2})
    assert read_json(p) == {"v": 2}
    assert [q.name for q in tmp_path.iterdir()] == ["r.json"]  # no temp files left behind


def test_new_files_get_normal_permissions(tmp_path):
    p = write_csv(tmp_path / "a.csv", ["x"], [[1.0]])
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(p.stat().st_mode) == 0o666 & ~umask


def test_write_csv_exact_and_checked(tmp_path):
    x = np.array([0.1, 1 / 3, 1e-300, np.nan])
    p = write_csv(tmp_path / "c.csv", ["x", "label"], [x, ["a", "b", "", "d"]])
    lines = p.read_text().splitlines()
    assert lines[0] == "x,label"
    assert [float(v.split(",")[0]) for v in lines[1:4]] == x[:3].tolist()
    assert lines[4] == ",d"
    with pytest.raises(InputError, match="same length"):
        write_csv(tmp_path / "d.csv", ["a", "b"], [[1, 2], [1]])
    with pytest.raises(InputError, match="one name per column"):
        write_csv(tmp_path / "d.csv", ["a"], [[1], [2]])
    with pytest.raises(InputError, match="directory"):
        write_csv(tmp_path, ["a"], [[1]])


def test_read_json_errors(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        read_json(tmp_path / "no.json")
    bad = tmp_path / "bad.json"
    bad.write_text('{"a": 1,\n "b": }\n')
    with pytest.raises(InputError, match="line 2"):
        read_json(bad)


@pytest.mark.parametrize("encoding", ["utf-8-sig", "utf-16"])  # Excel/Notepad "UTF-8" and Notepad "Unicode"
def test_points_with_byte_order_mark(tmp_path, encoding):
    p = tmp_path / "bom.csv"
    p.write_bytes(GOOD.encode(encoding))
    ps, ref = read_points(p), read_points(points_file(tmp_path, GOOD))
    np.testing.assert_array_equal(ps.rpm, ref.rpm)
    np.testing.assert_array_equal(ps.depth_mm, ref.depth_mm)
    np.testing.assert_array_equal(ps.label, ref.label)


@pytest.mark.parametrize("encoding", ["utf-8-sig", "utf-16"])
@pytest.mark.parametrize("text", ["5000\n5500\n6000\n", "rpm,note\n5000,a\n5500,b\n6000,c\n"])
def test_rpm_file_with_byte_order_mark(tmp_path, encoding, text):
    from millstab.cli.app import read_rpm_file

    p = tmp_path / "speeds.txt"
    p.write_bytes(text.encode(encoding))
    np.testing.assert_array_equal(read_rpm_file(p), [5000.0, 5500.0, 6000.0])


@pytest.mark.parametrize("text,line", [("5000\n5500,5\n6000\n", 2), ("# speeds\n5000,5\n", 2), ("5000,6000,7000\n", 1)])
def test_rpm_file_refuses_decimal_commas_and_extra_cells(tmp_path, text, line):
    """Was read silently as the first cell (5500,5 -> 5500 rpm)."""
    from millstab.cli.app import read_rpm_file

    p = tmp_path / "speeds.txt"
    p.write_text(text)
    with pytest.raises(InputError, match="decimal point") as info:
        read_rpm_file(p)
    assert info.value.field == f"--rpm-file line {line}"


def test_rpm_file_trailing_comma_is_fine(tmp_path):
    from millstab.cli.app import read_rpm_file

    p = tmp_path / "speeds.txt"
    p.write_text("5000,\n6000,\n")
    np.testing.assert_array_equal(read_rpm_file(p), [5000.0, 6000.0])


@pytest.mark.parametrize("text,field", [
    ("rpm;depth_mm\n5500;1,2\n", "line 1"),              # a decimal-comma locale's ';'-separated "CSV"
    ("rpm\tdepth_mm\n5500\t1,2\n", "line 1"),             # or tab-separated
    ('rpm,depth_mm\n5500,"1,2"\n', "line 2, depth_mm"),  # a quoted decimal comma
    ("rpm,depth_mm\n5500,1,2\n", "line 2"),              # an unquoted one splits the cell
])
def test_points_decimal_commas_are_named(tmp_path, text, field):
    """Was 'unknown column' / 'must be a number' / a cell count with no word of the decimal comma."""
    p = tmp_path / "pts.csv"
    p.write_text(text)
    with pytest.raises(InputError, match="decimal point") as info:
        read_points(p)
    assert info.value.field == f"pts.csv {field}"


def test_points_infinite_depth_is_refused(tmp_path):
    p = tmp_path / "pts.csv"
    p.write_text("rpm,depth_mm\n5500,inf\n")
    with pytest.raises(InputError, match="finite"):
        read_points(p)


def test_json_with_byte_order_mark(tmp_path):
    """A fit file re-saved by a Windows editor carries a UTF-8 BOM; json.loads refused it."""
    from millstab.io.results import read_json

    p = tmp_path / "fit.json"
    p.write_bytes('{"a": 1}'.encode("utf-8-sig"))
    assert read_json(p) == {"a": 1}


def test_a_stickout_column_is_read_not_ignored(tmp_path):
    """stickout_mm is kept for its own reader (io.stickout), so the cuts reader does not call it ignored;
    a notes column still is."""
    import warnings

    from millstab.io.points import read_points
    from millstab.io.stickout import stickouts

    f = tmp_path / "cuts.csv"
    f.write_text("rpm,depth_mm,label,stickout_mm,notes\n9000,1.0,stable,45,a\n9500,2.0,chatter,,b\n")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        pts = read_points(f)
    text = " ".join(str(w.message) for w in caught)
    assert "ignored columns: notes" in text and "stickout_mm" not in text
    so = stickouts(pts)
    assert so[0] == 0.045 and np.isnan(so[1])


def test_a_misspelt_kept_column_is_an_error(tmp_path):
    """"stickout" for stickout_mm (or "recordings" for recording) is an error like "lable": ignored, it put every cut
    at the config's stickout with only an "ignored columns" warning."""
    for header, meant in (("stickout", "stickout_mm"), ("recordings", "recording")):
        e = err(tmp_path, f"rpm,depth_mm,label,{header}\n9000,1.0,stable,60\n")
        assert (e.field, e.value) == ("pts.csv header", header)
        assert f"unknown column that looks like a misspelt {meant!r}" in str(e)


def test_a_column_like_a_known_one_is_named_in_the_warning(tmp_path):
    """A column too unlike a known one to be an error, chatter_frequency for chatter_hz, is named in the warning
    with the column it may stand for; notes stays a plain ignored column."""
    from millstab.io.points import read_points

    f = tmp_path / "cuts.csv"
    f.write_text("rpm,depth_mm,label,chatter_frequency,notes\n9000,1.0,stable,,a\n9500,3.0,chatter,870,b\n")
    with pytest.warns(UserWarning) as caught:
        read_points(f)
    assert [str(w.message) for w in caught] == [
        "cuts.csv: ignored columns: chatter_frequency, notes (kept, not used); is 'chatter_frequency' meant as "
        "'chatter_hz'? rename it"]
