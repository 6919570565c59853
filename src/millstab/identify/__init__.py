"""In-process modal parameter identification from measured stability boundaries.

Given boundary points (spindle speed, limiting depth) and the cutting conditions, find the modal
parameters (fn [Hz], k [N/m], ζ [-] per direction) whose zero-order SLD explains them.

* :func:`identify` — one call from a config and a point set to a :class:`Fit`;
* :mod:`~millstab.identify.objective` — :class:`Problem` (the batched forward model), MLAE, residuals,
  x↔y symmetry;
* :mod:`~millstab.identify.lsq` — the default solver (multi-start trust-region least squares);
* :mod:`~millstab.identify.newton` — the seed paper's Newton–Raphson scheme with its refinements;
* :mod:`~millstab.identify.synthetic` — boundary points from known structures (with seeded noise);
* :mod:`~millstab.identify.result` — :class:`Fit` and its JSON contract.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

from millstab.errors import InputError
from millstab.identify.lsq import fit_lsq
from millstab.identify.newton import fit_newton
from millstab.identify.objective import Problem, make_problem
from millstab.identify.result import Fit

METHODS = ("lsq", "newton")


def identify(config, points, *, method: str = "lsq", free: Sequence[str] | str | None = None,
             axisymmetric: bool = False, initial: Mapping[str, float] | str | None = None,
             bounds: Mapping[str, tuple[float, float]] | None = None, engine: str = "zoa", residual: str = "log",
             seed: int = 0, progress=None, **options: Any) -> Fit:
    """Identify modal parameters from boundary points.

    Args:
        config: a :class:`~millstab.io.config.Config` (cutting conditions and the starting modal structure).
        points: a :class:`~millstab.io.points.PointSet` (unlabelled rows = boundary points, fitted; labelled
            rows = test cuts, reported).
        method: ``lsq`` (default) or ``newton`` (the paper's scheme).
        free, axisymmetric, initial, bounds: see :func:`~millstab.identify.objective.make_problem`.
        engine: ``zoa`` or ``sdm``; residual: ``log`` or ``mm`` (lsq).
        seed: seed of every random design (same seed ⇒ same numbers).
        options: passed to :func:`fit_lsq` or :func:`fit_newton`.
    """
    if method not in METHODS:
        raise InputError("method", method, f"must be one of {', '.join(METHODS)}")
    if not config.structure.is_modal:
        raise InputError("structure", "measured FRF", "identification needs a modal starting structure ([[structure.x]] modes)")
    problem = make_problem(config.structure, config.cutting, points, free=free, axisymmetric=axisymmetric,
                           initial=initial, bounds=bounds, engine=engine, residual=residual)
    solver = fit_lsq if method == "lsq" else fit_newton
    return solver(problem, seed=seed, progress=progress, **options)


__all__ = ["METHODS", "Fit", "Problem", "fit_lsq", "fit_newton", "identify", "make_problem"]
