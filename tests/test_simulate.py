"""Tests of the time-domain simulation and the chatter detector (millstab.simulate).

References are independent of the simulation: the Fourier series of the cutting force of an
unvibrating cut times the receptance (a stable cut's forced vibration), and the semi-discretization
engine's Floquet multipliers (stability, chatter frequency, lobe type). The full 10-speed boundary
comparison is benchmarks/bench_simulate.py; here a few speeds.

The classic benchmark (Insperger & Stépán): 2 teeth, Kt = 6e8 N/m², Kr = 1/3, one mode in x:
fn = 922 Hz, ζ = 0.011, m = 0.03993 kg.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from millstab.errors import InputError
from millstab.frf import measured_from_structure
from millstab.model import Cutting, Mode, Structure
from millstab.simulate import CutResult, default_steps, detect, label_cuts, simulate_cut
from millstab.simulate.boundary import multiplier
from millstab.stability import sdm

FN, ZETA, MASS = 922.0, 0.011, 0.03993
K = MASS * (2 * math.pi * FN) ** 2
BENCH = Structure(x=(Mode(FN, K, ZETA),))
SLOT = Cutting(2, 6e8, 1 / 3, 0.0, math.pi)
LOW = Cutting.from_immersion(2, 6e8, 1 / 3, 0.05, "down")
TWO = Structure(x=(Mode(FN, K, ZETA),), y=(Mode(1150.0, 1.3 * K, 0.015),))
HALF3 = Cutting.from_immersion(3, 6e8, 0.3, 0.5, "down")
FEED = 1e-4


def fourier_forced(structure: Structure, cutting: Cutting, rpm: float, depth: float, ft: float, t: np.ndarray,
                   n_fft: int = 1 << 16, n_harm: int = 400) -> np.ndarray:
    """(x, y) of the forced T-periodic motion at times t [s], independent of the simulation.

    On a T-periodic motion u(t) = u(t − T), so the chip is h = f_t sin ψ ≥ 0 for ψ in [φst, φex]
    and the force on the tool is F = Σ_teeth b Kt h (−cos ψ − Kr sin ψ, sin ψ − Kr cos ψ) (Altintas).
    Its Fourier coefficients are taken by FFT of n_fft samples per period (midpoint samples, so the
    entry jump costs O(1/n_fft)), each multiplied by the receptance Σ 1/(m(ωn² − ω² + 2iζωnω)).
    """
    T = 60.0 / (cutting.teeth * rpm)
    ts = (np.arange(n_fft) + 0.5) * T / n_fft
    F = np.zeros((2, n_fft))
    for j in range(cutting.teeth):
        psi = (2 * math.pi * rpm / 60 * ts + cutting.entry + 2 * math.pi * j / cutting.teeth) % (2 * math.pi)
        g = (psi >= cutting.entry) & (psi <= cutting.exit)
        h = np.where(g, ft * np.sin(psi), 0.0)
        F[0] += depth * cutting.kt * h * (-np.cos(psi) - cutting.kr * np.sin(psi))
        F[1] += depth * cutting.kt * h * (np.sin(psi) - cutting.kr * np.cos(psi))
    # coefficients of e^{i n ωT t}, with the half-sample shift of the midpoint grid undone
    c = np.fft.fft(F, axis=1)[:, : n_harm + 1] / n_fft
    n = np.arange(n_harm + 1)
    c = c * np.exp(-1j * np.pi * n / n_fft)
    w = 2 * math.pi * n / T
    out = np.zeros((2, t.size))
    for d, modes in ((0, structure.x), (1, structure.y)):
        G = sum(1 / (m.mass * (m.omega**2 - w**2 + 2j * m.zeta * m.omega * w)) for m in modes) if modes else 0 * w
        coef = np.where(n == 0, 1.0, 2.0) * G * c[d]
        out[d] = (coef[None, :] * np.exp(1j * np.outer(t, w))).real.sum(axis=1)
    return out


def forced_error(steps: int | None) -> float:
    """Largest |u_sim − u_fourier| over the last period, relative to the largest |u|."""
    rpm = 9000.0
    depth = 0.3 * sdm.envelope(TWO, HALF3, [rpm]).depth[0]
    res = simulate_cut(TWO, HALF3, rpm, depth, FEED, revs=300 / 3, steps_per_tooth=steps, start="rest")
    m = res.steps_per_tooth
    ref = fourier_forced(TWO, HALF3, rpm, depth, FEED, res.t[-m - 1:])
    sim = np.stack([res.x[-m - 1:], res.y[-m - 1:]])
    return float(np.abs(sim - ref).max() / np.abs(ref).max())


# --- the integrator -------------------------------------------------------------------------------


def test_stable_cut_forced_vibration_matches_frequency_domain_steady_state():
    """A stable cut started at rest settles on the Fourier-series × receptance solution."""
    assert forced_error(None) < 2e-4


def test_time_step_convergence_is_second_order():
    """Halving the step divides the error of the forced vibration by about four (first-order-hold force)."""
    e = [forced_error(m) for m in (40, 80, 160)]
    assert e[0] > e[1] > e[2]
    ratios = [e[0] / e[1], e[1] / e[2]]
    assert all(3.0 < r < 5.5 for r in ratios), (e, ratios)


@pytest.mark.parametrize("shift,expected", [(-1.0, [2.0, 1.0, 1.0]), (1.5, [0.0, 0.5, 1.0])])
def test_multiple_regeneration_keeps_the_surface_a_tooth_did_not_cut(shift, expected):
    """The surface is kept per angle: a tooth meets what the last *cutting* tooth left.

    A rigid tool (k = 1e14 N/m: no vibration) in slotting, and at ψ = 90° an initial surface moved
    by ``shift`` × f_t. Moved back (−1): the first tooth cuts a double chip, then f_t again. Moved
    forward (+1.5): the first tooth is out of the cut (no force) and leaves the surface as it was,
    so the next one cuts 0.5 f_t (a surface reset to the path of the idle tooth would give f_t),
    then f_t. Expected chips in units of f_t for the first three periods.
    """
    from millstab.simulate import _kernel

    m, N, ft, depth = 40, 2, 1e-4, 1e-3
    wn, zeta = np.array([2 * math.pi * 1000.0]), np.array([0.05])
    mass = np.array([1e14 / wn[0] ** 2])
    surf = _kernel.rest_surface(N, 0.0, math.pi, m, ft)
    surf[m // 2, 0] += shift * ft  # slot 0 at phase 1/2 is at ψ = 90°, sin ψ = 1
    n = 3 * m + 1
    out = [np.empty(n) for _ in range(4)]
    _kernel.simulate(N, 6e8, 1 / 3, 0.0, math.pi, 10000.0, m, 3, depth, ft, wn, zeta, mass, np.array([0]),
                     np.zeros(1), np.zeros(1), surf, 1.0, *out)
    fy = out[3][m // 2 + m * np.arange(3)]  # at ψ = 90°: F = b Kt h (−Kr, 1)
    assert np.allclose(fy / (depth * 6e8 * ft), expected, atol=1e-6)


# --- stability and chatter frequency against the semi-discretization engine -----------------------


@pytest.mark.parametrize("structure,cutting,rpm", [
    (BENCH, SLOT, 5000.0), (BENCH, SLOT, 18333.0), (BENCH, LOW, 9000.0), (BENCH, LOW, 17000.0),
    (TWO, HALF3, 11000.0), (TWO, HALF3, 16111.0), (Structure.symmetric(FN, K, ZETA), SLOT, 12000.0),
])
def test_simulated_multiplier_matches_sdm_and_brackets_its_boundary(structure, cutting, rpm):
    """At small vibration the once-per-tooth multiplier of the simulation is the engine's Floquet
    multiplier: |μ| within 1e-3 at the SDM boundary, the same angle (chatter frequency modulo the
    tooth-passing frequency, lobe type), and stable 2 % below, unstable 2 % above the SDM depth.
    With a mode in y and an exit (entry) at ψ = π (0), where the static chip is zero, a scheme that
    treats the sign of the dynamic chip there point-wise converges only O(τ) (|μ| 0.992 at 16 111 rpm)."""
    b0 = sdm.envelope(structure, cutting, [rpm]).depth[0]
    mu_sdm = sdm.critical_multipliers(structure, cutting, [rpm])[0]
    mu = multiplier(structure, cutting, rpm, b0)
    assert abs(abs(mu) - 1.0) < 1e-3
    assert abs(abs(np.angle(mu)) - abs(np.angle(mu_sdm))) < math.radians(0.5)
    assert abs(multiplier(structure, cutting, rpm, 0.98 * b0)) < 1.0
    assert abs(multiplier(structure, cutting, rpm, 1.02 * b0)) > 1.0


def test_detector_stable_and_hopf_chatter_with_the_sdm_chatter_frequency():
    rpm = 18333.0
    env = sdm.envelope(BENCH, SLOT, [rpm])
    b0, f_sdm = env.depth[0], env.chatter_hz[0]
    stable = detect(simulate_cut(BENCH, SLOT, rpm, 0.6 * b0, FEED))
    assert stable.label == "stable" and stable.lobe == "" and math.isnan(stable.chatter_hz)
    res = simulate_cut(BENCH, SLOT, rpm, 1.05 * b0, FEED, revs=300)
    d = detect(res)
    assert d.label == "chatter" and d.lobe == "hopf"
    f_t = res.tooth_hz
    fold = lambda f: min(f % f_t, f_t - f % f_t)  # noqa: E731  (a multiplier and its conjugate)
    assert abs(fold(d.chatter_hz) - fold(f_sdm)) < 2.0
    assert abs(d.chatter_hz - f_sdm) < 0.1 * FN  # the peak near the mode, as the engine reports
    # further above the limit the chatter saturates: the teeth leave the cut (zero force, where in
    # slotting a tooth is always in the cut, apart from the instants ψ = 0, π where h = f_t sin ψ = 0,
    # one sample per period), and the vibration stays bounded, a limit cycle of a few feeds
    res = simulate_cut(BENCH, SLOT, rpm, 1.3 * b0, FEED, revs=300)
    d = detect(res)
    assert d.label == "chatter" and 0.5 < d.growth < 1.5 and d.level > 0.2  # saturated: no growth
    assert not res.diverged and np.all(np.isfinite(res.x)) and np.abs(res.x).max() < 10 * FEED
    last = slice(res.x.size // 2, None)
    assert np.mean(np.hypot(res.fx[last], res.fy[last]) == 0.0) > 10 / res.steps_per_tooth


def test_detector_flip_lobe_at_low_immersion():
    """a/D = 0.05 at 17 000 rpm is a period-doubling boundary: chatter at an odd multiple of f_T/2."""
    rpm = 17000.0
    b0 = sdm.envelope(BENCH, LOW, [rpm]).depth[0]
    mu = sdm.critical_multipliers(BENCH, LOW, [rpm])[0]
    assert mu.real < 0 and abs(mu.imag) < 1e-6
    res = simulate_cut(BENCH, LOW, rpm, 1.1 * b0, FEED, revs=200)
    d = detect(res)
    assert d.label == "chatter" and d.lobe == "flip"
    half = d.chatter_hz / (res.tooth_hz / 2)
    assert abs(half - round(half)) < 0.02 and round(half) % 2 == 1
    # period two: the once-per-tooth samples alternate, every second one repeats
    x = res.once_x[-40:]
    assert np.abs(x[2:] - x[:-2]).max() < 0.2 * np.abs(x[1:] - x[:-1]).max()


def test_diverging_run_is_chatter_without_nan():
    """Far beyond the limit and with a bound only slightly above the chip, the run stops: chatter."""
    res = simulate_cut(BENCH, SLOT, 10000.0, 50e-3, FEED, revs=50)
    d = detect(res)
    assert d.label == "chatter"
    assert np.all(np.isfinite(res.x)) and np.all(np.isfinite(res.fx))
    json.dumps(d.to_dict(), allow_nan=False)


def test_overflow_guard_stops_the_run(monkeypatch):
    import millstab.simulate as sim

    monkeypatch.setattr(sim, "BOUND_FACTOR", 1e-3)  # bound below the forced vibration: must stop
    res = sim.simulate_cut(BENCH, SLOT, 10000.0, 1e-3, FEED, revs=20)
    assert res.diverged and res.x.size < 40 * res.steps_per_tooth + 1
    assert detect(res).label == "chatter"


# --- inputs ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("kw,field", [
    (dict(depth=0.0), "depth"), (dict(depth=-1e-3), "depth"), (dict(depth=float("nan")), "depth"),
    (dict(feed_per_tooth=0.0), "feed_per_tooth"), (dict(feed_per_tooth=-1e-4), "feed_per_tooth"),
    (dict(rpm=0.0), "rpm"), (dict(steps_per_tooth=19), "steps_per_tooth"),
    (dict(steps_per_tooth=40.5), "steps_per_tooth"), (dict(revs=0.0), "revs"), (dict(start="hot"), "start"),
])
def test_bad_input_is_a_clear_error(kw, field):
    args = dict(rpm=10000.0, depth=1e-3, feed_per_tooth=FEED)
    args.update({k: v for k, v in kw.items() if k in args})
    extra = {k: v for k, v in kw.items() if k not in args}
    with pytest.raises(InputError) as err:
        simulate_cut(BENCH, SLOT, args["rpm"], args["depth"], args["feed_per_tooth"], **extra)
    assert err.value.field.startswith(field)


def test_measured_frf_is_refused():
    frf = measured_from_structure(BENCH, np.linspace(100, 2000, 50))
    with pytest.raises(InputError, match="modal parameters"):
        simulate_cut(Structure(frf=frf), SLOT, 10000.0, 1e-3, FEED)


def test_default_steps_resolve_the_mode_and_the_cut():
    m = default_steps(BENCH, LOW, [5000.0, 25000.0])
    T = 60.0 / (2 * np.array([5000.0, 25000.0]))
    assert np.all(m >= 200) and np.all(m * 0.143 >= 39) and np.all(T / m <= 1 / (100 * FN) * 1.0001)


# --- many cuts, noise, results --------------------------------------------------------------------


@pytest.mark.slow
def test_label_cuts_matches_single_cuts_and_noise_is_seeded():
    rpm = np.array([5000.0, 9000.0, 12000.0, 18333.0, 18333.0, 25000.0])
    depth = np.array([0.2e-3, 3e-3, 0.5e-3, 0.5e-3, 1.2e-3, 1e-3])
    lab = label_cuts(BENCH, SLOT, rpm, depth, FEED, revs=60)
    for i in range(rpm.size):
        d = detect(simulate_cut(BENCH, SLOT, rpm[i], depth[i], FEED, revs=60))
        assert lab.label[i] == d.label
        assert np.isnan(lab.chatter_hz[i]) == np.isnan(d.chatter_hz)
        if not np.isnan(d.chatter_hz):
            assert abs(lab.chatter_hz[i] - d.chatter_hz) < 1e-6 * d.chatter_hz
    assert set(lab.label) >= {"stable", "chatter"}
    many_r, many_d = np.repeat(rpm, 20), np.repeat(depth, 20)
    a = label_cuts(BENCH, SLOT, many_r, many_d, FEED, revs=30, label_noise=0.3, seed=7)
    b = label_cuts(BENCH, SLOT, many_r, many_d, FEED, revs=30, label_noise=0.3, seed=7)
    c = label_cuts(BENCH, SLOT, many_r, many_d, FEED, revs=30, label_noise=0.3, seed=8)
    assert np.array_equal(a.label, b.label) and not np.array_equal(a.label, c.label)
    swapped = np.mean((a.label != a.true_label)[a.true_label != "marginal"])
    assert 0.15 < swapped < 0.45
    with pytest.raises(InputError, match="seed"):
        label_cuts(BENCH, SLOT, rpm, depth, FEED, label_noise=0.1)
    with pytest.raises(InputError):
        label_cuts(BENCH, SLOT, rpm, depth[:2], FEED)


def test_cut_result_round_trips_through_json():
    res = simulate_cut(TWO, HALF3, 9000.0, 0.2e-3, FEED, revs=5)
    back = CutResult.from_dict(json.loads(json.dumps(res.to_dict())))
    assert back.schema == "millstab.simulate.cut/1" and back.active == (True, True)
    assert np.array_equal(back.x, res.x) and np.array_equal(back.fy, res.fy) and back.rpm == res.rpm


# --- command line ---------------------------------------------------------------------------------


def test_cli_one_cut_plot_and_labelled_list(tmp_path, capsys):
    from millstab.cli import main

    png = tmp_path / "cut.png"
    trace = tmp_path / "trace.csv"
    assert main(["simulate", "example:ex1", "--rpm", "9000", "--depth", "8", "--revs", "40",
                 "--plot", str(png), "--out", str(trace)]) == 0
    text = capsys.readouterr().out
    assert "chatter at" in text and png.stat().st_size > 10_000
    assert trace.read_text().splitlines()[0] == "t_s,x_m,y_m,fx_N,fy_N"
    cuts = tmp_path / "cuts.csv"
    cuts.write_text("rpm,depth_mm\n9000,1\n9000,8\n")
    out = tmp_path / "labelled.csv"
    assert main(["simulate", "example:ex1", "--cuts", str(cuts), "--out", str(out), "--revs", "40"]) == 0
    rows = [r.split(",") for r in out.read_text().splitlines()]
    assert rows[0] == ["rpm", "depth_mm", "label", "chatter_hz"]
    assert rows[1][2] == "stable" and rows[1][3] == "" and rows[2][2] == "chatter" and float(rows[2][3]) > 0
    assert main(["simulate", "example:ex1", "--rpm", "9000"]) == 2
    assert main(["simulate", "example:ex1", "--rpm", "9000", "--depth", "1", "--steps", "10"]) == 2
    assert main(["simulate", "example:ex1", "--cuts", str(cuts), "--out", str(cuts)]) == 2  # never overwrite the input
    assert cuts.read_text() == "rpm,depth_mm\n9000,1\n9000,8\n"


def test_the_labelled_file_keeps_the_users_depths_as_written(tmp_path):
    """The labels hold depths in m; through m and back 3.34 mm reads 3.3400000000000003 mm, so the labelled file
    would not show the user's own numbers (it did until 2026-11-28). Every cell of rpm and depth is the input's."""
    from millstab.cli import main

    assert 3.34e-3 * 1e3 != 3.34  # the trap this guards against is real
    cuts = tmp_path / "cuts.csv"
    cuts.write_text("rpm,depth_mm\n9000,3.34\n7012.5,0.29\n")
    out = tmp_path / "labelled.csv"
    assert main(["simulate", "example:ex1", "--cuts", str(cuts), "--out", str(out), "--revs", "20"]) == 0
    rows = [r.split(",") for r in out.read_text().splitlines()[1:]]
    assert [(r[0], r[1]) for r in rows] == [("9000.0", "3.34"), ("7012.5", "0.29")]


def test_the_labelled_file_keeps_the_users_other_columns(tmp_path):
    """A shop's plan carries more than speed and depth: weights, a batch (the day), its notes and tool numbers. The
    labelled file keeps them (update reads them back: the notes kept and ignored with a note, the batch as a batch);
    until 2026-11-29 `simulate` dropped them while its warning said "kept". The chatter frequency is written to 0.1 Hz
    (the detector's spectrum has lines f_T/64 apart), its value the labels' own, rounded."""
    import csv

    from millstab import api
    from millstab.cli import main
    from millstab.io import read_points

    cuts = tmp_path / "plan.csv"
    cuts.write_text("rpm,depth_mm,weight,batch,notes,tool\n"
                    "9000,1,1,mon,first pass,T3\n9000,8,2,tue,\"deep, loud?\",T3\n")
    out = tmp_path / "labelled.csv"
    assert main(["simulate", "example:ex1", "--cuts", str(cuts), "--out", str(out), "--revs", "20"]) == 0
    rows = list(csv.DictReader(out.open()))
    assert [r["notes"] for r in rows] == ["first pass", "deep, loud?"] and [r["tool"] for r in rows] == ["T3", "T3"]
    assert [r["batch"] for r in rows] == ["mon", "tue"] and [float(r["weight"]) for r in rows] == [1.0, 2.0]
    lab = api.label_cuts(api.config("example:ex1"), read_points(cuts), revs=20)
    assert rows[1]["label"] == "chatter" and rows[1]["chatter_hz"] == f"{lab.chatter_hz[1]:.1f}"
    back = read_points(out)  # ready for update: the same cuts, batches and weights, the notes as extra columns
    assert list(back.batch) == ["mon", "tue"] and list(back.weight) == [1.0, 2.0]
    assert list(back.extra["notes"]) == ["first pass", "deep, loud?"]
