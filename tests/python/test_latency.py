"""The latency predictor (ibvs.loop.latency): its interaction matrix against the core's Cartesian one and
against finite differences of the projection; its prediction against the exact motion of the points
under the twists commanded; the first-order lag integrated exactly; its arguments refused when bad."""

from __future__ import annotations

import math

import numpy as np
import pytest

import ibvs
from ibvs.loop.latency import FeaturePredictor, point_interaction


def _points(rng, n=5):
    uv = rng.uniform(-0.4, 0.4, (n, 2))
    z = rng.uniform(0.3, 2.0, n)
    return uv, z


def _moved(uv, z, twist, dt):
    """The points after the camera moved with the constant twist for dt (exact: se3_exp of the twist)."""
    P = np.column_stack([uv * z[:, None], z])
    T = ibvs.se3_exp(np.asarray(twist) * dt)  # camera(t0) <- camera(t0 + dt)
    Q = (np.linalg.inv(T)[:3, :3] @ P.T).T + np.linalg.inv(T)[:3, 3]
    return Q[:, :2] / Q[:, 2:3], Q[:, 2]


def test_interaction_matrix_is_the_cores_cartesian_one():
    rng = np.random.default_rng(1)
    for _ in range(20):
        uv, z = _points(rng)
        L = ibvs.jacobian(uv, z, ibvs.Layout.cartesian(len(uv)))
        np.testing.assert_allclose(point_interaction(uv, z), np.asarray(L), rtol=1e-12, atol=1e-12)


def test_interaction_matrix_against_finite_differences_of_the_motion():
    rng = np.random.default_rng(2)
    uv, z = _points(rng)
    L = point_interaction(uv, z)
    h = 1e-6
    for j in range(6):
        e = np.zeros(6)
        e[j] = 1.0
        plus, _ = _moved(uv, z, e, h)
        minus, _ = _moved(uv, z, e, -h)
        np.testing.assert_allclose(((plus - minus) / (2 * h)).reshape(-1), L[:, j], rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("delay", [0.01, 0.05, 0.15])
def test_prediction_follows_the_exact_motion(delay):
    rng = np.random.default_rng(3)
    uv, z = _points(rng)
    twist = np.array([0.05, -0.03, 0.04, 0.1, -0.2, 0.5])
    p = FeaturePredictor(delay, max_step=1e-3)
    p.commanded(0.0, twist)
    got_uv, got_z = p.predict(uv, z, 0.0)
    want_uv, want_z = _moved(uv, z, twist, delay)
    # Euler over 1 ms steps: error O(step * delay); without prediction the error is O(delay)
    raw = np.abs(uv - want_uv).max()
    assert np.abs(got_uv - want_uv).max() < 2e-3 * delay / 0.15 + 1e-6 < raw / 10
    np.testing.assert_allclose(got_z, want_z, rtol=2e-3)


def test_prediction_spans_the_commands_since_capture():
    # commands at 0 (v1), 0.05 (v2); capture at 0.03, delay 0.04: 0.02 s of v1, then 0.02 s of v2
    rng = np.random.default_rng(4)
    uv, z = _points(rng)
    v1, v2 = np.array([0.1, 0, 0, 0, 0, 0.3]), np.array([0, 0.05, 0.02, 0.2, 0, 0])
    p = FeaturePredictor(0.04, max_step=1e-4)
    p.commanded(0.0, v1)
    p.commanded(0.05, v2)
    spans = p.spans(0.03, 0.07)
    assert sum(d for d, _ in spans) == pytest.approx(0.04)
    np.testing.assert_allclose(sum(x for _, x in spans), 0.02 * v1 + 0.02 * v2, atol=1e-15)
    got, _ = p.predict(uv, z, 0.03)
    mid_uv, mid_z = _moved(uv, z, v1, 0.02)
    want, _ = _moved(mid_uv, mid_z, v2, 0.02)
    np.testing.assert_allclose(got, want, atol=2e-5)
    # before the first command the robot was at rest
    q = FeaturePredictor(0.04)
    q.commanded(1.0, v1)
    np.testing.assert_array_equal(q.predict(uv, z, 0.5)[0], uv)


def test_first_order_lag_is_integrated_exactly():
    tau, v = 0.05, np.array([0.0, 0.0, 0.0, 0.0, 0.0, 1.0])
    p = FeaturePredictor(0.2, lag=tau, max_step=1.0)
    p.commanded(0.0, v)
    (d, x), = p.spans(0.0, 0.1)
    # the applied twist from rest: v (1 - exp(-t / tau)); its integral over [0, 0.1]
    assert x[5] == pytest.approx(0.1 - tau * (1 - math.exp(-0.1 / tau)), rel=1e-12)
    # a second command starts from the lagged value reached
    p.commanded(0.1, 2 * v)
    (_, y), = p.spans(0.1, 0.2)
    a0 = 1 - math.exp(-0.1 / tau)
    want = 2 * 0.1 + (a0 - 2) * tau * (1 - math.exp(-0.1 / tau))
    assert y[5] == pytest.approx(want, rel=1e-12)


def test_bad_arguments_are_refused():
    for kw, match in (({"delay": 0.0}, "delay"), ({"delay": float("nan")}, "delay"), ({"delay": 0.1, "lag": -1},
                                                                                       "lag"),
                      ({"delay": 0.1, "max_step": 0}, "max_step"), ({"delay": True}, "delay")):
        with pytest.raises(ValueError, match=match):
            FeaturePredictor(**kw)
    p = FeaturePredictor(0.1)
    p.commanded(1.0, np.zeros(6))
    with pytest.raises(ValueError, match="before"):
        p.commanded(0.5, np.zeros(6))
    with pytest.raises(ValueError, match="finite"):
        p.commanded(2.0, [np.nan] * 6)


def test_kinematic_model_moves_the_points_with_the_joints():
    # the gantry's joints measured at capture, then commanded: the predicted points are the projection
    # at the joints reached (exact depths given: to rounding)
    from ibvs import sim

    model = sim.Gantry.afma6()
    q0 = np.array(sim.cases.GANTRY_GOAL_Q)
    C0 = model.camera(q0)
    world = (C0[:3, :3] @ np.array([[-0.05, -0.05, 0.6], [0.05, -0.05, 0.62], [0.05, 0.05, 0.6]]).T).T + C0[:3, 3]

    def seen(q):
        T = np.linalg.inv(model.camera(q))
        P = world @ T[:3, :3].T + T[:3, 3]
        return P[:, :2] / P[:, 2:3], P[:, 2]

    qdot1, qdot2 = np.array([0.05, -0.02, 0.03, 0.1, -0.2, 0.4]), np.array([-0.02, 0.04, 0.0, 0.0, 0.3, -0.1])
    p = FeaturePredictor(0.1, kinematics=model)
    p.observed(0.0, q0)
    p.commanded(0.0, np.zeros(6), qdot1)
    q_mid = q0 + 0.04 * qdot1
    p.observed(0.04, q_mid)  # a state read mid-way
    p.commanded(0.04, np.zeros(6), qdot2)
    uv, z = seen(q0)
    got_uv, got_z = p.predict(uv, z, 0.0)
    want_uv, want_z = seen(q_mid + 0.06 * qdot2)
    np.testing.assert_allclose(got_uv, want_uv, atol=1e-12)
    np.testing.assert_allclose(got_z, want_z, rtol=1e-12)
    np.testing.assert_allclose(p.q_at(0.02), q0 + 0.02 * qdot1, atol=1e-15)
    with pytest.raises(TypeError, match="camera"):
        FeaturePredictor(0.1, kinematics=object())


def test_the_ros_node_tells_its_predictor_what_it_commanded():
    # ServoNodeCore (the node's message path) records each twist it publishes in its predictor
    pytest.importorskip("rosbags", reason="the node's messages are rosbags' classes (the ros extra)")
    from ibvs.ros.node import NodeParams, ServoNodeCore

    now = {"ns": 0}
    p = FeaturePredictor(0.05)
    core = ServoNodeCore(NodeParams(desired_pixels=[[300, 200], [340, 200], [340, 240], [300, 240]]),
                         clock=lambda: now["ns"], predictor=p)
    core.last_twist, core.last_good_ns = np.array([0.1, 0, 0, 0, 0, 0.2]), 0
    now["ns"] = 10_000_000
    core.tick()  # the ramp's command, published at 10 ms
    assert p._t == [0.01] and np.allclose(p._v[0], 0.95 * np.array([0.1, 0, 0, 0, 0, 0.2]))


def test_a_prediction_out_of_the_field_is_lost_features_not_an_error():
    pytest.importorskip("cv2", reason="the core tracks rendered dots (the vision extra)")
    import loop_world as lw

    w = lw.world()
    p = FeaturePredictor(1.0)
    core = lw.core(w, predictor=p)
    robot = lw.RecordingRobot(w.clock, w.q0, w.model)
    frame = lw.render_source(w, robot).read(1.0)
    first = core.twist_of_image(frame.image, frame.stamp)  # no command yet: the measured points
    assert core.state == "servoing" and np.isfinite(first).all()
    p.commanded(frame.stamp, [0, 0, 0, 3.0, 0, 0])  # 3 rad/s about x for the 1 s delay: behind the camera
    out = core.twist_of_image(frame.image, frame.stamp)
    assert "leaves the camera's field" in core.last_error and np.array_equal(out, first)  # the ramp, at age 0
