"""Sensitivity of the stability lobe diagram to the structural (modal) parameters.

* :func:`oat` -- one-at-a-time (the seed paper's Algorithm 1, Fig. SENS): MSE [mm²] of the SLD after
  scaling one parameter by (1 + ε), for ε on a grid.
* :func:`monte_carlo` -- Monte Carlo (Algorithm 2, Table 6): mean and SD of that MSE [mm²] for a small
  ε over N random centres in a ±t neighbourhood; streamed through the batched engine in chunks.
* :func:`sobol`, :func:`morris` -- global indices (SALib) of the SLD's MSE, b_lim at each speed and
  the envelope minimum.

Every study goes through the one forward model (:func:`millstab.forward.forward`, batched and chunked by
the engine's own ``chunk_rows``), centres on a structure's values or
a given θ, and rejects, before any work, settings that could push a parameter out of its valid range.
``monte_carlo``, ``sobol`` and ``morris`` take ``client=`` (a ``distributed.Client``) to run on a Dask
cluster with the same numbers (:mod:`millstab.cluster`).
Parameters are named as in :mod:`millstab.params` (``fn_x, k_x, zeta_x, fn_y, k_y, zeta_y``).
"""

from millstab.sensitivity._core import DEFAULT_EPS_GRID, PAPER_EPS_GRID, bounds_from, check_neighbourhood, mse_mm2
from millstab.sensitivity.globalsa import morris, sobol, sobol_function, sobol_indices
from millstab.sensitivity.montecarlo import PAPER_EPS, PAPER_N, PAPER_T, monte_carlo
from millstab.sensitivity.oat import oat
from millstab.sensitivity.presets import match_example, predicted_theta, table6
from millstab.sensitivity.results import MCResult, MorrisResult, OATResult, SobolResult

__all__ = ["DEFAULT_EPS_GRID", "MCResult", "MorrisResult", "OATResult", "PAPER_EPS", "PAPER_EPS_GRID", "PAPER_N",
           "PAPER_T", "SobolResult", "bounds_from", "check_neighbourhood", "match_example", "monte_carlo", "morris",
           "mse_mm2", "oat", "predicted_theta", "sobol", "sobol_function", "sobol_indices", "table6"]
