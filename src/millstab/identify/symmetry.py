"""The x ↔ y symmetries of the zero-order SLD: which cuts leave it unchanged under swapping x and y
(:func:`xy_symmetric_cut`, :func:`swap_permutation`), the generalised mode exchange of every cut with
α_xx α_yy > 0 (:func:`exchange_map`), the canonical member of a symmetric pair, and the notes a fit
reports about them. Parameters θ in Hz, N/m, -.
"""

from __future__ import annotations

import math

import numpy as np

from millstab.model import Cutting
from millstab.params import Parameterization
from millstab.stability import directional_matrix, get_engine


def xy_symmetric_cut(cutting: Cutting, tol: float = 1e-9) -> bool:
    """True when swapping x and y leaves every zero-order SLD unchanged exactly.

    With G = diag(g_x, g_y), swapping x and y turns the eigenvalues of [α][G] into those of
    P[α]P·G (P the swap); P[α]P equals [α]ᵀ (so the spectrum is unchanged: spec(αᵀG) = spec(Gα) = spec(αG))
    exactly when α_xx = α_yy, which holds for slotting (and a few other immersions).
    """
    a = directional_matrix(cutting)
    return abs(a[0, 0] - a[1, 1]) <= tol * max(1.0, np.abs(a).max())


def swap_permutation(par: Parameterization, cutting: Cutting) -> np.ndarray | None:
    """Index permutation of θ that swaps x and y, when that swap is an exact symmetry of the data.

    ``None`` unless: the cut is x/y symmetric (:func:`xy_symmetric_cut`), the tool is not tied
    (axisymmetric), x and y have the same number of modes, every free name's x↔y partner is free, and
    every fixed value equals its partner's.
    """
    if not xy_symmetric_cut(cutting):
        return None
    return _partner_permutation(par, 1.0)


def _partner_permutation(par: Parameterization, r: float) -> np.ndarray | None:
    """Index permutation of θ exchanging every free x parameter with its y partner, or ``None``.

    ``None`` when the tool is tied (axisymmetric), the mode counts differ, a free name's partner is not
    free, a fixed value differs from its partner's, a stiffness is fixed while the exchange rescales
    stiffnesses (r ≠ 1), or the permutation is the identity.
    """
    if par.axisymmetric or len(par.base.x) != len(par.base.y):
        return None
    swapped = [n.replace("_x", "_#").replace("_y", "_x").replace("_#", "_y") for n in par.free]
    if any(s not in par.free for s in swapped):
        return None
    free_slots = {s for n in par.free for s in par._slots(n)}
    for i, (mx, my) in enumerate(zip(par.base.x, par.base.y)):
        for p in ("fn", "k", "zeta"):
            fixed_x, fixed_y = ("x", i, p) not in free_slots, ("y", i, p) not in free_slots
            if fixed_x != fixed_y:
                return None
            if fixed_x and ((p == "k" and r != 1.0) or getattr(mx, p) != getattr(my, p)):
                return None  # (a fixed stiffness pair cannot follow the k_x' = r k_y scaling)
    perm = np.array([par.free.index(s) for s in swapped])
    return None if np.array_equal(perm, np.arange(par.size)) else perm


def exchange_map(par: Parameterization, cutting: Cutting, engine: str = "zoa") -> tuple[np.ndarray, np.ndarray] | None:
    """The generalised x↔y mode exchange that leaves every zero-order SLD unchanged exactly.

    The zero-order boundary depends only on the eigenvalues of [α][G], G = diag(g_x, g_y), i.e. on
    tr = α_xx g_x + α_yy g_y and det = det[α] g_x g_y. Exchanging the x and y modes (fn, ζ swapped) and
    scaling the stiffnesses k_x' = r k_y, k_y' = k_x / r with r = α_xx/α_yy (so g_x' = g_y/r, g_y' = r g_x)
    keeps both, for EVERY cut with α_xx α_yy > 0 — not only when α_xx = α_yy (r = 1, slotting, see
    :func:`swap_permutation`). Such a cut cannot tell the two structures apart from its boundary.

    Returns (perm, shift): θ' = θ[perm] · exp(shift) (shift = ±ln r on the k columns), or ``None`` when
    the engine's x↔y exchange is not exact (``exact_xy_exchange``: zoa only), the tool is tied, the mode counts differ,
    a free name's partner is not free, a fixed value differs from its partner's (or a stiffness is fixed while r ≠ 1),
    or α_xx α_yy ≤ 0.
    """
    if not get_engine(engine).exact_xy_exchange:
        return None
    a = directional_matrix(cutting)
    if not a[0, 0] * a[1, 1] > 0:
        return None
    r = float(a[0, 0] / a[1, 1])
    if abs(r - 1) <= 1e-9:
        r = 1.0
    perm = _partner_permutation(par, r)
    if perm is None:
        return None
    shift = np.zeros(par.size)
    for j, n in enumerate(par.free):
        if par.kind(n) == "k":
            shift[j] = math.log(r) if "_x" in n else -math.log(r)
    return perm, shift


def exchanged(theta: np.ndarray, xmap: tuple[np.ndarray, np.ndarray] | None) -> np.ndarray:
    """θ (P,) or (B, P) after the exchange ``xmap`` of :func:`exchange_map` (θ itself when ``None``)."""
    t = np.asarray(theta, dtype=float)
    if xmap is None:
        return t.copy()
    perm, shift = xmap
    return t[..., perm] * np.exp(shift)


def canonical(theta: np.ndarray, perm: np.ndarray | None) -> np.ndarray:
    """The canonical member of {θ, θ[perm]}: the one whose first differing x/y pair (in the order of the
    free names, fn first) has the smaller x value, so fn_x ≤ fn_y when they differ. Works on (P,) or (B, P)."""
    t = np.asarray(theta, dtype=float)
    if perm is None:
        return t.copy()
    single = t.ndim == 1
    t2 = np.atleast_2d(t)
    s = t2[:, perm]
    diff = t2 - s
    # first column where θ and its swap differ by more than round-off decides
    big = np.abs(diff) > 1e-12 * np.abs(t2)
    first = np.where(big.any(axis=1), big.argmax(axis=1), 0)
    take_swap = diff[np.arange(t2.shape[0]), first] > 0
    out = np.where(take_swap[:, None], s, t2)
    return out[0] if single else out


def xy_symmetry_note(order: str) -> tuple[str, str]:
    """(``Fit.symmetry`` text, warning text) for a cut whose SLD is unchanged by swapping x and y;
    ``order`` says how the estimate was put in canonical order."""
    symmetry = ("x and y are interchangeable: swapping the x and y parameters leaves this cut's SLD unchanged "
                f"exactly (α_xx = α_yy, e.g. slotting); the estimate is given in canonical order {order}")
    return symmetry, "x/y symmetry: " + symmetry.split(":", 1)[1].strip()


def exchange_note(cutting: Cutting) -> tuple[str, str]:
    """(``Fit.symmetry`` text, warning text) for the zero-order x↔y mode exchange of this cut."""
    a_dir = directional_matrix(cutting)
    symmetry = (f"x and y modes are exchangeable: with α_xx/α_yy = {a_dir[0, 0] / a_dir[1, 1]:.4g} for this cut, "
                "exchanging (fn, ζ) of x and y and scaling k_x' = (α_xx/α_yy) k_y, k_y' = k_x (α_yy/α_xx) leaves the "
                "zero-order SLD unchanged exactly; the points cannot tell the two structures apart "
                "(the exchanged estimate is listed in alternatives)")
    return symmetry, "x/y exchange: " + symmetry.split(":", 1)[1].strip()


__all__ = ["canonical", "exchange_map", "exchange_note", "exchanged", "swap_permutation", "xy_symmetric_cut",
           "xy_symmetry_note"]
