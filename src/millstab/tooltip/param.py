"""θ = the holder-face modes → the tool TIP's modes at any stickout, for B parameter sets at once.

The Bayesian loop's parameterization of a ``[tool]`` + ``[holder]`` config whose holder is given by modes
(``[[holder.modes]]``, :class:`~millstab.tooltip.holder.ModalHolder`): the uncertain part is the
spindle–holder at its face (each mode's fn, k, ζ), the tool is known physics (the Timoshenko beam of
:mod:`.beam`). :class:`TipParameterization` is a :class:`~millstab.params.Parameterization` whose names,
bounds and θ0 are those of the holder modes (``fn``, ``k``, ``zeta`` or ``fn1``…, ``fn_x1``…) and whose
:meth:`~TipParameterization.batch` returns the TIP's modes at its stickout as a
:class:`~millstab.frf.ModalBatch`, so every consumer of a parameterization (the forward function, the
prior, the likelihood) works unchanged; :meth:`~TipParameterization.at` gives the same parameterization at
another stickout (one posterior, every stickout).

The coupled assembly, in the time domain (the same physics as the RCSA of :mod:`.rcsa`, another path):

* the tool beam, Craig–Bampton reduced at its face (the two face DOFs x_f = (w, θ) kept, the interior
  DOFs as the static constraint modes plus the first ``keep`` fixed-face modes η, mass-normalised):
  K = diag(K̂_ff, Λ), M = [[M̂_ff, M̂_fη], [M̂_ηf, I]] — computed once per stickout (one eigen-solution);
* the holder modes as unit-mass modal coordinates q_r with stiffness ω_r² and the face displacement
  x_f = Σ_r φ_r q_r, φ_r = (1, s_r)·ω_r/√k_r (s_r the mode's ``slope``): exactly the receptance
  R₃₃ = Σ φ_rφ_rᵀ/(ω_r² − ω² + 2iζ_rω_rω) of :class:`ModalHolder`;
* the rigid joint x_f(tool) = x_f(holder) eliminates x_f: coordinates (q, η), B generalized symmetric
  eigenproblems of size M + ``keep``, solved batched with numpy (Cholesky of the mass, ``eigh``).

Damping approximation: each coupled mode j (mass-normalised shape ψ_j, ω_j) gets the diagonal of the
modal damping, ζ_j = Σ_r 2ζ_rω_r ψ_qr²/(2ω_j) (the holder's viscous part) + (η/2)·E_beam,j/ω_j² (the
tool's loss factor η = 2ζ_tool times the share of the mode's strain energy in the beam); the off-diagonal
(modal coupling) terms are dropped. That is exact for one mode and first-order for light damping; it
fails only for coupled modes closer in frequency than their bandwidths. Measured against the RCSA tip FRF
of the same holder (tests/test_tooltip_param.py, 12–32 mm … 4–6 D, random holders): fn within 0.1 %, peak
receptance within 3 %.

Truncation: ``keep`` = :data:`DEFAULT_KEEP` fixed-face modes of the tool (the tip's first modes come from
the holder modes and the tool's first bending modes; the test shows the same fn to 1e-6 with every mode
kept). The tip modes returned are the ``n_tip`` lowest coupled modes (default: the holder's modes + 1, the
tool's first bending mode); the ones above carry little of the tip's compliance in the chatter band.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field, replace

import numpy as np

from millstab.errors import InputError
from millstab.frf import ModalBatch
from millstab.model import Mode, Structure
from millstab.params import Parameterization
from millstab.tooltip.beam import Beam, one_blas_thread
from millstab.tooltip.holder import ModalHolder, XYHolder
from millstab.tooltip.tool import Tool

#: fixed-face modes of the tool kept in the reduced assembly
DEFAULT_KEEP = 12


@functools.lru_cache(maxsize=32)
def reduced_tool(beam: Beam, keep: int | None = DEFAULT_KEEP) -> tuple[np.ndarray, ...]:
    """Craig–Bampton reduction of ``beam`` at its face (node 0): (K̂_ff (2, 2), M̂_ff (2, 2), M̂_fη (2, n),
    Λ (n,), tip row of the static modes (2,), tip row of the fixed-face modes (n,)); n = ``keep`` (None: all)."""
    import scipy.linalg

    K, M = beam.matrices()
    f, r = slice(0, 2), slice(2, None)
    with one_blas_thread():
        S = -np.linalg.solve(K[r, r], K[r, f])  # static constraint modes (R, 2)
        lam, phi = scipy.linalg.eigh(K[r, r], M[r, r])
    n = lam.size if keep is None else min(int(keep), lam.size)
    lam, phi = lam[:n], phi[:, :n]
    Kh = K[f, f] + K[f, r] @ S
    Mh = M[f, f] + M[f, r] @ S + S.T @ M[r, f] + S.T @ M[r, r] @ S
    Mfe = (M[f, r] + S.T @ M[r, r]) @ phi
    tip = K.shape[0] - 2 - 2  # w of the last node, in the interior numbering
    out = (Kh, Mh, Mfe, lam, S[tip].copy(), phi[tip].copy())
    for a in out:
        a.flags.writeable = False
    return out


def tip_modes(tool: Tool, fn: np.ndarray, k: np.ndarray, zeta: np.ndarray, slope: np.ndarray,
              n_tip: int | None = None, keep: int | None = DEFAULT_KEEP) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The tip's ``n_tip`` lowest modes (fn [Hz], k [N/m], ζ) (B, n_tip) of ``tool`` coupled to holder-face
    modes fn [Hz], k [N/m], ζ (B, M) with slopes [rad/m] (M,) or (B, M) (module docstring)."""
    fn, k, zeta = (np.atleast_2d(np.asarray(a, dtype=float)) for a in (fn, k, zeta))
    b, m = fn.shape
    s = np.broadcast_to(np.asarray(slope, dtype=float), (b, m))
    n_tip = m + 1 if n_tip is None else int(n_tip)
    Kh, Mh, Mfe, lam, t_s, t_e = reduced_tool(tool.beam(), keep)
    ne = lam.size
    if not 1 <= n_tip <= m + ne:
        raise InputError("tip modes", n_tip, f"must be 1..{m + ne} (holder modes + kept tool modes)")
    w = 2.0 * math.pi * fn
    P = np.stack([np.ones_like(s), s], axis=1) * (w / np.sqrt(k))[:, None, :]  # (B, 2, M): face shapes
    n = m + ne
    Ka = np.zeros((b, n, n))
    Ma = np.zeros((b, n, n))
    Kq = np.einsum("bim,ij,bjn->bmn", P, Kh, P)  # the beam's face stiffness seen by the holder modes
    Ka[:, :m, :m] = Kq + np.eye(m) * (w * w)[:, :, None]
    Ka[:, m:, m:] = np.diag(lam)
    Ma[:, :m, :m] = np.einsum("bim,ij,bjn->bmn", P, Mh, P) + np.eye(m)
    Ma[:, :m, m:] = np.einsum("bim,ie->bme", P, Mfe)
    Ma[:, m:, :m] = np.swapaxes(Ma[:, :m, m:], 1, 2)
    Ma[:, m:, m:] = np.eye(ne)
    with one_blas_thread():
        Li = np.linalg.inv(np.linalg.cholesky(Ma))  # M = L Lᵀ: A = L⁻¹ K L⁻ᵀ, ψ = L⁻ᵀ v
        A = Li @ Ka @ np.swapaxes(Li, 1, 2)
        ev, v = np.linalg.eigh(0.5 * (A + np.swapaxes(A, 1, 2)))
        psi = (np.swapaxes(Li, 1, 2) @ v)[:, :, :n_tip]  # (B, n, n_tip), mass-normalised
    om2 = ev[:, :n_tip]
    if not (om2 > 0).all():
        raise InputError("holder modes", "a coupled mode with ω² <= 0", "the holder's modes must be > 0 Hz and stiff")
    # the tip's displacement per coordinate: holder modes move the face (static modes), then the fixed-face modes
    tip_row = np.concatenate([np.einsum("i,bim->bm", t_s, P), np.broadcast_to(t_e, (b, ne))], axis=1)
    phi_tip = np.einsum("bn,bnj->bj", tip_row, psi)
    # damping: the diagonal of the modal damping (module docstring)
    c_hold = np.einsum("bm,bmj->bj", 2.0 * zeta * w, psi[:, :m, :] ** 2)
    e_beam = (np.einsum("bmj,bmn,bnj->bj", psi[:, :m, :], Kq, psi[:, :m, :])
              + np.einsum("e,bej->bj", lam, psi[:, m:, :] ** 2))
    omega = np.sqrt(om2)
    z = c_hold / (2.0 * omega) + tool.zeta * e_beam / om2
    with np.errstate(divide="ignore"):
        kt = om2 / (phi_tip * phi_tip)  # a mode with no tip motion is infinitely stiff there
    kt = np.minimum(kt, 1e30)
    return omega / (2.0 * math.pi), kt, np.clip(z, 1e-6, 0.99)


def holder_structure(holder: ModalHolder | XYHolder) -> tuple[Structure, bool, dict[str, np.ndarray]]:
    """(the holder modes as a :class:`Structure` (fn, k, ζ), axisymmetric?, slopes per direction) of a holder
    given by modes; InputError for any other holder (a measured or rigid holder has no modal parameters)."""
    parts = {"x": holder.x, "y": holder.y} if isinstance(holder, XYHolder) else {"x": holder, "y": holder}
    for d, h in parts.items():
        if not isinstance(h, ModalHolder):
            raise InputError("holder", h.describe(), "updating over the holder needs the holder as modes "
                             "([[holder.modes]]: fn, k, zeta, slope); fit modes to a measured holder first")
    modes = {d: tuple(Mode(m.fn, m.k, m.zeta, f"holder.modes[{i}]") for i, m in enumerate(h.modes))
             for d, h in parts.items()}
    slopes = {d: np.array([m.slope for m in h.modes]) for d, h in parts.items()}
    return Structure(modes["x"], modes["y"]), not isinstance(holder, XYHolder), slopes


@dataclass(frozen=True, eq=False)
class TipParameterization(Parameterization):
    """Free holder-face modal parameters → the tip's modes of ``tool`` at its stickout (module docstring).

    Build it with :meth:`of`. ``slopes``: {"x": (M,), "y": (M,)} [rad/m], held; ``n_tip``: tip modes per
    direction (default holder modes + 1); ``keep``: fixed-face tool modes in the reduction."""

    tool: Tool | None = None
    slopes: dict = field(default_factory=dict)
    n_tip: int | None = None
    keep: int | None = DEFAULT_KEEP

    @classmethod
    def of(cls, tool: Tool, holder: ModalHolder | XYHolder, free: tuple[str, ...] = (), bounds=None,
           n_tip: int | None = None, keep: int | None = DEFAULT_KEEP) -> TipParameterization:
        base, axi, slopes = holder_structure(holder)
        return cls(base, tuple(free), axi, dict(bounds or {}), tool, slopes, n_tip, keep)

    @property
    def stickout(self) -> float:
        """The tool's stickout [m]."""
        return self.tool.stickout

    def at(self, stickout: float) -> TipParameterization:
        """The same holder parameters with the tool at ``stickout`` [m]."""
        if not (math.isfinite(stickout) and 0 < stickout <= 1.0):
            raise InputError("stickout", stickout, "must be a length > 0 m (and under 1 m; mm written as m?)")
        return replace(self, tool=self.tool.at(float(stickout)), free=self.free, bounds=self.bounds)

    def holder_batch(self, theta: np.ndarray) -> ModalBatch:
        """The holder-face modes of θ (B, P) as a batch (the base class's mapping)."""
        return super().batch(theta)

    def batch(self, theta: np.ndarray) -> ModalBatch:
        """The TIP's modes (B structures) at :attr:`stickout` from θ (B, P) of the holder parameters."""
        hb = self.holder_batch(theta)
        out = {}
        for d in ("x", "y"):
            if d == "y" and self.axisymmetric:
                for p in ("fn", "k", "zeta"):
                    out[f"{p}_y"] = out[f"{p}_x"]
                continue
            f, kk, z = tip_modes(self.tool, getattr(hb, f"fn_{d}"), getattr(hb, f"k_{d}"), getattr(hb, f"zeta_{d}"),
                                 self.slopes[d], self.n_tip, self.keep)
            out.update({f"fn_{d}": f, f"k_{d}": kk, f"zeta_{d}": z})
        return ModalBatch(**out)

    def record(self) -> dict:
        """Plain data (SI) of the tool and the held holder values, for a posterior's JSON (:meth:`from_record`)."""
        t, m = self.tool, self.tool.material
        return {"tool": {"diameter": t.diameter, "stickout": t.stickout, "fluted_length": t.fluted_length,
                         "flute_ratio": t.flute_ratio, "zeta": t.zeta, "elements": t.elements,
                         "material": {"name": m.name, "E": m.E, "density": m.density, "nu": m.nu}},
                "slopes": {d: np.asarray(v, float).tolist() for d, v in self.slopes.items()},
                "axisymmetric": self.axisymmetric, "n_tip": self.n_tip, "keep": self.keep}

    @classmethod
    def from_record(cls, rec: dict, base: Structure, free: tuple[str, ...]) -> TipParameterization:
        """The parameterization of :meth:`record` over the holder modes ``base`` with ``free`` names."""
        from millstab.tooltip.beam import Material

        t, m = rec["tool"], rec["tool"]["material"]
        tool = Tool(float(t["diameter"]), float(t["stickout"]), Material(str(m["name"]), float(m["E"]),
                    float(m["density"]), float(m["nu"])), float(t["fluted_length"]), float(t["flute_ratio"]),
                    float(t["zeta"]), int(t["elements"]))
        return cls(base, tuple(free), bool(rec["axisymmetric"]), {}, tool,
                   {d: np.asarray(v, float) for d, v in rec["slopes"].items()}, rec.get("n_tip"), rec.get("keep"))

    def tip_structure(self, theta) -> Structure:
        """One tip structure (modes) from θ (P,)."""
        return self.batch(np.asarray(theta, dtype=float)[None, :]).structure(0)


__all__ = ["DEFAULT_KEEP", "TipParameterization", "holder_structure", "reduced_tool", "tip_modes"]
