"""What `millstab modal` says about a tap test that is not as it should be: a sign-flipped FRF (reversed hammer
polarity), a noisy FRF whose mode count the user knows (--modes N), a fit with too few modes, a direction
without a file, and UFF58 files labelled as the standard writes them (numerator and denominator apart).
Every FRF is synthesised here from known modes."""

from __future__ import annotations

import warnings

import numpy as np
import pyuff
import pytest

from millstab.cli import main
from millstab.errors import FRFWarning, InputError
from millstab.frf import modal_receptance
from millstab.io import write_frf_csv
from millstab.modal import fit_direction
from millstab.modal.run import fit_files, negated_receptance

#: the tap test of the report: 2 Hz lines, 100..3000 Hz
F = np.arange(100.0, 3000.01, 2.0)
#: x: two modes 7 % apart and one at 2400 Hz; y: one mode ((fn [Hz], k [N/m], zeta))
X = ([800.0, 860.0, 2400.0], [20e6, 30e6, 80e6], [0.03, 0.025, 0.02])
Y = ([1100.0], [15e6], [0.02])


def exact(modes, f=F):
    return np.asarray(modal_receptance(f, *(np.asarray(v, float) for v in modes))).reshape(-1)


def noisy(h, share, seed):
    rng = np.random.default_rng(seed)
    return h + share * np.abs(h).max() * (rng.standard_normal(h.size) + 1j * rng.standard_normal(h.size)) / np.sqrt(2)


def cli(capsys, *args):
    code = main(["modal", *map(str, args)])
    out = capsys.readouterr()
    return code, out.out, out.err


def assert_modes(fit, modes, fn_tol, k_tol, zeta_tol):
    got = {p: np.array([getattr(m, p) for m in fit.modes]) for p in ("fn", "k", "zeta")}
    assert got["fn"].size == len(modes[0]), got["fn"]
    for p, want, tol in zip(("fn", "k", "zeta"), modes, (fn_tol, k_tol, zeta_tol)):
        np.testing.assert_allclose(got[p], want, rtol=tol, err_msg=p)


# ---- a whole sign flip -----------------------------------------------------------------------------------

@pytest.mark.parametrize("frf_type", ["auto", "accelerance", "receptance"])
def test_a_sign_flipped_receptance_is_named_whatever_the_frf_type(capsys, tmp_path, frf_type):
    """Before: 'looks like accelerance' (auto), '--frf-type accelerance ... looks like accelerance ... pass
    --frf-type accelerance' and 'negate the imaginary column' (receptance)."""
    p = write_frf_csv(tmp_path / "xx_neg.csv", F, -noisy(exact(X), 0.01, 1))
    code, _, err = cli(capsys, p, "--frf-type", frf_type, "--out", tmp_path / "s.toml")
    assert code == 2 and err.count("\n") == 1, err
    assert "both columns negated" in err and "negate both the real and the imaginary column" in err, err
    assert "negate the imaginary column" not in err and "pass --frf-type" not in err
    assert not (tmp_path / "s.toml").exists()


def test_the_fit_names_a_sign_flip_by_its_residues():
    """Every residue at +90 deg: the fit itself (a measured-FRF config's path) says negate both columns."""
    with pytest.raises(InputError, match="sign reversed .*negate both the real and the imaginary column"):
        fit_direction(F, -exact(X))


@pytest.mark.parametrize("band", [(100, 3000), (100, 1000), (500, 3000)])
@pytest.mark.parametrize("noise", [0.0, 0.02])
def test_an_accelerance_is_never_called_a_sign_flip(band, noise):
    f = F[(F >= band[0]) & (F <= band[1])]
    acc = -((2 * np.pi * f) ** 2) * noisy(exact(X, f), noise, 3)
    assert negated_receptance(f, acc) is None
    assert negated_receptance(f, noisy(exact(X, f), noise, 3)) is None  # nor a receptance


def test_a_sign_flip_with_a_stiffness_line_is_told_from_an_accelerance():
    """The band starts well below the modes: −H is flat there (a stiffness line), −H/ω² outgrows its peaks."""
    for modes in (X, Y):
        assert negated_receptance(F, -noisy(exact(modes), 0.02, 4)) == "yes"


def test_a_short_band_names_both_readings(capsys, tmp_path):
    """600..1100 Hz: slope and low end fit an accelerance as well as a flipped receptance; both are named."""
    keep = (F >= 600) & (F <= 1100)
    p = write_frf_csv(tmp_path / "x.csv", F[keep], -exact(X)[keep])
    code, _, err = cli(capsys, p, "--out", tmp_path / "s.toml")
    assert code == 2 and "accelerance" in err and "both columns negated" in err, err


# ---- --modes N on a noisy FRF --------------------------------------------------------------------------

@pytest.mark.parametrize("seed", [1, 5])
def test_modes_n_fits_n_modes_where_auto_finds_no_stable_pole(seed):
    """8 % noise: LSCF keeps only the 2400 Hz pole stable and the close pair is first fitted as one broad
    mode; auto refuses, naming --modes N and --band, and --modes 3 fits all three (seed 5 needed the split
    start: before, 'shows only 1 stable mode(s)')."""
    h = noisy(exact(X), 0.08, seed)
    with pytest.raises(InputError, match="--modes N fits that many.*--band"):
        fit_direction(F, h)
    with pytest.warns(FRFWarning, match="--modes 3 fitted .*not stabilised") as said:
        fit = fit_direction(F, h, modes=3)
    assert_modes(fit, X, 2e-3, 0.1, 0.12)
    assert not [w for w in said if "poor fit" in str(w.message)]  # 8 % white noise is noise, not a poor fit


def test_modes_n_beyond_what_the_data_hold_is_refused_saying_why():
    """Before: 'shows only 1 stable mode(s)', also where modes had been grown from the misfit."""
    with pytest.raises(InputError, match=r"gives only 1 physical mode\(s\) in 100..3000 Hz"):
        fit_direction(F, exact(([900.0], [2e7], [0.03])), modes=3)


# ---- a poor fit and a rigid direction ------------------------------------------------------------------

def test_too_few_modes_are_warned_as_a_poor_fit():
    """--modes 1 on three modes: a 9 % misfit that is structure (before: no warning)."""
    h = noisy(exact(X), 0.01, 1)
    with pytest.warns(FRFWarning, match=r"poor fit: the RMS misfit of the 1 mode\(s\) is 9\.\d+ %"):
        fit_direction(F, h, modes=1)
    with warnings.catch_warnings():
        warnings.simplefilter("error", FRFWarning)
        fit = fit_direction(F, h)  # the three modes: the misfit is the 1 % noise, no warning
    assert_modes(fit, X, 1e-3, 0.02, 0.03)


def test_a_direction_without_a_file_is_said_to_be_rigid(capsys, tmp_path):
    p = write_frf_csv(tmp_path / "xx.csv", F, exact(Y))
    code, out, _ = cli(capsys, p, "--out", tmp_path / "s.toml")
    assert code == 0 and "y: no FRF given: rigid" in out
    assert "# y: no FRF given: rigid" in (tmp_path / "s.toml").read_text()


# ---- UFF58 units as the standard writes them -------------------------------------------------------------

def uff58(h, num_type, num_lab, den_lab, rsp_dir=1):
    return pyuff.prepare_58(binary=1, func_type=4, rsp_node=1, rsp_dir=rsp_dir, ref_node=1, ref_dir=rsp_dir, data=h,
                            x=F, id1="tap", abscissa_spacing=1, abscissa_spec_data_type=18,
                            ordinate_spec_data_type=num_type, orddenom_spec_data_type=13,
                            ordinate_axis_units_lab=num_lab, orddenom_axis_units_lab=den_lab)


def test_cli_fits_a_standard_uff_with_m_and_g_over_n(capsys, tmp_path):
    """Before: "FRF_X.xx = 'm' is invalid: uff ordinate units: cannot convert to m/N"."""
    w = 2 * np.pi * F
    p = tmp_path / "tap_std.uff"
    u = pyuff.UFF(str(p))
    u.write_sets(uff58(noisy(exact(X), 0.01, 1), 8, "m", "N"), "add")
    u.write_sets(uff58(-(w**2) * noisy(exact(Y), 0.01, 2) / 9.80665, 12, "g", "N", rsp_dir=2), "add")
    code, _, err = cli(capsys, p, p, "--record-x", 0, "--record-y", 1, "--out", tmp_path / "s.toml")
    assert code == 0, err
    fit = fit_files(p, p, records=(0, 1))
    assert_modes(fit.fits["x"], X, 1e-3, 0.02, 0.03)
    assert_modes(fit.fits["y"], Y, 1e-3, 0.02, 0.03)
