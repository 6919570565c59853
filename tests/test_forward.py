"""The one forward model and the one log-Jacobian (millstab.forward): the forward call equals the engine
call it wraps, and the log-Jacobian agrees with an independent re-computation (another step, another
scheme, row by row) and with the SLD's exact scaling laws."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from millstab.datasets import load_example
from millstab.errors import InputError
from millstab.forward import Forward, forward, log_jacobian
from millstab.frf import ModalBatch
from millstab.params import Parameterization
from millstab.stability import zoa


@pytest.fixture(scope="module")
def ex3():
    cfg = load_example("ex3")
    return cfg, Parameterization(cfg.structure), np.linspace(4000, 20000, 57)


def test_forward_equals_the_engine_called_on_each_structure(ex3):
    """f(θ, rpm) row b is the engine's envelope of the structure built from θ_b by hand (not via par.batch)."""
    cfg, par, rpm = ex3
    theta = par.theta0 * np.array([[1.0] * par.size, [1.03, 0.9, 1.2, 0.97, 1.1, 0.8]])
    f = forward(par, cfg.cutting)
    depth = f(theta, rpm)
    assert depth.shape == (2, rpm.size)
    for b in range(2):
        s = par.structure(theta[b])
        assert [s.x[0].fn, s.x[0].k, s.y[0].zeta] == pytest.approx([theta[b][par.free.index(n)] for n in
                                                                     ("fn_x", "k_x", "zeta_y")], rel=1e-15)
        np.testing.assert_array_equal(depth[b], zoa.envelope(s, cfg.cutting, rpm).depth)
    np.testing.assert_array_equal(f(theta[1], rpm)[0], depth[1])  # a single row (P,) is one batch row
    np.testing.assert_array_equal(depth, zoa.envelope_batch(ModalBatch.from_structures(
        [par.structure(t) for t in theta]), cfg.cutting, rpm))


def test_forward_is_frozen_and_checks_the_engine_name(ex3):
    cfg, par, _ = ex3
    f = forward(par, cfg.cutting)
    assert isinstance(f, Forward) and f.engine == "zoa"
    with pytest.raises(dataclasses.FrozenInstanceError):
        f.engine = "sdm"
    with pytest.raises(InputError, match="engine"):
        forward(par, cfg.cutting, "nonsense")


def test_log_jacobian_matches_an_independent_recomputation(ex3):
    """Central (and forward) differences from one batched call equal, per row and parameter, separate
    engine calls at θ·e^{±h} differenced by hand."""
    cfg, par, rpm = ex3
    f = forward(par, cfg.cutting)
    theta = np.vstack([par.theta0, par.theta0 * 1.05])
    jac = log_jacobian(f, theta, rpm, rel_step=1e-4, central=True)
    assert jac.shape == (2, rpm.size, par.size)
    for b in range(2):
        for j in range(par.size):
            up, dn = theta[b].copy(), theta[b].copy()
            up[j] *= np.exp(1e-4)
            dn[j] *= np.exp(-1e-4)
            ref = (np.log(zoa.envelope(par.structure(up), cfg.cutting, rpm).depth)
                   - np.log(zoa.envelope(par.structure(dn), cfg.cutting, rpm).depth)) / 2e-4
            np.testing.assert_allclose(jac[b, :, j], ref, rtol=1e-6, atol=1e-8)
    fwd = log_jacobian(f, theta[:1], rpm, rel_step=1e-3, central=False)[0]
    ln0 = np.log(zoa.envelope(par.structure(theta[0]), cfg.cutting, rpm).depth)
    for j in range(par.size):
        up = theta[0].copy()
        up[j] *= np.exp(1e-3)
        ref = (np.log(zoa.envelope(par.structure(up), cfg.cutting, rpm).depth) - ln0) / 1e-3
        np.testing.assert_allclose(fwd[:, j], ref, rtol=1e-6, atol=1e-8)


def test_log_jacobian_obeys_the_scaling_laws(ex3):
    """b ∝ k (all stiffnesses × c ⇒ b × c) and b depends on Ω and the fn only through Ω/fn:
    Σ ∂ln b/∂ln k = 1 and ∂ln b/∂ln Ω = −Σ ∂ln b/∂ln fn, at the nominal structure and a perturbed one."""
    cfg, par, rpm = ex3
    theta = np.vstack([par.theta0, par.theta0 * np.array([1.04, 0.8, 1.3, 0.95, 1.2, 0.7])])
    jac, slope = log_jacobian(forward(par, cfg.cutting), theta, rpm, speed=True)
    names = list(par.free)
    kx, ky, fx, fy = (names.index(n) for n in ("k_x", "k_y", "fn_x", "fn_y"))
    np.testing.assert_allclose(jac[..., kx] + jac[..., ky], 1.0, atol=1e-6)
    # central differences across a lobe cusp are off by O(h); elsewhere the law holds to O(h²)
    np.testing.assert_allclose(slope, -(jac[..., fx] + jac[..., fy]), rtol=1e-3, atol=1e-3)


def test_log_jacobian_steps_backwards_at_the_upper_bound(ex3):
    """With bounds, a parameter sitting on its upper bound is differenced backwards (never evaluated
    outside the box): the result equals (ln b(θ) − ln b(θ·e^{−h}))/h computed by hand."""
    cfg, par, rpm = ex3
    seen = []
    base = forward(par, cfg.cutting)

    def f(theta, speeds):
        seen.append(theta.copy())
        return base(theta, speeds)

    upper = par.theta0.copy()  # every parameter on its upper bound
    jac = log_jacobian(f, par.theta0, rpm, central=False, bounds=(par.theta0 / 2, upper))
    assert len(seen) == 1 and (seen[0] <= upper * (1 + 1e-12)).all()
    ln0 = np.log(zoa.envelope(par.structure(par.theta0), cfg.cutting, rpm).depth)
    for j in range(par.size):
        dn = par.theta0.copy()
        dn[j] *= np.exp(-1e-4)
        ref = (ln0 - np.log(zoa.envelope(par.structure(dn), cfg.cutting, rpm).depth)) / 1e-4
        np.testing.assert_allclose(jac[0, :, j], ref, rtol=1e-6, atol=1e-8)
