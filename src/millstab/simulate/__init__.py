"""Time-domain milling simulation and chatter detection: virtual test cuts with labels.

* :func:`simulate_cut` -- one cut: tool-tip vibration x, y [m], forces fx, fy [N] at every step,
  and the once-per-tooth samples. Regenerative, nonlinear (a tooth out of the cut cuts nothing),
  multiple regeneration; equations and the integrator in :mod:`millstab.simulate._kernel`.
* :func:`detect` -- stable | marginal | chatter, chatter frequency, lobe type (hopf | flip);
  rules and thresholds in :mod:`millstab.simulate.detect`.
* :func:`label_cuts` -- many cuts simulated and labelled in parallel (compiled), with optional
  seeded label noise.

Step. One tooth period T = 60/(N Ω) is m equal steps, so the delay is exactly m steps (exit
instants between nodes become extra grid points). By default

    m = max(STEPS_DEFAULT_MIN, ceil(STEPS_PER_NATURAL_PERIOD · fn_max · T), ceil(STEPS_IN_CUT / (cut share of T)))

(200, 100, 40): the error of the first-order-hold force is O(τ²) in the step τ measured against the
natural period of the highest mode and against the time a tooth spends in the cut (a/D = 0.05 with
2 teeth cuts during 14 % of T). Measured (benchmarks/bench_simulate.py): on a slotting lobe flank
of the classic benchmark (11 667 rpm) 95 steps per tooth period (40 per natural period) put the
boundary 2 % high, 200 steps 0.4 %, 400 steps 0.1 % (hence the floor of 200 per tooth period); at
a/D = 0.05, 12 000 rpm: 40 steps 2.7 %, 80 0.69 %, 160 0.17 %, 320 0.04 % (second order). With the
defaults the simulated boundary is within 0.26 % of the semi-discretization engine at 30 speeds
(slotting, a/D = 0.05, a two-mode structure; bench_simulate.py). Fewer than
``STEPS_MIN`` steps per tooth period is refused.

Start. ``start="steady"`` (default) starts on the forced T-periodic motion of the cut (the vibration
of a stable cut after its transient, computed from the Fourier series of the cutting force and the
receptance) with every modal displacement moved by ``perturbation`` × f_t: a cut already engaged,
disturbed by a small bump, so the label tells whether a small disturbance grows (the linear
stability boundary of the SLD engines). ``start="rest"`` starts at rest with the ideal surface (the
tool entering the cut at full depth; the large entry transient can drive an unstable-looking
nonlinear response below the linear limit, as in real cuts).

Units: SI inside (m, N, s, Hz); rpm for the spindle speed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from threadpoolctl import threadpool_limits

from millstab.errors import InputError
from millstab.model import Cutting, Structure
from millstab.simulate import _kernel
from millstab.simulate.detect import LABELS, LOBES, Detection, detect, growth_multiplier, spectrum_band_hz

__all__ = ["add_label_noise", "CutResult", "Detection", "Labels", "simulate_cut", "detect", "label_cuts",
           "default_steps", "growth_multiplier", "STEPS_MIN"]

#: fewest steps per tooth period accepted
STEPS_MIN = 20
#: fewest steps per tooth period by default
STEPS_DEFAULT_MIN = 200
#: default steps per natural period of the highest mode
STEPS_PER_NATURAL_PERIOD = 100.0
#: default fewest steps during the time a tooth is in the cut
STEPS_IN_CUT = 40
#: default revolutions of a cut
REVS = 100.0
#: the vibration bound is this many times (f_t + static deflection under the largest force)
BOUND_FACTOR = 10.0
#: harmonics of the force in the steady start's surface (×16 for its initial state)
N_HARMONICS = 128
#: most samples one cut may store (memory: 4 arrays of 8 bytes each)
MAX_SAMPLES = 20_000_000

Start = Literal["steady", "rest"]


@dataclass(frozen=True, eq=False)
class CutResult:
    """One simulated cut, sampled m = ``steps_per_tooth`` times per tooth period from t = 0.

    Attributes:
        rpm: spindle speed [rev/min]; depth_m: axial depth [m]; feed_per_tooth_m [m]; teeth.
        steps_per_tooth: samples per tooth period (the once-per-tooth samples are every m-th).
        t: times [s]; x, y: tool-tip displacement [m] (feed, cross-feed); fx, fy: force on the tool [N].
        diverged: the vibration passed the bound and the run stopped (the arrays end there).
        fn_max_hz: highest natural frequency of the structure [Hz]; active: (x, y) carry modes.
        start: ``"steady"`` or ``"rest"``.
    """

    rpm: float
    depth_m: float
    feed_per_tooth_m: float
    teeth: int
    steps_per_tooth: int
    t: np.ndarray = field(repr=False)
    x: np.ndarray = field(repr=False)
    y: np.ndarray = field(repr=False)
    fx: np.ndarray = field(repr=False)
    fy: np.ndarray = field(repr=False)
    diverged: bool
    fn_max_hz: float
    active: tuple[bool, bool]
    start: str = "steady"
    schema: str = "millstab.simulate.cut/1"

    @property
    def tooth_hz(self) -> float:
        """Tooth-passing frequency N Ω / 60 [Hz]."""
        return self.teeth * self.rpm / 60.0

    @property
    def tooth_period_s(self) -> float:
        """Tooth period T [s]."""
        return 60.0 / (self.teeth * self.rpm)

    @property
    def periods(self) -> int:
        """Complete tooth periods simulated."""
        return (self.x.size - 1) // self.steps_per_tooth

    @property
    def once_t(self) -> np.ndarray:
        """Times of the once-per-tooth samples [s] (a tooth enters the cut)."""
        return self.t[:: self.steps_per_tooth]

    @property
    def once_x(self) -> np.ndarray:
        """Once-per-tooth samples of x [m]."""
        return self.x[:: self.steps_per_tooth]

    @property
    def once_y(self) -> np.ndarray:
        """Once-per-tooth samples of y [m]."""
        return self.y[:: self.steps_per_tooth]

    def to_dict(self) -> dict[str, Any]:
        from millstab.io.results import to_jsonable

        return to_jsonable({k: getattr(self, k) for k in self.__dataclass_fields__})

    #: the ``"schema"`` of :meth:`to_json`
    SCHEMA = "millstab.simulate.cut/1"

    def summary(self, detection=None) -> str:
        """What ``millstab simulate`` prints for one cut: speed, depth, feed and tooth periods simulated, and
        with its ``detection`` the verdict (:meth:`~millstab.simulate.detect.Detection.summary`); whether the
        vibration diverged."""
        line = (f"{self.rpm:g} rpm, {self.depth_m * 1e3:g} mm, {self.feed_per_tooth_m * 1e3:g} mm/tooth, "
                f"{self.periods} tooth periods")
        if detection is not None:
            line += ": " + detection.summary()
        return line + ("; the vibration diverged" if self.diverged else "")

    def figure(self, ax=None, *, detection=None, title: str | None = None):
        """The time trace with its once-per-tooth samples (:func:`millstab.plot.simulate.plot_trace`); with the
        cut's ``detection`` (:class:`~millstab.simulate.detect.Detection`) also the once-per-tooth map and the
        spectrum, titled by its verdict (:func:`~millstab.plot.simulate.draw_cut`). Into ``ax``'s place or a new
        figure, which it returns."""
        from millstab.plot.simulate import draw_cut, plot_trace

        if detection is None:
            return plot_trace(self, title=title, ax=ax)
        from millstab.plot._layout import finish, panels, suptitle

        fig, axes = panels(ax, 1, 3, figsize=(14, 3.8), gridspec_kw={"width_ratios": [2.2, 1, 1.6]})
        draw_cut(self, detection, axes)
        if title:
            suptitle(fig, ax, title)
        finish(fig, ax)
        return fig

    def table(self) -> tuple[list[str], list[np.ndarray]]:
        """(header, columns) of the trace CSV (``millstab simulate --out``): t_s, x_m, y_m, fx_N, fy_N."""
        return ["t_s", "x_m", "y_m", "fx_N", "fy_N"], [self.t, self.x, self.y, self.fx, self.fy]

    def to_json(self) -> dict[str, Any]:
        """Every field under its own name (SI; the Result protocol of :mod:`millstab.jsondoc`)."""
        from millstab.jsondoc import fields_out

        return fields_out(self, self.SCHEMA)

    @classmethod
    def from_json(cls, doc: Any, source: str = "simulated cut") -> CutResult:
        """The cut of :meth:`to_json`; InputError naming ``source`` and the field otherwise."""
        from millstab.jsondoc import fields_in

        return fields_in(cls, doc, cls.SCHEMA, source)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> CutResult:
        if d.get("schema") != "millstab.simulate.cut/1":
            raise InputError("schema", d.get("schema"), "expected millstab.simulate.cut/1")
        kw = {k: d[k] for k in cls.__dataclass_fields__ if k in d}
        for k in ("t", "x", "y", "fx", "fy"):
            kw[k] = np.asarray(kw[k], float)
        kw["active"] = tuple(bool(a) for a in kw["active"])
        return cls(**kw)


# ---------------------------------------------------------------------------------------------------
# checks and set-up shared by one cut and a batch
# ---------------------------------------------------------------------------------------------------


def _modal(structure: Structure) -> tuple[np.ndarray, ...]:
    """wn [rad/s], zeta, mass [kg], mdir (0 = x, 1 = y) per mode, and the active directions."""
    if not isinstance(structure, Structure) or not structure.is_modal:
        raise InputError("structure", "measured FRF" if isinstance(structure, Structure) else structure,
                         "the time-domain simulation needs modal parameters (fn, k, zeta per mode)")
    modes = structure.modes
    wn = np.array([m.omega for m in modes])
    zeta = np.array([m.zeta for m in modes])
    mass = np.array([m.mass for m in modes])
    mdir = np.array([0] * len(structure.x) + [1] * len(structure.y), dtype=np.int64)
    return wn, zeta, mass, mdir, (bool(structure.x), bool(structure.y))


def _positive(name: str, value, unit: str) -> np.ndarray:
    arr = np.atleast_1d(np.asarray(value, dtype=float)) if not isinstance(value, str) else None
    if arr is None:
        raise InputError(name, value, f"must be a number > 0 {unit}")
    bad = ~(np.isfinite(arr) & (arr > 0))
    if bad.any():
        i = int(np.argmax(bad))
        where = f"{name}[{i}]" if arr.size > 1 else name
        raise InputError(where, value if arr.size == 1 else float(arr[i]), f"must be a finite number > 0 {unit}")
    return arr


def default_steps(structure: Structure, cutting: Cutting, rpm) -> np.ndarray:
    """Default steps per tooth period at each speed [rpm] (rule in the module docstring)."""
    wn = _modal(structure)[0]
    r = _positive("rpm", rpm, "rev/min")
    T = 60.0 / (cutting.teeth * r)
    share = min(1.0, (cutting.exit - cutting.entry) / (2 * math.pi / cutting.teeth))
    fn_max = wn.max() / (2 * math.pi)
    m = np.maximum(np.ceil(STEPS_PER_NATURAL_PERIOD * fn_max * T), math.ceil(STEPS_IN_CUT / share))
    return np.maximum(m, STEPS_DEFAULT_MIN).astype(np.int64)


def _steps(structure, cutting, r, steps_per_tooth) -> np.ndarray:
    if steps_per_tooth is None:
        return default_steps(structure, cutting, r)
    st = np.broadcast_to(np.asarray(steps_per_tooth, dtype=float), r.shape)
    if not np.all(np.isfinite(st)) or np.any(st != np.round(st)):
        raise InputError("steps_per_tooth", steps_per_tooth, "must be a whole number of steps per tooth period")
    if np.any(st < STEPS_MIN):
        raise InputError("steps_per_tooth", steps_per_tooth,
                         f"at least {STEPS_MIN} steps per tooth period are needed (the delay is resolved by "
                         f"the steps and the force is interpolated linearly over each)")
    return st.astype(np.int64)


def _periods(cutting, revs, n: int) -> np.ndarray:
    rv = _positive("revs", REVS if revs is None else revs, "revolutions")
    # a writable copy whatever n: a broadcast view of one cut stays read-only through ascontiguousarray, and the
    # kernel compiled for a read-only array is another signature (warmup's one cut compiled the other one)
    p = np.array(np.broadcast_to(np.round(rv * cutting.teeth).astype(np.int64), (n,)))
    if np.any(p < 2):
        raise InputError("revs", revs, f"need at least 2 tooth periods ({2 / cutting.teeth:g} revolutions)")
    return p


def _check_samples(cutting: Cutting, rpm: np.ndarray, steps: np.ndarray, periods: np.ndarray, revs,
                   steps_given: bool) -> None:
    """Refuse a cut that would store more than MAX_SAMPLES samples, blaming what makes it long: the
    speed when one revolution alone is that long (the default steps follow the tooth period, so a
    very low speed needs ~ 100 steps per natural period over a very long period), else the revs."""
    n = periods * steps + 1
    if not np.any(n > MAX_SAMPLES):
        return
    i = int(np.argmax(n > MAX_SAMPLES))
    per_rev = int(steps[i]) * cutting.teeth
    if per_rev * 2 > MAX_SAMPLES and not steps_given:
        r_min = per_rev * float(rpm[i]) * 2 / MAX_SAMPLES  # samples per revolution fall as 1/rpm
        raise InputError("rpm", float(rpm[i]),
                         f"at {rpm[i]:g} rev/min one revolution needs {per_rev} steps (~100 per period of the "
                         f"highest mode); a cut may store at most {MAX_SAMPLES} samples: use at least "
                         f"{r_min:.3g} rev/min")
    what = "--steps" if steps_given and per_rev * 2 > MAX_SAMPLES else "revs"
    raise InputError(what, revs if what == "revs" else int(steps[i]),
                     f"{int(periods[i])} tooth periods x {int(steps[i])} steps = {int(n[i])} samples; "
                     f"at most {MAX_SAMPLES} (at most {MAX_SAMPLES // per_rev} revolutions at this speed)")


def _bound(structure, cutting, depth, ft) -> np.ndarray:
    """Vibration bound [m]: BOUND_FACTOR × (f_t + largest static force / smallest stiffness)."""
    k_min = min(m.k for m in structure.modes)
    f_max = depth * cutting.kt * math.hypot(1.0, cutting.kr) * ft * cutting.teeth
    return BOUND_FACTOR * (ft + f_max / k_min)


def _cut_args(cutting: Cutting) -> tuple:
    return cutting.teeth, cutting.kt, cutting.kr, cutting.entry, cutting.exit


# ---------------------------------------------------------------------------------------------------
# public functions
# ---------------------------------------------------------------------------------------------------


def simulate_cut(structure: Structure, cutting: Cutting, rpm: float, depth: float, feed_per_tooth: float,
                 revs: float | None = None, steps_per_tooth: int | None = None, start: Start = "steady",
                 perturbation: float = 0.01) -> CutResult:
    """Simulate one cut.

    Args:
        structure: modal structure (any number of modes in x and y).
        cutting: teeth, Kt [N/m²], Kr, entry/exit [rad]; its process damping (C, diameter), when set, acts
            on every tooth in contact (instantaneous, :mod:`millstab.simulate._kernel`).
        rpm: spindle speed [rev/min] > 0; depth: axial depth b [m] > 0; feed_per_tooth: f_t [m] > 0.
        revs: spindle revolutions to simulate (default 100); rounded to whole tooth periods.
        steps_per_tooth: steps per tooth period (≥ 20), default :func:`default_steps`.
        start: ``"steady"`` or ``"rest"`` (module docstring); perturbation: the initial bump of
            every modal displacement in units of f_t (steady start only).
    Returns:
        :class:`CutResult`; a diverging run stops at the bound and has ``diverged = True``.
    Raises:
        InputError: non-positive or non-finite rpm, depth, feed or revs; fewer than 20 steps per
            tooth period; a measured-FRF structure; an unknown start; a run too long to store.
    """
    wn, zeta, mass, mdir, active = _modal(structure)
    r = _positive("rpm", rpm, "rev/min")
    b = float(_positive("depth", depth, "m")[0])
    ft = float(_positive("feed_per_tooth", feed_per_tooth, "m")[0])
    if r.size != 1:
        raise InputError("rpm", rpm, "one speed per cut (use label_cuts for many)")
    if start not in ("steady", "rest"):
        raise InputError("start", start, 'must be "steady" or "rest"')
    pert = float(perturbation)
    if not math.isfinite(pert):
        raise InputError("perturbation", perturbation, "must be a finite number (units of the feed per tooth)")
    m = int(_steps(structure, cutting, r, steps_per_tooth)[0])
    n_per = int(_periods(cutting, revs, 1)[0])
    n = n_per * m + 1
    _check_samples(cutting, r, np.array([m]), np.array([n_per]), revs, steps_per_tooth is not None)
    from millstab.simulate._kernel import initial_state

    args = _cut_args(cutting)
    rpm0 = float(r[0])
    cpd = float(cutting.process_damping_per_depth(rpm0)) * b  # process damping b C / V [N·s/m] (0: none)
    q0, v0, S = initial_state(*args, rpm0, m, b, ft, wn, zeta, mass, mdir, start == "steady", pert * ft,
                              N_HARMONICS, cpd)
    x, y, fx, fy = (np.empty(n) for _ in range(4))
    n_out = _kernel.simulate(*args, rpm0, m, n_per, b, ft, wn, zeta, mass, mdir, q0, v0, S,
                             float(_bound(structure, cutting, b, ft)), x, y, fx, fy, cpd)
    T = 60.0 / (cutting.teeth * rpm0)
    t = np.arange(n_out) * (T / m)
    return CutResult(rpm0, b, ft, cutting.teeth, m, t, x[:n_out].copy(), y[:n_out].copy(), fx[:n_out].copy(),
                     fy[:n_out].copy(), bool(n_out < n), float(wn.max() / (2 * math.pi)), active, start)


@dataclass(frozen=True, eq=False)
class Labels:
    """Labels of many cuts (arrays of one value per cut).

    Attributes:
        rpm [rev/min], depth_m [m]; label: "stable" | "marginal" | "chatter" (after any label noise);
        true_label: the detector's label before noise; chatter_hz [Hz] of the detector (NaN where
            true_label is stable, also when noise swapped the label);
        lobe: "hopf" | "flip" | ""; level, growth, multiplier: the detector's metrics (see :mod:`.detect`);
        seed: the seed of the label noise (None: no noise).
    """

    rpm: np.ndarray
    depth_m: np.ndarray
    label: np.ndarray
    true_label: np.ndarray
    chatter_hz: np.ndarray
    lobe: np.ndarray
    level: np.ndarray
    growth: np.ndarray
    seed: int | None = None
    multiplier: np.ndarray | None = None
    schema: str = "millstab.simulate.labels/1"

    #: the ``"schema"`` of :meth:`to_json`
    SCHEMA = "millstab.simulate.labels/1"

    def figure(self, ax=None, *, title: str | None = None):
        """The cuts on speed and depth, one colour per label (:func:`millstab.plot.simulate.plot_labels`), into
        ``ax`` or a new figure, which it returns."""
        from millstab.plot.simulate import plot_labels

        return plot_labels(self, title=title, ax=ax)

    def table(self) -> tuple[list[str], list]:
        """(header, columns) of a labelled-cuts CSV rpm,depth_mm,label,chatter_hz (a cuts file for ``update``)."""
        return ["rpm", "depth_mm", "label", "chatter_hz"], [self.rpm, self.depth_mm, list(self.label), self.chatter_hz]

    def summary(self) -> str:
        """'12 cuts labelled: 7 stable, 1 marginal, 4 chatter'."""
        counts = ", ".join(f"{int(np.sum(self.label == k))} {k}" for k in ("stable", "marginal", "chatter"))
        return f"{len(self.rpm)} cuts labelled: {counts}"

    @property
    def depth_mm(self) -> np.ndarray:
        return self.depth_m * 1e3

    def to_dict(self) -> dict[str, Any]:
        from millstab.io.results import to_jsonable

        return to_jsonable({k: getattr(self, k) for k in self.__dataclass_fields__})

    def to_json(self) -> dict[str, Any]:
        """Every field under its own name (NaN where a field says "not defined", ±∞ kept)."""
        from millstab.jsondoc import fields_out

        return fields_out(self, self.SCHEMA)

    @classmethod
    def from_json(cls, doc: Any, source: str = "labelled cuts") -> Labels:
        """The labels of :meth:`to_json`; InputError naming ``source`` and the field otherwise."""
        from millstab.jsondoc import fields_in

        return fields_in(cls, doc, cls.SCHEMA, source)


def add_label_noise(true: np.ndarray, label_noise: float = 0.0, marginal: str = "keep",
                    seed: int | None = None) -> np.ndarray:
    """The labels an operator writes for the detector's ``true`` labels (n,): with ``seed``, a marginal cut
    called stable or chatter at even odds (``marginal="random"``) and a stable/chatter label swapped with
    probability ``label_noise``, drawn in cut order (two uniforms per cut), so a cut's label does not depend
    on how the cuts were grouped for the simulation."""
    out = np.asarray(true).astype("<U8").copy()
    if seed is not None:
        n = out.size
        rng = np.random.default_rng(seed)
        u_flip = rng.random(n)
        u_marg = rng.random(n)
        if marginal == "random":
            mg = out == "marginal"
            out[mg] = np.where(u_marg[mg] < 0.5, "stable", "chatter")
        flip = (u_flip < label_noise) & (out != "marginal")
        out[flip] = np.where(out[flip] == "stable", "chatter", "stable")
    return out


def label_cuts(structure: Structure, cutting: Cutting, rpm, depth, feed_per_tooth: float, revs: float | None = None,
               steps_per_tooth: int | None = None, start: Start = "steady", perturbation: float = 0.01,
               label_noise: float = 0.0, marginal: Literal["keep", "random"] = "keep",
               seed: int | None = None) -> Labels:
    """Simulate and label many cuts in parallel (compiled; one cut per thread at a time).

    Args:
        rpm, depth: per-cut speeds [rev/min] and depths [m] (broadcast together).
        feed_per_tooth [m], revs, steps_per_tooth, start, perturbation: as in :func:`simulate_cut`.
        label_noise: probability in [0, 0.5) that an operator swaps a stable/chatter label (seeded).
        marginal: ``"keep"`` the ``marginal`` label, or ``"random"``: the operator calls a marginal
            cut stable or chatter with equal odds (operator uncertainty near the boundary; seeded).
        seed: seed of the label noise; required when label_noise > 0 or marginal = "random".
    Returns:
        :class:`Labels`. The same seed gives the same labels on any number of threads (noise is
        drawn after the parallel part, in cut order).
    """
    wn, zeta, mass, mdir, active = _modal(structure)
    r = _positive("rpm", rpm, "rev/min")
    d = _positive("depth", depth, "m")
    try:
        r, d = (np.ascontiguousarray(a) for a in np.broadcast_arrays(r, d))
    except ValueError:
        raise InputError("depth", f"{d.size} values", f"need one depth per speed ({r.size})") from None
    ft = float(_positive("feed_per_tooth", feed_per_tooth, "m")[0])
    if start not in ("steady", "rest"):
        raise InputError("start", start, 'must be "steady" or "rest"')
    noise = float(label_noise)
    if not 0.0 <= noise < 0.5:
        raise InputError("label_noise", label_noise, "must be a probability in [0, 0.5)")
    if marginal not in ("keep", "random"):
        raise InputError("marginal", marginal, 'must be "keep" or "random"')
    if (noise > 0 or marginal == "random") and seed is None:
        raise InputError("seed", seed, "label noise needs a seed (an integer), so runs can be repeated")
    steps = np.ascontiguousarray(_steps(structure, cutting, r, steps_per_tooth))
    periods = _periods(cutting, revs, r.size)
    _check_samples(cutting, r, steps, periods, revs, steps_per_tooth is not None)
    bound = np.ascontiguousarray(_bound(structure, cutting, d, ft))
    fn_max = float(wn.max() / (2 * math.pi))
    f_hi = np.ascontiguousarray(spectrum_band_hz(fn_max, cutting.teeth * r / 60.0))
    n = r.size
    lab = np.empty(n, dtype=np.int64)
    hz = np.empty(n)
    lobe = np.empty(n, dtype=np.int64)
    level = np.empty(n)
    growth = np.empty(n)
    mu = np.empty(n)
    from millstab.simulate._kernel import label_batch

    with threadpool_limits(1):
        label_batch(*_cut_args(cutting), r, d, steps, periods, ft, wn, zeta, mass, mdir, start == "steady",
                    float(perturbation), N_HARMONICS, bound, f_hi, lab, hz, lobe, level, growth, mu,
                    np.ascontiguousarray(cutting.process_damping_per_depth(r)))
    true = np.array(LABELS, dtype=object)[lab].astype("<U8")
    out = add_label_noise(true, noise, marginal, seed)
    return Labels(r, d, out, true, hz, np.array(LOBES, dtype=object)[lobe].astype("<U4"), level, growth, seed, mu)
