"""ibvs.Task and its feature blocks from Python: the image line against central differences of its own
projection; a Task of points only is its Layout (bit for bit); weights, DOF; measurements given per
block or concatenated; every finite measurement answered with finite numbers or refused (hypothesis)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import ibvs


def line_of(P1, P2, P3):
    """Measurement of the 3-D line P1P2 (camera frame) in the plane through P1, P2, P3."""
    n = np.cross(P2 - P1, P3 - P1)
    d = n @ P1
    return ibvs.LineFeature.measure(P1[:2] / P1[2], P2[:2] / P2[2], n / d)


def moved(P, xi):
    T = np.linalg.inv(ibvs.se3_exp(xi))
    return T[:3, :3] @ P + T[:3, 3]


def test_line_interaction_is_the_derivative_of_its_projection(rng):
    line = ibvs.LineFeature()
    checked = 0
    for _ in range(100):
        P = [np.append(rng.uniform(-0.4, 0.4, 2), 1.0) * rng.uniform(0.5, 5.0) for _ in range(3)]
        m = line_of(*P)
        if abs(m[0]) < 0.02:
            continue
        try:
            L = line.interaction(m)
        except ValueError:  # a plane seen edge-on
            continue
        h, Ln = 1e-6, np.zeros((2, 6))
        for k in range(6):
            xi = np.zeros(6)
            xi[k] = h
            a, b = line_of(*[moved(p, xi) for p in P]), line_of(*[moved(p, -xi) for p in P])
            Ln[:, k] = [(a[0] - b[0]) / (2 * h), ibvs.wrap_angle(a[1] - b[1]) / (2 * h)]
        assert np.allclose(L, Ln, rtol=1e-6, atol=1e-6 * max(1.0, np.abs(L).max()))
        checked += 1
    assert checked > 50


def test_points_only_task_is_its_layout():
    layout = ibvs.Layout.stacked(4)
    uv_d = np.array([[0.1, 0.1], [-0.1, 0.1], [-0.1, -0.1], [0.1, -0.1]])
    uv = np.array([[0.16, 0.05], [-0.05, 0.16], [-0.16, -0.05], [0.05, -0.16]])
    a = ibvs.Servo(layout, gain=0.5).update(uv, 0.6, uv_d)
    b = ibvs.Servo(ibvs.Task(layout), gain=0.5).update(uv, 0.6, uv_d)
    assert np.array_equal(a.velocity, b.velocity) and a.sigma_min == b.sigma_min


def test_mixed_task_weights_dof_and_measurement_forms():
    task = ibvs.Task(ibvs.Layout.cartesian(2)).add(ibvs.LineFeature(), weight=2.0)
    task.dof = ["Tx", "Ty", "Tz", "wz"]
    assert task.rows == 6 and task.measurement_size == 5 and task.dof == [True, True, True, False, False, True]
    servo = ibvs.Servo(task, gain=0.5)
    m = ibvs.LineFeature.measure([0.1, 0.2], [0.3, -0.1], [0.0, 0.0, 0.5])
    md = ibvs.LineFeature.measure([0.12, 0.2], [0.3, -0.12], [0.0, 0.0, 0.5])
    uv, uv_d = [[0.1, 0.1], [-0.1, 0.1]], [[0.12, 0.1], [-0.1, 0.12]]
    r1 = servo.update(uv, 1.0, uv_d, measurements=[m], measurements_desired=[md])
    r2 = servo.update(uv, 1.0, uv_d, measurements=m, measurements_desired=md)  # concatenated: one block
    assert np.array_equal(r1.velocity, r2.velocity)
    assert r1.velocity[3] == 0.0 and r1.velocity[4] == 0.0  # wx, wy left out
    # The weighted rows: the line's error is twice its own error().
    assert np.allclose(r1.error[4:], 2.0 * ibvs.LineFeature().error(m, md))
    # Independent: least squares on the kept columns of the weighted stack.
    J, e = r1.jacobian, r1.error
    keep = [0, 1, 2, 5]
    x = np.linalg.lstsq(J[:, keep], e, rcond=None)[0]
    assert np.allclose(-r1.velocity[keep] / 0.5, x, rtol=1e-9, atol=1e-12)


def test_refusals_name_the_block():
    task = ibvs.Task().add(ibvs.LineFeature())
    servo = ibvs.Servo(task, gain=1.0)
    good = [0.1, 0.3, 0.0, 0.0, 0.5]
    none, none_z = np.zeros((0, 2)), np.zeros(0)  # no image points
    with pytest.raises(ValueError, match="measurements is required"):
        servo.update(none, none_z, none)
    with pytest.raises(ValueError, match=r"measurements\[0\]\[0\]: is not finite"):
        servo.update(none, none_z, none, measurements=[[np.nan, 0.3, 0, 0, 0.5]], measurements_desired=[good])
    with pytest.raises(ValueError, match="edge-on"):
        servo.update(none, none_z, none, measurements=[good], measurements_desired=[[0.1, 0.0, -10.0, 0.0, 1.0]])
    with pytest.raises(ValueError, match="must hold 5 values"):
        servo.update(none, none_z, none, measurements=[good[:4]], measurements_desired=[good])
    with pytest.raises(ValueError, match="nothing to servo"):
        ibvs.Servo(ibvs.Task(), gain=1.0)
    with pytest.raises(ValueError, match="weight"):
        ibvs.Task().add(ibvs.LineFeature(), weight=-1.0)
    with pytest.raises(ValueError, match=r"weight must be finite and in \[1e-06, 1e\+06\]"):
        ibvs.Task().add(ibvs.LineFeature(), weight=1e7)
    with pytest.raises(ValueError, match=r"point_weights\[1\]"):
        ibvs.Task(ibvs.Layout.cartesian(2)).point_weights = [1.0, 1e-7]
    with pytest.raises(ValueError, match="dof"):
        ibvs.Task().dof = ["Tq"]
    with pytest.raises(ValueError, match="distinct"):
        ibvs.LineFeature.measure([0.1, 0.1], [0.1, 0.1], [0, 0, 1])


_finite = st.floats(min_value=-1e12, max_value=1e12, allow_nan=False)


@given(st.lists(_finite, min_size=5, max_size=5), st.lists(_finite, min_size=5, max_size=5))
def test_line_measurements_are_finite_or_refused(m, md):
    servo = ibvs.Servo(ibvs.Task(ibvs.Layout.cartesian(1)).add(ibvs.LineFeature()), gain=1.0, damping=0.01)
    try:
        r = servo.update([[0.1, 0.0]], 1.0, [[0.0, 0.1]], measurements=[m], measurements_desired=[md])
    except ValueError as e:
        assert "measurements" in str(e)
        return
    assert np.isfinite(r.velocity).all() and np.isfinite(r.error).all() and np.isfinite(r.jacobian).all()
