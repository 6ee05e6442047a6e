"""Adaptive gain (vpAdaptiveGain formula) and uniform velocity saturation in ibvs.Servo."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import look

import ibvs

UV = np.array([[0.1, 0.09], [-0.12, 0.1], [-0.1, -0.1], [0.11, -0.13]])
UVD = np.array([[0.2, 0.2], [-0.2, 0.2], [-0.2, -0.2], [0.2, -0.2]])
Z = np.array([1.0, 1.1, 1.2, 0.9])


def test_adaptive_gain_formula():
    g = ibvs.AdaptiveGain(at_zero=4.0, at_infinity=0.4, slope_at_zero=30.0)
    assert g(0.0) == 4.0 and g(1e6) == pytest.approx(0.4, abs=1e-15)
    x = np.array([1e-3, 0.01, 0.1, 0.5])
    np.testing.assert_allclose(g(x), 3.6 * np.exp(-(30.0 / 3.6) * x) + 0.4, rtol=1e-14)
    assert (g(1e-7) - g(0.0)) / 1e-7 == pytest.approx(-30.0, rel=1e-5)
    assert ibvs.AdaptiveGain(2.0, 2.0, 5.0)(0.3) == 2.0  # constant: no 0/0
    assert repr(g) == "AdaptiveGain(at_zero=4.0, at_infinity=0.4, slope_at_zero=30.0)"
    assert g == ibvs.AdaptiveGain(4.0, 0.4, 30.0)


def test_defaults_reproduce_the_constant_gain_law_exactly():
    for layout in [ibvs.Layout.cartesian(4), ibvs.Layout.polar(4), ibvs.Layout.stacked(4)]:
        a = ibvs.Servo(layout, gain=0.7).update(UV, Z, UVD)
        b = ibvs.Servo(layout, gain=0.7, max_linear_speed=math.inf, max_angular_speed=math.inf).update(UV, Z, UVD)
        J, e = a.jacobian, a.error
        np.testing.assert_allclose(a.velocity, -0.7 * np.linalg.pinv(J) @ e, rtol=1e-9, atol=1e-12)
        np.testing.assert_array_equal(a.velocity, b.velocity)
        assert a.gain == 0.7 and not a.saturated and a.saturation_scale == 1.0


def test_adaptive_gain_in_servo():
    layout = ibvs.Layout.cartesian(4)
    ref = ibvs.Servo(layout, gain=1.0).update(UV, Z, UVD)
    g = ibvs.AdaptiveGain(4.0, 0.4, 30.0)
    servo = ibvs.Servo(layout, gain=g)
    assert servo.gain == g
    res = servo.update(UV, Z, UVD)
    assert res.gain == pytest.approx(g(ref.error_norm), rel=1e-15)
    np.testing.assert_allclose(res.velocity, res.gain * ref.velocity, rtol=1e-12)
    servo.gain = 0.5  # back to a constant gain
    assert servo.gain == 0.5 and servo.update(UV, Z, UVD).gain == 0.5


@pytest.mark.parametrize("vmax, wmax", [(0.05, math.inf), (math.inf, 0.01), (0.05, 0.01)])
def test_saturation_keeps_direction_and_bounds(vmax, wmax):
    layout = ibvs.Layout.polar(4)
    free = ibvs.Servo(layout, gain=2.0).update(UV, Z, UVD).velocity
    res = ibvs.Servo(layout, gain=2.0, max_linear_speed=vmax, max_angular_speed=wmax).update(UV, Z, UVD)
    v = res.velocity
    assert res.saturated and 0 < res.saturation_scale < 1
    assert np.linalg.norm(v[:3]) <= vmax * (1 + 1e-12) and np.linalg.norm(v[3:]) <= wmax * (1 + 1e-12)
    # One limit is met with equality (the scale is the largest admissible one).
    assert math.isclose(np.linalg.norm(v[:3]), vmax, rel_tol=1e-12) or math.isclose(
        np.linalg.norm(v[3:]), wmax, rel_tol=1e-12
    )
    np.testing.assert_allclose(v, res.saturation_scale * free, rtol=1e-13, atol=1e-16)
    assert v @ free / (np.linalg.norm(v) * np.linalg.norm(free)) == pytest.approx(1.0, abs=1e-14)


def test_loose_limits_do_not_touch_the_twist():
    layout = ibvs.Layout.polar(4)
    free = ibvs.Servo(layout, gain=2.0).update(UV, Z, UVD).velocity
    res = ibvs.Servo(layout, gain=2.0, max_linear_speed=1e3, max_angular_speed=1e3).update(UV, Z, UVD)
    assert not res.saturated
    np.testing.assert_array_equal(res.velocity, free)


def test_closed_loop_with_limits_and_adaptive_gain():
    uvd, zd = look(np.eye(4))
    T = ibvs.se3_exp([0.1, -0.05, -0.3, 0.05, -0.05, 2.5])
    servo = ibvs.Servo(
        ibvs.Layout.polar(4), gain=ibvs.AdaptiveGain(4.0, 0.5, 20.0), max_linear_speed=0.05, max_angular_speed=0.2
    )
    saturated = False
    for _ in range(6000):
        uv, z = look(T)
        res = servo.update(uv, z, uvd)
        assert np.linalg.norm(res.velocity[:3]) <= 0.05 + 1e-12 and np.linalg.norm(res.velocity[3:]) <= 0.2 + 1e-12
        saturated |= res.saturated
        if res.error_norm < 1e-9:
            break
        T = T @ ibvs.se3_exp(res.velocity / 60.0)
    assert res.error_norm < 1e-9 and saturated
    np.testing.assert_allclose(T, np.eye(4), atol=1e-6)


@pytest.mark.parametrize(
    "make, exc, word",
    [
        (lambda: ibvs.AdaptiveGain(-1.0, 0.5, 1.0), ValueError, "at_zero"),
        (lambda: ibvs.AdaptiveGain(0.0, 0.5, 1.0), ValueError, "at_zero"),
        (lambda: ibvs.AdaptiveGain(1.0, 2.0, 1.0), ValueError, "at_infinity"),
        (lambda: ibvs.AdaptiveGain(1.0, 0.0, 1.0), ValueError, "at_infinity"),
        (lambda: ibvs.AdaptiveGain(1.0, 0.5, -1.0), ValueError, "slope_at_zero"),
        (lambda: ibvs.AdaptiveGain(1.0, 0.5, math.nan), ValueError, "slope_at_zero"),
        (lambda: ibvs.Servo(ibvs.Layout.polar(4), gain=1.0, max_linear_speed=0.0), ValueError, "max_linear_speed"),
        (lambda: ibvs.Servo(ibvs.Layout.polar(4), gain=1.0, max_angular_speed=-1.0), ValueError, "max_angular_speed"),
        (lambda: ibvs.Servo(ibvs.Layout.polar(4), gain=1.0, max_angular_speed=math.nan), ValueError, "max_angular"),
        (lambda: ibvs.Servo(ibvs.Layout.polar(4), gain="fast"), TypeError, "gain"),
        (lambda: ibvs.Servo(ibvs.Layout.polar(4), gain=None), TypeError, "gain"),
        (lambda: ibvs.AdaptiveGain(4.0, 0.4, 30.0)(-1.0), ValueError, "x"),
    ],
)
def test_bad_gain_and_limits_raise(make, exc, word):
    with pytest.raises(exc, match=word):
        make()


def test_limit_setters_validate():
    servo = ibvs.Servo(ibvs.Layout.polar(4), gain=1.0)
    assert servo.max_linear_speed == math.inf and servo.max_angular_speed == math.inf
    servo.max_linear_speed = 0.1
    servo.max_angular_speed = 0.5
    assert servo.max_linear_speed == 0.1 and servo.max_angular_speed == 0.5
    with pytest.raises(ValueError, match="max_linear_speed"):
        servo.max_linear_speed = -0.1
    assert servo.max_linear_speed == 0.1
