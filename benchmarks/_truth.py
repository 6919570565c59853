"""The virtual shop's truth: the limiting depth of the TRUE structure by semi-discretization, to a stated accuracy.

The campaign benchmarks label their cuts and judge their recommendations by SDM of the true structure (never the
fitted model). A fixed step count is not the physics: SDM's error follows the step in natural periods of the highest
mode. Measured against SDM's accuracy-controlled default (Richardson-extrapolated, ≤ 0.23 % from the converged limit)
on the truths of ``bench_conditions_campaign.py`` (three machines, five conditions, 8 speeds 4 000–12 000 rpm) and
``bench_robust.py`` (Ex.1 in a slot, the hammer test ×/÷ (k 3, fn 1.2, ζ 3), 121 speeds 5 000–12 000 rpm ×3 speed
offsets), |ln(b / b_default)|:

* 40 steps per tooth period: median 0.2–2.6 %, max 2–11 % (``bench_conditions_campaign``'s truth until 2026-11-28),
  and the limits are too HIGH (a truly chattering cut labelled stable); stiffer Ex.1 median 2.2 %, max 10 %;
* 20 steps (``bench_robust.py``'s documented runs): Ex.1 softer median 1.2 %, max 20 %; stiffer median 8.8 %, max
  42 % (its best cut 7 % deeper than the physics');
* ``fn1`` (the default's control as if the highest mode were at 1 Hz: 20 and 40 steps at every speed, extrapolated):
  on the Ex.1 truths median 0.01–0.08 %, max 0.9 %, at ~1.2× the cost of 40 steps (on the conditions campaign's
  prior draws median 0.02 %, max 4 %: docs/updating.md; that bench uses ``auto``, a few seconds a campaign);
* the spectral engine at the truth: median ≤ 0.1 %, max 0.15 % (so a spectral fit no longer looks 1–3 % low).
* Ex.1's hammer test at a/D 0.1 down (``bench_update_campaign.py --immersion 0.1``, 57 speeds 5 000–12 000 rpm):
  40 steps median +3.7 %, max 8 % (6 ms a speed); ``fn1`` median 0.01 % but 10 % at one speed (a thin lobe its
  extrapolation misses; 12 ms); ``auto`` 34 ms a speed. Hence ``auto`` where a campaign can afford it
  (``bench_conditions_campaign.py``: ~180 truth speeds a campaign) and ``fn1`` where the best cut is sought on a
  fine grid (``bench_robust.py``, ``bench_labels.py``, ``bench_update_campaign.py``: in a slot ``auto`` costs
  0.1–0.4 s a speed, 434 s for one campaign's 1 083 speeds; ``--truth-steps auto`` at low immersion).

Spec: ``"auto"`` (SDM's default accuracy control), ``"fnF"`` (that control at a highest natural frequency of F Hz),
or an integer (fixed steps per tooth period; reproduces the runs before 2026-11-28).
"""

from __future__ import annotations

import argparse

import numpy as np

from millstab.model import Cutting, Structure
from millstab.stability import sdm


#: what a truth spec may be (:func:`sdm_options`)
ALLOWED = "auto, fnF (F > 0 Hz) or a whole number of steps per tooth period ≥ 2"


def sdm_options(spec: str) -> dict:
    """``sdm.envelope``'s keyword arguments for a truth spec (see the module docstring); ValueError for another."""
    spec = str(spec).strip()
    if spec == "auto":
        return {}
    if spec.startswith("fn"):
        hz = float(spec[2:])
        if hz > 0:
            return {"fn_max_hz": hz}
    elif int(spec) >= 2:
        return {"steps": int(spec)}
    raise ValueError(f"truth spec {spec!r}: {ALLOWED}")


def truth_spec(text: str) -> str:
    """argparse ``type`` of a ``--truth-steps`` option: the spec, checked by :func:`sdm_options` (one line naming
    what is allowed, exit 2, instead of a traceback once the campaigns run)."""
    try:
        sdm_options(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: {ALLOWED}") from None
    return text


def truth_envelope(structure: Structure, cutting: Cutting, rpm, spec: str):
    """SDM's envelope (limits [m], chatter frequencies) of the true ``structure`` at ``rpm`` under ``spec``."""
    return sdm.envelope(structure, cutting, np.asarray(rpm, float), **sdm_options(spec))


def truth_depth_mm(structure: Structure, cutting: Cutting, rpm, spec: str) -> np.ndarray:
    """The true limiting depth [mm] at each speed [rpm] under ``spec``."""
    return truth_envelope(structure, cutting, rpm, spec).depth_mm
