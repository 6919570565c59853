"""A test cut that tells the hammer test from a far-off alternative: the next test when the conflict is unclear.

The prior–data conflict check (:mod:`millstab.update.conflict`) can only read what the cuts hold. Cuts chosen
for productivity often hold little about a hammer test that is wrong in one kind of parameter: natural
frequencies 20 % off move every lobe by a large part of the lobe spacing, and cuts around one pocket are
explained nearly as well by the tap test's lobe with a label or two written off (``benchmarks/scan_lobes.py``:
campaign 41's likelihood has separate maxima at the tap test's and at the truth's fn); dampings 3× off
raise the lobes' floors, which moderate moves of every stiffness and damping explain as well
(docs/updating.md, "Prior–data conflict"). Neither posterior puts mass on the far alternative, so a test
chosen for its information about θ (mutual information over the posterior's samples) never asks.

This module asks directly. Alternatives: every parameter of one kind (all fn, all k or all ζ: a tool,
holder or clamping changes a kind together) shifted by ± :data:`SHIFT` σ of the hammer-test prior, the
other coordinates as the posterior has them: the posterior samples shifted, reweighted by how the
*cuts so far* like the shift (likelihood ratio, one batched engine call; the prior's penalty is left out
on purpose: the question is whether the data could tell, not whether the prior believes it). The
alternative the cuts like best (largest mean likelihood ratio) is the rival. The test is the cut whose
label distribution differs most between the posterior and the rival: the Jensen–Shannon divergence of
the two predictive label probabilities (the mutual information between the label and which of the two
is right, at even odds) [nats], among cuts the posterior gives at most ``test_risk`` to chatter,
below the depth cap. Cost: 6 alternatives × :data:`SAMPLES` samples → one likelihood call on the cuts
and one limits call on the speed grid.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from millstab.points import PointSet
from millstab.update._bald import label_information
from millstab.update.decide import guard_cap
from millstab.update.likelihood import Evidence, Likelihood, limits
from millstab.update.posterior import Posterior

#: the shift of an alternative [σ of the hammer-test prior]: a hammer test ≥ 3.5σ off is what must be named
SHIFT = 3.5
#: samples of the posterior per hypothesis (the rival's are resampled by weight)
SAMPLES = 300
#: below this divergence [nats] no cut tells the two apart: no conflict test is proposed
MIN_NATS = 0.02


def _h(p: np.ndarray) -> np.ndarray:
    q = np.clip(p, 1e-12, 1 - 1e-12)
    return -(q * np.log(q) + (1 - q) * np.log(1 - q))


def conflict_test(post: Posterior, rpm_range: tuple[float, float], cap_mm: float = math.inf, *,
                  test_risk: float = 0.5, n_rpm: int = 120, n_depth: int = 60, seed: int = 0,
                  guard: list[dict] = ()) -> dict | None:
    """The cut that best tells the posterior from the best-supported far-off alternative (module docstring),
    or ``None`` when there are no cuts yet or no cut tells them apart by :data:`MIN_NATS`.

    ``guard``: the data guard's chatter cuts (:func:`millstab.update.decide.data_guard`): no cut in a guarded
    cell is proposed (as for the recommendation's next test).

    Returns {"rpm", "depth_mm", "p_chatter" (the posterior's, process), "p_chatter_rival", "divergence_nats",
    "rival" (e.g. "fn +3.5σ"), "rival_log_likelihood_ratio" (ln of the mean likelihood ratio of the rival over the
    posterior on the cuts so far), "why"}.
    """
    c = post.cuts or {}
    lab = [x for x in (c.get("label") or []) if x]
    if not lab:
        return None
    pr = post.prior
    rng = np.random.default_rng(seed)
    n = post.u.shape[0]
    rows = rng.choice(n, min(SAMPLES, n), replace=False)
    u0 = post.sampler_state(rng)[rows]  # ln θ and the noise coordinates
    ps = PointSet(list(c["rpm"][:len(lab)]), list(c["depth_mm"][:len(lab)]), lab)
    with warnings.catch_warnings():  # the update has said what it has to say about these cuts
        warnings.simplefilter("ignore")
        lik = Likelihood(pr, Evidence.from_points(ps, base_cutting=pr.cutting), post.engine,
                         engine_options=post.engine_options)
    kinds = {}
    for j, name in enumerate(pr.names):
        kinds.setdefault(pr.par.kind(name), []).append(j)
    alts = [(k, sgn) for k in kinds for sgn in (+1, -1)]
    shifted = []
    for k, sgn in alts:
        v = u0.copy()
        v[:, kinds[k]] += sgn * SHIFT * pr.spread[kinds[k]]
        shifted.append(v)
    ll = lik(np.vstack([u0] + shifted)).reshape(len(alts) + 1, -1)  # (1 + A, M) one batched call
    ll = np.where(np.isfinite(ll), ll, -np.inf)
    lr = ll[1:] - ll[0]  # per sample: how much better the cuts like the shifted sample
    lse = np.array([np.log(np.mean(np.exp(r - r.max()))) + r.max() if np.isfinite(r.max()) else -np.inf for r in lr])
    a = int(np.argmax(lse))
    if not np.isfinite(lse[a]):
        return None
    w = np.exp(lr[a] - lr[a].max())
    pick = rng.choice(w.size, w.size, p=w / w.sum())  # the rival's samples, resampled by weight
    rival = shifted[a][pick]
    lo, hi = rpm_range
    speeds = np.linspace(lo, hi, n_rpm)
    b, _ = limits(pr, np.vstack([u0[:, :pr.size], rival[:, :pr.size]]), speeds, post.engine,
                  options=post.engine_options)
    b0, b1 = b[:u0.shape[0]], b[u0.shape[0]:]
    fin = np.where(np.isfinite(b0), b0, np.nan)
    top = float(np.nanquantile(fin, 0.95)) if np.isfinite(fin).any() else 1.0
    d_hi = min(cap_mm, 1.5 * top) if math.isfinite(cap_mm) else 1.5 * top
    depths = np.linspace(d_hi / n_depth, d_hi, n_depth)
    sig = pr.sigma_depth_mm(depths)
    eps, fac = post.label_error[rows], post.sigma_depth_factor[rows]
    p0, _, proc0 = label_information(b0, depths, sig, eps, fac)
    p1, _, proc1 = label_information(b1, depths, sig, eps[pick], fac[pick])
    js = _h(0.5 * (p0 + p1)) - 0.5 * (_h(p0) + _h(p1))  # (S, D) mutual information with "which is right"
    ok = (proc0 <= test_risk) & (depths[None, :] < guard_cap(list(guard), speeds)[:, None])
    if not ok.any() or np.where(ok, js, -np.inf).max() < MIN_NATS:
        return None
    i, j = np.unravel_index(int(np.argmax(np.where(ok, js, -np.inf))), js.shape)
    k, sgn = alts[a]
    name = f"{k} {'+' if sgn > 0 else '-'}{SHIFT:g}σ"
    return {"rpm": float(speeds[i]), "depth_mm": float(depths[j]), "p_chatter": float(proc0[i, j]),
            "p_chatter_rival": float(proc1[i, j]), "divergence_nats": float(js[i, j]), "rival": name,
            "rival_log_likelihood_ratio": float(lse[a]),
            "why": f"the cut whose label best tells the posterior from the hammer test off by {name} in every {k} "
                   f"(the far-off alternative the cuts so far fit best), at most {test_risk:g} likely to chatter"}


__all__ = ["MIN_NATS", "SAMPLES", "SHIFT", "conflict_test"]
