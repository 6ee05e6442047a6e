"""Feature error f (-) f*: theta rows wrapped into (-pi, pi] (eq. 13), others plain."""

from __future__ import annotations

import numpy as np
import pytest

import ibvs


def test_wrap_edges():
    pi = np.pi
    assert ibvs.wrap_angle(pi) == pi
    assert ibvs.wrap_angle(-pi) == pi  # a half-turn error always has a positive sign
    assert ibvs.wrap_angle(3 * pi) == pi and ibvs.wrap_angle(-3 * pi) == pi
    assert ibvs.wrap_angle(2 * pi) == 0.0
    assert ibvs.wrap_angle(pi + 1e-9) == pytest.approx(-pi + 1e-9, abs=1e-15)
    a = np.linspace(-20, 20, 1001)
    w = ibvs.wrap_angle(a)
    assert w.shape == a.shape and (w > -pi).all() and (w <= pi).all()
    np.testing.assert_allclose(np.cos(w), np.cos(a), atol=1e-12)
    np.testing.assert_allclose(np.sin(w), np.sin(a), atol=1e-12)


def test_wrap_rejects_non_finite():
    with pytest.raises(ValueError, match="angle"):
        ibvs.wrap_angle(np.array([0.0, np.nan]))


def test_theta_error_across_the_cut():
    layout = ibvs.Layout.polar(1)
    e = ibvs.feature_error([0.2, np.pi - 0.01], [0.25, -np.pi + 0.01], layout)
    np.testing.assert_allclose(e, [-0.05, -0.02], atol=1e-12)


def test_cartesian_rows_are_not_wrapped():
    e = ibvs.feature_error([0.0, 4.0], [0.0, -4.0], ibvs.Layout.cartesian(1))
    np.testing.assert_array_equal(e, [0.0, 8.0])


def test_stacked_error_wraps_only_theta_rows():
    layout = ibvs.Layout.stacked(1)  # rows u, v, r, theta
    e = ibvs.feature_error([4.0, 4.0, 4.0, 4.0], [0.0, 0.0, 0.0, 0.0], layout)
    np.testing.assert_allclose(e, [4.0, 4.0, 4.0, 4.0 - 2 * np.pi])


@pytest.mark.parametrize(
    "f, fd, word", [([0.0] * 3, [0.0] * 4, "f"), ([0.0] * 4, [0.0] * 3, "f_desired"), ([np.inf, 0, 0, 0], [0.0] * 4, "f")]
)
def test_bad_error_input(f, fd, word):
    with pytest.raises(ValueError, match=word):
        ibvs.feature_error(f, fd, ibvs.Layout.polar(2))
