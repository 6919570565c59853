"""Bayesian updating of the modal parameters from labelled test cuts, and decisions from the posterior.

* :mod:`~millstab.update.prior` -- log-normal prior around the hammer-test structure (``[prior]``);
* :mod:`~millstab.update.likelihood` -- probit likelihood of stable/chatter/marginal labels, chatter
  frequencies and boundary points through the one batched forward function;
* :mod:`~millstab.update.sampler` -- adaptive tempered sequential Monte Carlo;
* :mod:`~millstab.update.posterior` -- the result (samples, summaries, x↔y exchange modes, JSON);
* :mod:`~millstab.update.decide` -- P(stable) maps, the recommended cut and the next test.

:func:`update` runs the whole chain from a config and a cuts file.
"""

from __future__ import annotations

import warnings
from typing import Callable

import numpy as np

from millstab.points import PointSet
from millstab.update.decide import Recommendation, p_stable_map, recommend
from millstab.update.likelihood import Evidence, Likelihood
from millstab.update.posterior import Posterior
from millstab.update.prior import Prior, make_prior
from millstab.update.sampler import tempered_smc

#: the default number of posterior samples (the reference's ~4 000 weighted samples)
DEFAULT_SAMPLES = 4000


def update(config, cuts: PointSet, points: PointSet | None = None, *, engine: str = "zoa", samples: int = DEFAULT_SAMPLES,
           seed: int = 0, moves: int = 3, prior: Prior | None = None,
           progress: Callable[[str, int, int], None] | None = None) -> Posterior:
    """The posterior of the free parameters given labelled cuts (and optional boundary points).

    Args:
        config: a :class:`millstab.io.config.Config` (structure = prior medians; ``[prior]`` table).
        cuts: labelled cuts (unlabelled rows count as boundary points).
        points: more boundary points (or cuts), or ``None``.
        engine: a registered engine (:data:`millstab.stability.ENGINES`): ``zoa`` (fast) or an
            interrupted-cutting engine (``sdm``, ``spectral``); measured chatter frequencies are used with
            an engine declaring ``reports_chatter_frequency`` (``zoa``, ``spectral``).
        samples: posterior samples (SMC particles).
        seed: seed of the sampler (same seed, same samples).
        moves: Metropolis–Hastings moves per tempering stage.
        prior: a prior to use instead of the config's.
    Raises:
        InputError: bad data (see :class:`Evidence`), bad prior, unknown engine, or data no prior
            draw can explain.
    """
    pr = prior or make_prior(config.structure, config.cutting, getattr(config, "prior", None))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ev = Evidence.from_points(cuts, points)
        lik = Likelihood(pr, ev, engine)
    for w in caught:  # pass them on to the caller, and keep them in the result
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    res = tempered_smc(pr.sample, pr.logpdf, lik, samples, seed=seed, moves=moves, progress=progress)
    diag = res.diagnostics()
    diag["engine_sets"] = lik.n_sets
    diag["frequency_term"] = lik.uses_frequency
    data = {"rpm": np.r_[ev.cut_rpm, ev.pt_rpm].tolist(), "depth_mm": np.r_[ev.cut_depth_mm, ev.pt_depth_mm].tolist(),
            "label": [("stable", "chatter", "marginal")[k] for k in ev.cut_kind] + [""] * ev.pt_rpm.size,
            "chatter_hz": [None if not np.isfinite(h) else float(h) for h in ev.cut_hz] + [None] * ev.pt_rpm.size}
    return Posterior(pr, np.exp(res.u), engine, diag, data, tuple(str(w.message) for w in caught))


__all__ = ["DEFAULT_SAMPLES", "Evidence", "Likelihood", "Posterior", "Prior", "Recommendation", "make_prior",
           "p_stable_map", "recommend", "update"]
