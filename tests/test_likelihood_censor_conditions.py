"""Censored zero-order limits under several cutting conditions (issue 27): the likelihood hands the engine a
ceiling per (set, column), the depth above which no cut's label term at that column moves by more than
CENSOR_TOL (:meth:`Likelihood.ceilings`), and zoa's censored search certifies each limit only down to it
(``likelihood_ceiling``). Checked on random prior draws (learned label error and depth noise, Kr free in one case) over
1-4 conditions: log L with censored limits against every limit searched to its root, and, entry by entry, that a
ceiling only ever replaces a limit where every term of its column is saturated (with a negative control: the same
check fails on ceilings moved to the wrong columns)."""

from __future__ import annotations

import numpy as np
import pytest

from millstab.io import load_config
from millstab.io.config import PriorTable
from millstab.model import Cutting
from millstab.stability import zoa
from millstab.update import make_prior
from millstab.update.likelihood import CENSOR_TOL, Evidence, Likelihood, cut_loglik

IMMERSIONS = ((1.0, "down"), (0.5, "down"), (0.5, "up"), (0.25, "down"))


def _case(n_cond: int, kr_free: bool = False, seed: int = 0):
    """Example 1's tool in the first ``n_cond`` conditions, 24 cuts at distinct speeds labelled by the zero-order
    limit of a prior draw (depths ±60 % of it; one marginal, one graded, one of weight 2), a boundary point in the
    last condition, and 60 prior draws (noise coordinates included)."""
    cfg = load_config("example:ex1")
    c = cfg.cutting
    prior = make_prior(cfg.structure, c, PriorTable({"kr": 0.2} if kr_free else {}))
    conds = tuple(Cutting.from_immersion(c.teeth, c.kt, c.kr, ri, m) for ri, m in IMMERSIONS[:n_cond])
    rng = np.random.default_rng(seed)
    truth = prior.par.structure(prior.split(prior.sample(1, rng))[0][0])
    n = 24
    rpm = rng.permutation(np.arange(4000.0, 12000.0, 10.0))[:n]
    cond = np.arange(n) % n_cond
    blim = np.empty(n)
    for i, cut in enumerate(conds):
        blim[cond == i] = zoa.envelope(truth, cut, rpm[cond == i]).depth_mm
    depth = blim * rng.uniform(0.4, 1.6, n)
    kind = (depth > blim).astype(np.int64)
    kind[3] = 2
    grade = np.where(kind == 2, 0.5, kind.astype(float))
    grade[5] = 0.3
    weight = np.ones(n)
    weight[7] = 2.0
    ev = Evidence(rpm, depth, kind, weight, np.full(n, np.nan), np.array([rpm[n_cond - 1]]),
                  np.array([blim[n_cond - 1]]), np.ones(1), cut_grade=grade, cut_cond=cond,
                  pt_cond=np.array([n_cond - 1]), conditions=conds)
    return prior, ev, prior.sample_full(60, np.random.default_rng(seed + 10))


@pytest.mark.parametrize("n_cond, kr_free", [(1, False), (2, False), (3, False), (4, True)])
def test_censored_log_likelihood_is_the_exact_one_over_several_conditions(n_cond, kr_free):
    """log L with censored limits equals log L with every limit searched to its root bit for bit (zoa's limits below
    a ceiling are the same bits, and its ceilings are where every term is saturated to the last bit), while a large
    share of the (set, column) entries was censored. Fails on the old code (zoa did not censor: no entry censored),
    with the ceilings of CENSOR_TOL alone (~1 σ_b lower: log L off by up to ~1e-13) and with CENSOR_TOL 1e-6 (9e-6)."""
    prior, ev, v = _case(n_cond, kr_free)
    lik = Likelihood(prior, ev)
    assert lik._censor
    got = lik(v)
    exact = Likelihood(prior, ev)
    exact._censor = False
    want = exact(v)
    assert np.isfinite(want).all() and exact.n_censored == 0
    assert lik.n_censored > 0.2 * v.shape[0] * lik.speeds.size
    np.testing.assert_array_equal(got, want)


def _violation(lik: Likelihood, v: np.ndarray, cap: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(each cut's |term at the depth the censored engine gave − term at the limit| / (2 CENSOR_TOL |w|) (B, n),
    the censored depths (B, S)) with ceilings ``cap`` (B, S) [mm]."""
    prior, ev = lik.prior, lik.evidence
    u, w = v[:, :prior.size], v[:, prior.size:prior.dim]
    got, _ = lik._evaluate(u, cap=cap)
    plain, _ = lik._evaluate(u)
    eps, fac = prior.noise(w, v.shape[0])
    sig = lik._sig_c[None, :] * fac[:, None]

    def terms(depth):
        return cut_loglik((ev.cut_depth_mm[None, :] - depth[:, lik._ic]) / sig, None, eps[:, None], ev.cut_grade)

    moved = np.abs(terms(got) - terms(plain)) / (2 * CENSOR_TOL * np.abs(ev.cut_weight))
    # every entry is the limit itself (the same bits) or, where the limit is above it, the ceiling
    same = got == plain
    at_cap = np.isclose(got, cap, rtol=1e-12, atol=0) & (plain >= cap * (1 - 1e-12))
    assert np.all(same | at_cap)
    return moved, got != plain


@pytest.mark.parametrize("n_cond", [1, 4])
def test_a_ceiling_replaces_a_limit_only_where_its_column_no_longer_reads_it(n_cond):
    """Entry by entry: where the engine returned the ceiling instead of the limit, every cut at that column has the
    same term (to 2 CENSOR_TOL |w|) at the ceiling as at the limit; the boundary point's column (a Gaussian term,
    never saturated) is never censored. Negative control: the same ceilings moved to other columns (a column
    mix-up between the likelihood's and the engine's column order), or computed without each set's own noise
    levels, censor entries whose terms still move."""
    prior, ev, v = _case(n_cond, seed=3)
    lik = Likelihood(prior, ev)
    u, w = v[:, :prior.size], v[:, prior.size:prior.dim]
    cap = lik.ceilings(u, w)
    assert np.all(np.isinf(cap[:, lik._ip])) and np.isfinite(np.delete(cap, lik._ip, axis=1)).all()
    moved, censored = _violation(lik, v, cap)
    assert censored.mean() > 0.2
    assert moved.max() == 0.0  # saturated to the last bit (the CENSOR_TOL rule alone: ≤ 1)
    wrong = np.roll(cap, 5, axis=1)
    wrong[:, lik._ip] = np.inf
    assert _violation(lik, v, wrong)[0].max() > 1e6
    # and ceilings that ignore each set's own depth-noise factor and label error (the prior's held values)
    assert _violation(lik, v, lik.ceilings(u, None))[0].max() > 1e6


def test_an_engine_written_for_one_cutting_gets_each_conditions_own_ceilings():
    """base.by_condition (the engines that run condition by condition: spectral, sdm) hands each group of columns
    its own columns of a (B, S) ceiling, checked like any other ceiling; before, the whole array went to every group
    and a censored search under several conditions failed on its shape."""
    from millstab.errors import InputError
    from millstab.model import Conditions
    from millstab.stability.base import by_condition

    seen = []

    @by_condition
    def entry(batch, cutting, rpm, ceiling=None):
        seen.append((cutting, np.asarray(rpm).copy(), ceiling))
        return np.broadcast_to(rpm, (batch.size, rpm.size)) + (0.0 if ceiling is None else ceiling)

    class Batch:
        size = 3

    cuts = [Cutting.from_immersion(2, 7e8, 0.3, ri, m) for ri, m in IMMERSIONS[:3]]
    rpm = np.array([5000.0, 6000.0, 7000.0, 8000.0, 9000.0])
    index = np.array([2, 0, 2, 1, 0])
    cap = np.arange(15.0).reshape(3, 5) + 1.0
    got = entry(Batch(), Conditions.of(cuts, index), rpm, ceiling=cap)
    np.testing.assert_array_equal(got, rpm[None, :] + cap)
    assert len(seen) == 3 and all(c.shape == (3, r.size) for _, r, c in seen)
    np.testing.assert_array_equal(entry(Batch(), Conditions.of(cuts, index), rpm), np.broadcast_to(rpm, (3, 5)))
    with pytest.raises(InputError, match="ceiling"):
        entry(Batch(), Conditions.of(cuts, index), rpm, ceiling=cap[:, :4])


def test_the_spectral_engine_censors_under_several_conditions_too():
    """The accurate engine runs condition by condition (base.by_condition): with each group's own ceilings its
    censored log L over two conditions is the exact one to 1e-12 (its roots agree to ~1e-12), with entries censored.
    Before, the likelihood did not censor under several conditions, and a ceiling there failed on its shape."""
    prior, ev, v = _case(2, seed=5)
    ev = Evidence(ev.cut_rpm[:8], ev.cut_depth_mm[:8], ev.cut_kind[:8], ev.cut_weight[:8], ev.cut_hz[:8],
                  np.zeros(0), np.zeros(0), np.zeros(0), cut_grade=ev.cut_grade[:8], cut_cond=ev.cut_cond[:8],
                  conditions=ev.conditions)
    lik = Likelihood(prior, ev, "spectral")
    exact = Likelihood(prior, ev, "spectral")
    exact._censor = False
    got, want = lik(v[:10]), exact(v[:10])
    assert lik.n_censored > 0 and exact.n_censored == 0
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
