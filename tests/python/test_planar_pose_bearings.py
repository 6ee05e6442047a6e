"""ibvs.PlanarPose.estimate_bearings: the pose of a planar target from bearings, beyond 90 degrees off the
axis (fisheye pixels through CameraModel.to_bearing), its agreement with estimate() where normalised points
exist, and refusals. The C++ tests (tests/cpp/test_planar_pose_bearings.cpp) hold pixel noise through a fisheye
to its first-order bound."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import ibvs
from ibvs import sim

from test_properties_more import ENTRY

K = np.array([[300.0, 0.0, 640.0], [0.0, 300.5, 512.0], [0.0, 0.0, 1.0]])
FISH = ibvs.CameraModel.from_opencv(K, [-0.013, 0.02, -0.012, 0.002], 1280, 1024, fisheye=True)
SQUARE = np.asarray(sim.Target.square(0.5).points)


def camera_points(T, P=SQUARE):
    return P @ T[:3, :3].T + T[:3, 3]


def beside(angle_deg, distance=1.0):
    """camera <- target: the target's centre `angle_deg` off the axis (about y), facing the camera."""
    a = math.radians(angle_deg)
    return ibvs.se3_exp([0, 0, 0, 0, a, 0]) @ sim.pose(t=(0, 0, distance), r=(0.2, -0.1, 0.3))


@pytest.mark.parametrize("angle", [0.0, 60.0, 100.0, 120.0, 150.0])
def test_exact_pose_and_range_at_any_angle(angle):
    T = beside(angle)
    P = camera_points(T)
    est = ibvs.PlanarPose(SQUARE)
    pose, rng, degenerate = est.estimate_bearings(P * [[1.0], [3.0], [0.5], [2.0]])  # any length
    assert not degenerate
    assert np.abs(pose - T).max() < 1e-9 and np.abs(rng - np.linalg.norm(P, axis=1)).max() < 1e-9
    assert (angle < 90) == (P[:, 2] > 0).all()  # beyond 90 degrees the points have z < 0


def test_fisheye_pixels_beyond_90_degrees():
    """The docs' fisheye: a target 105 degrees off the axis, from its pixels (no normalised points exist)."""
    T = beside(105.0, 2.0)  # every point 96 to 114 degrees off the axis
    P = camera_points(T)
    px = FISH.from_bearing(P)
    assert ((px >= 0) & (px <= [1280, 1024])).all() and (P[:, 2] < 0).all()
    pose, rng, degenerate = ibvs.PlanarPose(SQUARE).estimate_bearings(FISH.to_bearing(px))
    assert not degenerate and np.abs(pose - T).max() < 1e-9 and np.abs(rng - np.linalg.norm(P, axis=1)).max() < 1e-9


def test_agrees_with_estimate_in_a_narrow_view():
    T = sim.pose(t=(0.02, -0.01, 0.6), r=(0.2, -0.1, 0.7))
    P = camera_points(T, np.asarray(sim.Target.square(0.1).points))
    est = ibvs.PlanarPose(sim.Target.square(0.1).points)
    a, depth, _ = est.estimate(P[:, :2] / P[:, 2:])
    b, rng, _ = est.estimate_bearings(np.c_[P[:, :2] / P[:, 2:], np.ones(4)])
    assert np.abs(a - b).max() < 1e-9 and np.allclose(rng, np.linalg.norm(P, axis=1), atol=1e-9)
    assert np.allclose(depth, P[:, 2], atol=1e-9)


def test_refusals():
    est = ibvs.PlanarPose(SQUARE)
    b = camera_points(beside(110.0))
    away = b.copy()
    away[2] *= -1  # one bearing pointing away from its point
    pose, rng, degenerate = est.estimate_bearings(away)
    assert degenerate and np.isnan(pose).all() and np.isnan(rng).all()
    T = beside(30.0)
    T[:3, 3] = -T[:3, :3] @ [0.7, 0.1, 0.0]  # the camera centre in the target's plane: the bearings in one plane
    assert est.estimate_bearings(camera_points(T))[2]
    with pytest.raises(ValueError, match="bearings must hold 4"):
        est.estimate_bearings(b[:3])
    with pytest.raises(ValueError, match="bearings must have shape"):
        est.estimate_bearings(b[:, :2])
    b[1] = np.nan
    with pytest.raises(ValueError, match=r"bearings\[1\] is not finite"):
        est.estimate_bearings(b)
    b[1] = 0.0
    with pytest.raises(ValueError, match=r"bearings\[1\] has zero length"):
        est.estimate_bearings(b)


@settings(max_examples=200, deadline=None)
@given(hnp.arrays(np.float64, (4, 3), elements=ENTRY))
def test_bearings_finite_or_refused(b):
    """Any bearings: a rigid pose and finite positive ranges, the degenerate flag with NaN, or a ValueError
    naming the bearing."""
    est = ibvs.PlanarPose(sim.Target.square(0.1).points)
    try:
        pose, rng, degenerate = est.estimate_bearings(b)
    except ValueError as e:
        assert any(f"bearings[{i}]" in str(e) for i in range(4)), e
        return
    if degenerate:
        assert np.isnan(pose).all() and np.isnan(rng).all()
    else:
        R = pose[:3, :3]
        assert np.isfinite(pose).all() and (rng > 0).all() and np.isfinite(rng).all()
        assert np.allclose(R.T @ R, np.eye(3), atol=1e-9) and np.isclose(np.linalg.det(R), 1.0)


@settings(max_examples=100, deadline=None)
@given(st.floats(0.0, 150.0), st.floats(0.4, 3.0), hnp.arrays(np.float64, 3, elements=st.floats(-0.8, 0.8)))
def test_exact_from_any_pose_in_front(angle, distance, tilt):
    """A target facing the camera within ~80 degrees, anywhere up to 150 degrees off the axis: its exact pose."""
    T = ibvs.se3_exp([0, 0, 0, 0, math.radians(angle), 0]) @ sim.pose(t=(0, 0, distance), r=tuple(tilt))
    P = camera_points(T)
    pose, rng, degenerate = ibvs.PlanarPose(SQUARE).estimate_bearings(P)
    assert not degenerate and np.abs(pose - T).max() < 1e-8


def test_simulator_pose_depth_from_bearings_beyond_90_degrees():
    """sim.run with depth="pose" and spherical blocks through the fisheye, the target's centre 100 degrees off
    the axis: the depth stage's PlanarPose works from the bearings, so the blocks' distances are the true ones
    from frame 0 and the episode converges as with exact depths."""
    target = sim.Target.square(0.5, sim.pose(t=(0, 0, 1.0))).with_features([sim.SphericalSource(i) for i in range(4)])
    task = ibvs.Task()
    for _ in range(4):
        task.add(ibvs.SphericalPolarFeature())
    start = ibvs.se3_exp([0.05, -0.04, -0.2, 0.0, math.radians(107), 0.3])
    P = camera_points(np.linalg.inv(start) @ np.asarray(target.pose))
    assert (P[:, 2] < 0).sum() >= 2
    r = sim.run(ibvs.Servo(task, gain=1.0), FISH, target, start, np.eye(4), duration=40, depth="pose", tolerance=1e-9)
    assert r.status.outcome == "converged" and r.metrics.final_translation_error < 1e-8
    m0 = np.asarray(r.history.measurements[0]).reshape(4, 4)
    assert np.abs(m0[:, 3] - np.linalg.norm(P, axis=1)).max() < 1e-9
    assert np.abs(r.history.depth[0] - P[:, 2]).max() < 1e-9
    exact = sim.run(ibvs.Servo(task, gain=1.0), FISH, target, start, np.eye(4), duration=40, tolerance=1e-9)
    assert abs(r.status.frame - exact.status.frame) <= 1
