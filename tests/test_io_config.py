"""Config files: the schema, units, and one clear error per problem (field, value, allowed)."""

from __future__ import annotations

import math
import textwrap
import warnings

import numpy as np
import pytest

from millstab.errors import InputError, UnitWarning
from millstab.frf import modal_receptance
from millstab.io.config import config_to_toml, load_config, parse_config, write_config
from millstab.config import Config
from millstab.io.frf_files import write_frf_csv

EX1 = """
[cutting]
teeth = 2
kt = "556.31 MPa"
kr = 0.404
entry = "0 deg"
exit = "180 deg"
[[structure.x]]
fn = "903 Hz"
k = "12.53 N/um"
zeta = 0.03
[[structure.y]]
fn = "903 Hz"
k = "12.53 N/um"
zeta = 0.03
"""


def write(tmp_path, text, name="c.toml"):
    p = tmp_path / name
    p.write_text(textwrap.dedent(text))
    return p


def error(tmp_path, text) -> InputError:
    with pytest.raises(InputError) as info:
        load_config(write(tmp_path, text))
    return info.value


def test_schema_example_loads_in_si(tmp_path):
    c = load_config(write(tmp_path, EX1))
    assert isinstance(c, Config)
    assert c.name == "c" and c.path == tmp_path / "c.toml" and c.rpm is None
    assert c.cutting.teeth == 2
    assert c.cutting.kt == pytest.approx(556.31e6, rel=1e-15)
    assert c.cutting.kr == 0.404
    assert c.cutting.entry == 0.0 and c.cutting.exit == pytest.approx(math.pi, rel=1e-15)
    (mx,), (my,) = c.structure.x, c.structure.y
    assert (mx.fn, mx.zeta) == (903.0, 0.03) and mx.k == pytest.approx(12.53e6, rel=1e-15)
    assert my == mx


def test_alternative_units_agree(tmp_path):
    text = EX1.replace('"556.31 MPa"', '"556.31 N/mm^2"').replace('"12.53 N/um"', '"12.53 MN/m"', 1)
    c = load_config(write(tmp_path, text))
    assert c.cutting.kt == pytest.approx(556.31e6, rel=1e-12)
    assert c.structure.x[0].k == pytest.approx(12.53e6, rel=1e-12)


def test_plain_numbers_are_si(tmp_path):
    text = (EX1.replace('"556.31 MPa"', "556.31e6").replace('"903 Hz"', "903.0", 1)
            .replace('"180 deg"', "3.141592653589793"))
    c = load_config(write(tmp_path, text))
    assert c.cutting.kt == 556.31e6 and c.structure.x[0].fn == 903.0 and c.cutting.exit == math.pi


def test_radial_immersion_down_and_up(tmp_path):
    base = EX1.replace('entry = "0 deg"\nexit = "180 deg"', "radial_immersion = 0.2\nmilling = \"{m}\"")
    down = load_config(write(tmp_path, base.format(m="down"))).cutting
    up = load_config(write(tmp_path, base.format(m="up"))).cutting
    assert math.degrees(down.entry) == pytest.approx(126.8699, abs=1e-4) and down.exit == math.pi
    assert up.entry == 0.0 and math.degrees(up.exit) == pytest.approx(53.1301, abs=1e-4)
    pct = load_config(write(tmp_path, base.format(m="down").replace("0.2", '"20 %"'))).cutting
    assert pct.entry == pytest.approx(down.entry, rel=1e-12)


def test_full_immersion_needs_no_milling(tmp_path):
    c = load_config(write(tmp_path, EX1.replace('entry = "0 deg"\nexit = "180 deg"', "radial_immersion = 1")))
    assert c.cutting.is_slotting


def test_rigid_direction(tmp_path):
    text = EX1[: EX1.index("[[structure.y]]")]
    c = load_config(write(tmp_path, text))
    assert len(c.structure.x) == 1 and c.structure.y == ()


def test_single_bracket_table_is_one_mode(tmp_path):
    c = load_config(write(tmp_path, EX1.replace("[[structure.y]]", "[structure.y]")))
    assert len(c.structure.y) == 1 and c.structure.y[0].fn == 903.0


def test_two_modes_and_speeds_and_name(tmp_path):
    text = 'name = "my tool"\n' + EX1 + """
[[structure.x]]
fn = "1.2 kHz"
k = "30 N/um"
zeta = 0.05
[speeds]
start = 5000
stop = "7000 rpm"
step = 500
"""
    c = load_config(write(tmp_path, text))
    assert c.name == "my tool"
    assert [m.fn for m in c.structure.x] == [903.0, 1200.0]
    np.testing.assert_array_equal(c.rpm, [5000.0, 5500.0, 6000.0, 6500.0, 7000.0])


def test_example_prefix():
    c = load_config("example:ex2")
    assert c.name == "ex2" and c.cutting.teeth == 4 and c.rpm is not None


# ------------------------------------------------------------------------------------ errors

@pytest.mark.parametrize("old,new,field,words", [
    ('k = "12.53 N/um"', 'k = "12.53 N/uq"', "structure.x[0].k", "unit"),
    ('kt = "556.31 MPa"', 'kt = "556.31 furlongs"', "cutting.kt", "unit"),
    ('fn = "903 Hz"', 'fn = "903 mm"', "structure.x[0].fn", "frequency"),
    ('k = "12.53 N/um"', 'k = "12.53 MPa"', "structure.x[0].k", "stiffness"),
    ('exit = "180 deg"', 'exit = "180 Hz"', "cutting.exit", "angle"),
    ("kr = 0.404", "kr = nan", "cutting.kr", "finite"),
    ('k = "12.53 N/um"', 'k = "nan N/um"', "structure.x[0].k", "finite"),
    ("zeta = 0.03", "zeta = 1.3", "structure.x[0].zeta", "(0, 1)"),
    ('fn = "903 Hz"', 'fn = "-903 Hz"', "structure.x[0].fn", "> 0"),
    ("teeth = 2", "teeth = 2.5", "cutting.teeth", "integer"),
    ("teeth = 2", 'teeth = "two"', "cutting.teeth", "integer"),
    ('exit = "180 deg"', "exit = 180", "cutting.exit", "deg"),
    ('entry = "0 deg"', 'entry = "190 deg"', "cutting.entry", "[0, pi]"),
    ('entry = "0 deg"', 'entry = "180 deg"', "cutting.entry", "less than the exit"),
])
def test_bad_values_name_the_field(tmp_path, old, new, field, words):
    assert old in EX1
    err = error(tmp_path, EX1.replace(old, new, 1))
    assert err.field == field
    assert field in str(err) and words in str(err)


@pytest.mark.parametrize("remove,field", [
    ("teeth = 2\n", "cutting.teeth"),
    ('kt = "556.31 MPa"\n', "cutting.kt"),
    ("kr = 0.404\n", "cutting.kr"),
    ('exit = "180 deg"\n', "cutting.exit"),
    ('entry = "0 deg"\nexit = "180 deg"\n', "cutting.entry"),
    ("zeta = 0.03\n", "structure.x[0].zeta"),
])
def test_missing_keys(tmp_path, remove, field):
    err = error(tmp_path, EX1.replace(remove, "", 1))
    assert err.field == field and "missing" in str(err)


def test_missing_tables(tmp_path):
    err = error(tmp_path, EX1[EX1.index("[[structure.x]]"):])
    assert err.field == "cutting" and "missing" in str(err)
    err = error(tmp_path, EX1[: EX1.index("[[structure.x]]")])
    assert err.field == "structure"


@pytest.mark.parametrize("old,new,field,hint", [
    ("kr = 0.404", "kn = 0.404", "cutting.kn", "kr"),
    ("zeta = 0.03", "zeta = 0.03\nxi = 0.03", "structure.x[0].xi", "zeta"),
    ("[cutting]", "colour = 'red'\n[cutting]", "colour", "allowed keys"),
    ("[cutting]", "[cuting]\nteeth = 2\n[cutting]", "cuting", "allowed keys"),
    ("teeth = 2", "teeth = 2\nspeed = 5000", "cutting.speed", "radial_immersion"),
])
def test_unknown_keys_are_errors(tmp_path, old, new, field, hint):
    err = error(tmp_path, EX1.replace(old, new, 1))
    assert err.field == field and hint in str(err)


def test_entry_exit_and_immersion_conflict(tmp_path):
    err = error(tmp_path, EX1.replace("kr = 0.404", "kr = 0.404\nradial_immersion = 0.5"))
    assert err.field == "cutting.radial_immersion" and "not both" in str(err)


def test_immersion_without_milling(tmp_path):
    err = error(tmp_path, EX1.replace('entry = "0 deg"\nexit = "180 deg"', "radial_immersion = 0.5"))
    assert err.field == "cutting.milling" and "down" in str(err)


def test_bad_milling_string(tmp_path):
    err = error(tmp_path, EX1.replace('entry = "0 deg"\nexit = "180 deg"', 'radial_immersion = 0.5\nmilling = "side"'))
    assert err.field == "cutting.milling" and err.value == "side" and "climb = down" in err.allowed  # climb is down


def test_immersion_out_of_range(tmp_path):
    err = error(tmp_path, EX1.replace('entry = "0 deg"\nexit = "180 deg"', 'radial_immersion = 1.5\nmilling = "up"'))
    assert err.field == "cutting.radial_immersion"


def test_no_modes_at_all(tmp_path):
    err = error(tmp_path, EX1[: EX1.index("[[structure.x]]")] + "[structure]\nx = []\n")
    assert err.field == "structure" and "at least one mode" in str(err)


def test_modes_and_frf_together(tmp_path):
    err = error(tmp_path, EX1 + '[structure.frf]\nxx = "a.csv"\n')
    assert err.field == "structure" and "not both" in str(err)


def test_toml_syntax_error_names_file_and_line(tmp_path):
    err = error(tmp_path, EX1.replace("kr = 0.404", "kr = = 0.404"))
    assert "c.toml" in str(err) and "line 5" in str(err)


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="does not exist") as info:
        load_config(tmp_path / "nope.toml")
    assert "nope.toml" in str(info.value)


def test_unknown_example_lists_available():
    with pytest.raises(InputError, match="ex1.*fourflute"):
        load_config("example:ex9")


@pytest.mark.parametrize("speeds,field", [
    ("start = 5000\nstop = 4000\nstep = 10", "speeds.stop"),
    ("start = 5000\nstop = 6000\nstep = 0", "speeds.step"),
    ("start = -5\nstop = 6000\nstep = 10", "speeds.start"),
    ("start = 5000\nstop = 6000", "speeds.step"),
    ('start = "5000 Hz"\nstop = 6000\nstep = 10', "speeds.start"),
    ("start = 5000\nstop = 6000\nstep = 10\nnum = 4", "speeds.num"),
    ("start = 1\nstop = 1e9\nstep = 1", "speeds.step"),
])
def test_bad_speeds(tmp_path, speeds, field):
    err = error(tmp_path, EX1 + "[speeds]\n" + speeds + "\n")
    assert err.field == field


def test_low_stiffness_warns_naming_the_mode(tmp_path):
    with pytest.warns(UnitWarning, match=r"structure\.x\[0\]\.k"):
        load_config(write(tmp_path, EX1.replace('k = "12.53 N/um"', "k = 12.53", 1)))


# ------------------------------------------------------------------------------ measured FRF

def _frf_files(tmp_path):
    f = np.linspace(100.0, 3000.0, 300)
    hx = modal_receptance(f, [903.0], [12.53e6], [0.03])
    hy = modal_receptance(f, [950.0], [10e6], [0.01])
    (tmp_path / "frf").mkdir()
    write_frf_csv(tmp_path / "frf" / "xx.csv", f, hx)
    write_frf_csv(tmp_path / "frf" / "yy.csv", f, hy)
    return f, hx, hy


def test_measured_frf_config_relative_paths(tmp_path):
    f, hx, hy = _frf_files(tmp_path)
    text = EX1[: EX1.index("[[structure.x]]")] + '[structure.frf]\nxx = "frf/xx.csv"\nyy = { file = "frf/yy.csv" }\n'
    sub = tmp_path / "cfg"
    sub.mkdir()
    c = load_config(write(tmp_path, text.replace('"frf/', '"../frf/'), "cfg/c.toml"))
    assert not c.structure.is_modal
    np.testing.assert_array_equal(c.structure.frf.freq_hz, f)
    np.testing.assert_array_equal(c.structure.frf.xx, hx)
    np.testing.assert_array_equal(c.structure.frf.yy, hy)
    assert c.structure.frf.xy is None


def test_measured_frf_errors(tmp_path):
    _frf_files(tmp_path)
    head = EX1[: EX1.index("[[structure.x]]")]
    err = error(tmp_path, head + '[structure.frf]\nxx = "frf/missing.csv"\n')
    assert err.field == "structure.frf.xx" and "does not exist" in str(err)
    err = error(tmp_path, head + '[structure.frf]\nxz = "frf/xx.csv"\n')
    assert err.field == "structure.frf.xz" and "xx, yy, xy, yx" in str(err)
    err = error(tmp_path, head + '[structure.frf]\nxx = { file = "frf/xx.csv", record = 1 }\n')
    assert err.field == "structure.frf.xx" and "UFF" in str(err)
    err = error(tmp_path, head + '[structure.frf]\nxy = "frf/xx.csv"\n')
    assert err.field == "structure.frf" and "direct term" in str(err)


# --------------------------------------------------------------------------------- round trip

@pytest.mark.parametrize("name", ["ex1", "ex2", "ex3", "fourflute"])
def test_write_config_round_trip(tmp_path, name):
    c = load_config(f"example:{name}")
    out = write_config(tmp_path / "out" / f"{name}.toml", c)
    back = load_config(out)
    assert back.name == c.name and back.cutting.teeth == c.cutting.teeth
    for a in ("kt", "kr", "entry", "exit"):
        assert getattr(back.cutting, a) == pytest.approx(getattr(c.cutting, a), rel=1e-13, abs=1e-15)
    for d in ("x", "y"):
        for m, n in zip(getattr(c.structure, d), getattr(back.structure, d), strict=True):
            assert (n.fn, n.k, n.zeta) == pytest.approx((m.fn, m.k, m.zeta), rel=1e-13)
    np.testing.assert_allclose(back.rpm, c.rpm, rtol=1e-13)


def test_write_config_refuses_to_overwrite_input(tmp_path):
    p = write(tmp_path, EX1)
    c = load_config(p)
    before = p.read_text()
    with pytest.raises(InputError, match="overwrite"):
        write_config(p, c, protect=[p])
    assert p.read_text() == before


def test_parse_config_text_has_no_path():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        c = parse_config(EX1, name="inline")
    assert c.path is None and c.name == "inline"
    assert config_to_toml(c).startswith('name = "inline"')


# ------------------------------------------------------------------ issue 10: BOM, commas, echo

@pytest.mark.parametrize("encoding", ["utf-8-sig", "utf-16"])  # Notepad's "UTF-8" and "Unicode"
def test_config_with_byte_order_mark_loads(tmp_path, encoding):
    p = tmp_path / "bom.toml"
    p.write_bytes(EX1.encode(encoding))
    c = load_config(p)
    ref = load_config(write(tmp_path, EX1))
    assert c.cutting == ref.cutting and c.structure == ref.structure
    assert parse_config("\ufeff" + EX1).structure == ref.structure


def test_config_not_utf8_is_named(tmp_path):
    p = tmp_path / "latin.toml"
    p.write_bytes(EX1.replace("12.53 N/um", "12.53 N/µm").encode("latin-1"))
    with pytest.raises(InputError, match="UTF-8") as info:
        load_config(p)
    assert info.value.field == "config"


def test_toml_decimal_comma_is_named(tmp_path):
    err = error(tmp_path, EX1.replace("zeta = 0.03", "zeta = 0,03", 1))
    assert "line 11" in str(err) and "decimal comma" in str(err)


@pytest.mark.parametrize("old,new,field,shown", [
    ('exit = "180 deg"', 'exit = "270 deg"', "cutting.exit", "cutting.exit = '270 deg'"),
    ('entry = "0 deg"', 'entry = "-10 deg"', "cutting.entry", "cutting.entry = '-10 deg'"),
    ('fn = "903 Hz"', 'fn = "-0.9 kHz"', "structure.x[0].fn", "structure.x[0].fn = '-0.9 kHz'"),
    ('k = "12.53 N/um"', 'k = "-3 N/um"', "structure.x[0].k", "structure.x[0].k = '-3 N/um'"),
    ("zeta = 0.03", 'zeta = "130 %"', "structure.x[0].zeta", "structure.x[0].zeta = '130 %'"),
    ('kt = "556.31 MPa"', 'kt = "-5 MPa"', "cutting.kt", "cutting.kt = '-5 MPa'"),
    ("kr = 0.404", 'kr = "-40 %"', "cutting.kr", "cutting.kr = '-40 %'"),
    ('entry = "0 deg"\nexit = "180 deg"', 'radial_immersion = "150 %"\nmilling = "up"', "cutting.radial_immersion",
     "cutting.radial_immersion = '150 %'"),
])
def test_errors_echo_the_value_as_written(tmp_path, old, new, field, shown):
    assert old in EX1
    err = error(tmp_path, EX1.replace(old, new, 1))
    assert err.field == field and str(err).startswith(shown + " is invalid")


def test_entry_after_exit_names_both_as_written(tmp_path):
    err = error(tmp_path, EX1.replace('entry = "0 deg"', 'entry = "100 deg"').replace('"180 deg"', '"1.2 rad"'))
    assert str(err).startswith("cutting.entry = '100 deg' is invalid") and "exit = '1.2 rad'" in str(err)


# ------------------------------------------------------------------ issue 17: [prior] written back

def _prior_fields(p):
    return (dict(p.spreads), p.fixed, p.sigma_depth_m, p.sigma_depth_rel, p.sigma_chatter_hz, p.label_error)


@pytest.mark.parametrize("table", [
    'fn = "3 %"\nk_y = 0.1\nkt = "10 %"\nfixed = ["zeta_y"]\nsigma_depth = "4 %"\nsigma_chatter_hz = "10 Hz"\n'
    'label_error = "1 %"\n',
    'zeta = 0.2\nsigma_depth = "0.07 mm"\nlabel_error = 0\n',
    'fn_x = 0.04\n'])
def test_write_config_keeps_the_prior_table(tmp_path, table):
    """A user's [prior] survives write → load (it was dropped: the app's config download lost it)."""
    c = parse_config(EX1 + "[prior]\n" + table)
    back = load_config(write_config(tmp_path / "out.toml", c))
    assert back.prior is not None
    a, b = _prior_fields(c.prior), _prior_fields(back.prior)
    assert a[0].keys() == b[0].keys() and a[1] == b[1]
    for x, y in zip((*a[0].values(), *a[2:]), (*b[0].values(), *b[2:]), strict=True):
        assert (x is None and y is None) or x == pytest.approx(y, rel=1e-13)
    assert load_config(write_config(tmp_path / "none.toml", parse_config(EX1))).prior is None  # none stays none


@pytest.mark.parametrize("value, ok", [("0", 0.0), ("0.02", 0.02), ('"2 %"', 0.02), ("0.49", 0.49),
                                       ("0.5", None), ("-0.01", None), ('"60 %"', None), ('"0.1 mm"', None)])
def test_prior_label_error_is_a_probability_below_one_half(value, ok):
    text = EX1 + f"[prior]\nlabel_error = {value}\n"
    if ok is not None:
        assert parse_config(text).prior.label_error == pytest.approx(ok)
        return
    with pytest.raises(InputError) as info:
        parse_config(text)
    assert info.value.field == "prior.label_error" and value.strip('"') in str(info.value)
