"""[tool] + [holder] configs: parsing, errors, holder files and the artifact test from files, the tip FRF as a
structure the engines take, and `millstab tooltip`."""

from __future__ import annotations

import csv
import textwrap

import numpy as np
import pytest

import reference_timoshenko as rt
from test_io_config import error, write  # the config tests' helpers: write a file, expect an InputError
from millstab.cli import main
from millstab.errors import InputError
from millstab.io import load_config
from millstab.io.config import load_tool_setup
from millstab.io.frf_files import write_frf_csv
from millstab.model import MeasuredFRF, Structure
from millstab.stability import zoa
from millstab.tooltip import MATERIALS, RigidHolder, tip_receptance
from millstab.warnlog import quiet

CUT = """
[cutting]
teeth = 3
kt = "700 MPa"
kr = 0.3
radial_immersion = 1
"""
TOOL = """
[tool]
diameter = "12 mm"
stickout = "45 mm"
fluted_length = "26 mm"
material = "carbide"
zeta = 0.01
"""
RIGID = "[holder]\nrigid = true\n"
STEEL, CARBIDE = MATERIALS["steel"], MATERIALS["carbide"]


def test_tool_config_gives_the_tip_frf_structure(tmp_path):
    cfg, tool, holder = load_tool_setup(write(tmp_path, CUT + TOOL + RIGID))
    assert (tool.diameter, tool.stickout, tool.fluted_length) == pytest.approx((0.012, 0.045, 0.026))
    assert tool.material is CARBIDE and tool.flute_ratio == 0.8 and isinstance(holder, RigidHolder)
    frf = cfg.structure.frf
    assert frf is not None and np.array_equal(frf.xx, frf.yy)
    np.testing.assert_allclose(frf.xx, tip_receptance(tool, holder, frf.freq_hz), rtol=1e-12)


def test_tip_grid_resolves_the_stability_limit():
    """zoa on the tip grid against zoa on the same FRF sampled every 0.5 Hz: the limit within 0.5 %."""
    cfg_text = CUT + TOOL + RIGID
    from millstab.io.config import parse_config

    cfg = parse_config(cfg_text)
    frf = cfg.structure.frf
    dense = np.arange(frf.freq_hz[0], frf.freq_hz[-1], 0.5)
    _, tool, holder = _setup(cfg_text)
    g = tip_receptance(tool, holder, dense)
    with quiet():
        ref = Structure(frf=MeasuredFRF(dense, g, g))
    rpm = np.linspace(8000, 30000, 120)
    a = zoa.envelope(cfg.structure, cfg.cutting, rpm).depth
    b = zoa.envelope(ref, cfg.cutting, rpm).depth
    np.testing.assert_allclose(a, b, rtol=5e-3)


def _setup(text):
    import tomllib

    from millstab.io.config import parse_config, tool_setup

    return parse_config(text), *tool_setup(tomllib.loads(text))


@pytest.mark.parametrize("edit, field, words", [
    (('stickout = "45 mm"', 'stickout = "-5 mm"'), "tool.stickout", "> 0"),
    (('stickout = "45 mm"', 'stickout = 0'), "tool.stickout", "> 0"),
    (('diameter = "12 mm"', 'diameter = "12 m"'), "tool.diameter", 'did you mean "12 mm"'),
    (('diameter = "12 mm"', 'diameter = 12'), "tool.diameter", "plain number"),
    (('diameter = "12 mm"', 'diameter = "250 mm"'), "tool.diameter", "more than 0.2 m for a tool's diameter"),
    (('material = "carbide"', 'material = "unobtainium"'), "material", "carbide: E 600 GPa, density 14600 kg/m^3"),
    (('material = "carbide"', 'E = "600 GPa"'), "tool.material", "density"),
    (('fluted_length = "26 mm"', 'fluted_length = "50 mm"'), "tool.fluted_length", "must not exceed the stickout"),
    (('zeta = 0.01', 'zeta = 0.7'), "tool.zeta", "[0, 0.5)"),
    (('zeta = 0.01', 'flutes = 3'), "tool.flutes", "unknown key"),
])
def test_tool_errors_name_field_value_and_what_is_allowed(tmp_path, edit, field, words):
    e = error(tmp_path, CUT + TOOL.replace(*edit) + RIGID)
    assert e.field == field and words in e.allowed
    assert ("did you mean" in e.allowed) == ("12" in edit[1])  # not "0.25 mm?" for a value written in mm


def test_custom_material_and_holder_errors(tmp_path):
    custom = TOOL.replace('material = "carbide"', 'E = "600 GPa"\ndensity = "14600 kg/m^3"\nnu = 0.22')
    cfg, tool, _ = load_tool_setup(write(tmp_path, CUT + custom + RIGID))
    assert (tool.material.E, tool.material.density, tool.material.nu) == (600e9, 14600.0, 0.22)
    assert error(tmp_path, CUT + TOOL).field == "holder"
    assert "rigid = true" in error(tmp_path, CUT + TOOL + "[holder]\n").allowed
    both = CUT + TOOL + RIGID + "[[holder.modes]]\nfn = 900\nk = 4e7\nzeta = 0.04\n"
    assert "exactly one" in error(tmp_path, both).allowed
    with_structure = CUT + TOOL + RIGID + "[[structure.x]]\nfn = 900\nk = 4e7\nzeta = 0.04\n"
    assert "not both" in error(tmp_path, with_structure).allowed
    assert error(tmp_path, CUT + TOOL + "[holder]\nrigid = false\n").field == "holder"


def _holder_exact(f, eta=0.02):
    return rt.clamped_tip([rt.section(0.07, 0.025, STEEL.E, STEEL.density, STEEL.nu)], f, eta)


def test_holder_frf_files_couple_like_the_assembly(tmp_path):
    """[holder.frf] with h, l, p files (n = l by reciprocity) from a synthetic steel holder: the tip matches
    the exact assembly (median 0.5 %, peak frequency 0.5 %)."""
    f = np.arange(20.0, 9001.0, 2.0)
    r = _holder_exact(f)
    for name, (i, j) in {"h": (0, 0), "l": (0, 1), "p": (1, 1)}.items():
        write_frf_csv(tmp_path / f"{name}.csv", f, r[:, i, j])
    text = CUT + TOOL.replace('fluted_length = "26 mm"\n', "") + '[holder.frf]\nh = "h.csv"\nl = "l.csv"\np = "p.csv"\n'
    cfg = load_config(write(tmp_path, text))
    upper = load_config(write(tmp_path, text.replace('\nh = "', '\nH = "').replace('\nl = "', '\nN = "'), "u.toml"))
    np.testing.assert_array_equal(upper.structure.frf.xx, cfg.structure.frf.xx)
    assert error(tmp_path, text.replace('l = "l.csv"\n', "")).field == "holder.frf.l"
    frf = cfg.structure.frf
    ref = rt.clamped_tip([rt.section(0.07, 0.025, STEEL.E, STEEL.density, STEEL.nu),
                          rt.section(0.045, 0.012, CARBIDE.E, CARBIDE.density, CARBIDE.nu)], frf.freq_hz, 0.02)[:, 0, 0]
    assert np.median(np.abs(frf.xx / ref - 1)) < 5e-3
    from millstab.tooltip import peaks

    assert peaks(frf.freq_hz, frf.xx, 1)[0][0] == pytest.approx(peaks(frf.freq_hz, ref, 1)[0][0], rel=5e-3)
    # the holder's files are inputs: no output may overwrite them
    cfg_path = tmp_path / "c.toml"
    h_before = (tmp_path / "h.csv").read_bytes()
    assert main(["tooltip", str(cfg_path), "--out", str(tmp_path / "h.csv")]) == 2
    assert main(["lobes", str(cfg_path), "--rpm", "8000:9000:500", "--out", str(tmp_path / "p.csv")]) == 2
    assert (tmp_path / "h.csv").read_bytes() == h_before


def test_undamped_tool_in_a_rigid_holder_warns(tmp_path):
    from millstab.errors import FRFWarning

    with pytest.warns(FRFWarning, match="no damping"):
        load_config(write(tmp_path, CUT + TOOL.replace("zeta = 0.01\n", "") + RIGID))


def test_holder_artifact_files(tmp_path):
    """[holder.artifact]: the three FRFs of a 16 × 80 mm steel artifact (synthetic, exact) recover the holder,
    and the tool's tip follows the exact assembly."""
    f = np.arange(50.0, 6001.0, 5.0)
    sec = lambda L, D: rt.section(L, D, STEEL.E, STEEL.density, STEEL.nu)  # noqa: E731
    before = [sec(0.07, 0.025), sec(0.06, 0.016) + (0.0,)]  # the damped holder, an undamped artifact
    tip = rt.clamped_tip(before + [sec(0.02, 0.016) + (0.0,)], f, 0.02)[:, 0, 0]
    at_s = rt.clamped_point_force(before, [sec(0.02, 0.016) + (0.0,)], f, 0.02)
    write_frf_csv(tmp_path / "tip.csv", f, tip)
    write_frf_csv(tmp_path / "cross.csv", f, at_s[:, 1])
    write_frf_csv(tmp_path / "off.csv", f, at_s[:, 0])
    text = CUT + TOOL.replace('fluted_length = "26 mm"\n', "") + textwrap.dedent("""
        [holder.artifact]
        diameter = "16 mm"
        length = "80 mm"
        offset = "20 mm"
        material = "steel"
        tip = "tip.csv"
        cross = "cross.csv"
        offset_direct = "off.csv"
        """)
    cfg, tool, holder = load_tool_setup(write(tmp_path, text))
    known = _holder_exact(holder.freq_hz)
    got = holder.receptance(holder.freq_hz)
    for i, j in ((0, 0), (0, 1), (1, 1)):
        assert np.median(np.abs(got[:, i, j] / known[:, i, j] - 1)) < 2e-3
    frf = cfg.structure.frf
    ref = rt.clamped_tip([sec(0.07, 0.025), rt.section(0.045, 0.012, CARBIDE.E, CARBIDE.density, CARBIDE.nu)],
                         frf.freq_hz, 0.02)[:, 0, 0]
    assert np.median(np.abs(frf.xx / ref - 1)) < 0.02


def test_cli_tooltip_csv_is_a_structure_frf_and_the_sweep_matches_lobes(tmp_path, capsys):
    cfg_path = write(tmp_path, CUT + TOOL + RIGID)
    out, sweep, fig = tmp_path / "tip.csv", tmp_path / "sweep.csv", tmp_path / "tip.png"
    assert main(["tooltip", str(cfg_path), "--out", str(out), "--plot", str(fig), "--stickout", "35:55:10",
                 "--sweep-out", str(sweep), "--rpm", "8000:30000:200"]) == 0
    assert "highest minimum limit" in capsys.readouterr().out
    assert fig.read_bytes()[:4] == b"\x89PNG"
    # the tip CSV read back as a measured tip FRF gives the [tool] config's own limits
    measured = write(tmp_path, CUT + '[structure.frf]\nxx = "tip.csv"\nyy = "tip.csv"\n', "m.toml")
    rpm = np.arange(8000.0, 30001.0, 200.0)
    a = zoa.envelope(load_config(measured).structure, load_config(cfg_path).cutting, rpm).depth
    b = zoa.envelope(load_config(cfg_path).structure, load_config(cfg_path).cutting, rpm).depth
    np.testing.assert_allclose(a, b, rtol=1e-12)
    rows = list(csv.DictReader(sweep.open()))
    assert [float(r["stickout_mm"]) for r in rows] == [35.0, 45.0, 55.0]
    assert float(rows[1]["min_blim_mm"]) == pytest.approx(np.min(b) * 1e3, rel=1e-9)
    mins = [float(r["min_blim_mm"]) for r in rows]
    assert mins[0] > mins[1] > mins[2]  # a longer tool is less stable (rigid holder)
    assert main(["tooltip", str(cfg_path), "--stickout", "0:50:10"]) == 2
    assert main(["tooltip", str(cfg_path), "--out", str(cfg_path)]) == 2
    assert main(["lobes", str(cfg_path), "--rpm", "8000:9000:500", "--engine", "sdm"]) == 2


def test_service_inputs_and_engine_errors(tmp_path):
    from millstab import api

    np.testing.assert_allclose(api.stickouts_mm("30:50:10"), [0.03, 0.04, 0.05])
    for bad in ("0:50:10", "50:30:5", "30:2000:500"):
        with pytest.raises(InputError):
            api.stickouts_mm(bad)
    cfg, tool, holder = api.tool_config(write(tmp_path, CUT + TOOL + RIGID))
    with pytest.raises(InputError, match="measured FRF"):
        api.stickout_sweep(cfg, tool, holder, np.array([0.04]), np.array([9000.0]), engine="sdm")
    with pytest.raises(InputError, match="no \\[tool\\]"):
        api.tool_config("example:ex1")


def test_holder_differing_in_x_and_y(tmp_path, capsys):
    """[holder.x] and [holder.y]: xx couples the tool to the x holder, yy to the y holder, on one grid; the
    command writes both terms, and they read back as a [structure.frf]."""
    from millstab.tooltip import FaceMode, ModalHolder

    xy = '[holder.x]\nrigid = true\n[[holder.y.modes]]\nfn = "900 Hz"\nk = "40 N/um"\nzeta = 0.04\nslope = "20 rad/m"\n'
    cfg_path = write(tmp_path, CUT + TOOL + xy)
    cfg, tool, holder = load_tool_setup(cfg_path)
    frf = cfg.structure.frf
    np.testing.assert_allclose(frf.xx, tip_receptance(tool, RigidHolder(), frf.freq_hz), rtol=1e-12)
    modal = ModalHolder((FaceMode(900.0, 40e6, 0.04, 20.0),))
    np.testing.assert_allclose(frf.yy, tip_receptance(tool, modal, frf.freq_hz), rtol=1e-12)
    assert np.max(np.abs(frf.yy / frf.xx - 1)) > 0.5
    ox, oy = tmp_path / "x.csv", tmp_path / "y.csv"
    assert main(["tooltip", str(cfg_path), "--out", str(ox), "--out-y", str(oy)]) == 0
    assert "tip FRF y" in capsys.readouterr().out
    back = write(tmp_path, CUT + '[structure.frf]\nxx = "x.csv"\nyy = "y.csv"\n', "b.toml")
    rpm = np.arange(8000.0, 30001.0, 500.0)
    np.testing.assert_allclose(zoa.envelope(load_config(back).structure, cfg.cutting, rpm).depth,
                               zoa.envelope(cfg.structure, cfg.cutting, rpm).depth, rtol=1e-12)
    e = error(tmp_path, CUT + TOOL + "[holder.x]\nrigid = true\n")
    assert e.field == "holder.y"
    assert error(tmp_path, CUT + TOOL + "[holder.x]\nrigid = true\n[holder.y]\n").field == "holder.y"


def test_holder_finite_differences_files(tmp_path):
    """[holder.finite_differences]: h00, h01, h11 (and h02, h12, h22) of a synthetic FE holder at 2 mm spacing,
    with the holder's diameter for the shear correction: the tip follows the same tool on the exact face
    terms (median over 50-8000 Hz: order 2 within 1 %, order 1 within 3 %)."""
    from millstab.tooltip import Beam, Section, couple

    Dh, Lh, s = 0.025, 0.07, 0.002
    f = np.arange(50.0, 8001.0, 10.0)
    # an undamped holder body (steel's own loss factor is ~1e-3; the shear correction is static and elastic)
    beam = Beam((Section(Lh - 3 * s, Dh, STEEL),) + tuple(Section(s, Dh, STEEL) for _ in range(3)), elements=60)
    nodes = [beam.node(Lh - i * s) for i in range(3)]
    H = beam.receptance(f, [2 * k for k in nodes], clamped=True)
    exact = beam.receptance(f, [2 * nodes[0], 2 * nodes[0] + 1], clamped=True)
    for i in range(3):
        for j in range(i, 3):
            write_frf_csv(tmp_path / f"h{i}{j}.csv", f, H[:, i, j])
    base = CUT + TOOL.replace('fluted_length = "26 mm"\n', "") + textwrap.dedent("""
        [holder.finite_differences]
        spacing = "2 mm"
        diameter = "25 mm"
        material = "steel"
        h00 = "h00.csv"
        h01 = "h01.csv"
        h11 = "h11.csv"
        """)
    _, tool, _ = load_tool_setup(write(tmp_path, base))
    ref = couple(tool.beam().end_receptances(f), exact)[:, 0, 0]
    errs = []
    for text in (base, base + 'h02 = "h02.csv"\nh12 = "h12.csv"\nh22 = "h22.csv"\n'):
        cfg, tool, holder = load_tool_setup(write(tmp_path, text, "fd.toml"))
        errs.append(np.median(np.abs(tip_receptance(tool, holder, f) / ref - 1)))
    assert errs[1] < 0.01 and errs[1] < errs[0] < 0.03
    e = error(tmp_path, base + 'h02 = "h02.csv"\n')
    assert "h02, h12 and h22 together" in e.allowed


def test_a_tool_config_is_simulated_on_the_modes_fitted_to_its_tip(tmp_path):
    """`simulate` on a [tool] + [holder] config (an exploratory test: refused with "structure = 'measured FRF'",
    pointing nowhere; fails on the old code): the tip FRF's modes are fitted first, said in a warning, and the cut's
    label agrees with the zero-order limit of the tip FRF itself (a slot with 3 teeth, where that limit is exact) at
    0.7 and 1.4 times it."""
    from millstab import api

    cfg = load_config(write(tmp_path, CUT + TOOL + RIGID))
    rpm = 9000.0
    limit = zoa.envelope(cfg.structure, cfg.cutting, [rpm]).depth_mm[0]
    with pytest.warns(UserWarning, match="the structure is a measured FRF; fitted its modes first"):
        _, below = api.simulate_cut(cfg, rpm, 0.7 * limit)
    with quiet():
        _, above = api.simulate_cut(cfg, rpm, 1.4 * limit)
    assert (below.label, above.label) == ("stable", "chatter")
