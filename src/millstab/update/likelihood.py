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
  informative modulo f_tp only, which is the honest content of one frequency reading;
* a boundary point (no label): Gaussian in depth, N(b; b_lim, σ_b²).

Units: rpm, mm, Hz at this module's interface; the engines work in m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import log_ndtr

from millstab.errors import InputError
from millstab.forward import forward
from millstab.points import PointSet
from millstab.stability import get_engine
from millstab.stability import zoa
from millstab.update.prior import Prior
from millstab.warnlog import warn

_LOG_SQRT_2PI = 0.5 * math.log(2 * math.pi)


def limits(prior: Prior, u: np.ndarray, rpm: np.ndarray, engine: str = "zoa",
           with_freq: bool = False, client=None) -> tuple[np.ndarray, np.ndarray | None]:
    """The one forward function: limiting depths (B, S) [mm] (and chatter frequencies (B, S) [Hz]).

    ONE batched engine call for all B samples u = ln θ (B, P) at the S speeds [rpm]; a free Kt
    scales the depths exactly (see :mod:`millstab.update.prior`). ``inf`` where no boundary exists.
    Frequencies come only from an engine declaring ``reports_chatter_frequency`` (else ``None``).
    ``client``: a ``distributed.Client``; the rows go to its cluster where that pays (same numbers).
    """
    if client is not None:  # the rule and the split live in millstab.cluster; None: it does not pay, run here
        from millstab.cluster import sample_limits

        out = sample_limits(client, prior, u, rpm, engine, with_freq)
        if out is not None:
            return out
    theta, factor = prior.split(u)
    rpm = zoa.check_rpm(rpm)
    eng = get_engine(engine)
    fwd = forward(prior.par, prior.cutting, engine)
    if with_freq and eng.reports_chatter_frequency:
        # the discretisation the depths-only path would get (Forward's settings), so both agree
        depth, hz = eng.envelope_batch_hz(prior.par.batch(theta), prior.cutting, rpm, **fwd.settings(rpm, theta[0]))
    else:
        depth, hz = fwd(theta, rpm), None
    return depth * 1e3 * factor[:, None], hz


def frequency_distance(measured_hz: np.ndarray, predicted_hz: np.ndarray, tooth_hz: np.ndarray) -> np.ndarray:
    """Distance [Hz] from a measured frequency to the nearest of ±f_c + m·f_tp (m integer).

    Broadcasts; a NaN prediction (no boundary) gives the largest possible distance, f_tp/2.
    """
    fc = np.where(np.isfinite(predicted_hz), predicted_hz, 0.5 * tooth_hz)
    r1 = np.mod(measured_hz - fc, tooth_hz)
    r2 = np.mod(measured_hz + fc, tooth_hz)
    d = np.minimum(np.minimum(r1, tooth_hz - r1), np.minimum(r2, tooth_hz - r2))
    return np.where(np.isfinite(predicted_hz), d, 0.5 * tooth_hz)


def cut_loglik(z: np.ndarray, kind: np.ndarray, label_error: float = 0.0) -> np.ndarray:
    """Log-likelihood of each cut's label from z = (b − b_lim)/σ_b; kind 0 stable, 1 chatter, 2 marginal;
    ``label_error`` ε ∈ [0, ½): the probability that a label is swapped (see the module docstring)."""
    up, down = log_ndtr(z), log_ndtr(-z)
    if label_error > 0:  # log((1 − ε)Φ(±z) + εΦ(∓z)) without cancellation in either tail
        a, b = math.log1p(-label_error), math.log(label_error)
        up, down = np.logaddexp(a + up, b + down), np.logaddexp(a + down, b + up)
    return np.where(kind == 1, up, np.where(kind == 0, down, 0.5 * (up + down)))


_KIND = {"stable": 0, "chatter": 1, "marginal": 2}


@dataclass(frozen=True, eq=False)
class Evidence:
    """The data of one update: labelled cuts and boundary points (rpm, mm, Hz; NaN = no frequency)."""

    cut_rpm: np.ndarray
    cut_depth_mm: np.ndarray
    cut_kind: np.ndarray
    cut_weight: np.ndarray
    cut_hz: np.ndarray
    pt_rpm: np.ndarray
    pt_depth_mm: np.ndarray
    pt_weight: np.ndarray

    @classmethod
    def from_points(cls, cuts: PointSet, points: PointSet | None = None) -> Evidence:
        """Split a cuts file (labelled rows; unlabelled rows are boundary points) and an optional
        boundary-point file into evidence.

        Raises:
            InputError: neither a stable nor a chatter cut, and no boundary point either.
        Warns:
            UserWarning: every cut has the same label (the answer is valid but leans on the prior).
        """
        pts = [p for p in (cuts, points) if p is not None]
        labelled = cuts.label != ""
        c = cuts.subset(labelled)
        b_rpm = np.concatenate([p.rpm[p.boundary] for p in pts])
        b_depth = np.concatenate([p.depth_mm[p.boundary] for p in pts])
        b_w = np.concatenate([p.weight[p.boundary] for p in pts])
        if points is not None and (~points.boundary).any():
            extra = points.subset(~points.boundary)
            c = PointSet(np.r_[c.rpm, extra.rpm], np.r_[c.depth_mm, extra.depth_mm], np.r_[c.label, extra.label],
                         np.r_[c.weight, extra.weight], cuts.source, np.r_[c.chatter_hz, extra.chatter_hz])
        n_st, n_ch = int(c.stable.sum()), int(c.chatter.sum())
        where = f" in {cuts.source.name}" if cuts.source is not None else ""
        if n_st == 0 and n_ch == 0 and b_rpm.size == 0:
            raise InputError("cuts", f"{int(c.marginal.sum())} marginal and no stable or chatter cut{where}",
                             "updating needs at least one cut labelled stable or chatter (or boundary points)")
        if b_rpm.size == 0 and (n_st == 0 or n_ch == 0):
            only = "stable" if n_ch == 0 else "chatter"
            side = "from below" if only == "stable" else "from above"
            warn(f"every cut{where} is {only}: the data bound the limit {side} only, so the posterior "
                 "and the P(stable) map lean on the prior; add a cut on the other side", UserWarning, stacklevel=2)
        kind = np.array([_KIND[s] for s in c.label], dtype=np.int64)
        return cls(c.rpm, c.depth_mm, kind, c.weight, c.chatter_hz, b_rpm, b_depth, b_w)

    @property
    def n_cuts(self) -> int:
        return int(self.cut_rpm.size)

    @property
    def speeds(self) -> np.ndarray:
        """Every speed the data mention [rpm] (sorted, unique)."""
        return np.unique(np.concatenate([self.cut_rpm, self.pt_rpm]))


class Likelihood:
    """log p(data | u) for batches u = ln θ (B, P): :meth:`__call__` makes ONE engine call per batch.

    Attributes:
        n_calls, n_sets: engine calls and parameter sets evaluated so far.
    """

    def __init__(self, prior: Prior, evidence: Evidence, engine: str = "zoa", client=None):
        get_engine(engine)  # a clear error for an unknown name
        self.prior, self.evidence, self.engine, self.client = prior, evidence, engine, client
        ev = evidence
        self.speeds = ev.speeds
        self._ic = np.searchsorted(self.speeds, ev.cut_rpm)
        self._ip = np.searchsorted(self.speeds, ev.pt_rpm)
        self._sig_c = prior.sigma_depth_mm(ev.cut_depth_mm)
        self._sig_p = prior.sigma_depth_mm(ev.pt_depth_mm)
        hz = np.isfinite(ev.cut_hz)
        if hz.any() and not get_engine(engine).reports_chatter_frequency:
            warn(f"the {engine} engine reports no limiting-lobe chatter frequency in its batched path: the "
                 f"{int(hz.sum())} measured chatter frequencies are not used", UserWarning, stacklevel=2)
            hz = np.zeros_like(hz)
        self._hz = np.flatnonzero(hz)
        self._tooth_hz = prior.cutting.teeth * ev.cut_rpm / 60.0
        self.n_calls = 0
        self.n_sets = 0

    @property
    def uses_frequency(self) -> bool:
        return self._hz.size > 0

    def __call__(self, u: np.ndarray) -> np.ndarray:
        depth, hz = limits(self.prior, u, self.speeds, self.engine, self.uses_frequency, self.client)
        self.n_calls += 1
        self.n_sets += depth.shape[0]
        return self.from_limits(depth, hz)

    def split(self, n_old: int):
        """``u -> (log L of the first n_old cuts and every boundary point, log L of the other cuts)``
        from ONE engine call: the likelihood of sequential reuse (:func:`tempered_smc`'s ``init``)."""
        if not 0 <= n_old <= self.evidence.n_cuts:
            raise InputError("start", f"{n_old} earlier cuts", f"at most the {self.evidence.n_cuts} cuts of this update")
        new = np.arange(self.evidence.n_cuts) >= n_old

        def parts(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            depth, hz = limits(self.prior, u, self.speeds, self.engine, self.uses_frequency, self.client)
            self.n_calls += 1
            self.n_sets += depth.shape[0]
            return self.from_limits(depth, hz, ~new, True), self.from_limits(depth, hz, new, False)

        return parts

    def from_limits(self, depth_mm: np.ndarray, hz: np.ndarray | None = None, cuts: np.ndarray | None = None,
                    points: bool = True) -> np.ndarray:
        """log-likelihood (B,) from limiting depths (B, S) [mm] (and frequencies (B, S) [Hz]) at :attr:`speeds`;
        ``cuts`` (bool per cut) and ``points`` select the data counted (default all)."""
        ev = self.evidence
        sel = np.ones(ev.n_cuts, bool) if cuts is None else np.asarray(cuts, bool)
        ll = np.zeros(depth_mm.shape[0])
        if sel.any():  # the columns of the selected cuts only (a zero weight times −inf would be NaN)
            i = np.flatnonzero(sel)
            z = (ev.cut_depth_mm[i] - depth_mm[:, self._ic[i]]) / self._sig_c[i]
            ll += cut_loglik(z, ev.cut_kind[i], self.prior.label_error) @ ev.cut_weight[i]
        j = self._hz[sel[self._hz]] if self._hz.size else self._hz
        if j.size and hz is not None:
            d = frequency_distance(ev.cut_hz[j], hz[:, self._ic[j]], self._tooth_hz[j])
            s = self.prior.sigma_chatter_hz
            ll += (-0.5 * (d / s) ** 2 - math.log(s) - _LOG_SQRT_2PI) @ ev.cut_weight[j]
        if ev.pt_rpm.size and points:
            r = (ev.pt_depth_mm - depth_mm[:, self._ip]) / self._sig_p
            ll += (-0.5 * r**2 - np.log(self._sig_p) - _LOG_SQRT_2PI) @ ev.pt_weight
        return np.where(np.isnan(ll), -np.inf, ll)


__all__ = ["Evidence", "Likelihood", "cut_loglik", "frequency_distance", "limits"]
