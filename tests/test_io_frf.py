"""FRF files: CSV, CutPro-style .frf and UFF58, written from modal receptances and read back."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

pyuff = pytest.importorskip("pyuff")

from millstab.errors import FRFWarning, InputError, UnitWarning  # noqa: E402
from millstab.frf import modal_receptance  # noqa: E402
from millstab.io.frf_files import (list_uff_records, load_measured_frf, read_frf, read_frf_csv,  # noqa: E402
                                   write_frf_csv)

# integer Hz: ASCII UFF stores the abscissa with 6 significant digits, so this grid survives exactly
F = np.arange(100.0, 3001.0, 10.0)
HX = modal_receptance(F, [903.0, 2100.0], [12.53e6, 40e6], [0.03, 0.02])
HY = modal_receptance(F, [950.0], [10e6], [0.01])


def uff58(h, f=F, binary=1, func_type=4, num=8, label=None, rsp_dir=1, ref_dir=1, id1="tap"):
    kw = dict(binary=binary, func_type=func_type, rsp_node=1, rsp_dir=rsp_dir, ref_node=1, ref_dir=ref_dir,
              data=h, x=f, id1=id1, abscissa_spacing=0, abscissa_spec_data_type=18,
              ordinate_spec_data_type=num, orddenom_spec_data_type=13)
    if label:
        kw["ordinate_axis_units_lab"] = label
    return pyuff.prepare_58(**kw)


def write_uff(path, *sets):
    u = pyuff.UFF(str(path))
    for s in sets:
        u.write_sets(s, "add")
    return path


# ------------------------------------------------------------------------------------ formats

def test_csv_round_trip_exact(tmp_path):
    p = write_frf_csv(tmp_path / "xx.csv", F, HX)
    assert p.read_text().splitlines()[0] == "freq_hz,real,imag"
    f, h = read_frf(p)
    np.testing.assert_array_equal(f, F)
    np.testing.assert_array_equal(h, HX)


def test_csv_columns_any_order_and_comments(tmp_path):
    p = tmp_path / "a.csv"
    p.write_text("# from the analyzer\nIMAG,freq_hz,Real\n-2e-8,100,1e-7\n-3e-8,200,2e-7\n")
    f, h = read_frf_csv(p)
    np.testing.assert_array_equal(f, [100.0, 200.0])
    np.testing.assert_array_equal(h, [1e-7 - 2e-8j, 2e-7 - 3e-8j])


def cutpro_text(f, h, label_row=True, header=""):
    rows = [f"{float(fi)!r}\t{float(hi.real)!r}\t{float(hi.imag)!r}" for fi, hi in zip(f, h)]
    if label_row:  # CutPro puts its labels after the first row's numbers
        rows[0] += "\tFreq\tHz\tReal\tm/N\tImag\tReal\t"
    return header + "\n".join(rows) + "\n"


def test_cutpro_layout_exact(tmp_path):
    p = tmp_path / "xx.frf"
    p.write_text(cutpro_text(F, HX))
    f, h = read_frf(p)
    np.testing.assert_array_equal(f, F)
    np.testing.assert_array_equal(h, HX)


def test_frf_with_header_comments_and_mm_per_n(tmp_path):
    p = tmp_path / "yy.FRF"
    text = cutpro_text(F, HY * 1e3, label_row=False,
                       header="% tool tip yy\nFrequency(Hz) Real(mm/N) Imag\n Hz  mm/N  mm/N\n\n")
    p.write_text(text.replace("\t", "   "))
    f, h = read_frf(p)
    np.testing.assert_array_equal(f, F)
    np.testing.assert_allclose(h, HY, rtol=1e-14)


@pytest.mark.parametrize("binary", [1, 0])
def test_uff_round_trip(tmp_path, binary):
    p = write_uff(tmp_path / "xx.uff", uff58(HX, binary=binary))
    f, h = read_frf(p)
    np.testing.assert_array_equal(f, F)
    if binary:  # binary double records are bit-exact
        np.testing.assert_array_equal(h, HX)
    else:  # ASCII records carry 12 significant digits
        np.testing.assert_allclose(h, HX, rtol=1e-11)


def test_uff_record_selection(tmp_path):
    p = write_uff(tmp_path / "tap.unv", uff58(HX, id1="xx"), uff58(HY, rsp_dir=2, ref_dir=2, id1="yy"))
    listing = list_uff_records(p)
    assert len(listing) == 2 and "[1]" in listing[1] and "1:2" in listing[1] and "yy" in listing[1]
    with pytest.raises(InputError, match="record = N") as info:
        read_frf(p)
    assert "yy" in str(info.value)
    np.testing.assert_array_equal(read_frf(p, record=0)[1], HX)
    np.testing.assert_array_equal(read_frf(p, record=1)[1], HY)
    with pytest.raises(InputError, match="0..1"):
        read_frf(p, record=2)


def test_uff_units_label_mobility_and_accelerance(tmp_path):
    w = 2j * np.pi * F
    p = write_uff(tmp_path / "u.uff", uff58(HX * 1e3, label="mm/N"), uff58(HX * w, num=11),
                  uff58(HX * w * w / 9.80665, num=12, label="g/N"))
    np.testing.assert_allclose(read_frf(p, 0)[1], HX, rtol=1e-14)
    np.testing.assert_allclose(read_frf(p, 1)[1], HX, rtol=1e-14)
    np.testing.assert_allclose(read_frf(p, 2)[1], HX, rtol=1e-14)


def test_uff_units_from_dataset_164(tmp_path):
    units = pyuff.prepare_164(units_code=3, units_description="mm_newton", temp_mode=1, length=1000.0, force=1.0,
                              temp=1.0, temp_offset=273.15)
    p = write_uff(tmp_path / "u.uff", units, uff58(HX * 1e3))
    np.testing.assert_allclose(read_frf(p)[1], HX, rtol=1e-14)


def test_uff_rejects_non_frf(tmp_path):
    p = write_uff(tmp_path / "coh.uff", uff58(np.abs(HX) + 0j, func_type=6))
    with pytest.raises(InputError, match="function type"):
        read_frf(p)
    p = write_uff(tmp_path / "bad.uff", uff58(HX, label="kg"))
    with pytest.raises(InputError, match="m/N"):
        read_frf(p)


# ------------------------------------------------------------------------------------- errors

@pytest.mark.parametrize("name,text,words", [
    ("a.csv", "", "empty"),
    ("a.csv", "f,real,imag\n1,2,3\n", "unknown column"),
    ("a.csv", "freq_hz,real\n1,2\n", "missing column 'imag'"),
    ("a.csv", "freq_hz,real,imag\n1,2,x\n", "line 2, imag"),
    ("a.csv", "freq_hz,real,imag\n2,1,1\n1,1,1\n", "increasing"),
    ("a.csv", "freq_hz,real,imag\n1,nan,1\n", "finite"),
    ("a.frf", "1 2\n", "three numbers"),
    ("a.frf", "1 2 3 4 5\n", "expected three columns"),
    ("a.frf", "1 2 3\nend of data\n", "line 2"),
    ("a.frf", "# nothing\n", "no data rows"),
    ("a.frf", "Hz m/N mm/N\n1 2 3\n", "conflicting"),
    ("a.txt", "1 2 3\n", "allowed: .csv, .frf, .uff, .unv"),
    ("a.uff", "this is not a universal file\n", "UFF"),
])
def test_malformed_files(tmp_path, name, text, words):
    p = tmp_path / name
    p.write_text(text)
    with pytest.raises(InputError, match=None) as info:
        read_frf(p)
    assert words in str(info.value)


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        read_frf(tmp_path / "gone.csv")


# ---------------------------------------------------------------------------- MeasuredFRF

def test_load_measured_frf_mixed_formats(tmp_path):
    write_frf_csv(tmp_path / "xx.csv", F, HX)
    (tmp_path / "yy.frf").write_text(cutpro_text(F, HY))
    write_uff(tmp_path / "cross.uff", uff58(HX * 0.1, id1="xy"), uff58(HY * 0.2, id1="yx"))
    m = load_measured_frf(xx="xx.csv", yy=tmp_path / "yy.frf", xy={"file": "cross.uff", "record": 0},
                          yx=("cross.uff", 1), base_dir=tmp_path)
    np.testing.assert_array_equal(m.freq_hz, F)
    np.testing.assert_array_equal(m.xx, HX)
    np.testing.assert_array_equal(m.yy, HY)
    np.testing.assert_array_equal(m.xy, HX * 0.1)
    np.testing.assert_array_equal(m.yx, HY * 0.2)


def test_leading_zero_hz_dropped(tmp_path):
    f0 = np.concatenate([[0.0], F])
    write_frf_csv(tmp_path / "xx.csv", f0, np.concatenate([[1 / 12.53e6], HX]))
    m = load_measured_frf(xx=tmp_path / "xx.csv")
    np.testing.assert_array_equal(m.freq_hz, F)
    assert m.yy is None


def test_other_axis_is_interpolated_onto_xx(tmp_path):
    fy = np.linspace(50.0, 3200.0, 2000)
    hy = modal_receptance(fy, [950.0], [10e6], [0.01])
    write_frf_csv(tmp_path / "xx.csv", F, HX)
    write_frf_csv(tmp_path / "yy.csv", fy, hy)
    with pytest.warns(FRFWarning, match=r"yy \(yy.csv, 50..3200 Hz\) is ignored outside"):  # yy reaches beyond xx
        m = load_measured_frf(xx=tmp_path / "xx.csv", yy=tmp_path / "yy.csv")
    np.testing.assert_array_equal(m.freq_hz, F)
    expected = np.interp(F, fy, hy.real) + 1j * np.interp(F, fy, hy.imag)
    np.testing.assert_array_equal(m.yy, expected)
    np.testing.assert_allclose(m.yy, HY, rtol=0.05, atol=2e-9)  # and close to the true term


def test_different_bands_are_trimmed_with_warning(tmp_path):
    fy = np.arange(500.0, 2001.0, 5.0)
    write_frf_csv(tmp_path / "xx.csv", F, HX)
    write_frf_csv(tmp_path / "yy.csv", fy, modal_receptance(fy, [950.0], [10e6], [0.01]))
    with pytest.warns(UserWarning, match="500..2000 Hz"):
        m = load_measured_frf(xx=tmp_path / "xx.csv", yy=tmp_path / "yy.csv")
    assert m.freq_hz[0] == 500.0 and m.freq_hz[-1] == 2000.0


def test_load_measured_frf_errors(tmp_path):
    write_frf_csv(tmp_path / "xx.csv", F, HX)
    with pytest.raises(InputError, match="direct term"):
        load_measured_frf(xy=tmp_path / "xx.csv")
    with pytest.raises(InputError) as info:
        load_measured_frf(xx=tmp_path / "xx.csv", yy=tmp_path / "nope.csv")
    assert info.value.field == "structure.frf.yy"
    fz = np.arange(5000.0, 6000.0, 10.0)
    write_frf_csv(tmp_path / "far.csv", fz, modal_receptance(fz, [5500.0], [10e6], [0.01]))
    with pytest.raises(InputError, match="at least 4"):
        load_measured_frf(xx=tmp_path / "xx.csv", yy=tmp_path / "far.csv")
    with pytest.raises(InputError, match="allowed keys: file, record"):
        load_measured_frf(xx={"path": "xx.csv"}, base_dir=tmp_path)


@pytest.mark.parametrize("k_n_per_um, zeta", [(None, None), (1.0, 0.01), (20.0, 0.03), (100.0, 0.03)])
def test_a_tip_in_mm_per_n_warns_and_in_m_per_n_does_not(tmp_path, k_n_per_um, zeta):
    """Tool tips measure ~1–100 N/µm: the same tip's receptance written in mm/N (×1e3) is warned whatever its stiffness
    in that range (a 20 N/µm tip at ζ 0.03 peaks at 1/(2ζk) = 8.3e-4 in mm/N: it passed the 1e-3 m/N threshold before),
    and in m/N it is not, the most flexible tip of the range included (peak 5e-5 m/N); None: the module's HX."""
    h = HX if k_n_per_um is None else modal_receptance(F, [700.0], [k_n_per_um * 1e6], [zeta])
    if k_n_per_um is not None:
        assert np.max(np.abs(h)) == pytest.approx(1 / (2 * zeta * k_n_per_um * 1e6), rel=0.02)  # F holds the peak
    write_frf_csv(tmp_path / "mm.csv", F, h * 1e3)
    with pytest.warns(UnitWarning, match="mm/N"):
        load_measured_frf(xx=tmp_path / "mm.csv")
    write_frf_csv(tmp_path / "m.csv", F, h)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_measured_frf(xx=tmp_path / "m.csv")


def test_config_with_uff_record(tmp_path):
    from millstab.io.config import load_config

    write_uff(tmp_path / "tap.uff", uff58(HX, id1="xx"), uff58(HY, rsp_dir=2, ref_dir=2, id1="yy"))
    cfg = tmp_path / "c.toml"
    cfg.write_text('[cutting]\nteeth = 4\nkt = "1110 MPa"\nkr = 0.22\nentry = "0 deg"\nexit = "180 deg"\n'
                   '[structure.frf]\nxx = { file = "tap.uff", record = 0 }\nyy = { file = "tap.uff", record = 1 }\n')
    c = load_config(cfg)
    np.testing.assert_array_equal(c.structure.frf.xx, HX)
    np.testing.assert_array_equal(c.structure.frf.yy, HY)
    cfg.write_text(cfg.read_text().replace(", record = 1 }", " }"))
    with pytest.raises(InputError, match="record = N") as info:
        load_config(cfg)
    assert info.value.field == "structure.frf.yy"


# ------------------------------------------------------------------ issue 10: input slips in FRF files

def _write(path, text, encoding="utf-8"):
    path.write_bytes(text.encode(encoding))
    return path


def _uff_ascii(tmp_path, h=HX, name="a.uff"):
    return write_uff(tmp_path / name, uff58(h, binary=0))


@pytest.mark.parametrize("encoding", ["utf-8-sig", "utf-16"])  # Notepad's "UTF-8" and "Unicode"
def test_byte_order_mark_in_every_frf_format(tmp_path, encoding):
    csv_text = (tmp_path / "ref.csv").write_text("") or write_frf_csv(tmp_path / "ref.csv", F, HX).read_text()
    for name, text in (("xx.csv", csv_text), ("xx.frf", cutpro_text(F, HX))):
        f, h = read_frf(_write(tmp_path / name, text, encoding))
        np.testing.assert_array_equal(f, F)
        np.testing.assert_array_equal(h, HX)
    if encoding == "utf-8-sig":  # a UFF is ASCII; an editor may still have prepended a UTF-8 BOM
        p = _uff_ascii(tmp_path)
        p.write_bytes(b"\xef\xbb\xbf" + p.read_bytes())
        np.testing.assert_allclose(read_frf(p)[1], HX, rtol=1e-11)


def test_cutpro_in_windows_1252_keeps_its_micro_sign_unit(tmp_path):
    p = _write(tmp_path / "xx.frf", cutpro_text(F, HX * 1e6, label_row=False, header="Hz µm/N µm/N\n"), "cp1252")
    np.testing.assert_allclose(read_frf(p)[1], HX, rtol=1e-14)


@pytest.mark.parametrize("name,text,line", [
    # a spreadsheet's CSV in a decimal-comma locale: ';' between cells, ',' in numbers
    ("a.csv", "freq_hz;real;imag\n100,5;1,2e-07;-3e-08\n", "line 1"),
    ("a.csv", "freq_hz,real,imag\n100,5,1.2e-07,-3e-08\n", "line 2"),
    ("a.csv", 'freq_hz,real,imag\n"100,5","1,2e-07","-3e-08"\n', "line 2, freq_hz"),
    ("a.frf", "100,5 1,2e-07 -3,0e-08\n101,5 1,3e-07 -3,1e-08\n", "line 1"),
    ("a.frf", "% header\nHz m/N\n100.5\t1,2e-07\t-3e-08\n", "line 3"),
])
def test_decimal_commas_are_named(tmp_path, name, text, line):
    with pytest.raises(InputError) as info:
        read_frf(_write(tmp_path / name, text))
    msg = str(info.value)
    assert f"a.{name[-3:]} {line}" in info.value.field and "decimal" in msg and "no data rows" not in msg


def test_comma_separated_frf_is_named(tmp_path):
    with pytest.raises(InputError, match="separated by commas") as info:
        read_frf(_write(tmp_path / "a.frf", "100.5,1.2e-07,-3e-08\n"))
    assert "line 1" in info.value.field


def test_uff_with_decimal_commas_is_named(tmp_path):
    p = _uff_ascii(tmp_path)
    text = p.read_text()
    p.write_text(text.replace("e-0", "E-0").replace(".", ","))
    with pytest.raises(InputError, match="decimal comma"):
        read_frf(p)


@pytest.mark.parametrize("bad", ["inf", "-inf", "nan", "Infinity"])
@pytest.mark.parametrize("fmt", ["csv", "frf"])
def test_non_finite_values_name_file_and_line(tmp_path, bad, fmt):
    rows = [f"{fi!r},{hi.real!r},{hi.imag!r}" for fi, hi in zip(F[:6].tolist(), HX[:6].tolist())]
    rows[3] = rows[3].split(",")[0] + f",{bad},{float(HX[3].imag)!r}"
    text = "freq_hz,real,imag\n" + "\n".join(rows) + "\n" if fmt == "csv" else "\n".join(rows).replace(",", " ") + "\n"
    p = _write(tmp_path / f"t.{fmt}", text)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no numpy RuntimeWarning may leak
        with pytest.raises(InputError) as info:
            read_frf(p)
    line = 5 if fmt == "csv" else 4
    assert f"t.{fmt} line {line}" in info.value.field and "finite" in str(info.value)
    assert info.value.value == bad


def test_non_finite_frequency_names_the_line(tmp_path):
    p = _write(tmp_path / "t.csv", "freq_hz,real,imag\n100,1e-7,-1e-8\ninf,1e-7,-1e-8\n")
    with pytest.raises(InputError) as info:
        read_frf(p)
    assert info.value.field == "t.csv line 3, freq_hz"


@pytest.mark.parametrize("bad", ["inf", "NaN"])
def test_uff_non_finite_value_names_record_and_sample(tmp_path, bad):
    p = _uff_ascii(tmp_path)
    lines = p.read_text().splitlines()
    i = next(k for k, ln in enumerate(lines) if ln.strip().startswith("4.00000e+02"))  # the 400 Hz row
    cells = lines[i].split()
    lines[i] = f"  {cells[0]}{bad:>20}{cells[2]:>20}"
    p.write_text("\n".join(lines) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(InputError) as info:
            read_frf(p)
    assert "a.uff record 0 sample 30 (400 Hz)" == info.value.field and "finite" in str(info.value)
    assert "np." not in str(info.value)


# sign convention: G = 1/(k(1 - r^2 + 2iζr)) has Im G < 0 at a resonance; conjugated data have Im G > 0

def _term_file(tmp_path, fmt, h, name):
    if fmt == "csv":
        return write_frf_csv(tmp_path / f"{name}.csv", F, h)
    if fmt == "frf":
        return _write(tmp_path / f"{name}.frf", cutpro_text(F, h))
    return write_uff(tmp_path / f"{name}.uff", uff58(h))


@pytest.mark.parametrize("fmt", ["csv", "frf", "uff"])
@pytest.mark.parametrize("term", ["xx", "yy"])
def test_conjugated_direct_term_warns_naming_file_and_convention(tmp_path, fmt, term):
    good = _term_file(tmp_path, fmt, HX, "good")
    bad = _term_file(tmp_path, fmt, np.conj(HY), "bad")
    kw = {"xx": good, "yy": good, term: bad}
    with pytest.warns(FRFWarning) as rec:
        m = load_measured_frf(**kw)
    msgs = [str(w.message) for w in rec if issubclass(w.category, FRFWarning)]
    assert len(msgs) == 1  # once, from the loader (which names the file), not again from MeasuredFRF
    assert f"structure.frf.{term} ({bad.name})" in msgs[0] and "950 Hz" in msgs[0]
    assert "Im G < 0" in msgs[0] and "sign convention" in msgs[0]
    np.testing.assert_array_equal(getattr(m, term), np.conj(HY))  # warned, not altered


def test_correct_sign_and_cross_terms_do_not_warn(tmp_path):
    write_frf_csv(tmp_path / "xx.csv", F, HX)
    write_frf_csv(tmp_path / "yy.csv", F, HY)
    write_frf_csv(tmp_path / "xy.csv", F, -0.3 * HX)  # a cross term may have either sign
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_measured_frf(xx="xx.csv", yy="yy.csv", xy="xy.csv", yx="xy.csv", base_dir=tmp_path)


def test_conjugated_term_in_a_config_warns(tmp_path):
    from millstab.io.config import load_config

    write_frf_csv(tmp_path / "xx.csv", F, np.conj(HX))
    cfg = tmp_path / "c.toml"
    cfg.write_text('[cutting]\nteeth = 4\nkt = "1110 MPa"\nkr = 0.22\nentry = "0 deg"\nexit = "180 deg"\n'
                   '[structure.frf]\nxx = "xx.csv"\n')
    with pytest.warns(FRFWarning, match=r"xx \(xx.csv\).*near 900 Hz"):
        load_config(cfg)


# band coverage: a term whose band extends beyond the others' loses data, perhaps a mode

FULL = np.arange(100.0, 2001.0, 2.0)
NARROW = np.arange(300.0, 501.0, 2.0)
G_NARROW = modal_receptance(NARROW, [400.0], [20e6], [0.03])
G_FULL = modal_receptance(FULL, [400.0, 1069.0], [20e6, 5e6], [0.03, 0.02])  # the weak y mode at 1069 Hz


@pytest.mark.parametrize("narrow,full", [("xx", "yy"), ("yy", "xx")])
def test_band_mismatch_warns_in_either_order_naming_the_lost_mode(tmp_path, narrow, full):
    write_frf_csv(tmp_path / "narrow.csv", NARROW, G_NARROW)
    write_frf_csv(tmp_path / "full.csv", FULL, G_FULL)
    with pytest.warns(FRFWarning) as rec:
        m = load_measured_frf(**{narrow: "narrow.csv", full: "full.csv"}, base_dir=tmp_path)
    (msg,) = [str(w.message) for w in rec if issubclass(w.category, FRFWarning)]
    assert f"{narrow} (narrow.csv) covers only 300..500 Hz" in msg
    assert f"{full} (full.csv, 100..2000 Hz) is ignored outside it" in msg
    # the strongest ignored response is the 1069 Hz mode (within one 2 Hz sample)
    f_peak = float(msg.split("m/N at ")[1].split(" Hz")[0])
    assert abs(f_peak - 1069.0) <= 2.0 and "probably a mode" in msg and "unsafe" in msg
    assert m.freq_hz[0] == 300.0 and m.freq_hz[-1] == 500.0


def test_band_mismatch_of_a_cross_term_warns(tmp_path):
    write_frf_csv(tmp_path / "xx.csv", FULL, G_FULL)
    write_frf_csv(tmp_path / "yy.csv", FULL, G_FULL)
    write_frf_csv(tmp_path / "xy.csv", NARROW, 0.1 * G_NARROW)
    with pytest.warns(FRFWarning, match=r"xy \(xy.csv\) covers only 300..500 Hz"):
        load_measured_frf(xx="xx.csv", yy="yy.csv", xy="xy.csv", base_dir=tmp_path)


def test_same_band_on_different_grids_does_not_warn(tmp_path):
    write_frf_csv(tmp_path / "xx.csv", FULL, G_FULL)
    fine = np.linspace(100.0, 2000.0, 3001)
    write_frf_csv(tmp_path / "yy.csv", fine, modal_receptance(fine, [950.0], [10e6], [0.01]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_measured_frf(xx="xx.csv", yy="yy.csv", base_dir=tmp_path)


# angular and rotational frequency axes: converted as cycles (ω/2π, n/60), never read as Hz

@pytest.mark.parametrize("header,scale", [
    ("Frequency(rad/s) Real(mm/N) Imag(mm/N)\n", 2 * np.pi),
    ("freq [rad/s]   real [mm/N]   imag [mm/N]\n", 2 * np.pi),
    ("Freq rad/s Real mm/N Imag\n", 2 * np.pi),
    ("f(rpm) re(mm/N) im(mm/N)\n", 60.0),
    ("f(KHZ) re(mm/N) im(mm/N)\n", 1e-3),
])
def test_cutpro_frequency_axis_units(tmp_path, header, scale):
    p = _write(tmp_path / "xx.frf", cutpro_text(F * scale, HX * 1e3, label_row=False, header=header))
    f, h = read_frf(p)
    np.testing.assert_allclose(f, F, rtol=1e-14)
    np.testing.assert_allclose(h, HX, rtol=1e-14)


@pytest.mark.parametrize("label,scale", [("rad/s", 2 * np.pi), ("RPM", 60.0), ("rpm", 60.0), ("kHz", 1e-3), ("Hz", 1.0),
                                         ("Frequency", 1.0)])
def test_uff_abscissa_units_label(tmp_path, label, scale):
    s = uff58(HX, f=F * scale)
    s["abscissa_axis_units_lab"] = label
    f, h = read_frf(write_uff(tmp_path / "a.uff", s))
    np.testing.assert_allclose(f, F, rtol=1e-14)
    np.testing.assert_array_equal(h, HX)


@pytest.mark.parametrize("kind, factor", [("mobility", lambda w: 1j * w), ("accelerance", lambda w: -w * w)])
def test_measured_frf_of_another_kind_is_refused_naming_it(tmp_path, kind, factor):
    """A config's tap-test file in mobility or accelerance was read as m/N (a meaningless boundary, with a
    'negate the imaginary column' hint); it is refused, naming the term, the kind and the conversion."""
    w = 2 * np.pi * F
    write_frf_csv(tmp_path / "xx.csv", F, HX * factor(w))
    write_frf_csv(tmp_path / "yy.csv", F, HY)
    with pytest.raises(InputError) as exc:
        load_measured_frf(xx="xx.csv", yy="yy.csv", base_dir=tmp_path)
    assert exc.value.field == "structure.frf.xx" and kind in exc.value.allowed and "--frf-type" in exc.value.allowed
    m = load_measured_frf(xx="yy.csv", yy="yy.csv", base_dir=tmp_path)  # receptances pass
    np.testing.assert_array_equal(m.xx, HY)


def test_a_sign_flipped_receptance_in_a_config_is_named_as_such(tmp_path):
    """Both columns negated (a reversed hammer: −G) read as an accelerance by its phase; the config's refusal
    advised integrating twice (G/ω², a wrong structure) where `millstab modal` already names the flip: the same
    test now names it here, and a true accelerance of the same modes is still called one."""
    f = np.arange(100.0, 3001.0, 5.0)
    g = modal_receptance(f, [900.0], [20e6], [0.03])
    write_frf_csv(tmp_path / "flip.csv", f, -g)
    write_frf_csv(tmp_path / "acc.csv", f, -(2 * np.pi * f) ** 2 * g)
    with pytest.raises(InputError) as exc:
        load_measured_frf(xx="flip.csv", base_dir=tmp_path)
    assert "both columns negated" in exc.value.allowed and "integrate" not in exc.value.allowed
    with pytest.raises(InputError) as exc:
        load_measured_frf(xx="acc.csv", base_dir=tmp_path)
    assert "accelerance" in exc.value.allowed and "integrate twice" in exc.value.allowed
    assert "negated, not" not in exc.value.allowed


def _uff_labelled(h, num, num_lab, den_lab):
    s = uff58(h, num=num)
    s.update(ordinate_axis_units_lab=num_lab, orddenom_axis_units_lab=den_lab)
    return s


@pytest.mark.parametrize("num, num_lab, den_lab, power, factor", [
    (8, "m", "N", 0, 1.0), (8, "mm", "N", 0, 1e3), (8, "um", "N", 0, 1e6), (8, "m", "kN", 0, 1e3),
    (11, "m/s", "N", 1, 1.0), (12, "m/s^2", "N", 2, 1.0), (12, "g", "N", 2, 1 / 9.80665),
    (0, "g", "N", 2, 1 / 9.80665), (0, "mm", "N", 0, 1e3), (12, "g/N", "N", 2, 1 / 9.80665),
    (8, "mm/N", "NONE", 0, 1e3),
])
def test_uff_numerator_and_denominator_labels_as_the_standard_writes_them(tmp_path, num, num_lab, den_lab, power,
                                                                          factor):
    """Record 9 holds the response's unit, record 10 the reference's (pyuff ordinate_axis_units_lab and
    orddenom_axis_units_lab); an unknown type (0) takes the quantity its label names. Before: 'm' over 'N'
    was refused as 'cannot convert to m/N'."""
    w = 2j * np.pi * F
    p = write_uff(tmp_path / "u.uff", _uff_labelled(HX * w**power * factor, num, num_lab, den_lab))
    np.testing.assert_allclose(read_frf(p)[1], HX, rtol=1e-12)


def test_uff_label_contradicting_its_type_names_file_and_record(tmp_path):
    p = write_uff(tmp_path / "tap.uff", uff58(HX), _uff_labelled(HX, 8, "g", "N"))
    with pytest.raises(InputError, match=r"tap.uff record 1 ordinate units.*displacement per force") as exc:
        load_measured_frf(xx={"file": str(p), "record": 1}, field="FRF_X")
    assert "'g' per 'N'" in str(exc.value)
