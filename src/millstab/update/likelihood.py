"""The likelihood of labelled test cuts (and boundary points) given the modal parameters.

For a cut at speed Ω and depth b with limiting depth b_lim(Ω; θ) (one batched engine call for all
samples, :func:`limits`) and depth noise σ_b:

* chatter: P = Φ(z), stable: P = Φ(−z), z = (b − b_lim)/σ_b (a probit boundary: a label is nearly
  certain far from the limit and a coin toss on it);
* marginal: half a chatter and half a stable observation, L = Φ(z)^½ Φ(−z)^½. Why this and not a
  narrow Gaussian at b_lim: "marginal" says the cut is near the limit without saying on which side;
  the half/half form is largest at b = b_lim, falls off with the same σ_b scale as the other labels
  (so one noise level serves all three), and carries at most one cut's worth of evidence, so a shop's
  loosely used "marginal" cannot pin the limit harder than a bracketing pair of cuts would;
* label error ε (``[prior] label_error``, default :data:`DEFAULT_LABEL_ERROR`): a shop writes the
  opposite label now and then (a microphone's false alarm, a swapped row), so the label is a
  mixture, P(chatter label) = (1 − ε)·Φ(z) + ε·Φ(−z) = ε + (1 − 2ε)·Φ(z): the probit label, swapped
  with probability ε. Why the swap form and not ε/2 + (1 − ε)·Φ(z) (a random label with probability
  ε): the two are the same family (ε_swap = ε_random/2), and ε as "the probability that a written label
  is wrong" is what a shop can estimate; ε ∈ [0, ½), since at ½ a label says nothing. Without it one
  swapped label far from the limit has likelihood ≈ Φ(−|z|) ≈ 0 for every sample near the truth, so
  the posterior must leave the truth to explain it (or the tempering stalls); with it, a label that
  contradicts a well-supported limit costs at most a factor ε. Marginal cuts use the mixed
  probabilities in their half/half form;
* a measured chatter frequency f_m (chatter or marginal cut): Gaussian in the distance from f_m to
  the nearest member of the family ±f_c + m·f_tp (f_c the limiting lobe's chatter frequency, f_tp =
  N Ω/60 the tooth-passing frequency, m any integer). The vibration of a milling process holds the
  whole family (the tooth-passing modulation), and a microphone's strongest peak may be any member,
  so the nearest-member distance (a max over harmonics instead of a mixture's sum) is used; it is
  informative modulo f_tp only, which is the honest content of one frequency reading. A reader that
  reports the member near the mode (`millstab listen`: the lobe theory's f_c, the strongest in
  displacement) says more: with ``[prior] chatter_hz_alias`` a < 1 the term is the mixture (1 − a)·N(f_m −
  f_c) + a·N(nearest-member distance), the first placing the natural frequency itself, not only the
  lobe's phase (the family's aliases are exactly the lobe-number ambiguity fn ↔ fn·(n + 1)/n, so the
  reading modulo f_tp cannot tell those lobes apart; measured in docs/updating-measured.md, "Chatter frequencies
  on the softer campaigns"); a = 1 is the family term alone, a = 0.1 the default
  (:data:`millstab.update.prior.DEFAULT_CHATTER_HZ_ALIAS`);
* a boundary point (no label): Gaussian in depth, N(b; b_lim, σ_b²);
* a graded label g ∈ [0, 1] (how strongly the written label says chatter: stable 0, marginal ½,
  chatter 1, a probability as written, or the mean over several raters): L = P(chatter label)^g ·
  P(stable label)^(1−g), with the ε-mixed probabilities. For g = 0, ½, 1 this is the stable, marginal
  and chatter likelihood above, bit for bit; in between it is a fractional observation that carries
  one cut's worth of evidence and peaks where P(chatter label) = g. Several raters of one cut are
  averaged into g (by the cuts reader) rather than multiplied as independent labels: they watched
  the same cut, so their labels are not independent observations of the process (two raters saying
  "chatter" of one cut are not two chattering cuts), and their disagreement is itself the information
  that the cut lies near the limit, which the fractional g expresses;
* learned noise levels: the label error ε and a factor s on σ_b are sampled with the parameters
  (:mod:`millstab.update.prior`), one value per sample; they reuse the engine's limits, so they cost
  no engine call.
* a test-day effect (``[prior] batch_effect``, :mod:`millstab.update.batch`): the cuts of day g are
  evaluated at θ·exp(δ_g) on the fn coordinates, δ_g sampled with the parameters; the limits are then
  computed per (day, speed) column, one engine call per day.

Conditions: each cut and boundary point has a condition index (``Evidence.cut_cond``/``pt_cond`` into
``Evidence.conditions``, a tuple of :class:`~millstab.model.Cutting`; default all 0 under the prior's
cutting), and the likelihood evaluates every distinct (speed, condition) column of the data in ONE
engine call (:class:`~millstab.model.Conditions`), so one posterior of the shared parameters (structure,
Kt, Kr) explains cuts at several widths, directions and tools. A free Kt scales every condition's Kt by
the same factor (depths by its inverse: one factor per sample for all columns); a free Kr replaces every
condition's Kr (a property of the tool and material). The tooth-passing frequency of a chatter-frequency
reading is the cut's own condition's N·Ω/60.

Support: rows of u outside the prior's support (ζ ≥ 1, …: :meth:`Prior.in_support`) get log L = −inf
and never reach the engine, so a proposal there is rejected instead of failing the model's checks.

Units: rpm, mm, Hz at this module's interface; the engines work in m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import log_ndtr, ndtri

from millstab.errors import InputError
from millstab.forward import Forward, Pinned, forward
from millstab.model import Conditions, Cutting, condition_index
from millstab.points import PointSet, cut_conditions, same_condition
from millstab.stability import check_rpm, get_engine, per_set_kr, per_set_process_damping
from millstab.update.batch import BatchEffect
from millstab.update.prior import PD, Prior
from millstab.warnlog import warn

_LOG_SQRT_2PI = 0.5 * math.log(2 * math.pi)
#: the engines' discretisation for the updating loop and its decisions (:class:`millstab.forward.Forward`'s
#: ``purpose``): the likelihood compares limits with a depth noise σ_b of several %, so the spectral engine's
#: converged node count serves (issue 28; measured within 0.03 σ_b of a reference 6 nodes finer on 100 prior
#: samples, 1.6× cheaper per depth than a fit's count, benchmarks/bench_spectral_nodes.py; the 300-sample
#: update of docs/updating.md 1.34× less CPU with 300 samples, 1.12× with 1 000, the posterior means within
#: 0.022 sd)
SAMPLING = "sample"
#: the speed columns :meth:`Likelihood.bounded` evaluates per round before the rest (the costliest first)
BOUND_ROUNDS = (2, 3)
#: a censored limit's largest effect on one cut's log-likelihood term, per unit weight (:meth:`Likelihood.ceilings`):
#: far below float resolution of a log-likelihood of order 1–100 (an ulp there is 2e-16–1.4e-14)
CENSOR_TOL = 1e-15
#: a censored term the same to the last bit (:meth:`Likelihood.saturation_depths` ``bits``): Φ(−k) ≤ this ×
#: ε min(|ln ε|, 1), a change below half an ulp of the saturated value (2⁻⁵⁴ of it) with a factor 4 to spare
SATURATED_BITS = 2.0 ** -56
#: fewer rows than this go through one call: each round is an engine call with a fixed cost of a few ms (OMP
#: passive); measured on the docs/updating.md case, a 30-sample update (~10 survivors per move) took 1.15× the CPU
#: with rounds, a 300-sample one (~70 per move) 1.05–1.14× less
BOUND_MIN_ROWS = 32


def limits(prior: Prior, u: np.ndarray, rpm: np.ndarray, engine: str = "zoa",
           with_freq: bool = False, client=None,
           conditions: Conditions | Cutting | None = None,
           fwd: Forward | None = None, options: dict | None = None,
           ceiling_mm: np.ndarray | None = None,
           floor_mm: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """The one forward function: limiting depths (B, S) [mm] (and chatter frequencies (B, S) [Hz]).

    ONE batched engine call for all B samples u = ln θ (B, P) at the S speeds [rpm], column s under
    ``conditions`` s (a :class:`~millstab.model.Conditions`; ``None``: the prior's cutting for all); a free
    Kt scales the depths exactly and a free Kr goes to the engine per sample (see
    :mod:`millstab.update.prior`). ``inf`` where no boundary exists. Frequencies come only from an engine
    declaring ``reports_chatter_frequency`` (else ``None``). ``client``: a ``distributed.Client``; the
    rows go to its cluster where that pays (same numbers). ``fwd``: the forward model of ``prior`` and
    ``engine`` whose discretisation to use (``purpose`` :data:`SAMPLING`; a :class:`Likelihood` holds one, so
    the engine's settings are chosen once per speed list for a whole update); default a fresh one. Either
    way the settings are chosen at the parameterization's θ0 (the prior median's structure), not at a
    sample: the same numbers whichever samples share a call. ``options``: the engine's discretisation of a
    fresh model (:func:`millstab.forward.engine_options`; a posterior's
    :attr:`millstab.update.Posterior.engine_options`, the one it was fitted with); ignored with ``fwd``.
    ``ceiling_mm`` (B, S) [mm]: a censored search (:meth:`Likelihood.ceilings`; an engine with ``takes_ceiling`` or
    ``likelihood_ceiling``, one Cutting or per-column conditions, here or on a client's cluster; with frequencies
    ``takes_ceiling`` only, and NaN frequencies where censored or floored): above it a depth is only a certified lower
    bound of the limit. ``floor_mm`` (B, S) [mm]: floors (:meth:`Likelihood.floors`; an engine with ``takes_floor``,
    the same conditions): below it a depth only says that the limit is below it.
    """
    pin = pinned_model(prior, u, rpm, engine, conditions, fwd, options)
    check_engine(prior, engine)
    if client is not None:  # the rule and the split live in millstab.cluster; None: it does not pay, run here
        from millstab.cluster import sample_limits

        out = sample_limits(client, prior, u, rpm, engine, with_freq, conditions, pin, ceiling_mm, floor_mm)
        if out is not None:
            return out
    return sample_depths(pin, prior, u, with_freq, ceiling_mm, floor_mm)


def pinned_model(prior: Prior, u: np.ndarray, rpm: np.ndarray, engine: str = "zoa",
                 conditions: Conditions | Cutting | None = None, fwd: Forward | None = None,
                 options: dict | None = None):
    """The one evaluator of :func:`limits` for the samples u = ln θ: ``fwd`` (default a fresh model, ``purpose``
    :data:`SAMPLING`, with the discretisation ``options``) pinned on their rows
    (:meth:`millstab.forward.Forward.pinned`), its discretisation chosen at θ0 (spectral: ``at=``, whatever ``fwd``
    was asked before) or from the rows (sdm's steps); what a cluster's tasks get too."""
    fwd = forward(prior.par, prior.cutting, engine, SAMPLING, options) if fwd is None else fwd
    return fwd.pinned(check_rpm(rpm), prior.split(u)[0], conditions, at=fwd.par.theta0)  # settings: at θ0


def sample_depths(pin, prior: Prior, u: np.ndarray, with_freq: bool = False,
                  ceiling_mm: np.ndarray | None = None,
                  floor_mm: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """Depths (B, S) [mm] (and chatter frequencies [Hz] or None) of samples u = ln θ by the pinned forward model
    ``pin`` (:func:`pinned_model`): a free Kt's exact factor, a free Kr and a free process-damping C per row; here
    and in a cluster's task (:func:`millstab.cluster.sample_limits`). ``ceiling_mm``, ``floor_mm``: as :func:`limits`
    (with frequencies only for an engine whose ``envelope_batch_hz`` takes them: ``takes_ceiling``)."""
    theta, factor = prior.split(u)
    kr, pd = prior.kr_of(u), prior.pd_of(u)
    extra = {}  # the engine's depths are the likelihood's / (1e3 · factor)
    if ceiling_mm is not None:
        extra["ceiling"] = np.asarray(ceiling_mm, float) / (1e3 * factor[:, None])
    if floor_mm is not None:
        extra["floor"] = np.asarray(floor_mm, float) / (1e3 * factor[:, None])
    if with_freq and pin.reports_frequency:
        depth, hz = pin.with_frequency(theta, kr, process_damping=pd, **extra)
    else:
        depth, hz = pin(theta, kr, process_damping=pd, **extra), None
    return depth * 1e3 * factor[:, None], hz


def stickout_groups(prior: Prior, column_stickout: np.ndarray) -> list[tuple[Prior, np.ndarray]]:
    """[(the prior at a stickout, its columns)] for columns with stickouts [m] (NaN: the prior's own): one
    group of every column when none is given. InputError when a stickout is given and the prior's
    parameterization has none (a prior over the tip's modes, not over the holder's)."""
    so = np.asarray(column_stickout, dtype=float)
    given = ~np.isnan(so)
    if not given.any():
        return [(prior, np.arange(so.size))]
    at = getattr(prior.par, "at", None)
    if at is None:
        from millstab.update.stickout import not_over_holder

        raise not_over_holder(so)
    own = prior.par.stickout
    so = np.where(given, so, own)
    from dataclasses import replace

    return [(prior if s == own else replace(prior, par=at(float(s))), np.flatnonzero(so == s)) for s in np.unique(so)]


def limits_by_condition(prior: Prior, u: np.ndarray, rpm: np.ndarray, column_cond: np.ndarray | None,
                        conditions: tuple | None, engine: str = "zoa", with_freq: bool = False,
                        client=None, options: dict | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """:func:`limits` where speed column s is cut under ``conditions[column_cond[s]]`` (a
    :class:`~millstab.model.Cutting` per distinct condition); ``conditions`` None: every column in
    ``prior.cutting``. ONE engine call (:class:`~millstab.model.Conditions`); ``options``: as :func:`limits`."""
    if conditions is None:
        return limits(prior, u, rpm, engine, with_freq, client, options=options)
    cc = np.zeros(np.size(rpm), dtype=np.int64) if column_cond is None else np.asarray(column_cond, dtype=np.int64)
    if np.all(cc == cc[0] if cc.size else True) and cc.size and conditions[int(cc[0])] == prior.cutting:
        return limits(prior, u, rpm, engine, with_freq, client, options=options)  # the plain one-condition path
    return limits(prior, u, rpm, engine, with_freq, client, Conditions.of(tuple(conditions), cc), options=options)


def _engines_with(capability) -> list[str]:
    """The registered engines for which ``capability(engine)`` holds (:func:`per_set_kr`, ...)."""
    from millstab.stability import ENGINES

    return [e for e in ENGINES if capability(get_engine(e))]


def check_engine(prior: Prior, engine: str):
    """The engine named ``engine``; InputError when the prior frees Kr and the engine takes one Kr per call, or frees
    the process-damping C and the engine takes no C per parameter set."""
    eng = get_engine(engine)
    if prior.kr_free and not per_set_kr(eng):
        have = ", ".join(_engines_with(per_set_kr))
        raise InputError("prior.kr", f"{prior.spread[prior.names.index('kr')]:.3g} with the {engine} engine",
                         f"the {engine} engine takes one Kr per call, so Kr cannot be learned with it: use an engine "
                         f"with a Kr per parameter set ({have}), or remove prior.kr to hold Kr")
    if prior.pd_learned and not per_set_process_damping(eng):
        have = ", ".join(_engines_with(per_set_process_damping))
        raise InputError("prior.process_damping", f"{prior.spread[prior.names.index(PD)]:.3g} with the {engine} engine",
                         f"the {engine} engine takes no process-damping coefficient per parameter set, so C cannot be "
                         f"learned with it: use {have} (--engine), or remove prior.process_damping to hold C")
    return eng


#: how far a chattering cut's frequency drifts from the boundary's chatter frequency f_c, relative to f_c, per unit of
#: x = ln(cut depth / limit): a cut deeper than its limit chatters at its own fastest-growing (and, with the teeth
#: leaving the cut, saturated) vibration, not at the boundary's. Measured on the virtual shop
#: (``benchmarks/bench_chatter_drift.py``, 1 082 chattering cuts of four tools in seven conditions, x uniform in
#: [0, 2]): median |f_m − f_c| / f_c 0.33 %, 0.92 %, 1.4 %, 1.7 %, 2.1 % in bins of x 0.4 wide; the rms slope of the
#: readings within 5 % is 0.0161 (0.017 was fitted on a first version of the benchmark that measured the distance
#: to the members within ±6 f_tp only, a little larger; kept: slightly wide). With the boundary's σ alone (20 Hz)
#: the readings of deep cuts (80–480 Hz off at 3.8 kHz) pulled a posterior confidently away from the truth:
#: docs/updating.md, "Chatter frequencies of deep cuts"
FREQ_DRIFT = 0.017
#: the share of readings of another vibration (another mode or lobe: beyond 5 % of f_c, 5 % of the readings at x < 0.4
#: and 23 % at x 1.6–2, same benchmark; this model's share is 0.27 at x = 1.8): FREQ_OUTLIER[0] + FREQ_OUTLIER[1]·x, at
#: most FREQ_OUTLIER[2]; such a reading is anywhere in one tooth-passing band (density 1/f_tp), so it costs a bounded
#: log-likelihood
FREQ_OUTLIER = (0.05, 0.12, 0.3)


def frequency_spread(sigma_hz: float, measured_hz: np.ndarray, cut_depth_mm: np.ndarray, limit_mm: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """(σ [Hz], outlier share) of chatter-frequency readings (B, J): σ = hypot(``sigma_hz``, FREQ_DRIFT·f_m·x) and the
    share FREQ_OUTLIER in x = ln(cut depth / limit) where the cut lies above the limit (x = 0 at or below it, and where
    there is no boundary: a reading there is judged by σ alone). ``measured_hz`` (J,) the readings f_m [Hz] (the drift's
    scale: the reading, not the model's f_c, so that the lobe aliases f_c ± m·f_tp of one limit keep one σ),
    ``cut_depth_mm`` (J,), ``limit_mm`` (B, J) [mm]."""
    with np.errstate(divide="ignore", invalid="ignore"):
        x = np.log(np.asarray(cut_depth_mm, float) / np.asarray(limit_mm, float))
    x = np.where(np.isfinite(x) & (x > 0), x, 0.0)
    o0, o1, o_max = FREQ_OUTLIER
    return np.hypot(sigma_hz, FREQ_DRIFT * np.abs(np.asarray(measured_hz, float)) * x), np.minimum(o0 + o1 * x, o_max)


def frequency_distance(measured_hz: np.ndarray, predicted_hz: np.ndarray, tooth_hz: np.ndarray) -> np.ndarray:
    """Distance [Hz] from a measured frequency to the nearest of ±f_c + m·f_tp (m integer).

    Broadcasts; a NaN prediction (no boundary) gives the largest possible distance, f_tp/2.
    """
    fc = np.where(np.isfinite(predicted_hz), predicted_hz, 0.5 * tooth_hz)
    r1 = np.mod(measured_hz - fc, tooth_hz)
    r2 = np.mod(measured_hz + fc, tooth_hz)
    d = np.minimum(np.minimum(r1, tooth_hz - r1), np.minimum(r2, tooth_hz - r2))
    return np.where(np.isfinite(predicted_hz), d, 0.5 * tooth_hz)


_KIND = {"stable": 0, "chatter": 1, "marginal": 2}
_KIND_GRADE = np.array([0.0, 1.0, 0.5])


def cut_loglik(z: np.ndarray, kind: np.ndarray | None = None, label_error=0.0,
               grade: np.ndarray | None = None) -> np.ndarray:
    """Log-likelihood of each cut's label from z = (b − b_lim)/σ_b: g·log P(chatter label) + (1 − g)·log
    P(stable label), the grade g from ``grade`` or else from ``kind`` (0 stable, 1 chatter, 2 marginal:
    g = 0, 1, ½); ``label_error`` ε ∈ [0, ½) (a number, or an array broadcasting with z, e.g. (B, 1) per
    sample): the probability that a label is swapped (see the module docstring)."""
    up, down = log_ndtr(z), log_ndtr(-z)
    eps = np.asarray(label_error, dtype=float)
    if (eps > 0).any():  # log((1 − ε)Φ(±z) + εΦ(∓z)) without cancellation in either tail
        if eps.ndim == 0:  # the libm logs of a held ε (the numbers of earlier versions, to the last bit)
            a, b = math.log1p(-float(eps)), math.log(float(eps))
        else:
            with np.errstate(divide="ignore"):
                a, b = np.log1p(-eps), np.log(eps)
        up, down = np.logaddexp(a + up, b + down), np.logaddexp(a + down, b + up)
    g = _KIND_GRADE[np.asarray(kind)] if grade is None else np.asarray(grade, dtype=float)
    # g = 0 and 1 pick one term (0·(−∞) would be NaN where a label is impossible); ½ is 0.5·(up + down) exactly
    return np.where(g == 1, up, np.where(g == 0, down, g * up + (1 - g) * down))


@dataclass(frozen=True, eq=False)
class Evidence:
    """The data of one update: labelled cuts and boundary points (rpm, mm, Hz; NaN = no frequency).

    ``cut_cond``/``pt_cond``: each row's index into ``conditions`` (a tuple of :class:`Cutting`), default all 0;
    ``conditions`` ``None`` means the prior's cutting (one condition). InputError for an index out of range or
    a count other than one per row. :meth:`columns` gives the distinct (speed, condition) engine columns."""

    cut_rpm: np.ndarray
    cut_depth_mm: np.ndarray
    cut_kind: np.ndarray
    cut_weight: np.ndarray
    cut_hz: np.ndarray
    pt_rpm: np.ndarray
    pt_depth_mm: np.ndarray
    pt_weight: np.ndarray
    cut_grade: np.ndarray | None = None  # graded labels in [0, 1]; None: from cut_kind
    cut_batch: np.ndarray | None = None  # the test day of each cut ("" none); None: all ""
    cut_cond: np.ndarray | None = None  # each cut's index into ``conditions``; None: all 0
    pt_cond: np.ndarray | None = None  # each boundary point's index into ``conditions``; None: all 0
    #: the cutting conditions the indices point into; None: the prior's cutting (one condition)
    conditions: tuple[Cutting, ...] | None = None
    #: each cut's / boundary point's tool stickout [m] (NaN: the config's); None: all the config's. Only a
    #: prior over the holder (:mod:`millstab.update.stickout`) takes stickouts
    cut_stickout: np.ndarray | None = None
    pt_stickout: np.ndarray | None = None

    def __post_init__(self):
        if self.cut_grade is None:
            object.__setattr__(self, "cut_grade", _KIND_GRADE[np.asarray(self.cut_kind, dtype=np.int64)])
        if self.cut_batch is None:
            object.__setattr__(self, "cut_batch", np.full(np.size(self.cut_rpm), "", dtype=object))
        n_cond = 1 if self.conditions is None else len(Conditions.of(self.conditions).cuttings)
        if self.conditions is not None:
            object.__setattr__(self, "conditions", tuple(self.conditions))
        for name, rpm in (("cut_cond", self.cut_rpm), ("pt_cond", self.pt_rpm)):
            idx = getattr(self, name)
            idx = np.zeros(np.size(rpm), dtype=np.int64) if idx is None else np.asarray(idx)
            if idx.shape != (np.size(rpm),):
                raise InputError(name, f"{idx.size} values", f"one condition index per row ({np.size(rpm)})")
            object.__setattr__(self, name, condition_index(idx, n_cond, name))
        for name, rpm in (("cut_stickout", self.cut_rpm), ("pt_stickout", self.pt_rpm)):
            v = getattr(self, name)
            v = np.full(np.size(rpm), np.nan) if v is None else np.asarray(v, dtype=float)
            if v.shape != (np.size(rpm),):
                raise InputError(name, f"{v.size} values", f"one stickout per row ({np.size(rpm)})")
            bad = ~np.isnan(v) & ~((v > 0) & (v <= 1.0))
            if bad.any():
                raise InputError(name, float(v[bad][0]), "a stickout in m, > 0 and under 1 m (mm written as m?)")
            object.__setattr__(self, name, v)

    @classmethod
    def from_points(cls, cuts: PointSet, points: PointSet | None = None, stickout: np.ndarray | None = None,
                    base_cutting=None, diameter_mm: float | None = None) -> Evidence:
        """Split a cuts file (labelled rows; unlabelled rows are boundary points) and an optional
        boundary-point file into evidence; ``stickout``: the tool's stickout [m] of each row of ``cuts``
        (NaN: the config's; the rows of ``points`` are at the config's).

        Per-cut conditions (the files' condition columns, :func:`millstab.points.cut_conditions`): with
        ``base_cutting`` (the config's cutting, which fills empty cells; ``diameter_mm`` the tool diameter
        for ``radial_width_mm``) the evidence holds ``conditions`` and each row's ``cut_cond``/``pt_cond``;
        without condition columns they are ``None``/zeros (every row in the prior's cutting).

        Raises:
            InputError: neither a stable nor a chatter cut, and no boundary point either; condition
                columns without ``base_cutting``; a bad condition (see :func:`millstab.points.condition_of`).
        Warns:
            UserWarning: every cut has the same label (the answer is valid but leans on the prior).
        """
        pts = [p for p in (cuts, points) if p is not None]
        conditions, idx = None, [np.zeros(len(p), dtype=np.int64) for p in pts]
        if any(p.has_conditions for p in pts):
            if base_cutting is None:
                raise InputError("cuts", "per-cut condition columns", "the config's cutting conditions (base_cutting) "
                                                                      "fill their empty cells: pass them")
            conds: list = []
            idx = []
            for p in pts:  # one list of distinct conditions over both files
                cs, ix = cut_conditions(p, base_cutting, diameter_mm)
                remap = []
                for c in cs:
                    j = next((k for k, o in enumerate(conds) if same_condition(o, c)), None)
                    if j is None:
                        conds.append(c)
                        j = len(conds) - 1
                    remap.append(j)
                idx.append(np.asarray(remap, dtype=np.int64)[ix])
            conditions = tuple(conds)
        labelled = cuts.label != ""
        c = cuts.subset(labelled)
        c_cond = idx[0][labelled]
        p_cond = np.concatenate([ix[p.boundary] for p, ix in zip(pts, idx)])
        if points is not None:
            c_cond = np.r_[c_cond, idx[1][~points.boundary]]
        b_rpm = np.concatenate([p.rpm[p.boundary] for p in pts])
        b_depth = np.concatenate([p.depth_mm[p.boundary] for p in pts])
        b_w = np.concatenate([p.weight[p.boundary] for p in pts])
        if points is not None and (~points.boundary).any():
            extra = points.subset(~points.boundary)
            c = PointSet(np.r_[c.rpm, extra.rpm], np.r_[c.depth_mm, extra.depth_mm], np.r_[c.label, extra.label],
                         np.r_[c.weight, extra.weight], cuts.source, np.r_[c.chatter_hz, extra.chatter_hz],
                         np.r_[c.grade, extra.grade], np.r_[c.batch, extra.batch])
        n_st, n_ch = int(c.stable.sum()), int(c.chatter.sum())
        where = f" in {cuts.source.name}" if cuts.source is not None else ""
        if n_st == 0 and n_ch == 0 and b_rpm.size == 0:
            raise InputError("cuts", f"{int(c.marginal.sum())} marginal and no stable or chatter cut{where}",
                             "updating needs at least one cut labelled stable or chatter (or boundary points)")
        if b_rpm.size == 0 and (n_st == 0 or n_ch == 0) and not c.marginal.any():  # a marginal cut is at the limit
            only = "stable" if n_ch == 0 else "chatter"
            side = "from below" if only == "stable" else "from above"
            warn(f"every cut{where} is {only}: the data bound the limit {side} only, so the posterior "
                 "and the P(stable) map lean on the prior; add a cut on the other side", UserWarning, stacklevel=2)
        kind = np.array([_KIND[s] for s in c.label], dtype=np.int64)
        grade = np.asarray(c.grade, dtype=float) if c.grade is not None else None
        batch = np.asarray(c.batch, dtype=object) if c.batch is not None else None
        so_c = so_p = None
        if stickout is not None:
            so = np.asarray(stickout, dtype=float)
            if so.shape != (len(cuts.rpm),):
                raise InputError("stickout", f"{so.size} values", f"one per row of the cuts ({len(cuts.rpm)})")
            n_pts = 0 if points is None else int(points.boundary.sum())
            n_extra = 0 if points is None else int((~points.boundary).sum())
            so_c = np.r_[so[labelled], np.full(n_extra, np.nan)]
            so_p = np.r_[so[cuts.boundary], np.full(n_pts, np.nan)]
        return cls(c.rpm, c.depth_mm, kind, c.weight, c.chatter_hz, b_rpm, b_depth, b_w, grade, batch,
                   cut_cond=c_cond, pt_cond=p_cond, conditions=conditions, cut_stickout=so_c, pt_stickout=so_p)

    @property
    def n_cuts(self) -> int:
        return int(self.cut_rpm.size)

    @property
    def speeds(self) -> np.ndarray:
        """Every speed the data mention [rpm] (sorted, unique)."""
        return np.unique(np.concatenate([self.cut_rpm, self.pt_rpm]))

    def columns(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The distinct (speed, condition, stickout) columns of the data: (rpm (S,), condition index (S,),
        each cut's column (n_cuts,), each point's column (n_points,)); sorted by condition, stickout (the
        config's first), then speed. Each column's stickout: :meth:`column_stickouts`."""
        keys, inverse = self._column_keys()
        return keys[:, 2].copy(), keys[:, 0].astype(np.int64), inverse[:self.n_cuts], inverse[self.n_cuts:]

    def column_stickouts(self) -> np.ndarray:
        """The stickout [m] of each column of :meth:`columns` (NaN: the config's)."""
        keys, _ = self._column_keys()
        so = np.concatenate([self.cut_stickout, self.pt_stickout])
        out = np.full(keys.shape[0], np.nan)
        g = keys[:, 1] >= 0
        out[g] = np.unique(so[~np.isnan(so)])[keys[g, 1].astype(int)]
        return out

    def _column_keys(self) -> tuple[np.ndarray, np.ndarray]:
        cond = np.concatenate([self.cut_cond, self.pt_cond])
        rpm = np.concatenate([self.cut_rpm, self.pt_rpm]).astype(float)
        so = np.concatenate([self.cut_stickout, self.pt_stickout])
        code = np.full(so.size, -1.0)  # the config's stickout; then the distinct given ones, ascending
        given = ~np.isnan(so)
        if given.any():
            code[given] = np.unique(so[given], return_inverse=True)[1].ravel()
        keys, inverse = np.unique(np.stack([cond.astype(float), code, rpm], axis=1), axis=0, return_inverse=True)
        return keys, np.asarray(inverse).ravel()


class Likelihood:
    """log p(data | u) for batches u = ln θ (B, P): :meth:`__call__` makes ONE engine call per batch.

    Attributes:
        n_calls, n_sets: engine calls and parameter sets evaluated so far.
    """

    def __init__(self, prior: Prior, evidence: Evidence, engine: str = "zoa", client=None,
                 engine_options: dict | None = None):
        check_engine(prior, engine)  # also a clear error for an unknown name
        self.prior, self.evidence, self.engine, self.client = prior, evidence, engine, client
        ev = evidence
        # the distinct (speed, condition) columns of the data: ONE engine call evaluates them all
        self.speeds, self.column_cond, self._ic, self._ip = ev.columns()
        self.conditions = (prior.cutting,) if ev.conditions is None else ev.conditions
        if prior.kr_free and any(c.kr != prior.cutting.kr for c in self.conditions):
            raise InputError("conditions", "several Kr", f"with Kr free every condition takes the sampled Kr; give "
                             f"each condition the config's Kr ({prior.cutting.kr:g}) or hold Kr")
        if prior.pd_free and any(c.process_damping != prior.cutting.process_damping for c in self.conditions):
            raise InputError("conditions", "several process-damping coefficients",
                             f"with C free every condition takes the sampled C; give each condition the config's C "
                             f"({prior.cutting.process_damping:g} N/m) or hold C")
        # one engine call per stickout group of columns (one group, all columns, without stickouts)
        self._groups = stickout_groups(prior, ev.column_stickouts())
        self._group_conditions = [self._conditions_of(self.column_cond[cols]) for _, cols in self._groups]
        self._sig_c = prior.sigma_depth_mm(ev.cut_depth_mm)
        self._sig_p = prior.sigma_depth_mm(ev.pt_depth_mm)
        hz = np.isfinite(ev.cut_hz)
        if hz.any() and not get_engine(engine).reports_chatter_frequency:
            warn(f"the {engine} engine reports no limiting-lobe chatter frequency in its batched path: the "
                 f"{int(hz.sum())} measured chatter frequencies are not used", UserWarning, stacklevel=2)
            hz = np.zeros_like(hz)
        self._hz = np.flatnonzero(hz)
        teeth = np.array([c.teeth for c in self.conditions], dtype=float)
        self._tooth_hz = teeth[ev.cut_cond] * ev.cut_rpm / 60.0
        # a test-day effect: the limits' columns are (day, column) pairs, each day's at its own shift
        self.batch = BatchEffect.of(prior, ev, self._ic, self._ip)
        if self.batch is not None:
            self._ic, self._ip = self.batch.ic, self.batch.ip
        # one forward model per group, held for the whole update: the engine's discretisation is chosen once
        # per speed list (at θ0, :func:`limits`), so log L is one function of θ in every call (before, the first
        # row of each call chose, and the spectral engine's node count moved between calls: the same θ got
        # depths up to 0.11 % apart, tests/test_spectral_sampling.py)
        # ``engine_options``: the engine's discretisation fixed for the whole update (sdm ``steps``, spectral
        # ``nodes``: millstab.forward.engine_options), over what the engine would choose
        self._forwards = [forward(p.par, p.cutting, engine, SAMPLING, engine_options) for p, _ in self._groups]
        self.options = self._forwards[0].options  # checked (keywords and values) by the forward model
        self.n_calls = 0
        self.n_sets = 0
        # delayed acceptance's bounded second stage (:meth:`bounded`): rows decided early, the (row, column)
        # entries they did not need, each column's log-likelihood cost so far
        self.n_decided = 0
        self.n_entries_saved = 0
        self._column_cost = np.zeros(self.speeds.size)
        # censored limits (:meth:`ceilings`): an engine that takes a ceiling (``takes_ceiling``, or zoa's
        # ``likelihood_ceiling``; per (set, column), so under several conditions too: issue 27; a cluster's tasks get
        # their rows' ceilings and floors: the numbers of a local call), no test-day columns; with chatter frequencies
        # only an engine whose frequency path takes ceilings and floors too (``takes_ceiling``: spectral), and a column
        # holding a reading is exact (its f_c is read at the limit itself)
        eng = get_engine(engine)
        with_hz = not self.uses_frequency or bool(getattr(eng, "takes_ceiling", False))
        self._censor = (bool(getattr(eng, "takes_ceiling", False) or getattr(eng, "likelihood_ceiling", False))
                        and with_hz and self.batch is None)
        # an engine whose limits below a ceiling are the same bits as without one (zoa): ceilings where every term
        # is saturated to the last bit, so log L, and the sampler's particles, are the same bit for bit
        self._censor_bits = bool(getattr(eng, "likelihood_ceiling", False))
        # columns holding a boundary point (a Gaussian term: it never saturates) or a frequency reading: never censored
        self._exact_column = np.zeros(self.speeds.size, bool)
        self._exact_column[self._ip] = True
        self._exact_column[self._ic[self._hz]] = True
        self.n_censored = 0
        # floors (:meth:`floors`): an engine that takes one (``takes_floor``), under the censoring's conditions
        self._floor = self._censor and bool(getattr(eng, "takes_floor", False))
        self.n_floored = 0
        self._column_order = None  # (cut order by column, columns, starts) of :meth:`_per_column`, found at first use

    def _conditions_of(self, column_cond: np.ndarray):
        """The engine's conditions of columns with these condition indices (``None``: the prior's cutting)."""
        used = sorted(set(column_cond.tolist()))
        # one condition, the prior's own: the plain single-Cutting path (the numbers of earlier versions)
        if len(used) == 1 and self.conditions[used[0]] == self.prior.cutting:
            return None
        return Conditions.of(self.conditions, column_cond)

    @property
    def uses_frequency(self) -> bool:
        return self._hz.size > 0

    def ceilings(self, u: np.ndarray, noise: np.ndarray | None) -> np.ndarray | None:
        """Per row of u = ln θ (B, P) (learned noise coordinates ``noise`` (B, Q) or None) and speed column, the depth
        [mm] above which no cut's log-likelihood term at that column changes by more than :data:`CENSOR_TOL` × its
        |weight| (B, S); inf where the column holds a boundary point; None where this likelihood censors nothing.

        Why (issue 28): the spectral engine's search climbs a ladder of depths from below, and a limit far above
        every cut at its speed costs the rungs up to it and its root, though the label likelihood ε + (1 − 2ε)Φ(z),
        z = (b − b_lim)/(s σ_b), no longer moves there: above b + k s σ_b, Φ(z) ≤ Φ(−k). A chatter term log(ε +
        (1 − 2ε)Φ) moves from its floor log ε by at most Φ(z)/ε, a stable term log(1 − ε − (1 − 2ε)Φ) from log(1 −
        ε) by at most 2Φ(z); a graded label g mixes them, so a cut's term moves by at most |w| Φ(z) (g/ε + 2(1 −
        g)), and k per (row, cut) is where that is :data:`CENSOR_TOL` |w| (k = ∞ for a chatter label with ε = 0:
        its term never saturates). The engine then stops the search once every depth up to one at or above the
        column's largest b + k s σ_b is stable (:func:`millstab.stability.spectral.envelope_batch`'s ``ceiling``)
        and returns that depth: both it and the true limit give every term within CENSOR_TOL |w| of its value at
        b_lim = ∞, so log L moves by at most 2 CENSOR_TOL Σ|w| (~1e-14). With an engine whose limits below the
        ceiling are the same bits as without one (zoa's ``likelihood_ceiling``, which returns the ceiling itself above
        it) the ceilings are raised until every term there is saturated to the last bit (:meth:`saturation_depths`'s
        ``bits``, ~0.5–0.9 s σ_b higher): log L is then the same bit for bit, and so is every particle of an update
        (issue 27). Only the log-likelihood reads these depths (:meth:`__call__`, :meth:`bounded`, :meth:`split`);
        the posterior's limits, maps and predictions are computed by :func:`limits` without a ceiling."""
        if not self._censor:
            return None
        top = self.saturation_depths(u, noise, above=True, bits=self._censor_bits)
        cap = self._per_column(top, np.maximum, -np.inf)  # each column's largest over its cuts
        cap[:, self._exact_column] = np.inf
        # no cut and no point at a column cannot happen (the columns are the data's); the margin covers the
        # engine's root brackets (a limit at least the certified depth to 1e-6)
        return np.where(np.isfinite(cap), cap * (1.0 + 1e-5), np.inf)

    def floors(self, u: np.ndarray, noise: np.ndarray | None) -> np.ndarray | None:
        """Per row of u = ln θ (B, P) (learned noise coordinates ``noise`` (B, Q) or None) and speed column, the depth
        [mm] below which every cut's log-likelihood term at that column is the same to the last bit (B, S): the
        smallest of its cuts' :meth:`saturation_depths` (``above=False``, ``bits=True``); 0 (none) where a term never
        saturates (ε = 0) or the column holds a boundary point; None where this likelihood has no floors.

        Why (issue 28): the mirror of :meth:`ceilings`. A limit far below every cut at its speed costs the spectral
        engine its ladder up to it and its root, though no term reads more than "below". The engine tests the exact
        ρ at its ladder's highest rung at or below 0.997 × the floor (:func:`millstab.stability.spectral.
        envelope_batch`'s ``floor``): where that rung is unstable the limit is below it (the search from below would
        stop there), and the rung itself is returned, a depth below the floor, a deterministic function of the row
        (the anchored screen's state, :meth:`depths`, reads it; its ratio to the zero-order limit is the rung's
        ladder factor, a finite positive number). Every term is then the same to the last bit as at the true limit,
        so log L is the same bit for bit (``tests/test_likelihood_floor.py``), and so are the particles of a sampler
        that reads log L only (the plain zero-order screen); the anchored screen also reads the stored depths, so its
        chain differs (its target does not)."""
        if not (self._censor and self._floor):
            return None
        bot = self.saturation_depths(u, noise, above=False, bits=True)
        low = self._per_column(bot, np.minimum, np.inf)  # each column's smallest over its cuts
        low[:, self._exact_column] = 0.0
        return np.where(np.isfinite(low) & (low > 0), low, 0.0)

    def _per_column(self, per_cut: np.ndarray, reduce: np.ufunc, fill: float) -> np.ndarray:
        """(B, S): ``reduce`` (``np.maximum``, ``np.minimum``) of ``per_cut`` (B, n_cuts) over each speed column's cuts;
        ``fill`` at a column without a cut (:meth:`ceilings`, :meth:`floors`). One ``reduceat`` over the cuts sorted
        by column (~5× ``reduce.at``); the order depends on the data alone, so it is found once."""
        if self._column_order is None:
            order = np.argsort(self._ic, kind="stable")
            self._column_order = (order, *np.unique(self._ic[order], return_index=True))
        order, cols, starts = self._column_order
        out = np.full((per_cut.shape[0], self.speeds.size), fill)
        if cols.size:
            out[:, cols] = reduce.reduceat(per_cut[:, order], starts, axis=1)
        return out

    def saturation_depths(self, u: np.ndarray, noise: np.ndarray | None, above: bool = True,
                          bits: bool = False) -> np.ndarray:
        """Per row of u (B, P) and cut, the depth [mm] beyond which the cut's term moves by at most :data:`CENSOR_TOL`
        × |w| (B, n_cuts): ``above`` b + k s σ_b (a limit above it: :meth:`ceilings`), else b − k s σ_b (a limit
        below it: the mirror, a chatter term's (1 − g) and a stable term's g swapped; ``benchmarks/
        bench_conditions.py --census``). ±inf where a term never saturates (ε = 0 and that label).

        ``bits``: beyond it the term is also the same to the last bit (:data:`SATURATED_BITS`): its part that tends
        to log ε moves by ≤ Φ(−k)(1/ε + 1) and the part that tends to log(1 − ε) by ≤ 2Φ(−k), and a change below half
        an ulp of the value, ≥ 2⁻⁵⁴ |value|, rounds away (log_ndtr, logaddexp and the sums in :func:`cut_loglik`),
        so Φ(−k) ≤ 2⁻⁵⁶ ε min(|ln ε|, 1) (k ≈ 8.9 at ε = 2 % against 8.0–8.4; a held ε = 0: never)."""
        ev = self.evidence
        if noise is None:
            eps, fac = np.full(u.shape[0], float(self.prior.label_error)), np.ones(u.shape[0])
        else:
            eps, fac = self.prior.noise(noise, u.shape[0])
        # k depends on a cut only through its (grade, |weight|): computed per distinct pair (two or three in a
        # campaign instead of one per cut: the ceilings were ~3 µs per set and call, ~8 % of a one-condition engine)
        pairs, inv = np.unique(np.stack([ev.cut_grade, np.abs(ev.cut_weight)]), axis=1, return_inverse=True)
        g, w = pairs[0][None, :], pairs[1][None, :]
        g = g if above else 1.0 - g  # the weight of the part that tends to log ε
        with np.errstate(divide="ignore", invalid="ignore"):
            per = np.where(g > 0, g / eps[:, None], 0.0) + 2.0 * (1.0 - g)  # (B, pairs): Φ(±z)'s factor, per |w|
            p = np.clip(CENSOR_TOL / (w * per), 0.0, 0.5)
            if bits:
                e = eps[:, None]
                far = np.where(g > 0, e * np.abs(np.log(e)), np.inf)  # the part tending to log ε
                near = np.where(g < 1, e, np.inf)  # the part tending to log(1 − ε)
                p = np.minimum(p, SATURATED_BITS * np.minimum(far, near))
        k = -ndtri(p)[:, np.asarray(inv).ravel()]  # p = 0 (ε = 0 and a chatter label): k = ∞
        sign = 1.0 if above else -1.0
        return ev.cut_depth_mm[None, :] + sign * k * fac[:, None] * self._sig_c[None, :]

    def _evaluate(self, u: np.ndarray, cols: np.ndarray | None = None, cap: np.ndarray | None = None,
                  low: np.ndarray | None = None):
        """Limits (B, n) [mm] (and chatter frequencies, or ``None``) of rows u = ln θ (B, P) at the data's
        columns ``cols`` (indices into :attr:`speeds`; default all): one engine call per stickout group
        that has columns among them (one call without stickouts). ``cap`` (B, S) [mm] (:meth:`ceilings`, all
        columns): censored limits; ``low`` (B, S) [mm] (:meth:`floors`, all columns): floored limits."""
        every = cols is None
        cols = np.arange(self.speeds.size) if every else np.asarray(cols, dtype=np.int64)
        where = np.full(self.speeds.size, -1, dtype=np.int64)
        where[cols] = np.arange(cols.size)
        depth = np.empty((u.shape[0], cols.size))
        hz = np.full_like(depth, np.nan) if self.uses_frequency else None
        for (prior, group), cond, fwd in zip(self._groups, self._group_conditions, self._forwards):
            sel = group if every else group[where[group] >= 0]
            if not sel.size:
                continue
            if not every:
                cond = self._conditions_of(self.column_cond[sel])
            d, h = limits(prior, u, self.speeds[sel], self.engine, self.uses_frequency, self.client, cond, fwd,
                          ceiling_mm=None if cap is None else cap[:, sel],
                          floor_mm=None if low is None else low[:, sel])
            self.n_calls += 1
            if cap is not None:
                self.n_censored += int((d >= cap[:, sel]).sum())
            if low is not None:
                self.n_floored += int((d < low[:, sel]).sum())
            depth[:, where[sel]] = d
            if hz is not None and h is not None:
                hz[:, where[sel]] = h
            elif h is None:
                hz = None
        self.n_sets += u.shape[0]
        return depth, hz

    def _parts(self, v: np.ndarray):
        """(v (B, ·) as a float array, u = ln θ (B, P), the noise coordinates (B, Q) or None, in-support (B,)) of
        sampler vectors v: a row is in the support when its u is (:meth:`Prior.in_support`) and every coordinate
        after u is finite."""
        v = np.atleast_2d(np.asarray(v, dtype=float))
        p, q = self.prior.size, self.prior.dim
        u, w = v[:, :p], (v[:, p:q] if v.shape[1] > p and q > p else None)
        return v, u, w, self.prior.in_support(u) & np.isfinite(v[:, p:]).all(axis=1)

    def _limits(self, v: np.ndarray, censor: bool = False):
        """(depths (B, S), freqs, noise coordinates (B, Q) or None, in-support (B,)) of sampler vectors v
        (B, P), (B, P + Q) or, with a test-day effect, (B, P + Q + G) (the days' shifts last; absent: 0);
        rows outside the prior's support do not reach the engine (their limits: 1 mm, a placeholder: the
        callers mask them to −inf). With a test-day effect S is the number of (day, speed) columns.
        ``censor``: censored and floored limits (:meth:`ceilings`, :meth:`floors`) where this likelihood censors: for
        log L only."""
        v, u, w, ok = self._parts(v)
        q = self.prior.dim
        delta = v[:, q:] if self.batch is not None and v.shape[1] > q else None
        cols = self.speeds.size if self.batch is None else self.batch.col_base.size
        depth = np.ones((v.shape[0], cols))  # finite placeholders for the rejected rows (masked to −inf)
        hz = np.full_like(depth, np.nan) if self.uses_frequency else None
        if ok.any():
            def call(uu, cols):
                return self._evaluate(uu, cols)

            if self.batch is None:
                wk = None if w is None else w[ok]
                d, h = self._evaluate(u[ok], cap=self.ceilings(u[ok], wk) if censor else None,
                                      low=self.floors(u[ok], wk) if censor else None)
            else:
                d, h = self.batch.limits(call, u[ok], None if delta is None else delta[ok])
            depth[ok] = d
            if hz is not None and h is not None:
                hz[ok] = h
            elif h is None:
                hz = None
        return depth, hz, w, ok

    def __call__(self, v: np.ndarray) -> np.ndarray:
        """log L (B,) of sampler vectors v = (ln θ, noise coordinates) (B, P [+ Q]); without the noise
        columns the prior's held noise levels are used. −inf outside the prior's support."""
        depth, hz, w, ok = self._limits(v, censor=True)
        return np.where(ok, self.from_limits(depth, hz, noise=w), -np.inf)

    def depths(self, v: np.ndarray, floor: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(log L (B,), the limits it read (B, S) [mm]) of sampler vectors v (as :meth:`__call__`): the anchored
        screen's state (:func:`millstab.update.sampler.tempered_smc`'s ``anchored``: each particle carries its
        limits per data column). ``floor``: :meth:`bounded`'s, and a row it decided early has NaN at the columns it
        did not evaluate; NaN rows outside the prior's support. The limits are :meth:`__call__`'s, censored where it
        censors (:meth:`ceilings`: a censored limit is far above every cut at its speed in both models, so the
        anchored screen's ratio there only keeps a term saturated) and floored where it floors (:meth:`floors`: a
        ladder rung below the floor in place of a limit below it, a function of the row; the screen's ratio there is
        the rung's ladder factor, finite and positive, and keeps a proposal's term near saturation). With chatter
        frequencies the features are (B, 2S): the limits, then each column's chatter frequency [Hz] (NaN where none
        was found or the column was censored or floored: no reading is there), which the anchored screen scales by
        the particle's own accurate / screen ratio as it scales the limits (:func:`millstab.update.sampler.
        anchored_features`: exact at the particle, a model's f_c a smooth function of θ near it)."""
        if floor is not None:  # (with frequencies the bounded stage falls back to the full call: here, floor None)
            return self.bounded(v, floor, depths=True)
        depth, hz, w, ok = self._limits(v, censor=True)
        ll = np.where(ok, self.from_limits(depth, hz, noise=w), -np.inf)
        feat = depth if hz is None else np.hstack([depth, hz])
        return ll, np.where(ok[:, None], feat, np.nan)

    def loglik_at(self, v: np.ndarray, features: np.ndarray) -> np.ndarray:
        """log L (B,) of sampler vectors v (their noise coordinates and support, as :meth:`__call__`) at given features
        instead of the engine's: the limits (B, S) [mm], and with chatter frequencies the frequencies after them
        (B, 2S) [mm, Hz] (:meth:`depths`): the anchored screen's likelihood (no engine call)."""
        _, _, w, ok = self._parts(v)
        features = np.asarray(features, float)
        n_s = features.shape[1] // 2 if self.uses_frequency else features.shape[1]
        depth, hz = features[:, :n_s], (features[:, n_s:] if self.uses_frequency else None)
        with np.errstate(invalid="ignore"):
            return np.where(ok, self.from_limits(np.where(ok[:, None], depth, 1.0), hz, noise=w), -np.inf)

    def bounded(self, v: np.ndarray, floor: np.ndarray, depths: bool = False):
        """log L (B,) of sampler vectors v (as :meth:`__call__`), exact where it may reach ``floor`` (B,); where it
        cannot, a value below ``floor`` (a partial sum, never used as log L): delayed acceptance's second stage
        only asks whether log L clears a threshold (:func:`millstab.update.sampler.tempered_smc`).

        Why (issue 28): 42 % of the proposals that pass the zero-order screen are rejected by the accurate
        engine (docs/updating-measured.md, "Where the accurate update's time goes"), and a rejection is often decided by
        one or two cuts. Each cut's term is a log-probability (≤ 0) and each speed's limit does not depend on the
        other speeds of a call, so the speed columns are evaluated in rounds (:data:`BOUND_ROUNDS`, the columns
        whose cuts cost the most log-likelihood so far first): a row whose partial sum is below the floor by
        more than rounding is decided, and its other columns are never computed. The rows that go on get the
        numbers of :meth:`__call__` (each round keeps the discretisation of a full call on these rows, so a
        column's limit is the one a full call gives, to the root's ~1e-12). Falls back to :meth:`__call__` with
        boundary points, chatter frequencies, a test-day effect or a negative weight (terms not bounded by 0),
        and with a cluster. (Rounds with the frequencies, each unevaluated reading at its largest possible term, were
        measured on a spectral update of 20 cuts with 11 readings, 2026-11-29: 609 rows decided early, 7 % of the
        entries saved, no time saved, the same particles: not kept.) ``depths``: also the limits (B, S) [mm] as
        :meth:`depths` (NaN where not evaluated)."""
        v = np.atleast_2d(np.asarray(v, dtype=float))
        floor = np.broadcast_to(np.asarray(floor, dtype=float), (v.shape[0],))
        ev, n_s = self.evidence, self.speeds.size
        if (self.batch is not None or ev.pt_rpm.size or self.uses_frequency or (ev.cut_weight < 0).any()
                or self.client is not None or n_s <= BOUND_ROUNDS[0] or v.shape[0] < BOUND_MIN_ROWS):
            return self.depths(v) if depths else self(v)
        v, u, w, ok = self._parts(v)
        rows = np.flatnonzero(ok)
        out = np.full(v.shape[0], -np.inf)
        seen = np.full((v.shape[0], n_s), np.nan)  # the limits evaluated (``depths``)
        if not rows.size:
            return (out, seen) if depths else out
        order = np.argsort(-self._column_cost, kind="stable")  # the costliest columns first
        settings = self._settings(u[rows])
        cap = self.ceilings(u[rows], None if w is None else w[rows])
        low = self.floors(u[rows], None if w is None else w[rows])
        depth = np.ones((rows.size, n_s))  # finite placeholders where not evaluated (those cuts not summed)
        done = np.zeros(n_s, bool)
        live = np.arange(rows.size)
        start = 0
        for size in (*BOUND_ROUNDS, n_s):
            cols = order[start:start + size] if size < n_s else order[start:]
            start += cols.size
            if not cols.size:
                break
            depth[np.ix_(live, cols)] = self._columns(u[rows[live]], cols, settings,
                                                      None if cap is None else cap[np.ix_(live, cols)],
                                                      None if low is None else low[np.ix_(live, cols)])
            seen[np.ix_(rows[live], cols)] = depth[np.ix_(live, cols)]
            done[cols] = True
            if done.all():
                break
            part = self.from_limits(depth[live], None, done[self._ic], False, None if w is None else w[rows[live]])
            # decided: below the floor by more than rounding (the other cuts' terms are ≤ 0); NaN goes on
            dead = part < floor[rows[live]] - 1e-9 * (1.0 + np.abs(floor[rows[live]]))
            out[rows[live[dead]]] = part[dead]
            self.n_decided += int(dead.sum())
            self.n_entries_saved += int(dead.sum()) * int((~done).sum())
            live = live[~dead]
            if not live.size:
                break
        if live.size:  # from_limits on an array of __call__'s shape: its numbers for these rows, bit for bit
            whole = np.ones((v.shape[0], n_s))
            whole[rows[live]] = depth[live]
            out[rows[live]] = self.from_limits(whole, None, noise=w)[rows[live]]
            self._learn_costs(depth[live], None if w is None else w[rows[live]])
        self.n_sets += rows.size
        return (out, seen) if depths else out

    def _columns(self, u: np.ndarray, cols: np.ndarray, settings: list[dict],
                 cap: np.ndarray | None = None, low: np.ndarray | None = None) -> np.ndarray:
        """Limits (B, len(cols)) [mm] of rows u = ln θ at the data's columns ``cols`` (indices into
        :attr:`speeds`), one engine call per stickout group with columns among them, each under ``settings``
        (:meth:`_settings`: the discretisation a full call would use), so that a subset of columns gives the
        numbers of a full call (the spectral node count is chosen per speed list). ``cap`` (B, len(cols)) [mm]:
        censored limits (:meth:`ceilings`); ``low`` (B, len(cols)) [mm]: floored limits (:meth:`floors`)."""
        where = np.full(self.speeds.size, -1, dtype=np.int64)
        where[cols] = np.arange(cols.size)
        depth = np.empty((u.shape[0], cols.size))
        for (prior, group), fwd, chosen in zip(self._groups, self._forwards, settings):
            sel = group[where[group] >= 0]
            if not sel.size:
                continue
            cond = self._conditions_of(self.column_cond[sel])
            pin = Pinned(fwd, self.speeds[sel], chosen, fwd.cutting if cond is None else cond)
            c = None if cap is None or cond is not None else cap[:, where[sel]]
            f = None if low is None or cond is not None else low[:, where[sel]]
            depth[:, where[sel]] = sample_depths(pin, prior, u, False, c, f)[0]
            self.n_calls += 1
            if c is not None:
                self.n_censored += int((depth[:, where[sel]] >= c).sum())
            if f is not None:
                self.n_floored += int((depth[:, where[sel]] < f).sum())
        return depth

    def _settings(self, u: np.ndarray) -> list[dict]:
        """Per stickout group, the discretisation of a full call on the rows u (B, P) (:func:`pinned_model` on
        all the group's columns: spectral's chosen at θ0 once per speed list, sdm's from the rows)."""
        return [dict(pinned_model(g, u, self.speeds[c], self.engine, gc, f).settings)
                for (g, c), gc, f in zip(self._groups, self._group_conditions, self._forwards)]

    def _learn_costs(self, depth_mm: np.ndarray, noise: np.ndarray | None) -> None:
        """Add each column's summed −log L of its cuts over these rows to :attr:`_column_cost` (the order of
        :meth:`bounded`'s rounds: deterministic, from the rows evaluated so far)."""
        ev = self.evidence
        if noise is None:
            eps, fac = self.prior.label_error, np.ones((1, 1))
        else:
            e, f = self.prior.noise(noise, depth_mm.shape[0])
            eps, fac = e[:, None], f[:, None]
        z = (ev.cut_depth_mm - depth_mm[:, self._ic]) / (self._sig_c * fac)
        terms = -cut_loglik(z, None, eps, ev.cut_grade) * ev.cut_weight
        cost = np.bincount(self._ic, weights=np.nan_to_num(terms, posinf=1e6).sum(0), minlength=self.speeds.size)
        self._column_cost += cost

    def split(self, n_old: int):
        """``u -> (log L of the first n_old cuts and every boundary point, log L of the other cuts)``
        from ONE engine call: the likelihood of sequential reuse (:func:`tempered_smc`'s ``init``)."""
        if not 0 <= n_old <= self.evidence.n_cuts:
            raise InputError("start", f"{n_old} earlier cuts",
                             f"at most the {self.evidence.n_cuts} cuts of this update")
        new = np.arange(self.evidence.n_cuts) >= n_old

        def parts(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            depth, hz, w, ok = self._limits(v, censor=True)
            return (np.where(ok, self.from_limits(depth, hz, ~new, True, w), -np.inf),
                    np.where(ok, self.from_limits(depth, hz, new, False, w), -np.inf))

        return parts

    def from_limits(self, depth_mm: np.ndarray, hz: np.ndarray | None = None, cuts: np.ndarray | None = None,
                    points: bool = True, noise: np.ndarray | None = None) -> np.ndarray:
        """log-likelihood (B,) from limiting depths (B, S) [mm] (and frequencies (B, S) [Hz]) at :attr:`speeds`;
        ``cuts`` (bool per cut) and ``points`` select the data counted (default all); ``noise``: the
        learned noise levels' coordinates (B, Q) per row (``None``: the prior's held values)."""
        ev = self.evidence
        sel = np.ones(ev.n_cuts, bool) if cuts is None else np.asarray(cuts, bool)
        ll = np.zeros(depth_mm.shape[0])
        if noise is None:
            eps, fac = self.prior.label_error, np.ones((1, 1))
        else:
            e, f = self.prior.noise(noise, depth_mm.shape[0])
            eps, fac = e[:, None], f[:, None]
        if sel.any():  # the columns of the selected cuts only (a zero weight times −inf would be NaN)
            i = np.flatnonzero(sel)
            z = (ev.cut_depth_mm[i] - depth_mm[:, self._ic[i]]) / (self._sig_c[i] * fac)
            ll += cut_loglik(z, None, eps, ev.cut_grade[i]) @ ev.cut_weight[i]
        j = self._hz[sel[self._hz]] if self._hz.size else self._hz
        if j.size and hz is not None:
            fc = hz[:, self._ic[j]]
            d = frequency_distance(ev.cut_hz[j], fc, self._tooth_hz[j])
            s, o = frequency_spread(self.prior.sigma_chatter_hz, ev.cut_hz[j], ev.cut_depth_mm[j],
                                    depth_mm[:, self._ic[j]])
            a = self.prior.chatter_hz_alias
            lf = -0.5 * (d / s) ** 2
            if a < 1:  # the member near the mode with probability 1 − a (module docstring)
                d0 = np.where(np.isfinite(fc), np.abs(ev.cut_hz[j] - fc), d)
                lf = np.logaddexp(math.log1p(-a) - 0.5 * (d0 / s) ** 2, math.log(a) + lf)
            # a reading of another vibration (FREQ_OUTLIER): anywhere in one tooth-passing band
            lf = np.logaddexp(np.log1p(-o) + lf - np.log(s) - _LOG_SQRT_2PI, np.log(o) - np.log(self._tooth_hz[j]))
            ll += lf @ ev.cut_weight[j]
        if ev.pt_rpm.size and points:
            sig = self._sig_p * fac
            r = (ev.pt_depth_mm - depth_mm[:, self._ip]) / sig
            ll += (-0.5 * r**2 - np.log(sig) - _LOG_SQRT_2PI) @ ev.pt_weight
        return np.where(np.isnan(ll), -np.inf, ll)


__all__ = ["Evidence", "Likelihood", "FREQ_DRIFT", "FREQ_OUTLIER", "check_engine", "cut_loglik", "frequency_distance",
           "frequency_spread", "limits",
           "limits_by_condition", "stickout_groups"]
