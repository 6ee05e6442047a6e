"""ibvs.DepthEstimator and ibvs.PlanarPose: the classes the simulator uses (its depth histories are
reproduced from its own points), convergence on synthetic scenes, and bad input."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ibvs
from ibvs import sim

SCENE = np.array([[0.2, 0.2, 1.0], [-0.2, 0.2, 1.2], [-0.2, -0.2, 0.9], [0.2, -0.2, 1.5], [0.05, 0.1, 0.7]])


def look(T_wc, P=SCENE):
    """Normalised points (N, 2) and depths (N,) of world points P from camera pose T_wc."""
    Pc = (np.linalg.inv(T_wc) @ np.c_[P, np.ones(len(P))].T).T[:, :3]
    return Pc[:, :2] / Pc[:, 2:], Pc[:, 2]


def test_depth_converges_from_a_wrong_prior():
    v = np.array([0.3, -0.1, 0.05, 0.05, 0.1, 0.2])  # camera twist, m/s and rad/s
    dt = 1 / 60
    est = ibvs.DepthEstimator(np.full(5, 1.5))
    assert not est.initialized and np.array_equal(est.depth, np.full(5, 1.5))
    T = np.eye(4)
    for _ in range(120):
        uv, z = look(T)
        depth, variance = est.update(uv, v * dt)  # motion as twist * dt
        T = T @ ibvs.se3_exp(v * dt)
    assert np.abs(depth / z - 1).max() < 1e-6
    assert variance.shape == (5,) and (variance > 0).all() and np.array_equal(est.variance, variance)
    assert est.restarts == 0 and est.initialized


def test_motion_as_pose_or_twist():
    d = np.array([0.01, 0.0, -0.02, 0.0, 0.01, 0.03])
    uv0, _ = look(np.eye(4))
    uv1, _ = look(ibvs.se3_exp(d))
    a, b = ibvs.DepthEstimator(np.ones(5)), ibvs.DepthEstimator(np.ones(5))
    a.update(uv0, np.eye(4))
    b.update(uv0[:, None, :], d)  # OpenCV's (N, 1, 2) too
    za, va = a.update(uv1, ibvs.se3_exp(d))
    zb, vb = b.update(uv1, d)
    assert np.array_equal(za, zb) and np.array_equal(va, vb)
    a.reset()
    assert not a.initialized
    assert np.array_equal(a.update(uv1, d)[0], np.ones(5))  # back at the prior
    a.reset(np.full(5, 2.0))
    assert np.array_equal(a.prior, np.full(5, 2.0)) and np.array_equal(a.depth, np.full(5, 2.0))


def test_depth_estimator_bad_input():
    with pytest.raises(ValueError, match=r"prior\[1\]"):
        ibvs.DepthEstimator([1.0, -1.0])
    with pytest.raises(ValueError, match="prior must have shape"):
        ibvs.DepthEstimator(np.ones((2, 2)))
    with pytest.raises(TypeError, match="prior"):
        ibvs.DepthEstimator("deep")
    with pytest.raises(ValueError, match="point_noise"):
        ibvs.DepthEstimator(np.ones(3), point_noise=-1.0)
    with pytest.raises(ValueError, match="max_depth_ratio"):
        ibvs.DepthEstimator(np.ones(3), max_depth_ratio=0.5)
    est = ibvs.DepthEstimator(np.ones(5))
    uv, _ = look(np.eye(4))
    with pytest.raises(ValueError, match="uv must hold 5 points"):
        est.update(uv[:3], np.eye(4))
    with pytest.raises(ValueError, match=r"uv\[2\] is not finite"):
        bad = uv.copy()
        bad[2, 0] = np.inf
        est.update(bad, np.eye(4))
    with pytest.raises(ValueError, match="motion must be a 4x4"):
        est.update(uv, np.eye(3))
    with pytest.raises(ValueError, match="rigid"):
        est.update(uv, 2 * np.eye(4))
    with pytest.raises(ValueError, match="motion"):
        est.update(uv, [0, 0, np.nan, 0, 0, 0])
    with pytest.raises(ValueError, match="prior must hold 5"):
        est.reset(np.ones(4))
    # scale limits: depths in [1e-6, 1e6] m, |uv| <= 10 (pixels by mistake), a motion of at most 1e6 m
    for prior in (1e-300, 1e300):
        with pytest.raises(ValueError, match=r"prior\[0\]"):
            ibvs.DepthEstimator(np.full(5, prior))
    with pytest.raises(ValueError, match="CameraModel.normalize"):
        est.update(uv * 1000.0, np.eye(4))
    far = np.eye(4)
    far[0, 3] = 1e300
    with pytest.raises(ValueError, match="motion"):
        est.update(uv, far)
    with pytest.raises(ValueError, match="prior_uncertainty"):
        ibvs.DepthEstimator(np.ones(3), prior_uncertainty=1e200)
    for name in ("point_noise", "prior_uncertainty", "process_noise", "position_noise", "min_depth",
                 "max_depth_ratio"):
        with pytest.raises(TypeError, match=name):
            ibvs.DepthEstimator(np.ones(3), **{name: True})
    assert not est.initialized  # nothing above changed it


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.floats(-5, 5), min_size=10, max_size=10),
    st.lists(st.floats(-2, 2), min_size=6, max_size=6),
    st.floats(0, 1e-2),
)
def test_depth_estimator_finite_or_refused(points, motion, noise):
    """Any finite frame gives finite depths within [min_depth, max_depth_ratio * prior]."""
    est = ibvs.DepthEstimator(np.full(5, 0.8), point_noise=noise)
    uv = np.reshape(points, (5, 2))
    est.update(uv, np.zeros(6))
    depth, variance = est.update(uv[::-1].copy(), np.array(motion))
    assert np.isfinite(depth).all() and np.isfinite(variance).all() and (variance >= 0).all()
    assert depth.min() >= 1e-3 and depth.max() <= 80.0 * (1 + 1e-12)


def test_planar_pose():
    target = sim.Target.square(0.1)
    est = ibvs.PlanarPose(target.points)
    T = sim.pose(t=(0.02, -0.01, 0.6), r=(0.2, -0.1, 0.7))  # camera <- target
    P = (T @ np.c_[target.points, np.ones(4)].T).T[:, :3]
    pose, depth, degenerate = est.estimate(P[:, :2] / P[:, 2:])
    assert not degenerate
    assert np.abs(pose - T).max() < 1e-9 and np.abs(depth - P[:, 2]).max() < 1e-9
    line = np.array([[0.0, 0.0], [0.1, 0.0], [0.2, 0.0], [0.3, 0.0]])
    pose, depth, degenerate = est.estimate(line)
    assert degenerate and np.isnan(pose).all() and np.isnan(depth).all()
    with pytest.raises(ValueError, match="uv must hold 4"):
        est.estimate(line[:3])
    with pytest.raises(ValueError, match=r"uv\[0\] is not finite"):
        est.estimate(np.full((4, 2), np.nan))
    with pytest.raises(ValueError, match="planar"):
        ibvs.PlanarPose(target.points + [0, 0, 0.01])
    with pytest.raises(ValueError, match="one line"):
        ibvs.PlanarPose(np.c_[np.arange(4.0), np.zeros(4), np.zeros(4)])
    with pytest.raises(ValueError, match="points must have shape"):
        ibvs.PlanarPose(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="iterations"):
        ibvs.PlanarPose(target.points, iterations=-1)
    with pytest.raises(ValueError, match="iterations"):
        ibvs.PlanarPose(target.points, iterations=10**30)
    with pytest.raises(TypeError, match="iterations"):
        ibvs.PlanarPose(target.points, iterations=True)
    with pytest.raises(ValueError, match="CameraModel.normalize"):  # pixels by mistake
        est.estimate(P[:, :2] / P[:, 2:] * 800 + 320)
    with pytest.raises(ValueError, match="points must be finite and within"):
        ibvs.PlanarPose(target.points * 1e300)


def motions(history):
    """The camera's motion between successive frames (previous <- current) from the history's poses,
    formed as the episode forms it."""
    P = history.pose
    out = np.tile(np.eye(4), (len(P) - 1, 1, 1))
    for k in range(len(P) - 1):
        R0, t0 = P[k, :3, :3], P[k, :3, 3]
        out[k, :3, :3] = R0.T @ P[k + 1, :3, :3]
        out[k, :3, 3] = R0.T @ (P[k + 1, :3, 3] - t0)
    return out


def test_simulator_estimated_depth_is_the_depth_estimator():
    """The simulator's depth="estimated" runs ibvs.DepthEstimator: fed the same points and the same
    motions, the Python object gives the same depths (to rounding: numpy forms the motions)."""
    case = sim.cases.gantry_general_motion()
    servo = ibvs.Servo(ibvs.Layout.cartesian(4), gain=2.0)
    r = sim.run(servo, case.camera, case.target, case.start, case.goal,
                robot=case.robot, duration=3.0, depth="estimated", noise=0.3, seed=5, depth_scale=1.2)
    h = r.history
    est = ibvs.DepthEstimator(1.2 * r.depth_desired, point_noise=0.3 / min(case.camera.px, case.camera.py))
    M = motions(h)
    for k in range(len(h) - 1):
        depth, _ = est.update(h.uv[k], M[k - 1] if k else np.eye(4))
        assert np.allclose(depth, h.depth[k], rtol=1e-9), k


def test_simulator_pose_depth_is_the_planar_pose():
    case = sim.cases.gantry_general_motion()
    servo = ibvs.Servo(ibvs.Layout.cartesian(4), gain=2.0)
    r = sim.run(servo, case.camera, case.target, case.start, case.goal,
                robot=case.robot, duration=2.0, depth="pose", noise=0.3, seed=5)
    est = ibvs.PlanarPose(case.target.points)
    for k in range(len(r.history) - 1):
        _, depth, degenerate = est.estimate(r.history.uv[k])
        assert not degenerate and np.array_equal(depth, r.history.depth[k])


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-3, 3), min_size=8, max_size=8))
def test_planar_pose_finite_or_degenerate(points):
    """Any finite image gives a rigid pose and finite depths, or the degenerate flag with NaN."""
    est = ibvs.PlanarPose(sim.Target.square(0.1).points)
    pose, depth, degenerate = est.estimate(np.reshape(points, (4, 2)))
    if degenerate:
        assert np.isnan(pose).all() and np.isnan(depth).all()
    else:
        R = pose[:3, :3]
        assert np.isfinite(pose).all() and np.isfinite(depth).all()
        assert np.allclose(R.T @ R, np.eye(3), atol=1e-9) and np.isclose(np.linalg.det(R), 1.0)


def test_planar_pose_refuses_a_nan_target_point():
    """A NaN anywhere in the target (here the last point's z, which the planarity test alone lets through)."""
    pts = np.asarray(sim.Target.square(0.1).points, dtype=float).copy()
    pts[-1, 2] = np.nan
    with pytest.raises(ValueError, match="points must be finite"):
        ibvs.PlanarPose(pts)


def test_estimated_depth_with_huge_noise_runs():
    """sim.run's noise has no upper limit; the depth filter's point noise is capped at its own (10 normalised
    units) instead of refusing the episode with an option the caller never gave."""
    case = sim.cases.general_motion()
    servo = ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0)
    r = sim.run(servo, case.camera, case.target, case.start, case.goal, duration=0.2, depth="estimated", noise=50.0)
    assert np.isfinite(r.history.twist).all()


def test_depth_bounds_with_a_tiny_prior():
    """max_depth_ratio * prior below min_depth: the depths stay at min_depth (the clamp's range is ordered)."""
    est = ibvs.DepthEstimator(np.full(4, 1e-5), min_depth=1e-3)
    uv = np.array([[0.1, 0.1], [-0.1, 0.1], [-0.1, -0.1], [0.1, -0.1]])
    est.update(uv, np.eye(4))
    depth, variance = est.update(uv * 1.01, np.zeros(6))
    assert np.all(depth == 1e-3) and np.isfinite(variance).all()
