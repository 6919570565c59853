"""Identification with the SDM engine: zero-order global search, then a local SDM stage."""

from __future__ import annotations

import numpy as np
import pytest

from millstab.identify import identify
from millstab.identify.synthetic import boundary_points
from millstab.config import Config
from millstab.model import Cutting, Structure


@pytest.mark.slow
def test_sdm_identification_recovers_where_zoa_is_exact():
    """Four-tooth slotting: the directional matrix is time-invariant, so the SDM boundary equals the
    zero-order one and the two-stage fit must recover the SDM points' truth (axisymmetric tool)."""
    truth = Structure.symmetric(500.0, 8e6, 0.02)
    cut = Cutting(4, 695e6, 0.404)
    pts = boundary_points(truth, cut, np.linspace(5000, 8000, 7), engine="sdm")  # few SDM steps per period here
    cfg = Config(cutting=cut, structure=Structure.symmetric(540.0, 7e6, 0.024), name="sdm-test")
    fit = identify(cfg, pts, engine="sdm", axisymmetric=True, seed=0)
    np.testing.assert_allclose(fit.estimate, [500.0, 8e6, 0.02], rtol=5e-3)
    assert fit.settings["engine"] == "sdm" and "stage1_zoa" in fit.settings
    assert any("two stages" in w for w in fit.warnings)
    assert not any("poor fit" in w for w in fit.warnings)
