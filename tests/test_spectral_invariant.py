"""A time-invariant cutting (a slot with 4, 6, 8 … teeth) is solved by the zero-order model in the spectral engine.

``Cutting.time_invariant`` is checked against the directional matrix itself, sampled densely over the tooth period
(the compiled kernel's [A(φ)], an independent computation of the rule's closed form); the hand-over against the
engine's own collocation of the whole period (``spectral.INVARIANT_BY_ZOA = False``), which converges to the same
boundary because the delay equation then has constant coefficients.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from millstab.frf import ModalBatch
from millstab.model import Conditions, Cutting
from millstab.stability import spectral
from millstab.stability._spectral_kernel import dir_matrix

KT = 6e8


def _sampled_invariant(c: Cutting, kr: float) -> bool:
    """[A(φ)] at 997 instants of one tooth period (none on an entry or exit instant) all equal."""
    pitch = 2 * math.pi / c.teeth
    out = np.zeros((2, 2))
    vals = []
    for phi in (np.arange(997) + 0.5) / 997 * pitch + 1e-7:
        dir_matrix(c.teeth, kr, c.entry, c.exit, phi, phi, out)
        vals.append(out.copy())
    v = np.array(vals)
    return bool(np.ptp(v, axis=0).max() <= 1e-9 * max(1.0, np.abs(v).max()))


@pytest.mark.parametrize("teeth", [1, 2, 3, 4, 5, 6, 8, 12])
def test_the_rule_is_the_directional_matrix_sampled(teeth):
    cases = [Cutting(teeth, KT, 0.3, 0.0, math.pi)]
    cases += [Cutting.from_immersion(teeth, KT, 0.3, a, m) for a in (0.05, 0.25, 0.5, 0.75) for m in ("up", "down")]
    pitch = 2 * math.pi / teeth
    cases += [Cutting(teeth, KT, 0.3, e, e + k * pitch) for k in (1, 2, 3) for e in (0.0, 0.3)
              if e + k * pitch <= math.pi + 1e-12]
    for c in cases:
        for kr in (0.0, 0.3, 1.2):
            assert c.time_invariant == _sampled_invariant(c, kr), (teeth, c.entry, c.exit, kr)
    assert Cutting(teeth, KT, 0.3, 0.0, math.pi).time_invariant == (teeth >= 4 and teeth % 2 == 0)


def _random_batch(n: int, seed: int) -> ModalBatch:
    rng = np.random.default_rng(seed)
    return ModalBatch(fn_x=rng.uniform(600, 1500, (n, 1)), k_x=rng.uniform(5e6, 3e7, (n, 1)),
                      zeta_x=rng.uniform(0.01, 0.05, (n, 1)), fn_y=rng.uniform(600, 1500, (n, 1)),
                      k_y=rng.uniform(5e6, 3e7, (n, 1)), zeta_y=rng.uniform(0.01, 0.05, (n, 1)))


@pytest.mark.slow
@pytest.mark.parametrize("teeth", [4, 6])
def test_a_slot_of_four_or_six_teeth_is_the_collocated_boundary(teeth, monkeypatch):
    batch = _random_batch(4, teeth)
    slot = Cutting(teeth, KT, 0.3, 0.0, math.pi)
    rpm = np.array([3000.0, 5200.0, 8000.0, 11500.0, 16000.0])
    kr = np.array([0.2, 0.3, 0.5, 0.9])
    fast, fast_hz = spectral.envelope_batch_hz(batch, slot, rpm, kr=kr)
    assert np.isfinite(fast).all()
    monkeypatch.setattr(spectral, "INVARIANT_BY_ZOA", False)
    # the collocation converged (8 nodes per element: 1e-7 from 8 to 12 nodes), and as the engine chooses it alone
    # (its convergence check's TOL is 1e-3: ~0.2 % off here, the error the hand-over removes)
    fine, fine_hz = spectral.envelope_batch_hz(batch, slot, rpm, kr=kr, nodes=8)
    np.testing.assert_allclose(fast, fine, rtol=1e-6)
    np.testing.assert_allclose(fast_hz, fine_hz, rtol=1e-5)
    np.testing.assert_allclose(fast, spectral.envelope_batch(batch, slot, rpm, kr=kr), rtol=5e-3)


def test_other_conditions_are_collocated_as_before(monkeypatch):
    """The hand-over touches only time-invariant conditions: in one call with a slot of four teeth, a three-tooth
    slot and a/D 0.25 are the same bits with and without it, and the four-tooth slot's columns are the zero-order
    engine's."""
    from millstab.stability import zoa

    batch = _random_batch(2, 7)
    slot4 = Cutting(4, KT, 0.3, 0.0, math.pi)
    cond = Conditions.of((slot4, Cutting(3, KT, 0.3, 0.0, math.pi), Cutting.from_immersion(4, KT, 0.3, 0.25, "up")),
                         [0, 1, 2, 0, 1, 2])
    rpm = np.array([6000.0, 6000.0, 6000.0, 9000.0, 9000.0, 9000.0])
    on = spectral.envelope_batch(batch, cond, rpm)
    np.testing.assert_array_equal(on[:, [0, 3]], zoa.envelope_batch(batch, slot4, rpm[[0, 3]]))
    assert spectral.settings(batch, slot4, rpm[:2], purpose="sample") == {}  # nothing to discretise
    monkeypatch.setattr(spectral, "INVARIANT_BY_ZOA", False)
    off = spectral.envelope_batch(batch, cond, rpm)
    np.testing.assert_array_equal(on[:, [1, 2, 4, 5]], off[:, [1, 2, 4, 5]])
    np.testing.assert_allclose(on[:, [0, 3]], off[:, [0, 3]], rtol=5e-3)
