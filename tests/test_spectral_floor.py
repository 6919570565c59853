"""The spectral engine's floor (issue 28; ``envelope_batch(..., floor=...)``, the mirror of the ceiling): at a speed
with a floor F, the exact ρ at the search from below's highest ladder rung x_k ≤ 0.997 F; where it is unstable the
limit is below x_k/0.998 < F and x_k is returned without a search, elsewhere the search runs as without a floor.

Checked against the plain search (no floor) and an independent ρ (:func:`spectral.rho_map`: numpy's eigenvalues of the
full monodromy): a floored answer is x_k, below F, and the plain limit is below it; ρ(x_k) > 1 exactly where the
answer was floored; every other depth is the plain one bit for bit (sparse speeds, and a dense run whose speeds
continue their branches); a limit below x_k that was not floored has a stable x_k (a band below it)."""

from __future__ import annotations

import numpy as np
import pytest

from millstab.errors import InputError
from millstab.frf import ModalBatch
from millstab.io import load_config
from millstab.io.config import PriorTable
from millstab.model import Cutting
from millstab.stability import _spectral_kernel as _k
from millstab.stability import spectral
from millstab.update import make_prior
from spectral_cases import random_case

NODES = 6


def _check(batch: ModalBatch, structures, cut: Cutting, rpm: np.ndarray, floor: np.ndarray) -> tuple[int, int]:
    """The assertions of the module docstring on one batch at ascending speeds rpm; (floored, entries below x_k)."""
    plain, _, _ = spectral._limit(batch, cut, rpm, NODES, warm=False)
    depth, mu, _ = spectral._limit(batch, cut, rpm, NODES, warm=False, floor=floor)
    floored = mu == complex(_k.FLOORED, 0.0)
    np.testing.assert_array_equal(depth[~floored], plain[~floored])  # bit for bit
    b_ref = spectral._b_ref(batch, cut, rpm)
    last = spectral._block_starts(batch, cut, rpm, NODES)[1:] - 1  # a run's last speed: the only one floored
    assert not floored[:, np.setdiff1d(np.arange(rpm.size), last)].any()
    below = 0
    for i, j in zip(*np.nonzero(floor[:, last] > 0)):
        j = last[j]
        k, x = _k.floor_rung(b_ref[i, j], spectral.LADDER, floor[i, j])
        if k < 0 or not b_ref[i, j] <= spectral.FLOOR_GATE * floor[i, j]:  # no rung, or not tested (FLOOR_GATE)
            assert not floored[i, j]
            continue
        assert x <= _k.FLOOR_MARGIN * floor[i, j] and x == _k.ladder_depth(b_ref[i, j], spectral.LADDER, k)
        rho = spectral.rho_map(structures[i], cut, [rpm[j]], [x], NODES)[0, 0]
        if abs(rho - 1.0) < 1e-9:  # on the unit circle to rounding: the two eigenvalue paths may disagree
            continue
        assert floored[i, j] == (rho > 1.0), (i, j, rho, plain[i, j], x)
        if floored[i, j]:
            assert depth[i, j] == x < floor[i, j] and plain[i, j] <= x / 0.998
        elif plain[i, j] < x:  # a limit below a stable rung: a band under it, which the search from below found
            below += 1
            assert rho < 1.0
    return int(floored.sum()), below


@pytest.fixture(scope="module")
def prior_case():
    """Example 1 at a/D 0.1 down milling (docs/updating.md's low-immersion case), 24 prior draws."""
    cfg = load_config("example:ex1")
    cut = Cutting.from_immersion(cfg.cutting.teeth, cfg.cutting.kt, cfg.cutting.kr, 0.1, "down")
    prior = make_prior(cfg.structure, cut, PriorTable({}, sigma_depth_rel=0.05))
    u = prior.sample_full(24, np.random.default_rng(7))[:, :prior.size]
    theta, _ = prior.split(u)
    return prior.par.batch(theta), [prior.par.structure(t) for t in theta], cut


@pytest.fixture
def everywhere(monkeypatch):
    """A floor tested at every entry (:data:`spectral.FLOOR_GATE` inf)."""
    monkeypatch.setattr(spectral, "FLOOR_GATE", np.inf)


def test_floored_answers_on_prior_draws_at_sparse_speeds(prior_case, everywhere):
    """Floors from 0.4 to 2.5 times each plain limit at 6 sparse speeds (each its own run): about half floored."""
    batch, structures, cut = prior_case
    rpm = np.array([5116.0, 6889.0, 8805.0, 10106.0, 11546.0, 14020.0])
    plain = spectral.envelope_batch(batch, cut, rpm, nodes=NODES, warm=False)
    floor = np.where(np.isfinite(plain), plain * np.random.default_rng(1).uniform(0.4, 2.5, plain.shape), 0.0)
    n_floored, _ = _check(batch, structures, cut, rpm, floor)
    assert 0.3 * floor.size < n_floored < 0.8 * floor.size


def test_floored_answers_with_the_default_gate(prior_case):
    """The default :data:`spectral.FLOOR_GATE`: a floor tested only where the zero-order depth is at most that multiple
    of it; the same checks, fewer floored."""
    batch, structures, cut = prior_case
    rpm = np.array([5116.0, 8805.0, 11546.0])
    plain = spectral.envelope_batch(batch, cut, rpm, nodes=NODES, warm=False)
    floor = np.where(np.isfinite(plain), plain * np.random.default_rng(2).uniform(0.4, 2.5, plain.shape), 0.0)
    assert _check(batch, structures, cut, rpm, floor)[0] > 0.1 * floor.size


def test_floored_answers_on_random_structures_and_a_dense_run(everywhere):
    """Random structures and cuts (up and down milling, a/D 0.03–1), 5 sparse speeds and 12 dense ones (a run that
    continues its branches: only its last speed may be floored, every other depth is the plain one bit for bit)."""
    rng = np.random.default_rng(11)
    n_floored = 0
    for _ in range(6):
        structure, cut = random_case(rng)
        batch = ModalBatch.from_structures([structure])
        for rpm in (np.sort(rng.uniform(4000, 25000, 5)), np.linspace(9000, 9300, 12)):
            plain = spectral.envelope_batch(batch, cut, rpm, nodes=NODES, warm=False)
            floor = np.where(np.isfinite(plain), plain * rng.uniform(0.5, 3.0, plain.shape), 0.0)
            n_floored += _check(batch, [structure], cut, rpm, floor)[0]
    assert n_floored >= 10


def test_no_floor_tested_outside_the_gate_and_bad_floors(prior_case, everywhere, monkeypatch):
    batch, _, cut = prior_case
    rpm = np.array([6889.0, 10106.0])
    plain = spectral.envelope_batch(batch, cut, rpm, nodes=NODES, warm=False)
    floor = np.where(np.isfinite(plain), 3.0 * plain, 0.0)
    depth, mu, _ = spectral._limit(batch, cut, rpm, NODES, warm=False, floor=floor)
    assert np.all(mu[floor > 0] == complex(_k.FLOORED, 0.0))  # every limit is far below its floor here
    monkeypatch.setattr(spectral, "FLOOR_GATE", 0.0)  # the zero-order depth is never below 0 × the floor
    np.testing.assert_array_equal(spectral.envelope_batch(batch, cut, rpm, nodes=NODES, warm=False, floor=floor), plain)
    with pytest.raises(InputError, match="floor"):
        spectral.envelope_batch(batch, cut, rpm, nodes=NODES, floor=floor[:, :1])
    with pytest.raises(InputError, match="floor"):
        spectral.envelope_batch(batch, cut, rpm, nodes=NODES, floor=np.full(floor.shape, np.nan))
