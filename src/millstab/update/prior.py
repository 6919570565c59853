"""The prior of Bayesian updating: independent heavy-tailed spreads around a hammer-test structure,
and the priors of the label model's noise levels.

Coordinates: the sampler works in u = ln θ (θ in Hz, N/m, -, and Kt in N/m²). Per parameter, z =
(u − ln θ_config)/``spread`` has a unit-scale density chosen by ``tails``:

* ``"student"``: Student-t with ν = :data:`DEFAULT_NU` = 4 degrees of freedom, one per
  parameter (independent, so one parameter can be wrong while the others hold);
* ``"normal"``: the Gaussian (log-normal θ) of millstab ≤ 0.x;
* ``"mixture"``: 0.9·N(0, 1) + 0.1·N(0, 4²), a Gaussian with a broad component;
* ``"multivariate_t"``: one multivariate t with ν = :data:`DEFAULT_NU` over the
  M free *modal* parameters, density ∝ (1 + |z|²/ν)^(−(ν+M)/2), i.e. z = N(0, I)/√(W/ν) with one W ~ χ²_ν
  shared by all of them (one scale: "how far off is this hammer test"). Each parameter alone is still t_ν (the
  same marginals as ``"student"``); what differs is the joint: the prior prices the whole tap test off by r σ in every
  parameter about like one parameter off by r√M σ, where independent tails make the one far-off
  parameter much cheaper (measured: a softer tool, all six parameters 3.6σ off, against a posterior
  with k 8.6σ off and the rest at the tap test: 13.8 nats apart under ``"student"``, 0.3 under this;
  docs/updating-measured.md, "Why the softer campaigns stop low"). A free Kt or Kr keeps its own independent
  t_ν: it comes from cutting tests or a table, not from the tap test, so its error is not the tap
  test's error and must not share its scale (a shared one would also let a Kt far off make every
  modal parameter's tails broad).
* ``"multivariate_t_shift"`` (:data:`SHIFT`, the default since 2026-11-28, :data:`DEFAULT_TAILS`; issue 24): the
  multivariate t with a rival component,
  (1 − w)·t_ν(0, I) + w·t_ν(0, Σ) over the modal z, Σ = I + S²·Σ_kind 1 1ᵀ (:data:`SHIFT_WEIGHT` w = 0.2,
  :data:`SHIFT_SCALE` S = 5): every kind (all fn, all k, all ζ; :attr:`Prior.kind_groups`) may share one common
  shift. The physics: a tool held otherwise than in the idle tap test (clamping, holder, overhang, bearings under
  load) moves every mode's stiffness together and every natural frequency together, one hypothesis, not six
  coincidences: the whole tap test 3.66σ off in all six is 5.9 nats above one stiffness 8.6σ off (0.4 apart under
  ``"multivariate_t"``). Measured (docs/updating-measured.md, "A rival component and the gain test"; S chosen among 1.5,
  3 and 5 on 8 softer campaigns, then checked on 32 wrong-hammer-test campaigns, 16 of them new, the one-kind-off
  ones and the 100 calibration campaigns): see :data:`DEFAULT_TAILS`. Its support removes 4.4 % of its draws (the
  widest common shifts), a constant left out of :meth:`Prior.logpdf`.

Why heavy tails (docs/updating.md, "A prior that can be wrong", has the measured comparison): with a
Gaussian, moving a parameter 4σ costs 8 nats, which k contradicting labels, each written off as a label
error for −ln ε ≈ 3.9 nats, undercut, so a wrong hammer test survives its contradicting cuts. The
t's penalty grows like (ν+1)/2·ln(1 + z²/ν), only logarithmically in z, so many consistent
contradicting labels move the structure while a few are still written off (near the median the t
is as informative as the Gaussian). So a spread of 0.05 is still a ≈ 5 % scale of a natural frequency.

Support: ζ < 1 (u_ζ < 0) and |z| ≤ :data:`TRUNCATE` (a guard that keeps every value the engine sees
finite and physical; it removes < 0.1 % of a t's mass). Outside it the density is 0 (log −inf); the
draws are the truncated distribution (rejection). Spreads are capped at :data:`MAX_SPREAD`.

Noise levels (learned from the data): the label error ε and a factor s on the depth noise σ_b are
sampled with the modal parameters (they cost no engine call). Their priors are Gaussian in the
sampler's coordinates: logit(2ε) ~ N(logit(2ε₀), :data:`DEFAULT_LABEL_ERROR_SPREAD`²) (ε ∈ (0, ½), ε₀
the config's ``label_error``; its 90 % range is ε₀/3 … 3ε₀ for ε₀ = 2 %) and ln s ~ N(0,
:data:`DEFAULT_SIGMA_DEPTH_SPREAD`²) (s σ_config within ×/÷ 2.3 at 90 %). ``fixed = ["label_error",
"sigma_depth"]`` in ``[prior]`` holds them at the config's values (ε₀ = 0 is always held).

Defaults of the spreads (the shop's experience of how far in-process dynamics drift from a tap test):
fn 5 %, k 30 %, ζ 30 %; every modal parameter free; the cutting coefficients fixed unless ``[prior]``
gives Kt a spread.

Kt free is exact and cheap: in both engines the boundary depends on b·Kt only (F = ½ b Kt [A] Δ),
so b_lim(Kt) = b_lim(Kt₀) · Kt₀/Kt, and the chatter frequency does not change. Kr free (``kr = "20 %"``,
its own coordinate ln Kr after Kt's, Kr ≥ 0): no scaling absorbs it (the zero-order eigenvalues of
[α][Φ] depend on det α/(α_xx α_yy), (1 + Kr²)/Kr² in slotting), so each sample's Kr goes to the engine
(``envelope_batch(..., kr=(B,))``; the brackets are linear in Kr, α = α₀ + Kr·α₁, recomputed per set).
Only an engine declaring ``per_set_kr`` (zoa, sdm and spectral, whose kernels build each (set, speed)'s
directional factors anyway) takes it; another is refused with an InputError when the likelihood is built.
With several cutting conditions the sampled Kr is every condition's Kr.

Process damping learned (``process_damping = "50 %"``, its coordinate ln C after Kr's): the config's coefficient C
(``[cutting] process_damping``, > 0, with the tool ``diameter``) is the median of its prior in ln C (the chosen
tails, as Kr's), and each sample's C goes to the engine (``envelope_batch(..., process_damping=(B,))``, the
``per_set_process_damping`` capability: sdm, the one engine that carries the term). C is a property of the tool's
flank and the material, so the sampled C is every condition's. Only the engine's limits depend on it: a zero-order
screen (delayed acceptance) reads the same prior without the term (:func:`millstab.update.screen_model`), and
:meth:`Prior.pd_of` gives no C for a prior whose cutting has none.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.special import expit, gammaln, logit

from millstab.errors import InputError
from millstab.model import Cutting, Mode, Structure
from millstab.params import Parameterization
from millstab.update.batch import check_tau

#: the free name of the process-damping coefficient C [N/m] (after Kt's and Kr's)
PD = "process_damping"
#: the free names that are cutting coefficients, not modal parameters, in the order they follow the modal ones
CUTTING_NAMES = ("kt", "kr", PD)
#: default σ of ln(value) per kind of parameter
DEFAULT_SPREADS = {"fn": 0.05, "k": 0.30, "zeta": 0.30}
#: default depth noise of the stability likelihood [m] (the reference's experimental value)
DEFAULT_SIGMA_DEPTH_M = 0.05e-3
#: default noise of a measured chatter frequency [Hz]
DEFAULT_SIGMA_CHATTER_HZ = 20.0
#: default probability that a measured chatter frequency is another member of its family f_c + m·f_tp, ±f_c
#: (not the one near the mode): 1 = any member alike, the reading informative modulo f_tp only
#: (:mod:`millstab.update.likelihood`). 0.1 (issue 24, measured on the 16 wrong-hammer-test campaigns 60–75 of
#: docs/updating.md with frequencies ±10 Hz, `multivariate_t`): read as the member near the mode the frequency places
#: fn itself, and the softer tool's last recommendation reached 0.90 of the best (8 / 8 stable and ≥ 0.60) where
#: read modulo f_tp it stayed at 0.29 (the family's aliases are the lobe-number ambiguity); 0.1 because `listen`'s
#: benchmark heard another member than the one near the mode on 6 of 73 chatter cuts
DEFAULT_CHATTER_HZ_ALIAS = 0.1
#: default probability that a cut's label is swapped (a shop mislabels a cut now and then)
DEFAULT_LABEL_ERROR = 0.02
#: default tails of the modal parameters' prior (see the module docstring): ``"multivariate_t_shift"`` since 2026-11-28
#: (docs/updating-measured.md, "The default prior, again"): on 32 campaigns with the hammer test 3.6σ off in every
#: parameter (16 softer, 16 stiffer; no chatter frequencies) against ``"multivariate_t"`` in the same campaigns: softer
#: side, recommendations from round 3 on that chatter 1 / 128 against 4 / 128, last recommendation 0.56 of the best
#: against 0.48 (6 / 16 against 4 / 16 at ≥ 0.60), test cuts that chattered 41 / 288 against 83 / 288; stiffer side 1.00
#: either way; the 100 calibration campaigns (hammer test right) 98 / 100 final recommendations truly stable, 90 %
#: coverage 0.94, no conflict named. Where it lost: ζ ×3 alone (4 campaigns), last recommendation 0.72 against 0.85 of
#: the best, one chattering recommendation (round 5) against none from round 3 on. ``"multivariate_t"`` before it moved
#: the whole structure where independent tails move k alone (softer tool, no frequencies: 0.54 of the best against
#: 0.16). Switched on 2026-11-28, back the same night (with the accurate engine's sampler its quantiles were off a
#: reference by up to 11 sd in one of 8 seeds), and again after that was explained (32 seeds, six references, importance
#: sampling): no bias of the sampler; the rival component gives that case far modes (a lobe alias, both fn about a third
#: low) of ~2 % mass, which every sampler weighs with heavy-tailed scatter
DEFAULT_TAILS = "multivariate_t_shift"
TAILS = ("student", "normal", "mixture", "multivariate_t", "multivariate_t_shift")
#: the tails whose modal parameters share one t scale (see the module docstring)
MVT = "multivariate_t"
#: the multivariate t with a rival component, every kind's common shift (see the module docstring)
SHIFT = "multivariate_t_shift"
SHARED = (MVT, SHIFT)
#: the rival component of :data:`SHIFT`: its weight, and the σ of each kind's common shift [spreads]
SHIFT_WEIGHT, SHIFT_SCALE = 0.2, 5.0
#: degrees of freedom of the Student-t prior
DEFAULT_NU = 4.0
#: the broad component of the mixture prior: its weight and scale (in units of the spread)
MIX_WEIGHT, MIX_SCALE = 0.1, 4.0
#: the prior's support in z = (u − μ)/spread
TRUNCATE = 12.0
#: the largest spread (σ of ln) of a parameter: 100 % (a factor e per σ; a heavy tail reaches far beyond)
MAX_SPREAD = 1.0
#: σ of logit(2ε) of the learned label error, and σ of ln s of the learned depth-noise factor
DEFAULT_LABEL_ERROR_SPREAD = 0.7
DEFAULT_SIGMA_DEPTH_SPREAD = 0.5
#: the names of the learned noise levels in the sampler's vector (after the modal parameters and Kt)
NOISE_NAMES = ("label_error", "sigma_depth")
_LOG_SQRT_2PI = 0.5 * math.log(2 * math.pi)


def _log_density(z: np.ndarray, tails: str, nu: float) -> np.ndarray:
    """Log density of the unit-scale distribution of z (elementwise)."""
    if tails == "normal":
        return -0.5 * z * z - _LOG_SQRT_2PI
    if tails == "student":
        c = gammaln(0.5 * (nu + 1)) - gammaln(0.5 * nu) - 0.5 * math.log(nu * math.pi)
        return c - 0.5 * (nu + 1) * np.log1p(z * z / nu)
    a = math.log1p(-MIX_WEIGHT) - 0.5 * z * z
    b = math.log(MIX_WEIGHT) - math.log(MIX_SCALE) - 0.5 * (z / MIX_SCALE) ** 2
    return np.logaddexp(a, b) - _LOG_SQRT_2PI


def _mvt_quad(zm: np.ndarray, groups: tuple[tuple[int, ...], ...], scale: float) -> tuple[np.ndarray, float]:
    """(zᵀΣ⁻¹z (B,), ln det Σ) of Σ = I + scale²·Σ_g 1_g 1_gᵀ over the columns of zm (B, m): each group g (the
    columns of one kind) shares a common shift of σ ``scale`` (Sherman–Morrison per group; scale 0: Σ = I)."""
    q = (zm * zm).sum(axis=1)
    logdet = 0.0
    if scale > 0:
        s2 = scale * scale
        for g in groups:
            q = q - s2 / (1 + len(g) * s2) * zm[:, list(g)].sum(axis=1) ** 2
            logdet += math.log1p(len(g) * s2)
    return q, logdet


def _log_density_rows(z: np.ndarray, tails: str, nu: float, m: int,
                      groups: tuple[tuple[int, ...], ...] = ()) -> np.ndarray:
    """Log density of each row of z (B, P) (B,): independent columns, or with ``tails`` in :data:`SHARED` one
    multivariate t over the first m columns (the modal parameters) and independent t's over the rest; with
    :data:`SHIFT` the modal part is the mixture (1 − :data:`SHIFT_WEIGHT`)·t(0, I) + :data:`SHIFT_WEIGHT`·t(0, Σ),
    Σ = I + :data:`SHIFT_SCALE`²·Σ_kind 1 1ᵀ over ``groups`` (the columns of each kind)."""
    if tails not in SHARED:
        return _log_density(z, tails, nu).sum(axis=1)
    zm = z[:, :m]
    c = gammaln(0.5 * (nu + m)) - gammaln(0.5 * nu) - 0.5 * m * math.log(nu * math.pi)
    q, _ = _mvt_quad(zm, (), 0.0)
    lp = c - 0.5 * (nu + m) * np.log1p(q / nu)
    if tails == SHIFT and groups:
        q2, logdet = _mvt_quad(zm, groups, SHIFT_SCALE)
        lp = np.logaddexp(math.log1p(-SHIFT_WEIGHT) + lp,
                          math.log(SHIFT_WEIGHT) + c - 0.5 * logdet - 0.5 * (nu + m) * np.log1p(q2 / nu))
    return lp + _log_density(z[:, m:], "student", nu).sum(axis=1)


def _draw_rows(shape: tuple[int, int], tails: str, nu: float, m: int, rng: np.random.Generator,
               groups: tuple[tuple[int, ...], ...] = ()) -> np.ndarray:
    """Unit-scale draws of z (n, P) (the first m columns share the t's scale with ``tails`` in :data:`SHARED`;
    with :data:`SHIFT` a share :data:`SHIFT_WEIGHT` of the draws adds a common N(0, :data:`SHIFT_SCALE`²) shift
    per group of ``groups`` before the shared scale)."""
    if tails not in SHARED:
        return _draw(shape, tails, nu, rng)
    n, p = shape
    w = rng.chisquare(nu, n) / nu
    zm = rng.standard_normal((n, m))
    if tails == SHIFT and groups:
        shifted = rng.random(n) < SHIFT_WEIGHT
        common = SHIFT_SCALE * rng.standard_normal((n, len(groups)))
        for j, g in enumerate(groups):
            zm[:, list(g)] += np.where(shifted, common[:, j], 0.0)[:, None]
    return np.hstack([zm / np.sqrt(w)[:, None], rng.standard_t(nu, (n, p - m))])


def _draw(shape: tuple[int, int], tails: str, nu: float, rng: np.random.Generator) -> np.ndarray:
    """Unit-scale draws of z (independent elements)."""
    if tails == "normal":
        return rng.standard_normal(shape)
    if tails == "student":
        return rng.standard_t(nu, shape)
    broad = rng.random(shape) < MIX_WEIGHT
    return rng.standard_normal(shape) * np.where(broad, MIX_SCALE, 1.0)


@dataclass(frozen=True, eq=False)
class Prior:
    """Independent log-normal prior on the free parameters, and the noise levels of the likelihood.

    Attributes:
        par: the modal parameterization (free modal names; the fixed values come from its base).
        cutting: the cutting conditions (Kt is the median when ``kt`` is free).
        names: the free names, ``par.free`` followed by ``"kt"`` when Kt is free, ``"kr"`` when Kr is free and
            ``"process_damping"`` when the process-damping coefficient C is free.
        median: prior medians (P,) [Hz, N/m, -, N/m², -, N/m].
        spread: σ of ln(value) (P,), > 0.
        sigma_depth_m: absolute depth noise [m], or ``None`` when relative.
        sigma_depth_rel: relative depth noise (fraction of the cut's depth), or ``None``.
        sigma_chatter_hz: chatter-frequency noise [Hz].
        chatter_hz_alias: probability in (0, 1] that a measured chatter frequency is another member of its
            tooth-passing family than the one near the mode (1: any member alike; see the likelihood).
        label_error: probability ε ∈ [0, ½) that a cut's stable/chatter label is swapped
            (:mod:`millstab.update.likelihood`); the prior median of ε when it is learned.
        tails: ``"student"``, ``"normal"``, ``"mixture"`` or ``"multivariate_t"`` (module docstring).
        nu: degrees of freedom of the Student-t (and of the multivariate t).
        label_error_spread: σ of logit(2ε) of the learned label error; 0: ε held at ``label_error``.
        sigma_depth_spread: σ of ln s, s the learned factor on the depth noise; 0: held.
        batch_effect: σ τ of a test day's shift of ln fn (:mod:`millstab.update.batch`); 0: none.
    """

    par: Parameterization
    cutting: Cutting
    names: tuple[str, ...]
    median: np.ndarray
    spread: np.ndarray
    sigma_depth_m: float | None = DEFAULT_SIGMA_DEPTH_M
    sigma_depth_rel: float | None = None
    sigma_chatter_hz: float = DEFAULT_SIGMA_CHATTER_HZ
    label_error: float = DEFAULT_LABEL_ERROR
    tails: str = "normal"
    nu: float = DEFAULT_NU
    label_error_spread: float = 0.0
    sigma_depth_spread: float = 0.0
    batch_effect: float = 0.0
    chatter_hz_alias: float = DEFAULT_CHATTER_HZ_ALIAS

    def __post_init__(self):
        if not (isinstance(self.chatter_hz_alias, (int, float)) and 0 < self.chatter_hz_alias <= 1):
            raise InputError("prior.chatter_hz_alias", self.chatter_hz_alias,
                             "the probability that a chatter frequency is another member of its family, in (0, 1] "
                             "(e.g. 0.1 for frequencies from `millstab listen`; 1: any member alike)")
        if not (isinstance(self.label_error, (int, float)) and 0 <= self.label_error < 0.5):
            raise InputError("prior.label_error", self.label_error, "the probability that a label is swapped must be "
                                                                    "in [0, 0.5), e.g. 0.02 (0: labels never wrong)")
        if self.tails not in TAILS:
            raise InputError("prior.tails", self.tails, f"one of {', '.join(TAILS)}")
        if not (np.isfinite(self.nu) and self.nu > 0):
            raise InputError("prior.nu", self.nu, "the t's degrees of freedom must be > 0")
        object.__setattr__(self, "batch_effect", check_tau(self.batch_effect))
        if self.label_error == 0 and self.label_error_spread:  # ε = 0 cannot be learned (logit(0) = −∞): hold it
            object.__setattr__(self, "label_error_spread", 0.0)

    @property
    def noise_names(self) -> tuple[str, ...]:
        """The learned noise levels, in the order they follow the free parameters in the sampler's vector."""
        return tuple(n for n, s in zip(NOISE_NAMES, (self.label_error_spread, self.sigma_depth_spread)) if s > 0)

    @property
    def dim(self) -> int:
        """Length of the sampler's vector: the free parameters and the learned noise levels."""
        return self.size + len(self.noise_names)

    def _noise_prior(self) -> tuple[np.ndarray, np.ndarray]:
        """(mean, σ) of the learned noise levels' sampler coordinates (Gaussian)."""
        mu = {"label_error": float(logit(2 * self.label_error)) if self.label_error > 0 else 0.0, "sigma_depth": 0.0}
        sd = {"label_error": self.label_error_spread, "sigma_depth": self.sigma_depth_spread}
        return np.array([mu[n] for n in self.noise_names]), np.array([sd[n] for n in self.noise_names])

    def sample_noise(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """n prior draws of the learned noise levels' coordinates (n, Q)."""
        mu, sd = self._noise_prior()
        return mu + sd * rng.standard_normal((n, mu.size))

    def noise(self, w: np.ndarray | None, n: int) -> tuple[np.ndarray, np.ndarray]:
        """(ε (n,), depth-noise factor s (n,)) from the noise coordinates w (n, Q) (``None``: the held values)."""
        eps, fac = np.full(n, float(self.label_error)), np.ones(n)
        if w is not None and w.shape[1]:
            for j, name in enumerate(self.noise_names):
                if name == "label_error":
                    eps = 0.5 * expit(w[:, j])
                else:
                    fac = np.exp(w[:, j])
        return eps, fac

    def noise_coordinates(self, eps: np.ndarray, fac: np.ndarray) -> np.ndarray:
        """The inverse of :meth:`noise`: coordinates (n, Q) of ε and s."""
        cols = [logit(2 * np.asarray(eps, float)) if n == "label_error" else np.log(np.asarray(fac, float))
                for n in self.noise_names]
        return np.stack(cols, axis=1) if cols else np.zeros((np.size(eps), 0))

    def sample_full(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """n prior draws of the sampler's whole vector (n, :attr:`dim`): ln θ and the noise coordinates."""
        return np.hstack([self.sample(n, rng), self.sample_noise(n, rng)])

    def logpdf_full(self, v: np.ndarray) -> np.ndarray:
        """Log prior density of the sampler's whole vector (B, :attr:`dim`)."""
        v = np.atleast_2d(v)
        lp = self.logpdf(v[:, :self.size])
        if self.dim > self.size:
            mu, sd = self._noise_prior()
            z = (v[:, self.size:] - mu) / sd
            lp = lp + (-0.5 * z * z - np.log(sd) - _LOG_SQRT_2PI).sum(axis=1)
        return lp

    @property
    def size(self) -> int:
        """Number of free parameters P."""
        return len(self.names)

    @property
    def kt_free(self) -> bool:
        return "kt" in self.names

    @property
    def kr_free(self) -> bool:
        return "kr" in self.names

    @property
    def pd_free(self) -> bool:
        return PD in self.names

    @property
    def pd_learned(self) -> bool:
        """Whether each sample's C goes to the engine: C is free and the cutting carries the term (not in a zero-order
        screen's prior, :func:`millstab.update.screen_model`)."""
        return self.pd_free and self.cutting.has_process_damping

    @property
    def n_modal(self) -> int:
        """Number of free modal parameters (the first columns of u)."""
        return self.size - int(self.kt_free) - int(self.kr_free) - int(self.pd_free)

    @property
    def kind_groups(self) -> tuple[tuple[int, ...], ...]:
        """The columns of each kind of modal parameter (fn, k, ζ) among the first :attr:`n_modal`, in the order
        the kinds first appear (the groups of :data:`SHIFT`'s common shifts)."""
        kinds: dict[str, list[int]] = {}
        for j, name in enumerate(self.names[:self.n_modal]):
            kinds.setdefault(self.par.kind(name), []).append(j)
        return tuple(tuple(v) for v in kinds.values())

    def kr_of(self, u: np.ndarray) -> np.ndarray | None:
        """Each sample's Kr (B,) from u (B, P) when Kr is free, else ``None`` (the cutting's Kr)."""
        if not self.kr_free:
            return None
        return np.exp(np.atleast_2d(u)[:, self.names.index("kr")])

    def pd_of(self, u: np.ndarray) -> np.ndarray | None:
        """Each sample's process-damping coefficient C (B,) [N/m] from u (B, P) when C is free and the prior's
        cutting carries the term, else ``None`` (the cutting's own C; none in a zero-order screen's prior)."""
        if not self.pd_learned:
            return None
        return np.exp(np.atleast_2d(u)[:, self.names.index(PD)])

    @property
    def mean_u(self) -> np.ndarray:
        """Prior mean of u = ln θ (P,)."""
        return np.log(self.median)

    def units(self) -> list[str]:
        """Unit of each free parameter."""
        return (self.par.units() + (["N/m^2"] if self.kt_free else []) + (["-"] if self.kr_free else [])
                + (["N/m"] if self.pd_free else []))

    def in_support(self, u: np.ndarray) -> np.ndarray:
        """Whether each row of u = ln θ (B, P) lies in the prior's support (B,): finite, ζ < 1, |z| ≤ TRUNCATE."""
        u = np.atleast_2d(u)
        z = (u - self.mean_u) / self.spread
        ok = np.isfinite(u).all(axis=1) & (np.abs(z) <= TRUNCATE).all(axis=1)
        zeta = [j for j, n in enumerate(self.par.free) if self.par.kind(n) == "zeta"]
        if zeta:
            ok &= (u[:, zeta] < 0).all(axis=1)
        return ok

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """n draws of u = ln θ, shape (n, P), from the prior restricted to its support (rejection)."""
        g = self.kind_groups
        u = self.mean_u + self.spread * _draw_rows((n, self.size), self.tails, self.nu, self.n_modal, rng, g)
        for _ in range(100):  # the support holds > 99 % of the mass: a few rounds at most
            bad = ~self.in_support(u)
            if not bad.any():
                return u
            u[bad] = self.mean_u + self.spread * _draw_rows((int(bad.sum()), self.size), self.tails, self.nu,
                                                            self.n_modal, rng, g)
        raise InputError("prior", "spreads",
                         "the prior puts almost no mass on damping ratios < 1: reduce the zeta spread")

    def logpdf(self, u: np.ndarray, tails: str | None = None) -> np.ndarray:
        """Log density of u = ln θ (B,) (``tails``: another family's, e.g. ``"normal"`` for the conflict
        check); −inf outside the support. Normalised on the untruncated space (the truncation's constant
        is below 10⁻³ in log for the defaults and is left out)."""
        u = np.atleast_2d(u)
        z = (u - self.mean_u) / self.spread
        lp = (_log_density_rows(z, tails or self.tails, self.nu, self.n_modal, self.kind_groups)
              - float(np.log(self.spread).sum()))
        return np.where(self.in_support(u), lp, -np.inf)

    def split(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(modal θ (B, Pm) [Hz, N/m, -], depth factor Kt₀/Kt (B,)) from u (B, P) (a free Kr: :meth:`kr_of`)."""
        t = np.exp(np.atleast_2d(u))
        if not self.kt_free:
            return t[:, :self.n_modal], np.ones(t.shape[0])
        return t[:, :self.n_modal], self.cutting.kt / t[:, self.names.index("kt")]

    def sigma_depth_mm(self, depth_mm: np.ndarray) -> np.ndarray:
        """The depth noise [mm] of cuts at ``depth_mm`` (absolute, or relative to each depth)."""
        d = np.asarray(depth_mm, dtype=float)
        if self.sigma_depth_rel is not None:
            return self.sigma_depth_rel * d
        return np.full(d.shape, self.sigma_depth_m * 1e3)

    # --- JSON -------------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        """Plain data (SI) that :meth:`from_dict` rebuilds the prior from."""
        c, s = self.cutting, self.par.base
        cut = {"teeth": c.teeth, "kt": c.kt, "kr": c.kr, "entry": c.entry, "exit": c.exit}
        if c.has_process_damping:
            cut |= {"process_damping": c.process_damping, "diameter": c.diameter}
        return {"cutting": cut,
                "structure": {d: [{"fn": m.fn, "k": m.k, "zeta": m.zeta} for m in getattr(s, d)] for d in ("x", "y")},
                "names": list(self.names), "median": self.median.tolist(), "spread": self.spread.tolist(),
                "sigma_depth_m": self.sigma_depth_m, "sigma_depth_rel": self.sigma_depth_rel,
                "sigma_chatter_hz": self.sigma_chatter_hz, "label_error": self.label_error, "tails": self.tails,
                "nu": self.nu, "label_error_spread": self.label_error_spread,
                "sigma_depth_spread": self.sigma_depth_spread, "batch_effect": self.batch_effect,
                "chatter_hz_alias": self.chatter_hz_alias,
                **({"tooltip": self.par.record()} if hasattr(self.par, "record") else {})}

    @classmethod
    def from_dict(cls, d: dict) -> Prior:
        try:
            c = d["cutting"]
            cutting = Cutting(int(c["teeth"]), c["kt"], c["kr"], c["entry"], c["exit"],
                              c.get("process_damping", 0.0), c.get("diameter"))
            structure = Structure(*(tuple(Mode(m["fn"], m["k"], m["zeta"], f"structure.{dd}[{i}]")
                                          for i, m in enumerate(d["structure"][dd])) for dd in ("x", "y")))
            names = tuple(d["names"])
            modal = tuple(n for n in names if n not in CUTTING_NAMES)
            if "tooltip" in d:  # a prior over the holder-face modes of a [tool] + [holder] config
                from millstab.tooltip.param import TipParameterization

                par = TipParameterization.from_record(d["tooltip"], structure, modal)
            else:
                par = Parameterization(structure, modal)
            return cls(par, cutting, names, np.asarray(d["median"], float), np.asarray(d["spread"], float),
                       d.get("sigma_depth_m"), d.get("sigma_depth_rel"), float(d["sigma_chatter_hz"]),
                       # a posterior written before label errors existed had none
                       float(d.get("label_error", 0.0)),
                       # a posterior written before heavy tails and learned noise had a Gaussian prior, noise held
                       str(d.get("tails", "normal")), float(d.get("nu", DEFAULT_NU)),
                       float(d.get("label_error_spread", 0.0)), float(d.get("sigma_depth_spread", 0.0)),
                       float(d.get("batch_effect", 0.0)),  # a posterior written before test-day effects had none
                       float(d.get("chatter_hz_alias", 1.0)))  # before: any member of the family alike
        except (KeyError, TypeError, ValueError) as exc:
            if isinstance(exc, InputError):
                raise
            raise InputError("posterior.prior", type(exc).__name__, f"not a millstab prior record ({exc})") from None


def make_prior(structure: Structure, cutting: Cutting, table=None, par: Parameterization | None = None) -> Prior:
    """The prior from a config's structure and cutting conditions and its ``[prior]`` table.

    Args:
        structure: the hammer-test modal structure (the prior medians).
        cutting: the cutting conditions (Kt the median when ``table`` frees it).
        table: a :class:`millstab.io.config.PriorTable` or ``None`` (all defaults).
        par: the parameterization over every parameter, whose names ``table`` frees or fixes (default
            ``Parameterization(structure)``; a :class:`~millstab.tooltip.param.TipParameterization`: the
            prior is over the holder-face modes, its ``base``, see :mod:`millstab.update.stickout`).
    Raises:
        InputError: a measured-FRF structure, an unknown or duplicated name, Kr freed with a config Kr of 0,
            every parameter fixed, a spread above :data:`MAX_SPREAD`.
    """
    spreads = dict(getattr(table, "spreads", {}) or {})
    fixed = tuple(getattr(table, "fixed", ()) or ())
    held = {n for n in NOISE_NAMES if n in fixed}
    fixed = tuple(f for f in fixed if f not in NOISE_NAMES)
    for key, value in spreads.items():
        if not value <= MAX_SPREAD:
            raise InputError(f"prior.{key}", f"{value:.4g} ({value:.0%})",
                             f"a spread is the σ of ln(value) and at most {MAX_SPREAD:.0%} (a factor "
                             f"{math.exp(MAX_SPREAD):.2g} per σ; the heavy-tailed prior reaches several σ beyond): "
                             "a larger one lets the sampler try physically absurd values (k of 10⁶⁰ N/µm)")
    if not structure.is_modal:
        raise InputError("structure", "measured FRF",
                         "Bayesian updating needs a modal structure (fn, k, zeta per mode)")
    if "kr" in spreads and not cutting.kr > 0:
        raise InputError("prior.kr", spreads["kr"], f"Kr free needs a config Kr > 0 as its median (the prior is "
                                                    f"log-normal in Kr; cutting.kr = {cutting.kr:g}); set cutting.kr "
                                                    "or remove prior.kr")
    if PD in spreads and not cutting.has_process_damping:  # (a Cutting with C > 0 has its tool diameter)
        raise InputError("prior.process_damping", spreads[PD],
                         f"C free needs a config coefficient C > 0 as its median (the prior is over ln C; "
                         f"cutting.process_damping = {cutting.process_damping:g} N/m): set cutting.process_damping "
                         "(e.g. \"0.02 N/um\") and cutting.diameter, or remove prior.process_damping")
    fixed = tuple(f for f in fixed if f not in CUTTING_NAMES)
    full = Parameterization(structure) if par is None else par
    fixed_c = set()
    for f in fixed:
        try:
            fixed_c.add(full.canonical(f))
        except InputError as exc:
            raise InputError("prior.fixed", f, exc.allowed) from None
    free = tuple(n for n in full.available() if n not in fixed_c)
    if not free:
        raise InputError("prior.fixed", list(fixed), "every modal parameter is fixed; leave at least one free")
    par = Parameterization(structure, free) if par is None else replace(par, free=free, bounds={})
    spread = np.array([DEFAULT_SPREADS[par.kind(n)] for n in par.free])
    for key, value in spreads.items():
        if key in DEFAULT_SPREADS:
            spread[[par.kind(n) == key for n in par.free]] = value
    for key, value in spreads.items():  # a named parameter's own spread wins over its kind's
        if key in DEFAULT_SPREADS or key in CUTTING_NAMES:
            continue
        try:
            name = full.canonical(key)
        except InputError as exc:
            raise InputError(f"prior.{key}", value, exc.allowed) from None
        if name not in par.free:
            raise InputError(f"prior.{key}", value,
                             f"{name} is listed in prior.fixed; give it a spread or fix it, not both")
        spread[par.free.index(name)] = value
    names, median = par.free, par.theta0
    if "kt" in spreads:
        names = names + ("kt",)
        median = np.append(median, cutting.kt)
        spread = np.append(spread, spreads["kt"])
    if "kr" in spreads:
        names = names + ("kr",)
        median = np.append(median, cutting.kr)
        spread = np.append(spread, spreads["kr"])
    if PD in spreads:
        names = names + (PD,)
        median = np.append(median, cutting.process_damping)
        spread = np.append(spread, spreads[PD])
    sd_m = getattr(table, "sigma_depth_m", None)
    sd_rel = getattr(table, "sigma_depth_rel", None)
    if sd_m is None and sd_rel is None:
        sd_m = DEFAULT_SIGMA_DEPTH_M
    sf = getattr(table, "sigma_chatter_hz", None) or DEFAULT_SIGMA_CHATTER_HZ
    eps = getattr(table, "label_error", None)
    eps = DEFAULT_LABEL_ERROR if eps is None else float(eps)
    tails = getattr(table, "tails", None) or DEFAULT_TAILS
    return Prior(par, cutting, names, median, spread, sd_m, sd_rel, float(sf), eps, tails, DEFAULT_NU,
                 0.0 if "label_error" in held else DEFAULT_LABEL_ERROR_SPREAD,
                 0.0 if "sigma_depth" in held else DEFAULT_SIGMA_DEPTH_SPREAD,
                 float(getattr(table, "batch_effect", None) or 0.0),
                 float(getattr(table, "chatter_hz_alias", None) or DEFAULT_CHATTER_HZ_ALIAS))


__all__ = ["DEFAULT_CHATTER_HZ_ALIAS",
           "DEFAULT_LABEL_ERROR", "DEFAULT_NU", "DEFAULT_TAILS", "MAX_SPREAD", "MVT", "NOISE_NAMES", "TAILS",
           "DEFAULT_SIGMA_CHATTER_HZ", "DEFAULT_SIGMA_DEPTH_M", "DEFAULT_SPREADS", "Prior", "make_prior"]
