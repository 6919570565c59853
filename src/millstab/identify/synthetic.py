"""Synthetic boundary points: the limiting depth of a known structure at chosen speeds, with seeded noise.

The seed paper's Examples 1–3 are generated this way (its "SLD^exp" is the zero-order SLD of the
Table 1 parameters). The documented default speed set is ``N_SPEEDS = 100`` speeds evenly spaced over
the config's ``[speeds]`` range (start..stop inclusive).

Noise model: relative Gaussian, ``b_noisy = b · (1 + noise · z)``, z ~ N(0, 1) from
``numpy.random.default_rng(seed)`` (re-drawn where a depth would become ≤ 0.01 b).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from millstab.errors import InputError
from millstab.points import PointSet
from millstab.model import Cutting, Mode, Structure
from millstab.forward import forward, log_jacobian
from millstab.params import Parameterization

#: boundary points per synthetic example (the documented speed set)
N_SPEEDS = 100


def default_speeds(config, n: int = N_SPEEDS) -> np.ndarray:
    """``n`` speeds evenly spaced over the config's ``[speeds]`` range [rev/min] (inclusive)."""
    if config.rpm is None:
        raise InputError("speeds", None, "the config has no [speeds] table; pass rpm explicitly")
    return np.linspace(float(np.min(config.rpm)), float(np.max(config.rpm)), n)


def boundary_points(structure: Structure, cutting: Cutting, rpm, *, noise: float = 0.0, seed: int = 0,
                    engine: str = "zoa") -> PointSet:
    """Boundary points (rpm, depth_mm) of ``structure`` at speeds ``rpm`` [rev/min].

    Args:
        noise: relative standard deviation of the Gaussian depth noise (0.02 = 2 %); 0 = exact.
        seed: seed of the noise generator (same seed ⇒ same points).
    Raises:
        InputError: negative noise, or a speed where the structure has no finite limit.
    """
    if not (math.isfinite(noise) and noise >= 0):
        raise InputError("noise", noise, "relative noise must be a finite number >= 0")
    r = np.asarray(rpm, dtype=float)
    par = Parameterization(structure)  # all parameters free: θ0 reproduces the structure exactly
    depth = forward(par, cutting, engine)(par.theta0, r)[0] * 1e3
    if not np.isfinite(depth).all():
        raise InputError("rpm", float(r[~np.isfinite(depth)][0]), "no finite stability limit at this speed")
    if noise > 0:
        rng = np.random.default_rng(seed)
        factor = 1 + noise * rng.standard_normal(depth.size)
        while (factor <= 0.01).any():  # practically never for percent-level noise
            bad = factor <= 0.01
            factor[bad] = 1 + noise * rng.standard_normal(int(bad.sum()))
        depth = depth * factor
    return PointSet(r, depth)


def example_points(name: str, *, n: int = N_SPEEDS, noise: float = 0.0, seed: int = 0, engine: str = "zoa"):
    """(config, points) for a packaged example: its true structure's boundary at :func:`default_speeds`."""
    from millstab.datasets import load_example

    cfg = load_example(name)
    return cfg, boundary_points(cfg.structure, cfg.cutting, default_speeds(cfg, n), noise=noise, seed=seed,
                                engine=engine)


@dataclass(frozen=True)
class RandomCase:
    """A random identification case for robustness studies.

    Attributes: structure (the truth), cutting, rpm (speeds of the points) [rev/min], start (a structure
    whose every parameter is the truth's times a factor in [1 − spread, 1 + spread]).
    """

    structure: Structure
    cutting: Cutting
    rpm: np.ndarray
    start: Structure


def random_case(rng: np.random.Generator, *, spread: float = 0.3, n: int = N_SPEEDS, fn_ratio: float = 1.5,
                band: tuple[float, float] = (0.1, 0.6)) -> RandomCase:
    """Draw a case: fn_x 300–5000 Hz, fn_y = fn_x ×/÷ up to ``fn_ratio`` (log-uniform; a tool's two
    bending modes sit close together, and a mode far from the other is often invisible in the
    boundary), k 2–50 N/µm and ζ 0.005–0.08 (log-uniform, independently in x and y), 2–6 teeth,
    radial immersion a/D 0.05–1 (uniform), up or down milling, Kt 600–2500 MPa, Kr 0.1–0.5.

    The speeds: n evenly spaced speeds whose tooth-passing frequencies span ``band`` (default 0.1–0.6)
    of the lower natural frequency (0.1–0.6: about lobes k = 1..9 of that mode). The start: every parameter of the truth
    times an independent factor uniform in [1 − spread, 1 + spread].
    """
    lu = lambda lo, hi: float(math.exp(rng.uniform(math.log(lo), math.log(hi))))  # noqa: E731
    fn_x = lu(300, 5000)
    fn_y = fn_x * lu(1 / fn_ratio, fn_ratio)
    modes = {d: Mode(fn, lu(2e6, 50e6), lu(0.005, 0.08), f"structure.{d}[0]") for d, fn in (("x", fn_x), ("y", fn_y))}
    teeth = int(rng.integers(2, 7))
    ri = float(rng.uniform(0.05, 1.0))
    milling = "down" if rng.random() < 0.5 else "up"
    cutting = Cutting.from_immersion(teeth, rng.uniform(600e6, 2500e6), rng.uniform(0.1, 0.5), ri, milling)
    f_lo = min(modes["x"].fn, modes["y"].fn)
    rpm = np.linspace(band[0], band[1], n) * 60 * f_lo / teeth
    f = lambda: float(rng.uniform(1 - spread, 1 + spread))  # noqa: E731
    start = Structure(x=(Mode(modes["x"].fn * f(), modes["x"].k * f(), modes["x"].zeta * f(), "structure.x[0]"),),
                      y=(Mode(modes["y"].fn * f(), modes["y"].k * f(), modes["y"].zeta * f(), "structure.y[0]"),))
    return RandomCase(Structure(x=(modes["x"],), y=(modes["y"],)), cutting, rpm, start)


def identifiability(structure: Structure, cutting: Cutting, rpm, *, engine: str = "zoa") -> float:
    """Smallest singular value of J/√n at the truth: J = ∂ ln b_i / ∂ ln θ_j (central differences, one
    batched engine call) over all six parameters. A 1 % change along the worst-determined parameter
    combination moves the boundary by this × 1 % RMS; near 0 the points cannot determine that
    combination (e.g. a mode too stiff or too far from the speeds to show in the boundary)."""
    par = Parameterization(structure)
    jac = log_jacobian(forward(par, cutting, engine), par.theta0, rpm, rel_step=1e-4, central=True)[0]
    return float(np.linalg.svd(jac / math.sqrt(jac.shape[0]), compute_uv=False)[-1])


__all__ = ["N_SPEEDS", "RandomCase", "boundary_points", "default_speeds", "example_points", "identifiability",
           "random_case"]
