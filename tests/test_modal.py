"""Modal fitting of measured FRFs (``millstab modal``): exact recovery, noisy must-reach figures in every
file format, the SLD from the fit, the CLI and its one-line errors."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from millstab.cli import main
from millstab.errors import FRFWarning, InputError
from millstab.frf import modal_receptance
from millstab.io import parse_config, write_frf_csv
from millstab.modal import fit_direction
from millstab.modal.run import fit_files, parse_band, parse_modes

pyuff = pytest.importorskip("pyuff")

#: 4 000 lines, as a hammer test exports them
F = np.linspace(0.5, 2000.0, 4000)
#: (fn [Hz], k [N/m], zeta) per direction; x has two modes 6 % apart, y two modes 3.8 % apart, which
#: overlap (half-power bandwidths 26-27 Hz against 25 Hz spacing)
X_MODES = ([520.0, 903.0, 960.0], [30e6, 12.5e6, 20e6], [0.03, 0.025, 0.02])
Y_MODES = ([650.0, 675.0], [20e6, 25e6], [0.02, 0.02])
ONE_MODE = ([903.0], [12.53e6], [0.03])
CUTTING = """
[cutting]
teeth = 2
kt = "556.31 N/mm^2"
kr = 0.404
entry = "0 deg"
exit = "180 deg"
"""


def exact(modes, f=F):
    return modal_receptance(f, *(np.asarray(v, float) for v in modes))


def noisy(h, share=0.02, seed=0):
    """Additive complex Gaussian noise, RMS ``share`` of the largest |H| (the issue's 2 % noise)."""
    rng = np.random.default_rng(seed)
    sigma = share * np.abs(h).max()
    return h + sigma * (rng.standard_normal(h.size) + 1j * rng.standard_normal(h.size)) / np.sqrt(2)


def assert_modes(fit, modes, fn_tol, k_tol, zeta_tol):
    fn, k, zeta = (np.asarray(v, float) for v in modes)
    assert len(fit.modes) == fn.size, [m.fn for m in fit.modes]
    got = {p: np.array([getattr(m, p) for m in fit.modes]) for p in ("fn", "k", "zeta")}
    np.testing.assert_allclose(got["fn"], fn, rtol=fn_tol)
    np.testing.assert_allclose(got["k"], k, rtol=k_tol)
    np.testing.assert_allclose(got["zeta"], zeta, rtol=zeta_tol)


# ------------------------------------------------------------------------------- exact FRFs

@pytest.mark.parametrize("modes", [ONE_MODE, X_MODES, Y_MODES], ids=["one", "three", "close-pair"])
def test_exact_modal_frf_recovered_to_1e6(modes):
    fit = fit_direction(F, exact(modes))
    assert_modes(fit, modes, 1e-6, 1e-6, 1e-6)
    # the free residue of a drive point lies at -90 deg: A = -i wn^2/(2 k wd) (derivation in modal.fit)
    assert max(abs(m.phase_deg) for m in fit.modes) < 1e-3


def test_conversion_matches_pole_residue_closed_form():
    """k = wn^2/(2 wd |A|) with A the residue of G at its pole, computed here by a contour-free limit."""
    fn, k, zeta = 903.0, 12.53e6, 0.03
    wn = 2 * np.pi * fn
    wd = wn * np.sqrt(1 - zeta**2)
    lam = -zeta * wn + 1j * wd
    eps = 1e-3 * wn * np.array([1, 1j, -1, -1j])  # (s - lam) G(s) -> A as s -> lam; average over directions
    s = lam + eps
    g = 1.0 / (k * (1 + (s / wn) ** 2 + 2 * zeta * s / wn))  # G(w) = 1/(k(1 - r^2 + 2i zeta r)) with iw -> s
    a = np.mean(eps * g)
    np.testing.assert_allclose(a, -1j * wn**2 / (2 * k * wd), rtol=1e-6)
    np.testing.assert_allclose(wn**2 / (2 * wd * abs(a)), k, rtol=1e-6)
    fit = fit_direction(F, exact(([fn], [k], [zeta])))
    np.testing.assert_allclose(fit.modes[0].k, wn**2 / (2 * wd * abs(a)), rtol=1e-6)


# ------------------------------------------------------------------ noisy FRFs, every file format

def write_cutpro(path, f, h):
    rows = [f"{fi!r}\t{hi.real!r}\t{hi.imag!r}" for fi, hi in zip(f.tolist(), h.tolist())]
    rows[0] += "\tFreq Hz Real m/N Imag m/N"
    path.write_text("\n".join(rows) + "\n")
    return path


def write_uff(path, f, h, func_type=4):
    u = pyuff.UFF(str(path))
    u.write_sets(pyuff.prepare_58(binary=1, func_type=func_type, rsp_node=1, rsp_dir=1, ref_node=1, ref_dir=1,
                                  data=h, x=f, id1="tap", abscissa_spacing=0, abscissa_spec_data_type=18,
                                  ordinate_spec_data_type=8, orddenom_spec_data_type=13), "add")
    return path


WRITERS = {"csv": lambda p, f, h: write_frf_csv(p, f, h), "frf": write_cutpro, "uff": write_uff}


@pytest.mark.parametrize("fmt", list(WRITERS))
@pytest.mark.slow
def test_noisy_two_directions_reach_the_targets_in_each_format(tmp_path, fmt):
    """2 % noise: fn within 0.2 %, zeta and k within 5 % for every mode (all stand above the noise)."""
    px = WRITERS[fmt](tmp_path / f"x.{fmt}", F, noisy(exact(X_MODES), seed=1))
    py = WRITERS[fmt](tmp_path / f"y.{fmt}", F, noisy(exact(Y_MODES), seed=2))
    res = fit_files(px, py)
    assert_modes(res.fits["x"], X_MODES, 2e-3, 0.05, 0.05)
    assert_modes(res.fits["y"], Y_MODES, 2e-3, 0.05, 0.05)
    for fit in res.fits.values():
        assert 0.015 < fit.nrmse < 0.025  # the misfit is the noise itself (RMS 2 % of max|H|)


@pytest.mark.parametrize("seed", [3, 4, 5])
def test_noisy_targets_hold_across_noise_draws(seed):
    fit = fit_direction(F, noisy(exact(X_MODES), seed=seed))
    assert_modes(fit, X_MODES, 2e-3, 0.05, 0.05)


def test_sld_minimum_from_fit_within_3_percent_of_true():
    from millstab.model import Mode, Structure
    from millstab.stability import zoa

    cutting = parse_config(CUTTING + '[[structure.x]]\nfn = "1 kHz"\nk = "10 N/um"\nzeta = 0.03\n').cutting
    true = Structure(x=tuple(Mode(*p) for p in zip(*X_MODES)), y=tuple(Mode(*p) for p in zip(*Y_MODES)))
    res = fit_files_arrays(noisy(exact(X_MODES), seed=6), noisy(exact(Y_MODES), seed=7))
    rpm = np.arange(3000.0, 15000.0, 10.0)
    b_true = zoa.envelope(true, cutting, rpm).depth
    b_fit = zoa.envelope(res, cutting, rpm).depth
    assert abs(b_fit.min() / b_true.min() - 1) < 0.03


def fit_files_arrays(hx, hy):
    from millstab.model import Mode, Structure

    fx, fy = fit_direction(F, hx, direction="x"), fit_direction(F, hy, direction="y")
    return Structure(x=tuple(Mode(m.fn, m.k, m.zeta) for m in fx.modes),
                     y=tuple(Mode(m.fn, m.k, m.zeta) for m in fy.modes))


def test_modes_at_the_band_edges_are_found():
    """40 Hz (5 lines per half-power band) and 1980 Hz (20 Hz below the top): LSCF finds no stable pole
    under noise; the modes are grown from the misfit instead."""
    modes = ([40.0, 1980.0], [12.5e6, 20e6], [0.03, 0.02])
    fit = fit_direction(F, noisy(exact(modes), seed=11))
    assert_modes(fit, modes, 2e-3, 0.05, 0.05)


def test_only_modes_above_the_noise_are_reported():
    """A mode whose peak is 6x the noise RMS is found; one at 1x (hidden in the noise) is not invented."""
    strong = ([903.0], [12.5e6], [0.03])
    peak = 1 / (2 * 0.03 * 12.5e6)
    sigma = 0.02 * peak
    for ratio, found in ((6.0, 2), (1.0, 1)):
        k_weak = 1 / (2 * 0.03 * ratio * sigma)
        h = exact(strong) + exact(([300.0], [k_weak], [0.03]))
        rng = np.random.default_rng(12)
        h = h + sigma * (rng.standard_normal(F.size) + 1j * rng.standard_normal(F.size)) / np.sqrt(2)
        fit = fit_direction(F, h)
        assert len(fit.modes) == found, (ratio, [m.fn for m in fit.modes])
        np.testing.assert_allclose(fit.modes[-1].fn, 903.0, rtol=2e-3)
        np.testing.assert_allclose(fit.modes[-1].k, 12.5e6, rtol=0.05)
        if found == 2:
            np.testing.assert_allclose(fit.modes[0].fn, 300.0, rtol=2e-3)
            np.testing.assert_allclose(fit.modes[0].k, k_weak, rtol=0.1)  # 6x the noise: k to 10 %


def test_modes_option_keeps_the_largest_peaks_and_refuses_too_many():
    h = exact(X_MODES)
    with pytest.warns(FRFWarning, match="poor fit"):  # the 520 Hz mode left out is a shape, not noise
        fit = fit_direction(F, h, modes=2)
    # peaks 1/(2 zeta k): 903 Hz (1.6e-6) and 960 Hz (1.25e-6) beat 520 Hz (0.56e-6)
    assert [round(m.fn) for m in fit.modes] == [903, 960]
    with pytest.raises(InputError, match="--modes"):
        fit_direction(F, h, modes=6)


def test_band_cuts_the_fit():
    res_all = fit_direction(F, exact(X_MODES))
    keep = (F >= 800) & (F <= 1200)
    fit = fit_direction(F[keep], exact(X_MODES)[keep])
    assert [round(m.fn) for m in fit.modes] == [903, 960]  # 520 Hz is below the band: a residual term now
    assert len(res_all.modes) == 3
    np.testing.assert_allclose([m.k for m in fit.modes], X_MODES[1][1:], rtol=1e-3)


# ------------------------------------------------------------------------------- bad input

def test_no_clear_peak_is_refused():
    rng = np.random.default_rng(8)
    flat = 1e-7 * (1 + 0.02 * (rng.standard_normal(F.size) + 1j * rng.standard_normal(F.size)))
    with pytest.raises(InputError, match="no clear resonance peak"):
        fit_direction(F, flat)


def test_cross_frf_is_refused():
    """A transfer FRF: modes of both signs (shape products +1 and -1)."""
    h = exact(([600.0], [20e6], [0.02])) - exact(([900.0], [15e6], [0.02]))
    with pytest.raises(InputError, match="cross"):
        fit_direction(F, h)


def test_conjugated_frf_is_refused():
    with pytest.raises(InputError, match="opposite sign convention"):
        fit_direction(F, np.conj(exact(ONE_MODE)))


def test_parsers_refuse_bad_text():
    assert parse_band("200:2500") == (200.0, 2500.0)
    assert parse_modes("2,auto") == (2, "auto")
    for bad in ("2500:200", "a:b", "1:2:3"):
        with pytest.raises(InputError, match="--band"):
            parse_band(bad)
    for bad in ("0", "x", "1,2,3"):
        with pytest.raises(InputError, match="--modes"):
            parse_modes(bad)


def cli(capsys, *args):
    code = main(["modal", *map(str, args)])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_cli_band_without_data_is_one_line(tmp_path, capsys):
    p = write_frf_csv(tmp_path / "x.csv", F, exact(ONE_MODE))
    code, _, err = cli(capsys, p, "--band", "3000:4000", "--out", tmp_path / "s.toml")
    assert code == 2 and err.count("\n") == 1 and "--band" in err and "holds 0 of the 4000 lines" in err
    assert not (tmp_path / "s.toml").exists()


def test_cli_uff_of_another_type_is_one_line(tmp_path, capsys):
    p = write_uff(tmp_path / "x.uff", F, exact(ONE_MODE), func_type=6)
    code, _, err = cli(capsys, p, "--out", tmp_path / "s.toml")
    assert code == 2 and err.count("\n") == 1 and "function type" in err


def test_cli_non_drive_point_is_one_line(tmp_path, capsys):
    h = exact(([600.0], [20e6], [0.02])) - exact(([900.0], [15e6], [0.02]))
    p = write_frf_csv(tmp_path / "x.csv", F, h)
    code, _, err = cli(capsys, p, "--out", tmp_path / "s.toml")
    errors = [line for line in err.splitlines() if not line.startswith("millstab: warning:")]
    assert code == 2 and len(errors) == 1 and "drive-point" in errors[0]


def test_fit_refuses_malformed_arrays():
    with pytest.raises(InputError, match="strictly increasing"):
        fit_direction(F[::-1], exact(ONE_MODE))
    with pytest.raises(InputError, match="at least 20"):
        fit_direction(F[:10], exact(ONE_MODE)[:10])


def test_cli_picks_a_uff_record(tmp_path, capsys):
    p = tmp_path / "two.uff"
    write_uff(p, F, exact(Y_MODES))
    write_uff(p, F, exact(ONE_MODE))
    code, _, err = cli(capsys, p, "--out", tmp_path / "s.toml")
    assert code == 2 and "record" in err
    code, text, err = cli(capsys, p, "--record-x", 1, "--out", tmp_path / "s.toml")
    assert code == 0, err
    fitted = parse_config(CUTTING + (tmp_path / "s.toml").read_text()).structure.x
    assert [m.fn for m in fitted] == pytest.approx([903.0])


def test_cli_refuses_to_overwrite_an_input(tmp_path, capsys):
    p = write_frf_csv(tmp_path / "x.csv", F, exact(ONE_MODE))
    code, _, err = cli(capsys, p, "--out", p)
    assert code == 2 and "would overwrite" in err
    assert p.read_text().startswith("freq_hz,real,imag")


# ------------------------------------------------------------------------------- CLI end to end

@pytest.mark.slow
def test_cli_writes_a_structure_that_a_config_accepts(tmp_path, capsys):
    px = write_frf_csv(tmp_path / "x.csv", F, noisy(exact(X_MODES), seed=9))
    py = write_cutpro(tmp_path / "y.frf", F, noisy(exact(Y_MODES), seed=10))
    cfg = tmp_path / "cut.toml"
    cfg.write_text(CUTTING + '[[structure.x]]\nfn = "903 Hz"\nk = "12.53 N/um"\nzeta = 0.03\n'
                   "[speeds]\nstart = 3000\nstop = 15000\nstep = 50\n")
    out, js, png = tmp_path / "s.toml", tmp_path / "q.json", tmp_path / "fit.png"
    code, text, err = cli(capsys, px, py, "--out", out, "--json", js, "--plot", png, "--config", cfg)
    assert code == 0, err
    assert "SLD check" in text and "worst difference" in text
    merged = parse_config(CUTTING + out.read_text())
    got_x = np.array([[m.fn, m.k, m.zeta] for m in merged.structure.x])
    np.testing.assert_allclose(got_x[:, 0], X_MODES[0], rtol=2e-3)
    np.testing.assert_allclose(got_x[:, 1], X_MODES[1], rtol=0.05)
    assert len(merged.structure.y) == 2
    q = json.loads(js.read_text())
    assert q["schema"] == "millstab.modal/1"
    assert [round(m["fn_hz"]) for m in q["directions"]["y"]["modes"]] == [650, 675]
    # the fitted modes and the measured FRF give nearly the same minimum depth
    assert abs(q["sld_check"]["min_difference"]) < 0.1
    assert png.stat().st_size > 10_000


def test_conjugated_file_warns_then_refuses(tmp_path):
    p = write_frf_csv(tmp_path / "x.csv", F, np.conj(exact(ONE_MODE)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FRFWarning)
        with pytest.raises(InputError, match="opposite sign convention"):
            fit_files(p)


# ------------------------------------------------------- commands that need modes, given a measured FRF

def measured_config(tmp_path):
    write_frf_csv(tmp_path / "xx.csv", F, exact(X_MODES))
    write_frf_csv(tmp_path / "yy.csv", F, exact(Y_MODES))
    p = tmp_path / "tool.toml"
    p.write_text(CUTTING + '[structure.frf]\nxx = "xx.csv"\nyy = "yy.csv"\n')
    return p


def test_fitted_config_starts_from_the_fit(tmp_path):
    from millstab.io import load_config
    from millstab.modal.run import fitted_config

    cfg = load_config(str(measured_config(tmp_path)))
    assert not cfg.structure.is_modal
    modal_cfg, note = fitted_config(cfg)
    assert "fitted its modes first" in note and "x: 520 Hz" in note
    for d, truth in (("x", X_MODES), ("y", Y_MODES)):
        got = np.array([[m.fn, m.k, m.zeta] for m in getattr(modal_cfg.structure, d)]).T
        np.testing.assert_allclose(got, np.array(truth), rtol=1e-6)
    assert modal_cfg.cutting is cfg.cutting and fitted_config(modal_cfg) == (modal_cfg, None)


def test_sensitivity_accepts_a_measured_frf_config(tmp_path, capsys):
    cfg = measured_config(tmp_path)
    code = main(["sensitivity", "oat", str(cfg), "--rpm", "3000:12000:500", "--out", str(tmp_path / "oat.csv")])
    out = capsys.readouterr()
    assert code == 0, out.err
    assert "fitted its modes first" in out.out and (tmp_path / "oat.csv").exists()


def test_update_accepts_a_measured_frf_config(tmp_path, capsys):
    """`update` centres its prior on the fitted modes of a measured-FRF config (it refused it before)."""
    cfg = measured_config(tmp_path)
    cuts = tmp_path / "cuts.csv"
    cuts.write_text("rpm,depth_mm,label\n6000,0.2,stable\n6000,20,chatter\n9000,0.2,stable\n9000,20,chatter\n")
    out = tmp_path / "post.json"
    code = main(["update", str(cfg), str(cuts), "--samples", "200", "--seed", "1", "--out", str(out)])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "fitted its modes first" in captured.out
    doc = json.loads(out.read_text())
    # the prior's median is the fitted x mode that dominates (520 Hz within its 5 % spread)
    assert abs(doc["parameters"]["fn_x1"]["q50"] / 520.0 - 1) < 0.15
