"""Parameterization (millstab.params): names, dominant-mode resolution, x = y ties, round trips
θ → structure → θ, batch shapes, bounds, and bad names as InputError."""

from __future__ import annotations

import numpy as np
import pytest

from millstab.errors import InputError
from millstab.model import Mode, Structure
from millstab.params import Parameterization, default_bounds


@pytest.fixture
def one_mode():
    return Structure(x=(Mode(900.0, 2e7, 0.03),), y=(Mode(1100.0, 3e7, 0.04),))


@pytest.fixture
def two_modes():
    # x mode 2 has the larger peak compliance 1/(kζ): 1/(1e7·0.02) > 1/(4e7·0.03)
    return Structure(x=(Mode(700.0, 4e7, 0.03), Mode(1500.0, 1e7, 0.02)), y=(Mode(1000.0, 3e7, 0.04),))


def test_all_six_parameters_by_default(one_mode):
    par = Parameterization(one_mode)
    assert par.free == ("fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y")
    np.testing.assert_array_equal(par.theta0, [900.0, 2e7, 0.03, 1100.0, 3e7, 0.04])
    assert par.units() == ["Hz", "N/m", "-", "Hz", "N/m", "-"]


def test_structure_round_trip(one_mode):
    par = Parameterization(one_mode, free=("k_y", "fn_x"))
    theta = np.array([2.5e7, 950.0])
    s = par.structure(theta)
    np.testing.assert_array_equal(par.values(s), theta)
    # parameters not free keep the base structure's values
    assert s.x[0].k == 2e7 and s.x[0].zeta == 0.03 and s.y[0].fn == 1100.0
    assert s.x[0].fn == 950.0 and s.y[0].k == 2.5e7
    assert par.as_dict(theta) == {"k_y": 2.5e7, "fn_x": 950.0}
    np.testing.assert_array_equal(par.with_values(fn_x=905.0), [3e7, 905.0])


def test_batch_shapes_and_rows(two_modes):
    par = Parameterization(two_modes, free=("fn_x2", "zeta_y"))
    theta = np.array([[1500.0, 0.04], [1600.0, 0.05], [1700.0, 0.06]])
    b = par.batch(theta)
    assert b.size == 3
    assert b.fn_x.shape == (3, 2) and b.fn_y.shape == (3, 1)
    np.testing.assert_array_equal(b.fn_x[:, 1], theta[:, 0])
    np.testing.assert_array_equal(b.fn_x[:, 0], 700.0)  # the fixed first x mode in every row
    np.testing.assert_array_equal(b.zeta_y[:, 0], theta[:, 1])
    for i in range(3):  # each row is the single structure of that θ
        assert b.structure(i) == par.structure(theta[i])
    assert par.batch(theta[0]).size == 1  # (P,) is one row
    with pytest.raises(InputError, match="theta"):
        par.batch(np.ones((2, 3)))


def test_direction_name_means_the_dominant_mode(two_modes):
    par = Parameterization(two_modes, free=("fn_x", "k_y"))
    assert par.free == ("fn_x2", "k_y")
    assert par.canonical("zeta_x") == "zeta_x2"
    assert par.canonical("zeta_x1") == "zeta_x1"
    assert "fn_x1" in par.available() and "fn_x" not in par.available()


def test_tied_names_set_x_and_y_together():
    s = Structure.symmetric(800.0, 2e7, 0.04)
    par = Parameterization(s, free=("fn", "k"), axisymmetric=True)
    assert par.free == ("fn", "k")
    st = par.structure([850.0, 2.2e7])
    assert st.x[0].fn == st.y[0].fn == 850.0
    assert st.x[0].k == st.y[0].k == 2.2e7
    assert st.x[0].zeta == st.y[0].zeta == 0.04
    b = par.batch(np.array([[850.0, 2.2e7], [900.0, 2.4e7]]))
    np.testing.assert_array_equal(b.fn_x, b.fn_y)
    np.testing.assert_array_equal(b.k_x[:, 0], [2.2e7, 2.4e7])


@pytest.mark.parametrize("kwargs, name, match", [
    ({}, "omega_x", "unknown name"),
    ({}, "fn", "give the direction"),
    ({}, "fn_x3", "has 1 mode"),
    ({"axisymmetric": True}, "fn_x", "axisymmetric tool has no x/y"),
])
def test_bad_names_raise_input_error(kwargs, name, match):
    s = Structure.symmetric(800.0, 2e7, 0.04)
    with pytest.raises(InputError, match=match) as err:
        Parameterization(s, free=(name,), **kwargs)
    assert name in str(err.value)  # the name as the user wrote it


def test_other_bad_input(one_mode):
    with pytest.raises(InputError, match="listed once"):
        Parameterization(one_mode, free=("fn_x", "fn_x"))
    with pytest.raises(InputError, match="rigid"):
        Parameterization(Structure(x=one_mode.x), free=("fn_y",))
    with pytest.raises(InputError, match="bounds.fn_x"):
        Parameterization(one_mode, free=("fn_x",), bounds={"fn_x": (1000.0, 900.0)})
    with pytest.raises(InputError, match="same number of modes"):
        Parameterization(Structure(x=one_mode.x), axisymmetric=True)
    with pytest.raises(InputError, match="not a free parameter"):
        Parameterization(one_mode, free=("fn_x",)).with_values(k_x=1e7)


def test_default_and_given_bounds(one_mode):
    assert default_bounds("fn", 900.0) == (450.0, 1800.0)
    assert default_bounds("k", 2e7) == (2e6, 2e8)
    assert default_bounds("zeta", 0.03) == pytest.approx((0.0015, 0.5))
    assert default_bounds("zeta", 1e-3) == (1e-4, pytest.approx(0.02))
    par = Parameterization(one_mode, free=("fn_x", "zeta_y"), bounds={"fn_x": (800, 1000)})
    np.testing.assert_array_equal(par.lower, [800.0, 0.002])
    np.testing.assert_allclose(par.upper, [1000.0, 0.5])
