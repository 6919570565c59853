"""In-process modal parameter identification from measured stability boundaries.

Given boundary points (spindle speed, limiting depth) and the cutting conditions, find the modal
parameters (fn [Hz], k [N/m], ζ [-] per direction) whose zero-order SLD explains them.

* :func:`identify` — one call from a config and a point set to a :class:`Fit`;
* :mod:`~millstab.identify.objective` — :class:`Problem` (the batched forward model), MLAE, residuals,
  x↔y symmetry;
* :mod:`~millstab.identify.lsq` — the default solver (multi-start trust-region least squares);
* :mod:`~millstab.identify.newton` — the seed paper's Newton–Raphson scheme with its refinements;
* :mod:`~millstab.identify.tie` — the F-test that reports alike x and y tied in symmetric cuts;
* :mod:`~millstab.identify.quality` — degrees of freedom, the noise behind the standard errors, poor or
  systematic residuals, the zero-order model's weak cuts (warning codes in ``Fit.codes``);
* :mod:`~millstab.identify.design` — where to measure next: speeds that pin the parameters best;
* :mod:`~millstab.identify.synthetic` — boundary points from known structures (with seeded noise);
* :mod:`~millstab.identify.result` — :class:`Fit` and its JSON contract.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

from millstab.errors import InputError
from millstab.identify.lsq import fit_lsq
from millstab.identify.newton import fit_newton
from millstab.identify.objective import Problem, make_problem
from millstab.identify.quality import check_noise
from millstab.identify.result import Fit
from millstab.identify.tie import is_tied
from millstab.stability import get_engine

METHODS = ("lsq", "newton")


def identify(config, points, *, method: str = "lsq", free: Sequence[str] | str | None = None,
             axisymmetric: bool = False, initial: Mapping[str, float] | str | None = None,
             bounds: Mapping[str, tuple[float, float]] | None = None, engine: str = "zoa", residual: str = "log",
             seed: int = 0, progress=None, noise: float | None = None, **options: Any) -> Fit:
    """Identify modal parameters from boundary points.

    Args:
        config: a :class:`~millstab.config.Config` (cutting conditions and the starting modal structure).
        points: a :class:`~millstab.points.PointSet` (unlabelled rows = boundary points, fitted; labelled
            rows = test cuts, reported).
        method: ``lsq`` (default) or ``newton`` (the paper's scheme).
        free, axisymmetric, initial, bounds: see :func:`~millstab.identify.objective.make_problem`.
        engine: ``zoa``, ``sdm`` or ``spectral``; residual: ``log`` or ``mm`` (lsq).
        seed: seed of every random design (same seed ⇒ same numbers).
        noise: the relative standard deviation of a measured limiting depth (0.02 = 2 %), if known: the
            standard errors use it (or the residual scatter where larger) and the fit is checked against
            it; default ``None``: the residual scatter, or an assumed 2 % where the points leave fewer than
            10 degrees of freedom (:mod:`~millstab.identify.quality`).
        options: passed to :func:`fit_lsq` or :func:`fit_newton`.
    """
    if method not in METHODS:
        raise InputError("method", method, f"must be one of {', '.join(METHODS)}")
    noise = check_noise(noise)
    if not config.structure.is_modal:
        raise InputError("structure", "measured FRF",
                         "identification needs a modal starting structure ([[structure.x]] modes)")
    def problem_for(eng: str) -> Problem:
        return make_problem(config.structure, config.cutting, points, free=free, axisymmetric=axisymmetric,
                            initial=initial, bounds=bounds, engine=eng, residual=residual)

    # an engine too slow for the global search gets the zero-order search first, then its own polish
    if method == "lsq" and not get_engine(engine).cheap:
        return _zoa_then_sdm(problem_for, seed, progress, {**options, "noise": noise}, engine)
    solver = fit_lsq if method == "lsq" else fit_newton
    return solver(problem_for(engine), seed=seed, progress=progress, noise=noise, **options)


#: the SDM stage after the global ZOA search: 64 candidates around the ZOA estimate, LM on the best 4
#: then 1, no re-seeding, a capped trust-region polish; no zero-order basins (it starts from the best one) and no
#: merged-mode starts (~1 000 SLDs: minutes with SDM; a local stage)
SDM_POLISH = dict(n_candidates=64, schedule=((4, 3), (1, 10)), rounds=0, n_local=0, max_nfev=30, zoa_basins=0,
                  merge=False)


def _zoa_then_sdm(problem_for, seed: int, progress, options: dict, engine: str = "sdm") -> Fit:
    """Least squares with the SDM engine in two stages.

    The global search (hundreds of screening candidates, multi-start LM) needs thousands of SLD
    evaluations: with SDM (tens of ms per speed) that would take tens of minutes. The zero-order
    solution differs from SDM only locally (flip lobes, partial immersion), so the search runs on
    ZOA and its estimate starts a local SDM polish (:data:`SDM_POLISH`), whose result, standard errors
    and diagnostics are reported. The SDM stage screens candidates around the ZOA estimate, but it
    cannot leave a wrong basin: where the two boundaries differ a lot (low immersion) the quality checks
    (:mod:`~millstab.identify.quality`: residuals above the noise, or systematic along the speed axis)
    flag it.
    """
    first = fit_lsq(problem_for("zoa"), seed=seed, progress=progress, **options)
    polish = {**options, **SDM_POLISH}
    sdm_problem = problem_for(engine)
    # the x = y test again under SDM only where the zero-order stage kept x = y (otherwise it was rejected)
    fit = fit_lsq(sdm_problem, theta0=first.estimate, seed=seed, progress=progress, tie_xy=is_tied(first), **polish)
    note = ("two_stages", f"two stages: global search with the zero-order engine (MLAE {first.mlae:.4g}, "
                          f"{first.evaluations} SLDs), then a local polish with SDM ({fit.evaluations} SLDs)")
    stage1 = {"estimate": first.as_dict(), "mlae": first.mlae, "evaluations": first.evaluations,
              "warning_codes": list(first.codes)}
    return fit.with_warnings([note], first=True, settings={**fit.settings, "stage1_zoa": stage1})


__all__ = ["METHODS", "Fit", "Problem", "fit_lsq", "fit_newton", "identify", "make_problem"]
