"""Timoshenko beams by finite elements: a tool (or artifact, or holder) as stepped circular sections, and its
receptances between any node's translation w [m] and rotation θ [rad].

Conventions (used by the whole :mod:`millstab.tooltip` package): the beam axis z runs from the holder face
(z = 0, the *coupling end*) to the free end (z = L, the tool tip); w is the lateral displacement, θ the
rotation of the cross-section, positive where w grows with z (θ = dw/dz for a slender beam). The loads
conjugate to (w, θ) are a force f [N] and a moment m [N·m]; a receptance matrix per point pair is
[[h, l], [n, p]] = [[w/f, w/m], [θ/f, θ/m]] in m/N, m/(N·m) = 1/N, rad/N, rad/(N·m).

Element: the 2-node Timoshenko element with interdependent (exact static) interpolation — cubic w, quadratic
θ, shear parameter Φ = 12EI/(κGAℓ²) — with the consistent translational and rotary-inertia mass matrices
(Przemieniecki 1968; Friedman & Kosmatka 1993, Comput. Struct. 47:473). It is free of shear locking and its
static tip deflection of a uniform cantilever is exact for any element count; natural frequencies converge
as ℓ² (measured: a carbide cantilever of 2 D with 24 elements has f1, f2, f3 within 3e-5, 5e-4, 2e-3 of the
exact Timoshenko values, with 48 elements 4× closer; tests/test_tooltip.py checks against the exact
transfer-matrix solution of the Timoshenko equations). Shear coefficient of a solid circular section: Cowper
(1966), κ = 6(1+ν)/(7+6ν); of a hollow one with inner/outer ratio m:
κ = 6(1+ν)(1+m²)²/((7+6ν)(1+m²)² + (20+12ν)m²).

Damping: a structural (hysteretic) loss factor η on the stiffness, K(1+iη) — each mode then has the
resonant damping ratio ζ = η/2, and two substructures with the same η couple into exactly the assembly with
that η (viscous modal damping would not: a coupled mode's damping is then no longer any substructure's).

Receptances come from the complete modal sum of the FE model (no truncation; rigid-body modes of a free beam
as −φφᵀ/ω²), vectorized over frequency: one symmetric eigen-solution per beam, then one array expression.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from millstab.errors import InputError


@dataclass(frozen=True)
class Material:
    """An isotropic elastic material: Young's modulus ``E`` [Pa], density [kg/m³], Poisson's ratio ``nu``."""

    name: str
    E: float
    density: float
    nu: float
    source: str = ""

    def __post_init__(self) -> None:
        for f, v, lo in (("E", self.E, 1e8), ("density", self.density, 100.0)):
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise InputError(f"material.{f}", v, "must be a finite number > 0 (SI: Pa, kg/m^3)")
        if not -1.0 < self.nu < 0.5:
            raise InputError("material.nu", self.nu, "Poisson's ratio must be in (-1, 0.5)")

    @property
    def G(self) -> float:
        """Shear modulus E/(2(1+ν)) [Pa]."""
        return self.E / (2.0 * (1.0 + self.nu))


#: materials a config may name; handbook room-temperature values (ranges in docs/tooltip.md)
MATERIALS: dict[str, Material] = {
    "carbide": Material("carbide", 600e9, 14600.0, 0.22,
                        "cemented tungsten carbide WC-Co, ~10 % Co (handbook range E 530-650 GPa, "
                        "14 400-15 000 kg/m^3)"),
    "steel": Material("steel", 200e9, 7800.0, 0.29, "carbon/low-alloy steel (e.g. AISI 4140: 205 GPa, 7850 kg/m^3)"),
    "hss": Material("hss", 215e9, 8150.0, 0.29, "high-speed steel (M2: ~210-220 GPa, 8 100-8 200 kg/m^3)"),
    "aluminium": Material("aluminium", 70e9, 2700.0, 0.33, "aluminium alloys (e.g. 7075: 71.7 GPa, 2 810 kg/m^3)"),
}


def material(name: str) -> Material:
    """A named material from :data:`MATERIALS` (case-insensitive; ``aluminum`` also works)."""
    key = str(name).strip().lower().replace("aluminum", "aluminium")
    if key not in MATERIALS:
        known = "; ".join(f"{m.name}: E {m.E / 1e9:g} GPa, density {m.density:g} kg/m^3, nu {m.nu:g} ({m.source})"
                          for m in MATERIALS.values())
        raise InputError("material", name, f"unknown material; known: {known}; or give E and density")
    return MATERIALS[key]


def cowper_kappa(nu: float, inner_ratio: float = 0.0) -> float:
    """Cowper's (1966) shear coefficient of a circular (hollow: inner/outer diameter ``inner_ratio``) section."""
    m2 = inner_ratio * inner_ratio
    a = (1.0 + m2) ** 2
    return 6.0 * (1.0 + nu) * a / ((7.0 + 6.0 * nu) * a + (20.0 + 12.0 * nu) * m2)


@dataclass(frozen=True)
class Section:
    """A uniform circular section of a stepped beam: ``length`` [m], outer ``diameter`` [m], ``inner`` bore
    diameter [m] (0: solid), ``material``."""

    length: float
    diameter: float
    material: Material
    inner: float = 0.0

    def __post_init__(self) -> None:
        for f in ("length", "diameter"):
            v = getattr(self, f)
            if not (math.isfinite(v) and v > 0):
                raise InputError(f"section.{f}", v, "must be a finite length > 0 m")
        if not 0.0 <= self.inner < self.diameter:
            raise InputError("section.inner", self.inner, f"bore must be in [0, diameter = {self.diameter:g} m)")

    @property
    def area(self) -> float:
        return math.pi / 4.0 * (self.diameter**2 - self.inner**2)

    @property
    def inertia(self) -> float:
        """Second moment of area [m⁴]."""
        return math.pi / 64.0 * (self.diameter**4 - self.inner**4)

    @property
    def kappa(self) -> float:
        return cowper_kappa(self.material.nu, self.inner / self.diameter)

    @property
    def shear_stiffness(self) -> float:
        """κGA [N]."""
        return self.kappa * self.material.G * self.area


#: elements per beam when the caller gives none: a uniform carbide cantilever of 2 D (the stubbiest,
#: slowest-converging case) then has f1, f2, f3 within 1.1e-5, 1.7e-4, 7.4e-4 of the exact Timoshenko values
#: (tests/test_tooltip.py, convergence test); 40 elements cost ~1 ms per eigen-solution
DEFAULT_ELEMENTS = 40


@dataclass(frozen=True)
class Beam:
    """A stepped beam: ``sections`` from the coupling end (z = 0) to the free end, loss factor ``eta``.

    ``elements``: total FE elements, spread over the sections by length (at least 2 per section).
    """

    sections: tuple[Section, ...]
    eta: float = 0.0
    elements: int = DEFAULT_ELEMENTS

    def __post_init__(self) -> None:
        object.__setattr__(self, "sections", tuple(self.sections))
        if not self.sections:
            raise InputError("beam.sections", "()", "need at least one section")
        if not (math.isfinite(self.eta) and 0.0 <= self.eta < 1.0):
            raise InputError("beam.eta", self.eta, "loss factor must be in [0, 1) (eta = 2 zeta)")

    @property
    def length(self) -> float:
        return float(sum(s.length for s in self.sections))

    def mesh(self) -> tuple[np.ndarray, list[Section]]:
        """Node positions z (n+1,) [m] and the section of each of the n elements."""
        total = self.length
        counts = [max(2, round(self.elements * s.length / total)) for s in self.sections]
        z = [0.0]
        secs: list[Section] = []
        for s, n in zip(self.sections, counts):
            z.extend(z[-1] + s.length * np.arange(1, n + 1) / n)
            secs.extend([s] * n)
        return np.asarray(z), secs

    def node(self, z: float) -> int:
        """The index of the node at position ``z`` [m] (to 1e-9 of the length), else an InputError."""
        zs, _ = self.mesh()
        i = int(np.argmin(np.abs(zs - z)))
        if abs(zs[i] - z) > 1e-9 * self.length:
            raise InputError("beam point", z, "is no node of the mesh: start a section there")
        return i

    def matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """Global stiffness and mass matrices (undamped), DOFs [w0, θ0, w1, θ1, ...]."""
        z, secs = self.mesh()
        n = 2 * z.size
        K = np.zeros((n, n))
        M = np.zeros((n, n))
        for e, s in enumerate(secs):
            ke, me = element_matrices(z[e + 1] - z[e], s)
            K[2 * e:2 * e + 4, 2 * e:2 * e + 4] += ke
            M[2 * e:2 * e + 4, 2 * e:2 * e + 4] += me
        return K, M

    def modes(self, clamped: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Undamped modes: eigenvalues ω² (R,) [rad²/s²] ascending and mass-normalised shapes (2(n+1), R).

        ``clamped``: the coupling end (node 0) fixed; its rows of the shapes are zero. A free beam's two
        rigid-body eigenvalues are set to exactly 0 (they come out as ±1e-10 of the largest).
        """
        return _modes(self, clamped)

    def receptance(self, freq_hz: np.ndarray, dofs: Sequence[int], clamped: bool = False) -> np.ndarray:
        """Receptances between the FE DOFs ``dofs`` (2·node for w, 2·node+1 for θ), shape (F, D, D).

        Σ_r φ_r φ_rᵀ/(ω_r²(1 + iη) − ω²) over every mode of the model (see the module doc for units).
        """
        lam, phi = self.modes(clamped)
        return modal_receptance(freq_hz, lam, phi[list(dofs)], self.eta)

    def end_receptances(self, freq_hz: np.ndarray) -> np.ndarray:
        """Free–free receptances between the ends, (F, 4, 4), DOF order [w_a, θ_a, w_b, θ_b]
        (a: coupling end z = 0, b: free end z = L)."""
        last = 2 * (self.mesh()[0].size - 1)
        return self.receptance(freq_hz, [0, 1, last, last + 1])


@functools.lru_cache(maxsize=1)
def _blas_controller():
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()  # built once: each threadpool_limits() call would scan the libraries again


def one_blas_thread():
    """A context in which BLAS runs on one thread: the FE problems here are ~80×80 and the modal sums
    (F, 82) @ (82, 16); BLAS threads only cost (an eigen-solution took 0.5 s instead of 1 ms, a modal sum
    3× longer, on the busy 2-core machine)."""
    return _blas_controller().limit(limits=1, user_api="blas")


@functools.lru_cache(maxsize=64)
def _modes(beam: Beam, clamped: bool) -> tuple[np.ndarray, np.ndarray]:
    """Cached per beam: a tip grid asks for the same beam's modes 3 times, a sweep once per stickout."""
    import scipy.linalg

    K, M = beam.matrices()
    keep = np.arange(2 if clamped else 0, K.shape[0])
    with one_blas_thread():
        lam, phi = scipy.linalg.eigh(K[np.ix_(keep, keep)], M[np.ix_(keep, keep)])
    if not clamped:
        lam[:2] = 0.0
    shapes = np.zeros((K.shape[0], lam.size))
    shapes[keep] = phi
    lam.flags.writeable = False
    shapes.flags.writeable = False
    return lam, shapes


def modal_receptance(freq_hz: np.ndarray, lam: np.ndarray, phi: np.ndarray, eta: float) -> np.ndarray:
    """Σ_r φ_r φ_rᵀ/(λ_r(1 + iη) − ω²): (F, D, D) from eigenvalues λ (R,) and shapes φ (D, R)."""
    w2 = (2.0 * math.pi * np.asarray(freq_hz, dtype=float)) ** 2
    if np.any(w2 <= 0):
        raise InputError("frequency", float(np.min(freq_hz)), "receptances need frequencies > 0 Hz")
    den = 1.0 / (lam[None, :] * (1.0 + 1j * eta) - w2[:, None])  # (F, R)
    d = phi.shape[0]
    outer = (phi[:, None, :] * phi[None, :, :]).reshape(d * d, -1)  # (D², R)
    return (den @ outer.T.astype(complex)).reshape(-1, d, d)


def element_matrices(ell: float, s: Section) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and consistent mass (translational + rotary inertia) of one Timoshenko element of length
    ``ell`` [m], DOFs [w1, θ1, w2, θ2] (formulas of Przemieniecki 1968 / Friedman & Kosmatka 1993)."""
    m = s.material
    E, I, A = m.E, s.inertia, s.area
    phi = 12.0 * E * I / (s.kappa * m.G * A * ell**2)
    L = ell
    c = E * I / ((1.0 + phi) * L**3)
    k = c * np.array([[12, 6 * L, -12, 6 * L],
                      [6 * L, (4 + phi) * L**2, -6 * L, (2 - phi) * L**2],
                      [-12, -6 * L, 12, -6 * L],
                      [6 * L, (2 - phi) * L**2, -6 * L, (4 + phi) * L**2]])
    p = phi
    m1 = 13 / 35 + 7 / 10 * p + p**2 / 3
    m2 = (11 / 210 + 11 / 120 * p + p**2 / 24) * L
    m3 = 9 / 70 + 3 / 10 * p + p**2 / 6
    m4 = -(13 / 420 + 3 / 40 * p + p**2 / 24) * L
    m5 = (1 / 105 + p / 60 + p**2 / 120) * L**2
    m6 = -(1 / 140 + p / 60 + p**2 / 120) * L**2
    mt = m.density * A * L / (1 + p) ** 2 * np.array([[m1, m2, m3, m4],
                                                      [m2, m5, -m4, m6],
                                                      [m3, -m4, m1, -m2],
                                                      [m4, m6, -m2, m5]])
    r1 = 6 / 5
    r2 = (1 / 10 - p / 2) * L
    r3 = (2 / 15 + p / 6 + p**2 / 3) * L**2
    r4 = (-1 / 30 - p / 6 + p**2 / 6) * L**2
    mr = m.density * I / ((1 + p) ** 2 * L) * np.array([[r1, r2, -r1, r2],
                                                         [r2, r3, -r2, r4],
                                                         [-r1, -r2, r1, -r2],
                                                         [r2, r4, -r2, r3]])
    return k, mt + mr


__all__ = ["Beam", "DEFAULT_ELEMENTS", "MATERIALS", "Material", "Section", "cowper_kappa", "element_matrices",
           "material", "modal_receptance"]
