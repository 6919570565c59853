"""Process damping (Cutting.process_damping, the C·b/V flank-contact term) in the engines that carry it.

References, independent of the engines' code paths:

* a closed form: four teeth in slotting make the directional matrix and the process-damping matrix
  time-invariant (Σ over the two teeth in the cut of sin 2φ and cos 2φ is zero, of n nᵀ the identity),
  so a one-mode structure in x obeys the constant-coefficient delay equation

      m ẍ + (c + C b / V) ẋ + k x = −b Kt Kr (x(t) − x(t − T)),

  whose boundary at iω is a quadratic in b (below, :func:`closed_form_limit`), scanned here with numpy;
* self-consistency by another path: the limit with process damping equals the limit of the structure
  whose damping ratio is raised by the equivalent c_pd = C b_lim / V at that depth (no process damping);
* the 1/V scaling: at a fixed spindle speed (fixed lobes) the gain over the undamped limit halves when
  the diameter (the cutting speed) doubles, and vanishes at high cutting speed;
* the time-domain simulation (instantaneous per tooth, nonlinear, its own integrator) against the
  semi-discretization engine's limit at ±10 % at a low and a high speed.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import brentq

from millstab.errors import InputError
from millstab.forward import Forward
from millstab.frf import ModalBatch
from millstab.io.config import parse_config
from millstab.model import Cutting, Mode, Structure
from millstab.params import Parameterization
from millstab.stability import process_damping as pd
from millstab.stability import sdm, spectral, zoa

FN, ZETA, MASS = 922.0, 0.011, 0.03993
K = MASS * (2 * math.pi * FN) ** 2
ONE = Structure(x=(Mode(FN, K, ZETA),))
TWO = Structure(x=(Mode(FN, K, ZETA),), y=(Mode(1150.0, 1.3 * K, 0.015),))
KT, KR, D = 6e8, 0.3, 0.016


def slot4(c: float = 0.0, diameter: float | None = D) -> Cutting:
    return Cutting(4, KT, KR, 0.0, math.pi, process_damping=c, diameter=diameter)


def closed_form_limit(mode: Mode, kt: float, kr: float, c_over_v: float, rpm: float, teeth: int = 4,
                      n_grid: int = 50_000) -> float:
    """The first depth [m] at which m ẍ + (c + c_over_v b) ẋ + k x = −b kt kr (x − x(t − T)) has a root
    on the imaginary axis, T = 60 / (teeth rpm); inf when none (scan of ω over (ωn, 4 ωn]).

    At s = iω with R = k − m ω², K = b kt kr: e^{−iωT} = 1 + (R + iω c_b)/K must have modulus 1, i.e.
    ω² c'² b² + 2(ω² c c' + R kt kr) b + R² + ω² c² = 0 (c' = c_over_v), and its phase fixes ωT mod 2π.
    For each root branch of the quadratic the phase condition is solved on a fine ω grid (Brent)."""
    m, k, c = mode.mass, mode.k, 2 * mode.zeta * mode.mass * mode.omega
    T = 60.0 / (teeth * rpm)
    ks = kt * kr

    def depth(w, sign):
        R = k - m * w * w
        a, bq, c0 = w * w * c_over_v**2, 2 * (w * w * c * c_over_v + R * ks), R * R + w * w * c * c
        if a == 0.0:
            return -c0 / bq if bq < 0 else np.nan
        disc = bq * bq - 4 * a * c0
        if disc < 0:
            return np.nan
        b = (-bq + sign * math.sqrt(disc)) / (2 * a)
        return b if b > 0 else np.nan

    def phase(w, sign):
        b = depth(w, sign)
        if not np.isfinite(b):
            return np.nan
        z = 1 + complex(k - m * w * w, w * (c + c_over_v * b)) / (b * ks)
        return math.remainder(w * T + math.atan2(z.imag, z.real), 2 * math.pi)  # 0 on the boundary

    best = math.inf
    w_grid = np.linspace(mode.omega * (1 + 1e-9), 4 * mode.omega, n_grid)
    for sign in ((-1.0, 1.0) if c_over_v > 0 else (1.0,)):
        ph = np.array([phase(w, sign) for w in w_grid])
        for i in np.flatnonzero(np.isfinite(ph[:-1]) & np.isfinite(ph[1:]) & (np.sign(ph[:-1]) != np.sign(ph[1:]))
                                & (np.abs(ph[1:] - ph[:-1]) < 1.0)):
            w = brentq(phase, w_grid[i], w_grid[i + 1], args=(sign,), xtol=1e-12 * w_grid[i])
            best = min(best, depth(w, sign))
    return best


# --- the model field and its errors ---------------------------------------------------------------


@pytest.mark.parametrize("kw,field", [
    ({"process_damping": -1.0, "diameter": D}, "cutting.process_damping"),
    ({"process_damping": float("nan"), "diameter": D}, "cutting.process_damping"),
    ({"process_damping": 2e4}, "cutting.diameter"),
    ({"process_damping": 2e4, "diameter": 0.0}, "cutting.diameter"),
])
def test_bad_process_damping_is_a_clear_error(kw, field):
    with pytest.raises(InputError) as exc:
        Cutting(4, KT, KR, 0.0, math.pi, **kw)
    assert exc.value.field == field


def test_per_depth_coefficient_is_c_over_cutting_speed():
    cut = slot4(2e4)
    v = math.pi * D * 3000.0 / 60.0
    assert cut.process_damping_per_depth([3000.0])[0] == pytest.approx(2e4 / v, rel=1e-15)
    assert cut.scaled_kt(2.0).process_damping == 2e4 and cut.scaled_kt(2.0).diameter == D
    assert not cut.without_process_damping().has_process_damping
    # the averaged contact matrix (N/2π)∫ n nᵀ dφ: slotting with 4 teeth is the identity, and any cut's
    # trace is the number of teeth in the cut on average, N (φex − φst) / 2π
    np.testing.assert_allclose(pd.mean_contact(cut), np.eye(2), atol=1e-15)
    half = Cutting.from_immersion(3, KT, KR, 0.5, "down")
    assert np.trace(pd.mean_contact(half)) == pytest.approx(3 * (half.exit - half.entry) / (2 * math.pi))


def test_step_contact_is_the_identity_in_four_tooth_slotting():
    """The semi-discretization's step averages of Σ g n nᵀ: exactly I at every step for four teeth in
    slotting (why the closed form below holds), and for a half-immersion cut their time average is the
    closed-form mean (N/2π)∫ n nᵀ dφ."""
    h, cut, _, pbar = sdm.step_matrices(slot4(), 3000.0, 40, contact=True)
    assert cut.all()
    np.testing.assert_allclose(pbar, np.broadcast_to(np.eye(2), pbar.shape), atol=1e-13)
    half = Cutting.from_immersion(3, KT, KR, 0.5, "down")
    h, cut, _, pbar = sdm.step_matrices(half, 3000.0, 60, contact=True)
    np.testing.assert_allclose(np.einsum("i,ijk->jk", h, pbar) / h.sum(), pd.mean_contact(half), atol=1e-12)


def test_engines_without_process_damping_refuse_it_naming_those_that_carry_it():
    cut = slot4(2e4)
    batch = ModalBatch.from_structures([ONE])
    for call in (lambda: zoa.envelope(ONE, cut, [3000.0]), lambda: zoa.envelope_batch(batch, cut, [3000.0]),
                 lambda: spectral.envelope_batch(batch, cut, [3000.0]),
                 lambda: Forward(Parameterization(ONE, ("fn_x",)), cut, "zoa")):
        with pytest.raises(InputError) as exc:
            call()
        assert exc.value.field == "cutting.process_damping" and "sdm" in str(exc.value)
    assert sdm.process_damping and not zoa.process_damping and not spectral.process_damping
    Forward(Parameterization(ONE, ("fn_x",)), cut, "sdm")  # carried: no error


_CONFIG = """
[cutting]
teeth = 4
kt = "600 MPa"
kr = 0.3
radial_immersion = 1
process_damping = "0.02 N/um"
diameter = "16 mm"

[[structure.x]]
fn = "922 Hz"
k = "1.34 N/um"
zeta = 0.011
"""


def test_config_reads_process_damping_and_diameter_with_units():
    text = _CONFIG
    cfg = parse_config(text)
    assert cfg.cutting.process_damping == pytest.approx(2e4) and cfg.cutting.diameter == pytest.approx(0.016)
    with pytest.raises(InputError) as exc:
        parse_config(text.replace('diameter = "16 mm"\n', ""))
    assert exc.value.field == "cutting.diameter"


def test_a_face_mill_diameter_is_taken_and_mm_written_as_m_is_refused_once(recwarn):
    """[cutting] diameter is any milling tool's, a face mill's 250 mm too (it was refused over a [tool] beam's 0.2 m:
    'is 0.25 m, ...: did you mean "0.25 mm"?'); a plain 16 (mm written as m) is one error, no warning before it."""
    cfg = parse_config(_CONFIG.replace('diameter = "16 mm"', 'diameter = "250 mm"'))
    assert cfg.cutting.diameter == pytest.approx(0.25) and cfg.diameter_m == pytest.approx(0.25)
    recwarn.clear()
    with pytest.raises(InputError) as exc:
        parse_config(_CONFIG.replace('diameter = "16 mm"', "diameter = 16"))
    assert str(exc.value) == ("cutting.diameter = 16 is invalid: is 16 m, more than 2 m for a tool's diameter; a "
                              'plain number means metres: did you mean "16 mm"?')
    assert not [w for w in recwarn if "diameter" in str(w.message)]


def test_process_damping_survives_the_written_forms():
    """A config written back, a fit's cutting record and a prior's JSON keep C and the diameter."""
    from millstab.identify.result import _cutting, cutting_difference, cutting_record
    from millstab.io.config import config_to_toml
    from millstab.update.prior import Prior, make_prior

    cfg = parse_config(_CONFIG)
    again = parse_config(config_to_toml(cfg))
    assert again.cutting == cfg.cutting and again.cutting.process_damping == pytest.approx(2e4)
    assert _cutting(cutting_record(cfg.cutting), "fit") == cfg.cutting
    assert cutting_difference(cutting_record(cfg.cutting), cfg.cutting) is None
    assert "process_damping" in cutting_difference(cutting_record(cfg.cutting), cfg.cutting.without_process_damping())
    assert "process_damping" in cutting_difference(cutting_record(cfg.cutting.without_process_damping()), cfg.cutting)
    assert cutting_record(Cutting(4, KT, KR)) == {"teeth": 4, "kt": KT, "kr": KR, "entry": 0.0, "exit": math.pi}
    prior = make_prior(cfg.structure, cfg.cutting)
    assert Prior.from_dict(json.loads(json.dumps(prior.to_dict()))).cutting == cfg.cutting


# --- the semi-discretization engine ---------------------------------------------------------------


def test_zero_process_damping_is_bit_identical():
    """C = 0 takes no new arithmetic: the same bits as a cutting without the field (and, checked when
    the term was added, as the engine before it: 12 envelopes and ρ maps, 1- and 3-mode, slotting and
    a/D = 0.1, default and 40 steps)."""
    rpm = np.array([5000.0, 7000.0, 12000.0])  # (3 000 rpm cost 25 s here: the bits do not depend on the speed)
    a = sdm.envelope(TWO, Cutting.from_immersion(3, KT, KR, 0.5, "down"), rpm).depth
    b = sdm.envelope(TWO, Cutting.from_immersion(3, KT, KR, 0.5, "down", process_damping=0.0, diameter=D), rpm).depth
    assert np.array_equal(a, b)


@pytest.mark.parametrize("c", [0.0, 3e4])
def test_sdm_matches_the_closed_form_of_time_invariant_slotting(c):
    """Four teeth in slotting, one mode in x: the engine (time-periodic machinery throughout) against the
    quadratic closed form of the constant-coefficient delay equation, within 1e-3 (measured ≤ 3.4e-4).
    With the term, 1 460 rpm has a limit 9.6× the undamped one (the bracket grid beyond 3 b_ref) and at
    1 420 rpm no depth is unstable (inf in both)."""
    cut = slot4(c)
    rpm = np.array([1500.0, 3000.0, 9000.0, 15000.0] + ([1420.0, 1460.0] if c else []))
    got = sdm.envelope(ONE, cut, rpm).depth
    want = [closed_form_limit(ONE.x[0], KT, KR, float(cut.process_damping_per_depth(r)), r) for r in rpm]
    np.testing.assert_allclose(got, want, rtol=1e-3)


def test_limit_equals_the_limit_of_the_equivalently_damped_structure():
    """At b_lim the process damping is the viscous c_pd = C b_lim / V (times N/4 = 1 here); the structure
    with ζ raised by c_pd / (2 m ωn) and no process damping has its own limit at that same depth."""
    cut = slot4(3e4)
    rpm = np.array([2000.0, 6000.0, 14000.0])
    b = sdm.envelope(ONE, cut, rpm).depth
    for r, bl in zip(rpm, b):
        c_pd = pd.equivalent_damping(cut, r, bl)[0, 0]
        mode = ONE.x[0]
        raised = Structure(x=(Mode(mode.fn, mode.k, mode.zeta + c_pd / (2 * mode.mass * mode.omega)),))
        b2 = sdm.envelope(raised, slot4(0.0), [r]).depth[0]
        assert b2 == pytest.approx(bl, rel=3e-4)


def test_gain_scales_as_one_over_cutting_speed_and_vanishes_at_high_speed():
    """At a fixed spindle speed (the lobes fixed) the cutting speed is set by the diameter: the gain
    b_pd / b_0 − 1 doubles when V halves (small gains: linear in C/V), grows as V falls, and → 0 as V → ∞."""
    cut = Cutting.from_immersion(3, KT, KR, 0.5, "down")
    rpm = [4000.0]
    b0 = sdm.envelope(TWO, cut, rpm).depth[0]
    gain = []
    for d in (0.5, 0.25, 0.125, 0.0625):
        c = Cutting.from_immersion(3, KT, KR, 0.5, "down", process_damping=2e3, diameter=d)
        gain.append(sdm.envelope(TWO, c, rpm).depth[0] / b0 - 1.0)
    gain = np.array(gain)
    assert np.all(np.diff(gain) > 0) and gain[0] > 0
    np.testing.assert_allclose(gain[1:] / gain[:-1], 2.0, rtol=0.1)
    assert gain[0] < 0.02  # V = 105 m/s: the term is negligible at high cutting speed


@pytest.mark.slow
def test_low_speed_limits_rise_above_the_undamped_ones():
    """Over a speed range the undamped lobes are the floor, and the gain is largest at the lowest speeds."""
    rpm = np.array([1500.0, 3000.0, 6000.0, 12000.0, 24000.0])
    half = Cutting.from_immersion(3, KT, KR, 0.5, "down", diameter=D)
    b0 = sdm.envelope(TWO, half, rpm).depth
    b = sdm.envelope(TWO, Cutting.from_immersion(3, KT, KR, 0.5, "down", process_damping=2e4, diameter=D), rpm).depth
    gain = b / b0  # measured: 1.90, 1.11, 1.09, 1.08, 1.02
    assert np.all(gain > 1.0) and np.all(np.diff(gain) < 0)
    assert gain[0] > 1.5 and gain[-1] < 1.05


# --- the time-domain simulation -------------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("rpm", [1500.0, 12000.0])
def test_simulation_agrees_with_sdm_at_ten_percent(rpm):
    """The nonlinear simulation (process damping instantaneous per tooth in contact) is stable 10 % below
    the SDM limit and unstable 10 % above, at a low speed (gain ×1.9 over the undamped limit) and a high
    one; its once-per-tooth multiplier at the limit is 1 within 2e-3."""
    from millstab.simulate import detect, simulate_cut
    from millstab.simulate.boundary import multiplier

    cut = Cutting.from_immersion(3, KT, KR, 0.5, "down", process_damping=2e4, diameter=D)
    b = sdm.envelope(TWO, cut, [rpm]).depth[0]
    assert abs(multiplier(TWO, cut, rpm, 0.9 * b)) < 1.0 < abs(multiplier(TWO, cut, rpm, 1.1 * b))
    assert abs(abs(multiplier(TWO, cut, rpm, b)) - 1.0) < 2e-3
    assert detect(simulate_cut(TWO, cut, rpm, 0.9 * b, 1e-4)).label == "stable"
    assert detect(simulate_cut(TWO, cut, rpm, 1.1 * b, 1e-4, revs=200)).label != "stable"


def test_simulation_without_process_damping_is_unchanged_bit_for_bit():
    from millstab.simulate import simulate_cut

    a = simulate_cut(TWO, Cutting.from_immersion(3, KT, KR, 0.5, "down"), 5000.0, 2e-4, 1e-4, revs=5)
    b = simulate_cut(TWO, Cutting.from_immersion(3, KT, KR, 0.5, "down", process_damping=0.0, diameter=D), 5000.0,
                     2e-4, 1e-4, revs=5)
    assert np.array_equal(a.x, b.x) and np.array_equal(a.fy, b.fy)


def test_label_cuts_carries_process_damping_like_single_cuts():
    """The parallel labeller passes each cut's C b / V to its start and its steps: the same growth, bit
    for bit, as the single cuts, stable below and chatter above the SDM limit at 12 000 rpm."""
    from millstab.simulate import detect, label_cuts, simulate_cut

    cut = Cutting.from_immersion(3, KT, KR, 0.5, "down", process_damping=2e4, diameter=D)
    b = sdm.envelope(TWO, cut, [12000.0]).depth[0]
    depths = np.array([0.7, 1.4]) * b
    lab = label_cuts(TWO, cut, 12000.0, depths, 1e-4, revs=60)
    single = [detect(simulate_cut(TWO, cut, 12000.0, d, 1e-4, revs=60)) for d in depths]
    assert list(lab.true_label) == ["stable", "chatter"] == [s.label for s in single]
    assert np.array_equal(lab.growth, [s.growth for s in single])


def test_simulated_steady_start_is_periodic_with_process_damping():
    """The damped steady start is the T-periodic motion of the unregenerated cut: a stable cut started
    there has (almost) no transient: tooth-to-tooth changes ≤ 1e-3 f_t from the first period."""
    from millstab.simulate import simulate_cut

    cut = Cutting.from_immersion(3, KT, KR, 0.5, "down", process_damping=2e4, diameter=D)
    res = simulate_cut(TWO, cut, 1500.0, 3e-4, 1e-4, revs=3, perturbation=0.0)
    d = np.hypot(np.diff(res.once_x), np.diff(res.once_y))
    assert d.max() < 1e-3 * 1e-4


def test_an_update_of_a_process_damping_config_screens_without_the_term():
    """An update with the engine that models process damping (sdm) is screened by the zero-order engine, which does
    not: the screen reads the same prior and data without the term (it refused the update before), and an engine
    that carries it, or data without it, read them unchanged."""
    from millstab.update import Evidence, make_prior, screen_model
    from millstab.update.likelihood import Likelihood, limits

    cut = Cutting.from_immersion(4, KT, KR, 0.5, "down", process_damping=2e4, diameter=D)
    prior = make_prior(TWO, cut)
    up = Cutting.from_immersion(4, KT, KR, 0.25, "up", process_damping=2e4, diameter=D)
    ev = Evidence(np.array([3000.0, 4000.0]), np.array([2.0, 5.0]), np.array([0, 1]), np.ones(2),
                  np.full(2, np.nan), np.zeros(0), np.zeros(0), np.zeros(0), cut_cond=np.array([0, 1]),
                  conditions=(cut, up))
    p2, e2 = screen_model(prior, ev, "zoa")
    assert p2.cutting == cut.without_process_damping() and not p2.cutting.has_process_damping
    assert e2.conditions == (cut.without_process_damping(), up.without_process_damping())
    np.testing.assert_array_equal(p2.median, prior.median)
    u = prior.sample(4, np.random.default_rng(0))
    want = np.array([limits(p2, u, [3000.0], "zoa")[0][:, 0], limits(p2, u, [4000.0], "zoa", conditions=up
                                                                      .without_process_damping())[0][:, 0]]).T
    lik = Likelihood(p2, e2, "zoa")  # built without the refusal; its limits are the plain zero-order ones
    np.testing.assert_array_equal(lik.depths(u)[1], want)
    assert screen_model(prior, ev, "sdm") == (prior, ev)
    plain = make_prior(TWO, cut.without_process_damping())
    ev0 = replace(ev, conditions=(cut.without_process_damping(), up.without_process_damping()))
    assert screen_model(plain, ev0, "zoa") == (plain, ev0)
    with pytest.raises(InputError, match="process_damping"):
        Likelihood(prior, ev, "zoa")  # what the update met before
