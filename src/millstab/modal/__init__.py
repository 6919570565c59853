"""Modal fitting of measured drive-point FRFs (a tap test) to millstab's modal form (fn, k, ζ per mode).

* :mod:`millstab.modal.lscf` -- poles over model orders (LSCF) and the stabilisation diagram's clusters.
* :mod:`millstab.modal.fit` -- poles and residues refined by least squares (LSFD), the pole/residue ↔
  (fn, k, ζ) conversion, the mode choice and the drive-point check.
* :mod:`millstab.modal.run` -- files in, fits of x and y, the structure, and the SLD check.
* :mod:`millstab.modal.output` -- the TOML ``[structure]`` section and the quality JSON.

Written on numpy/scipy rather than sdypy-EMA: on the issue's must-reach cases sdypy-EMA's LSCF+LSFD
missed ζ by 7-9 % even with the true frequencies handed to its pole picker, has no automatic pole
choice (a GUI or given frequencies), and pulls in tqdm; see benchmarks/bench_modal.py.
"""

from millstab.modal.fit import DirectionFit, FittedMode, fit_direction

__all__ = ["DirectionFit", "FittedMode", "fit_direction"]
