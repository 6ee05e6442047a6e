"""ibvs.calibrate_hand_eye and the target poses (ibvs.calibration): known answers for both mounts and every method,
OpenCV's conventions checked against a direct call, agreement of the methods with noise, and every refusal."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

import ibvs
from ibvs import sim
from ibvs.calibration import METHODS, calibrate_hand_eye, pose_error, tag_points, target_pose, target_poses
from ibvs.calibration.rigid import invert, mean_pose, rotation_angle

cv2 = pytest.importorskip("cv2")

EMC = sim.pose(t=(0.05, -0.03, 0.04), r=(0.1, -0.2, 0.3))  # end effector <- camera
BMO = sim.pose(t=(0.6, 0.1, 0.02), r=(3.0, 0.1, 0.2))  # base <- target (eye in hand)
BMC = sim.pose(t=(1.0, 0.2, 0.3), r=(2.0, 0.1, 0.2))  # base <- camera (eye to hand)
EMO = sim.pose(t=(0.0, 0.01, 0.1), r=(math.pi, 0.0, 0.3))  # end effector <- target (eye to hand)


def robot_poses(n=10, seed=0, rotation=0.5):
    rng = np.random.default_rng(seed)
    return np.array([sim.pose(t=rng.uniform(-0.3, 0.3, 3) + [0.4, 0, 0.5], r=rng.uniform(-rotation, rotation, 3))
                     for _ in range(n)])


def target_poses_of(bMe, mount="eye_in_hand"):
    if mount == "eye_in_hand":
        return np.array([invert(T @ EMC) @ BMO for T in bMe])
    return np.array([invert(BMC) @ T @ EMO for T in bMe])


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("mount", ["eye_in_hand", "eye_to_hand"])
def test_exact_data_give_the_known_answer(mount, method):
    bMe = robot_poses()
    r = calibrate_hand_eye(bMe, target_poses_of(bMe, mount), mount, method)
    X, Z = (EMC, BMO) if mount == "eye_in_hand" else (BMC, EMO)
    assert max(pose_error(r.hand_eye, X)) < 1e-9 and max(pose_error(r.target, Z)) < 1e-9
    assert r.rms_translation < 1e-9 and r.rms_rotation < 1e-9 and r.rotation_mismatch < 1e-9
    assert r.stations == 10 and r.method == method and r.mount == mount
    names = ("eMc", "bMo") if mount == "eye_in_hand" else ("bMc", "eMo")
    assert getattr(r, names[0]) is r.hand_eye and getattr(r, names[1]) is r.target
    other = ("bMc", "eMo") if mount == "eye_in_hand" else ("eMc", "bMo")
    for name in other:
        with pytest.raises(AttributeError, match=name):
            getattr(r, name)


def test_method_names_any_case_and_the_top_level_name():
    bMe = robot_poses()
    a = ibvs.calibrate_hand_eye(bMe, target_poses_of(bMe), method="TSAI")
    assert a.method == "tsai" and max(pose_error(a.eMc, EMC)) < 1e-9
    assert ibvs.calibrate_hand_eye is calibrate_hand_eye


@pytest.mark.parametrize("mount", ["eye_in_hand", "eye_to_hand"])
def test_opencv_arguments_as_documented(mount):
    """The same answer as cv2.calibrateHandEye given R_gripper2base = bMe (eye in hand) or bMe^-1 (eye to hand)."""
    rng = np.random.default_rng(3)
    bMe = robot_poses(8, seed=3)
    cMo = target_poses_of(bMe, mount)
    noisy = np.array([T @ sim.pose(t=rng.normal(0, 1e-3, 3), r=rng.normal(0, 2e-3, 3)) for T in cMo])
    gripper2base = bMe if mount == "eye_in_hand" else np.linalg.inv(bMe)
    R, t = cv2.calibrateHandEye([T[:3, :3] for T in gripper2base], [T[:3, 3] for T in gripper2base],
                                [T[:3, :3] for T in noisy], [T[:3, 3] for T in noisy], method=cv2.CALIB_HAND_EYE_PARK)
    r = calibrate_hand_eye(bMe, noisy, mount, "park")
    assert np.allclose(r.hand_eye[:3, :3], R, atol=1e-9) and np.allclose(r.hand_eye[:3, 3], t.ravel(), atol=1e-9)
    assert 0 < r.rms_translation < 0.01


@pytest.mark.parametrize("mount", ["eye_in_hand", "eye_to_hand"])
def test_methods_agree_on_noisy_data(mount):
    rng = np.random.default_rng(7)
    bMe = robot_poses(15, seed=7)
    cMo = np.array([T @ sim.pose(t=rng.normal(0, 2e-4, 3), r=rng.normal(0, 5e-4, 3))
                    for T in target_poses_of(bMe, mount)])
    results = {m: calibrate_hand_eye(bMe, cMo, mount, m) for m in METHODS}
    X = EMC if mount == "eye_in_hand" else BMC
    for m, r in results.items():
        dt, dr = pose_error(r.hand_eye, X)
        assert dt < 5e-3 and dr < math.radians(0.1), (m, dt, dr)
        assert 0 < r.rms_translation < 5e-3 and 0 < r.rotation_mismatch < math.radians(0.1)
    for m in ("tsai", "park", "horaud", "daniilidis"):  # the separable ones and dual quaternions: within 1 mm
        assert pose_error(results[m].hand_eye, results["park"].hand_eye)[0] < 1e-3


def test_wrong_mount_is_reported_by_the_residuals_not_refused():
    bMe = robot_poses()
    good = calibrate_hand_eye(bMe, target_poses_of(bMe, "eye_to_hand"), "eye_to_hand")
    wrong = calibrate_hand_eye(bMe, target_poses_of(bMe, "eye_to_hand"), "eye_in_hand")
    assert good.rms_translation < 1e-9 and wrong.rms_translation > 0.01 and wrong.rms_rotation > math.radians(1)
    assert "residuals RMS" in str(wrong)


def bad(robot=None, target=None, **options):
    bMe = robot_poses()
    cMo = target_poses_of(bMe)
    return calibrate_hand_eye(bMe if robot is None else robot, cMo if target is None else target, **options)


def nonrigid(kind):
    bMe = robot_poses()
    if kind == "scaled":
        bMe[2, :3, :3] *= 1.01
    elif kind == "mirrored":
        bMe[2, :3, 0] *= -1
    elif kind == "last_row":
        bMe[2, 3] = (0, 0, 1, 1)
    elif kind == "nan":
        bMe[2, 0, 3] = np.nan
    elif kind == "far":
        bMe[2, 0, 3] = 2e6
    return bMe


@pytest.mark.parametrize("kind, message", [("scaled", r"robot_poses\[2\] is not a rigid"),
                                           ("mirrored", r"robot_poses\[2\] is not a rigid"),
                                           ("last_row", r"robot_poses\[2\].*last row"),
                                           ("nan", r"robot_poses\[2\] is not finite"),
                                           ("far", r"robot_poses\[2\]: translation")])
def test_non_rigid_or_non_finite_poses_are_refused_by_name(kind, message):
    with pytest.raises(ValueError, match=message):
        bad(robot=nonrigid(kind))


def test_shapes_types_counts_and_names_are_refused():
    bMe = robot_poses()
    cMo = target_poses_of(bMe)
    with pytest.raises(ValueError, match="robot_poses: at least 3"):
        calibrate_hand_eye(bMe[:2], cMo[:2])
    with pytest.raises(ValueError, match="robot_poses and target_poses"):
        calibrate_hand_eye(bMe, cMo[:-1])
    with pytest.raises(ValueError, match=r"target_poses must have shape \(N, 4, 4\)"):
        calibrate_hand_eye(bMe, cMo[:, :3])
    with pytest.raises(TypeError, match="target_poses must hold real numbers"):
        calibrate_hand_eye(bMe, cMo.astype(bool))
    with pytest.raises(TypeError, match="robot_poses must hold real numbers"):
        calibrate_hand_eye(bMe.astype(complex), cMo)
    with pytest.raises(TypeError, match="robot_poses"):
        calibrate_hand_eye("poses", cMo)
    with pytest.raises(ValueError, match="robot_poses"):
        calibrate_hand_eye([np.eye(4), np.eye(3), np.eye(4)], cMo[:3])
    with pytest.raises(ValueError, match="method must be one of"):
        calibrate_hand_eye(bMe, cMo, method="svd")
    with pytest.raises(TypeError, match="method must be a str"):
        calibrate_hand_eye(bMe, cMo, method=cv2.CALIB_HAND_EYE_PARK)
    with pytest.raises(ValueError, match="mount must be one of"):
        calibrate_hand_eye(bMe, cMo, mount="hand_in_eye")
    with pytest.raises(ValueError, match="min_rotation"):
        calibrate_hand_eye(bMe, cMo, min_rotation=-1.0)
    with pytest.raises(TypeError, match="max_rotation_mismatch"):
        calibrate_hand_eye(bMe, cMo, max_rotation_mismatch="2 deg")


def test_pure_translations_are_refused():
    bMe = robot_poses(rotation=0.0)
    with pytest.raises(ValueError, match="robot_poses: the motions are pure translations"):
        calibrate_hand_eye(bMe, target_poses_of(bMe))


def test_rotations_about_one_axis_are_refused():
    rng = np.random.default_rng(1)
    bMe = np.array([sim.pose(t=rng.uniform(-0.2, 0.2, 3), r=(0, 0, a)) for a in np.linspace(-1, 1, 8)])
    with pytest.raises(ValueError, match="robot_poses: the motions all rotate about one axis"):
        calibrate_hand_eye(bMe, target_poses_of(bMe))
    bMe[3] = bMe[3] @ sim.pose(r=(0.3, 0, 0))  # one motion about another axis: enough (two motions, two axes)
    r = calibrate_hand_eye(bMe, target_poses_of(bMe))
    assert max(pose_error(r.eMc, EMC)) < 1e-6 and r.motion_spread > math.radians(1)


def test_unpaired_stations_are_refused_naming_target_poses():
    bMe = robot_poses()
    cMo = target_poses_of(bMe)[np.r_[1:10, 0]]  # shifted by one station
    with pytest.raises(ValueError, match="target_poses: the camera's motions rotate by other angles"):
        calibrate_hand_eye(bMe, cMo)


def test_rotations_near_orthonormal_are_projected():
    bMe = robot_poses()
    cMo = target_poses_of(bMe)
    cMo[:, :3, :3] += 1e-7
    r = calibrate_hand_eye(bMe, cMo)
    assert pose_error(r.eMc, EMC)[1] < 1e-5


def test_import_ibvs_does_not_import_opencv():
    code = "import sys, ibvs, ibvs.calibration; assert 'cv2' not in sys.modules; print('ok')"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0 and "ok" in out.stdout, out.stderr


def test_opencv_without_the_solvers_is_named(monkeypatch):
    class NoHandEye:
        __version__ = "5.0.0"

    monkeypatch.setitem(sys.modules, "cv2", NoHandEye())
    bMe = robot_poses()
    with pytest.raises(ImportError, match="calibrateHandEye.*opencv-contrib-python-headless>=4.7,!=5.0.0.93"):
        calibrate_hand_eye(bMe, target_poses_of(bMe))


def test_rigid_helpers():
    rng = np.random.default_rng(2)
    T = sim.pose(t=rng.normal(size=3), r=rng.normal(size=3))
    assert np.allclose(invert(T) @ T, np.eye(4), atol=1e-15)
    assert rotation_angle(sim.rotation(0, 0, 1e-9)) == pytest.approx(1e-9, rel=1e-6)
    assert rotation_angle(sim.rotation(0, math.pi, 0)) == pytest.approx(math.pi)
    assert np.allclose(mean_pose(np.array([T, T])), T)
    assert pose_error(T @ sim.pose(t=(0, 0, 0.002), r=(0.001, 0, 0)), T) == pytest.approx((0.002, 0.001), rel=1e-6)


# --------------------------------------------------------------------------- target poses

CAMERA = ibvs.CameraModel.from_opencv([[800.0, 0, 320], [0, 800, 240], [0, 0, 1]], [-0.1, 0.02, 0, 0, 0],
                                      width=640, height=480)
CMO = sim.pose(t=(0.01, -0.02, 0.5), r=(0.3, -0.2, 0.5))


def pixels_of(points, cMo=CMO):
    P = points @ cMo[:3, :3].T + cMo[:3, 3]
    return CAMERA.project(P[:, :2] / P[:, 2:])


def test_target_pose_from_a_tag_and_a_grid():
    tag = tag_points(0.1)
    assert np.allclose(tag, sim.Target.square(0.1).points)
    assert max(pose_error(target_pose(CAMERA, pixels_of(tag), tag), CMO)) < 1e-9
    grid = np.c_[np.random.default_rng(0).uniform(-0.05, 0.05, (9, 2)), np.zeros(9)]
    assert max(pose_error(target_pose(CAMERA, pixels_of(grid)[:, None], grid), CMO)) < 1e-9


def test_target_poses_drops_stations_without_enough_points():
    tag = tag_points(0.1)
    other = CMO @ sim.pose(r=(0.1, 0.2, 0.0))
    lost = pixels_of(tag).copy()
    lost[1] = np.nan
    poses, kept = target_poses(CAMERA, [pixels_of(tag), None, lost, pixels_of(tag, other)], tag)
    assert kept.tolist() == [True, False, False, True] and poses.shape == (2, 4, 4)
    assert max(pose_error(poses[1], other)) < 1e-9
    from ibvs.vision import Track

    poses, kept = target_poses(CAMERA, [Track(pixels_of(tag), ("detected",) * 4, 0.0)], tag)
    assert kept.tolist() == [True]


def test_target_poses_refusals():
    tag = tag_points(0.1)
    with pytest.raises(ValueError, match=r"detections\[0\] must have shape \(4, 2\)"):
        target_poses(CAMERA, [np.zeros((3, 2))], tag)
    with pytest.raises(ValueError, match="detections: no station"):
        target_poses(CAMERA, [None, np.full((4, 2), np.nan)], tag)
    with pytest.raises(ValueError, match="points must lie in the target's z = 0 plane"):
        target_poses(CAMERA, [pixels_of(tag)], tag + [0, 0, 0.01])
    with pytest.raises(ValueError, match=r"detections\[0\]: pixels must be finite"):
        target_poses(CAMERA, [np.array([[np.inf, 0.0], [1, 2], [3, 4], [5, 6]])], tag)
    with pytest.raises(TypeError, match="camera must be an ibvs.CameraModel"):
        target_poses("camera", [pixels_of(tag)], tag)
    with pytest.raises(ValueError, match="min_points"):
        target_poses(CAMERA, [pixels_of(tag)], tag, min_points=5)
    with pytest.raises(ValueError, match="pixels must be finite"):
        target_pose(CAMERA, np.full((4, 2), np.nan), tag)
    with pytest.raises(ValueError, match="pixels: no pose"):  # collinear pixels
        target_pose(CAMERA, np.array([[100.0, 100], [200, 200], [300, 300], [400, 400]]), tag)
    with pytest.raises(ValueError, match="side"):
        tag_points(0.0)
