"""Receptance coupling (RCSA): the tool tip of a tool rigidly joined to the holder face.

Substructure A, the tool as a free–free beam: coordinate 1 its tip, coordinate 2 its end at the holder face.
Substructure B, the spindle–holder: coordinate 3 its face. Every coordinate carries (w, θ) and the loads
(f, m); a receptance block is R_ij = [[h, l], [n, p]] (units and signs in :mod:`millstab.tooltip.beam`: the
axis z runs from the face to the tip for both substructures).

Rigid joint of 2 and 3 (same displacement and rotation, internal loads q₂ + q₃ = 0) under an external load
Q₁ at the tip:

    u₁ = R₁₁Q₁ + R₁₂q₂,   u₂ = R₂₁Q₁ + R₂₂q₂,   u₃ = R₃₃q₃ = −R₃₃q₂,   u₂ = u₃
    ⇒ q₂ = −(R₂₂ + R₃₃)⁻¹R₂₁Q₁   ⇒   G₁₁ = R₁₁ − R₁₂(R₂₂ + R₃₃)⁻¹R₂₁.

G₁₁[0, 0] is the tool-tip FRF w/f that chatter needs. A rigid holder is R₃₃ = 0 (the tool clamped at the
face). The joint's own flexibility (contact stiffness of a shrink fit, collet) is not modelled: give it as
part of a measured R₃₃ (an artifact test in the same holder type includes it) — see docs/tooltip.md.
"""

from __future__ import annotations

import numpy as np

from millstab.errors import InputError


def couple(tool: np.ndarray, holder: np.ndarray | None) -> np.ndarray:
    """The coupled tip receptance matrix G₁₁ (F, 2, 2) from the tool's free–free end receptances ``tool``
    (F, 4, 4), DOF order [w₂, θ₂, w₁, θ₁] (face end first, as :meth:`Beam.end_receptances` returns them),
    and the holder-face matrix ``holder`` (F, 2, 2) = [[H, L], [N, P]] (``None``: rigid holder)."""
    r = np.asarray(tool)
    if r.ndim != 3 or r.shape[1:] != (4, 4):
        raise InputError("tool receptances", r.shape, "must be (F, 4, 4)")
    r22, r21 = r[:, :2, :2], r[:, :2, 2:]
    r12, r11 = r[:, 2:, :2], r[:, 2:, 2:]
    s = r22 if holder is None else r22 + np.asarray(holder)
    return r11 - r12 @ _inv2(s) @ r21


def _inv2(a: np.ndarray) -> np.ndarray:
    """Inverses of (F, 2, 2) matrices in closed form (4× faster than a batched LU for 2×2)."""
    det = a[:, 0, 0] * a[:, 1, 1] - a[:, 0, 1] * a[:, 1, 0]
    out = np.empty_like(a)
    out[:, 0, 0], out[:, 1, 1] = a[:, 1, 1] / det, a[:, 0, 0] / det
    out[:, 0, 1], out[:, 1, 0] = -a[:, 0, 1] / det, -a[:, 1, 0] / det
    return out


def decouple_artifact(art: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """Inverse RCSA: the holder-face matrix R₃₃ (F, 2, 2) from translational FRFs measured on an artifact.

    Args:
        art: the artifact's free–free receptances (F, 4, 4), DOF order [w₂, θ₂, w_j, w_k]: its face end
            (2) and two measured points j, k (the tip and a point at a known offset).
        measured: (F, 3) the assembly's measured FRFs G_jj, G_jk (= G_kj), G_kk [m/N].

    Each measured translational FRF of the assembly is G_jk = R_jk − a_jᵀ X a_k with a_j = [h_j2, l_j2]
    (the artifact's receptances from the face loads to w_j) and X = (R₂₂ + R₃₃)⁻¹, symmetric: three
    equations, linear in X's three entries, per frequency (Park, Altintas & Movahhedy 2003, Int. J. Mach.
    Tools Manuf. 43:889). Then R₃₃ = X⁻¹ − R₂₂, symmetric (L = N) by construction.
    """
    a = np.asarray(art)
    g = np.asarray(measured)
    if a.ndim != 3 or a.shape[1:] != (4, 4) or g.shape != (a.shape[0], 3):
        raise InputError("artifact receptances", (a.shape, g.shape), "need (F, 4, 4) and (F, 3)")
    aj, ak = a[:, 2, :2], a[:, 3, :2]
    pairs = ((aj, aj, a[:, 2, 2]), (aj, ak, a[:, 2, 3]), (ak, ak, a[:, 3, 3]))
    C = np.stack([np.stack([u[:, 0] * v[:, 0], u[:, 0] * v[:, 1] + u[:, 1] * v[:, 0], u[:, 1] * v[:, 1]], axis=-1)
                  for u, v, _ in pairs], axis=1)  # (F, 3 equations, 3 unknowns)
    rhs = np.stack([r - g[:, i] for i, (_, _, r) in enumerate(pairs)], axis=-1)
    x = np.linalg.solve(C, rhs[..., None])[..., 0]
    X = np.stack([np.stack([x[:, 0], x[:, 1]], -1), np.stack([x[:, 1], x[:, 2]], -1)], axis=1)
    return np.linalg.inv(X) - a[:, :2, :2]


__all__ = ["couple", "decouple_artifact"]
