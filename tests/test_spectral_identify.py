"""The spectral engine inside an identification (issue 16): warm starts and one discretisation per problem.

Warm starts (:func:`millstab.stability.spectral._solve_warm`) must give the roots of the cold search
from below; the node count chosen once per problem (the ``settings`` capability, passed by
:class:`millstab.forward.Forward`) must make a row's depth independent of the other rows of a call.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from millstab.datasets import load_example
from millstab.forward import Forward, fd_rows
from millstab.frf import ModalBatch
from millstab.model import Cutting, Structure
from millstab.params import Parameterization
from millstab.stability import _spectral_kernel as _k
from millstab.stability import _spectral_warm as _w
from millstab.stability import spectral, zoa
from millstab.stability.sdm import _arrays

RPM = np.linspace(3000.0, 15000.0, 12)


@pytest.fixture(scope="module")
def case():
    """Example 1's structure at a/D = 0.1 (2 teeth, down milling), as in the identification benchmark."""
    cfg = load_example("ex1")
    cut = Cutting.from_immersion(2, cfg.cutting.kt, cfg.cutting.kr, 0.1, "down")
    s = cfg.structure
    theta = np.array([s.x[0].fn, s.x[0].k, s.x[0].zeta, s.y[0].fn, s.y[0].k, s.y[0].zeta])
    return s, cut, theta


def batch_of(theta: np.ndarray) -> ModalBatch:
    t = np.atleast_2d(theta)
    return ModalBatch(*(np.ascontiguousarray(t[:, [j]]) for j in range(6)))


def rho_at(batch: ModalBatch, row: int, cut: Cutting, rpm: float, depth: float, p: int) -> float:
    """ρ of the full monodromy (independent of the root search: eigenvalues of the whole matrix)."""
    wn, zeta, mass, act, mdir = _arrays(batch)
    x, Dm, lend = _k.gauss_nodes(p)
    g = _k.setup(cut.teeth, cut.kr, cut.entry, cut.exit, rpm, float(spectral._elem_len(wn)[row]), x, wn[row], zeta[row],
                 act)
    m = _k.monodromy(depth, cut.kt, wn[row], zeta[row], mass[row], mdir, act.size, g[0], g[1], g[2], g[3], g[4], Dm,
                     lend)
    return float(np.max(np.abs(np.linalg.eigvals(m))))


def test_warm_rows_give_the_cold_roots(case):
    """Finite-difference rows (8 random sets in the search box, each with its 6 perturbed rows): the warm
    starts from each set's boundary give the cold search's depths within 1e-9 wherever both found the
    same boundary; where they differ (a narrow unstable band at a lobe crossing, which either check ladder
    may step over), the lower value is a true crossing of ρ = 1 and the difference is rare."""
    _, cut, theta = case
    rng = np.random.default_rng(3)
    u = np.log(theta) + rng.uniform(-1, 1, (8, 6)) * np.log([1.5, 2.5, 2.5, 1.5, 2.5, 2.5])
    rows, _ = fd_rows(u, np.full(6, -np.inf), np.full(6, np.inf))
    b = batch_of(np.exp(rows))
    warm, mu_w, _ = spectral._limit(b, cut, RPM, 6, warm=True)
    cold, mu_c, _ = spectral._limit(b, cut, RPM, 6, warm=False)
    follow, _ = spectral._heads(*_arrays(b)[:3])
    assert follow.sum() == 8 * 6  # every perturbed row started warm
    assert np.array_equal(np.isfinite(warm), np.isfinite(cold))
    rel = np.abs(warm / cold - 1)
    differ = np.argwhere(rel > 1e-9)
    assert differ.shape[0] <= 0.02 * rel.size
    assert np.count_nonzero(rel <= 1e-9) >= 0.98 * rel.size
    for i, s in differ:
        lo = min(warm[i, s], cold[i, s])
        assert rho_at(b, i, cut, RPM[s], lo * (1 - 1e-3), 6) < 1.0 + 1e-9
        assert rho_at(b, i, cut, RPM[s], lo * (1 + 1e-3), 6) > 1.0


def test_warm_start_on_a_wrong_lobe_gives_the_cold_answer(case):
    """Guesses far from the boundary (depth 1.3-3 times it, multiplier angles across (0, π]): where Newton
    alone lands on another root, the checks find the crossing below; every accepted warm point is the cold
    boundary within 1e-9 (else the entry is left to the cold search)."""
    s, cut, theta = case
    b = batch_of(theta)
    wn, zeta, mass, act, mdir = _arrays(b)
    nd = _k.gauss_nodes(6)
    el = float(spectral._elem_len(wn)[0])
    cold = spectral.envelope(s, cut, RPM, nodes=6).depth
    b_ref = spectral._b_ref(b, cut, RPM)[0]
    recovered = accepted = 0
    for j, r in enumerate(RPM):
        for f in (1.3, 2.0, 3.0):
            for th in (0.4, 1.2, 2.0, 2.8, math.pi):
                g = _k.with_factors(_k.setup(cut.teeth, cut.kr, cut.entry, cut.exit, r, el, nd[0], wn[0], zeta[0], act),
                                    wn[0], zeta[0], mass[0], mdir, nd)
                b_n, _, ok_n, _ = _k.newton(f * cold[j], th, cut.kt, wn[0], zeta[0], mass[0], mdir, g, nd)
                d, _, ok, _ = _w.warm_point(cut.teeth, cut.kt, cut.kr, cut.entry, cut.exit, r, f * cold[j], th,
                                            b_ref[j], spectral.LADDER, spectral.NEAR, wn[0], zeta[0], mass[0], mdir,
                                            act, el, nd)
                if ok:
                    accepted += 1
                    assert abs(d / cold[j] - 1) < 1e-9, (r, f, th, d, cold[j])
                    recovered += ok_n and abs(b_n / cold[j] - 1) > 1e-3  # Newton alone: another root
    assert recovered >= 3 and accepted >= 10


def test_depth_of_a_row_does_not_depend_on_the_other_rows(case):
    """With the node count chosen once per problem, a row's depth is the same whichever row comes first
    in the call (a per-call check on the first row chose p from it: up to TOL = 0.1 % apart)."""
    s, cut, theta = case
    par = Parameterization(s)
    f = Forward(par, cut, "spectral")
    other = theta * np.array([1.2, 1.0, 1.0, 1.2, 1.0, 1.0])  # p = 8 there, 6 at theta
    assert spectral._limit(batch_of(other), cut, RPM, None)[2] != spectral._limit(batch_of(theta), cut, RPM, None)[2]
    alone = f(theta[None], RPM)[0]
    behind = f(np.vstack([other, theta]), RPM)[1]
    np.testing.assert_allclose(behind, alone, rtol=1e-12)


def test_forward_asks_the_engine_once_and_refines_at_a_solution(case, monkeypatch):
    s, cut, theta = case
    calls = []
    real = spectral.settings
    monkeypatch.setattr(spectral, "settings", lambda *a: calls.append(1) or real(*a))
    f = Forward(Parameterization(s), cut, "spectral")
    f(theta[None], RPM)
    f(theta[None] * 1.01, RPM)
    assert len(calls) == 1
    assert f.settings(RPM) == real(batch_of(theta), cut, RPM)
    other = theta * np.array([1.2, 1.0, 1.0, 1.2, 1.0, 1.0])  # p = 8 there, 6 at theta
    want = real(batch_of(other), cut, RPM)
    assert f.refine(other, RPM) == (want != real(batch_of(theta), cut, RPM))
    assert f.settings(RPM) == want
    assert f.refine(other, RPM) is False  # settled


def test_engines_without_settings_are_called_as_before(case):
    """zoa has no ``settings``: the forward model is its batched call, bit for bit."""
    s, cut, theta = case
    f = Forward(Parameterization(s), cut, "zoa")
    rows = theta[None] * np.array([[1.0] * 6, [1.1, 0.9, 1.2, 1.0, 1.0, 0.8]])
    assert f.settings(RPM) == {} and f.refine(rows[1], RPM) is False
    np.testing.assert_array_equal(f(rows, RPM), zoa.envelope_batch(batch_of(rows), cut, RPM))


def test_settings_rejects_a_structure(case):
    from millstab.errors import InputError

    s, cut, _ = case
    with pytest.raises(InputError, match="ModalBatch"):
        spectral.settings(s, cut, RPM)
    assert isinstance(s, Structure)
