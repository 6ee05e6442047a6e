"""Property-based tests (hypothesis) of the hand-eye input paths: ibvs.calibrate_hand_eye's poses and options,
ibvs.calibration.target_pose / target_poses' pixels and points, tag_points, and sim.MiscalibratedRobot's mount. The
rule of test_properties.py: every input is answered with finite numbers (a rigid estimate, finite residuals) or
refused with ValueError/TypeError naming the argument; valid inputs are not refused."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import ibvs
from test_properties import hostile_arrays
from ibvs import sim
from ibvs.calibration import METHODS, calibrate_hand_eye, tag_points, target_pose, target_poses
from ibvs.calibration.rigid import invert

from test_properties_more import ENTRY, refused_by_name

pytest.importorskip("cv2")

EMC = sim.pose(t=(0.05, -0.03, 0.04), r=(0.1, -0.2, 0.3))
BMO = sim.pose(t=(0.6, 0.1, 0.02), r=(3.0, 0.1, 0.2))
ANGLE = st.floats(-math.pi, math.pi)
METRES = st.one_of(st.floats(-2.0, 2.0), st.sampled_from([0.0, 1e-300, 1e5, 1e6, -1.01e6, 1e300]),
                   st.floats(allow_nan=True, allow_infinity=True, width=64))


@st.composite
def rigid(draw, metres=METRES):
    T = np.eye(4)
    T[:3, :3] = sim.poses.rotation_matrix(draw(ANGLE), draw(ANGLE), draw(ANGLE))
    T[:3, 3] = [draw(metres) for _ in range(3)]
    return T


@st.composite
def pose_stacks(draw):
    """Mostly rigid poses (some with NaN or huge translations), sometimes any 4x4 arrays, any count from 0 to 8."""
    n = draw(st.integers(0, 8))
    if draw(st.integers(0, 4)) == 0:
        return draw(hostile_arrays(np.float64, (n, 4, 4), elements=ENTRY))
    return np.array([draw(rigid()) for _ in range(n)]).reshape(n, 4, 4)


def is_rigid_stack(a) -> bool:
    a = np.asarray(a)
    if a.ndim != 3 or a.shape[1:] != (4, 4) or not np.isfinite(a).all():
        return False
    for T in a:
        R = T[:3, :3]
        if np.abs(R @ R.T - np.eye(3)).max() > 1e-6 or np.linalg.det(R) <= 0 or \
                np.abs(T[3] - [0, 0, 0, 1]).max() > 1e-9 or np.abs(T[:3, 3]).max() > 1e6:
            return False
    return True


def answered(r) -> bool:
    X = r.hand_eye
    return bool(np.isfinite(X).all() and np.allclose(X[:3, :3] @ X[:3, :3].T, np.eye(3), atol=1e-9)
                and np.isfinite(r.target).all() and np.isfinite(r.translation_residuals).all()
                and np.isfinite(r.rotation_residuals).all() and math.isfinite(r.rotation_mismatch))


NAMES = ("robot_poses", "target_poses", "mount", "method", "min_rotation", "max_rotation_mismatch")


@settings(max_examples=120)
@given(pose_stacks(), pose_stacks(), st.sampled_from(["eye_in_hand", "eye_to_hand", "EYE_IN_HAND", "other", 3]),
       st.sampled_from(list(METHODS) + ["Park", "svd", None]))
def test_calibrate_hand_eye_any_poses_finite_or_refused(bMe, cMo, mount, method):
    try:
        r = calibrate_hand_eye(bMe, cMo, mount, method)
    except (ValueError, TypeError) as e:
        assert refused_by_name(e, *NAMES), str(e)
        return
    assert answered(r)
    assert is_rigid_stack(bMe) and is_rigid_stack(cMo) and len(bMe) == len(cMo) >= 3


@settings(max_examples=60)
@given(st.integers(3, 12), st.integers(0, 2**32 - 1), st.sampled_from(["eye_in_hand", "eye_to_hand"]),
       st.sampled_from(METHODS), st.floats(0.0, 0.05), st.floats(0.0, 2e-3))
def test_valid_stations_are_answered_or_refused_as_degenerate(n, seed, mount, method, spin, noise):
    """Consistent stations with rotations from tiny to large: an answer whose residuals are small for small noise, or
    a refusal of degenerate motions (naming robot_poses) when the rotations are below min_rotation."""
    rng = np.random.default_rng(seed)
    bMe = np.array([sim.pose(t=rng.uniform(-0.5, 0.5, 3), r=rng.uniform(-1, 1, 3) * spin * 30) for _ in range(n)])
    cMo = np.array([invert(T @ EMC) @ BMO if mount == "eye_in_hand" else invert(BMO) @ T @ EMC for T in bMe])
    cMo = np.array([T @ sim.pose(t=rng.normal(0, noise, 3), r=rng.normal(0, noise, 3)) for T in cMo])
    try:
        r = calibrate_hand_eye(bMe, cMo, mount, method)
    except ValueError as e:
        assert refused_by_name(e, "robot_poses", "target_poses", "method"), str(e)
        assert "pure translations" in str(e) or "one axis" in str(e) or "other angles" in str(e) or \
            "no finite solution" in str(e)
        return
    assert answered(r) and r.motion_spread > math.radians(1)


PIXELS = st.one_of(st.floats(-1e3, 2e3), st.sampled_from([np.nan, np.inf, -np.inf, 1e8, -1e300]))


@settings(max_examples=120)
@given(hostile_arrays(np.float64, st.sampled_from([(4, 2), (4, 1, 2), (3, 2), (5, 2), (4,)]), elements=PIXELS),
       st.sampled_from(["tag", "grid", "raised", "few", "strings"]))
def test_target_pose_any_pixels_finite_or_refused(px, kind):
    camera = ibvs.CameraModel.from_opencv([[800.0, 0, 320], [0, 800, 240], [0, 0, 1]], [-0.1, 0.02, 0, 0, 0],
                                          width=640, height=480)
    points = {"tag": tag_points(0.1), "grid": np.c_[np.eye(4)[:, :2] * 0.1, np.zeros(4)],
              "raised": tag_points(0.1) + [0, 0, 0.1], "few": tag_points(0.1)[:3], "strings": [["a"] * 3] * 4}[kind]
    try:
        T = target_pose(camera, px, points)
    except (ValueError, TypeError) as e:
        assert refused_by_name(e, "pixels", "points"), str(e)
        return
    assert np.isfinite(T).all() and np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-6) and T[2, 3] > 0
    try:
        poses, kept = target_poses(camera, [px, None], points)
    except (ValueError, TypeError) as e:
        raise AssertionError(f"target_pose answered but target_poses refused: {e}") from None
    assert kept.tolist() == [True, False] and np.allclose(poses[0], T)


@given(st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-3, 3), st.booleans(), st.text()))
def test_tag_points_any_side(side):
    try:
        p = tag_points(side)
    except (ValueError, TypeError) as e:
        assert refused_by_name(e, "side"), str(e)
        return
    assert p.shape == (4, 3) and np.isfinite(p).all() and 0 < side <= 1e3


@settings(max_examples=60)
@given(st.one_of(rigid(st.floats(-1.0, 1.0)), hnp.arrays(np.float64, st.sampled_from([(4, 4), (3, 4), (4,)]),
                                                          elements=ENTRY)))
def test_miscalibrated_robot_any_mount(mount):
    gantry = sim.Gantry.afma6()
    try:
        robot = sim.MiscalibratedRobot(gantry, mount)
    except (ValueError, TypeError) as e:
        assert refused_by_name(e, "controller_mount"), str(e)
        return
    q = np.array([0.1, -0.05, 0.02, 0.1, 0.4, -0.2])
    assert np.allclose(robot.camera(q), gantry.camera(q), atol=1e-12)
    assert np.isfinite(robot.jacobian(q)).all()
