"""ibvs.sim.run(..., goal_pose="taught" | "given"): the goal pose c*Mo of the PBVS, 2.5-D and moments blocks taught
from the goal's image as the depth mode knows it (default), or given (the goal's true pose). With a wrong camera model
(sim.MiscalibratedCamera) and the pose depth mode, a taught goal carries the current estimate's bias and PBVS ends at
the goal; a given one does not, and PBVS ends where the estimate equals it (docs/compare.md, "Calibration errors")."""

from __future__ import annotations

import numpy as np
import pytest

import ibvs
from ibvs import sim
from ibvs.study import compare, schemes
from ibvs.study.scenario import DEFAULTS, offset

GENERAL = dict(rz_deg=60.0, tilt_deg=8.0, tilt_dir_deg=30.0, tx=0.1, ty=-0.05, tz=-0.3)
CALIBRATIONS = ["f ×0.8", "f ×1.25", "c +(24, −16) px"]
# Where the error norm's tolerance (compare.TOLERANCE = 1e-6, metres and radians) leaves the camera: the pose
# estimate within 1e-6 m of its goal is the camera within 1e-6 / s <= 1.25 um in depth of where the estimate is
# exactly the goal, and a rotation error of 1e-6 rad moves the target's image by at most 1e-6 x Z* = 3 um
# sideways: 20 um covers both with margin.
AT = 2e-5


def run(scheme: str, calibration, goal_pose: str, depth: str = "pose", start=None, goal=None, duration=None):
    """A run of the comparison's scheme from its general start, through the wrong model of `calibration`
    (None: the true camera), with the given depth mode and goal pose."""
    setup = compare.scenario()
    camera, believed = compare.cameras(calibration or "none")
    goal = setup.goal_pose() if goal is None else goal
    start = goal @ offset(dict(DEFAULTS, **GENERAL)) if start is None else start
    return sim.run(schemes.make(scheme, setup.gain, len(setup.target)), camera,
                   schemes.target_for(scheme, setup.target), start, goal, duration=duration or setup.duration,
                   depth=depth, tolerance=compare.TOLERANCE, vision=sim.MiscalibratedCamera(camera, believed),
                   goal_pose=goal_pose)


def final_position(r) -> np.ndarray:
    """The camera centre at the last frame, in the goal camera's frame."""
    return (np.linalg.inv(np.asarray(r.goal)) @ np.asarray(r.history.pose)[-1])[:3, 3]


def estimate(r, uv) -> np.ndarray:
    """ibvs.PlanarPose's camera <- target from the controller's points uv (what the pose depth mode computes)."""
    T, _, degenerate = ibvs.PlanarPose(np.asarray(r.target.points)).estimate(np.asarray(uv))
    assert not degenerate
    return np.asarray(T)


def goal_cMo(r) -> np.ndarray:
    return np.linalg.inv(np.asarray(r.goal)) @ np.asarray(r.target.pose)


def angle(Ra, Rb) -> float:
    return float(np.arccos(np.clip((np.trace(Ra.T @ Rb) - 1.0) / 2.0, -1.0, 1.0)))


def test_goal_pose_is_refused_unless_taught_or_given():
    case = sim.cases.general_motion()
    servo = ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0)
    for bad in ("measured", "", "Given", "taught "):
        with pytest.raises(ValueError, match="goal_pose"):
            sim.run(servo, case.camera, case.target, case.start, case.goal, duration=0.1, goal_pose=bad)
    for bad in (None, 1, True, b"given"):
        with pytest.raises(TypeError, match="goal_pose"):
            sim.run(servo, case.camera, case.target, case.start, case.goal, duration=0.1, goal_pose=bad)
    with pytest.raises(ValueError, match="goal_pose"):  # the binding refuses by itself too
        ibvs._core.sim._run(servo, case.camera, case.target, case.start, case.goal, duration=0.1, goal_pose="x")


@pytest.mark.parametrize("scheme", ["pbvs", "2.5d", "moments"])
def test_taught_is_the_default_bit_for_bit(scheme):
    """goal_pose="taught" is what sim.run did before the option (the calibration study's runs, compare.run, use
    the default): the same run to the last bit."""
    default = compare.run(scheme, offset(dict(DEFAULTS, **GENERAL)), calibration="f ×0.8")
    taught = run(scheme, "f ×0.8", "taught")
    assert default.status.outcome == taught.status.outcome == "converged"
    for name in ("pose", "twist", "error", "measurements"):
        np.testing.assert_array_equal(getattr(default.history, name), getattr(taught.history, name))
    np.testing.assert_array_equal(default.measurements_desired, taught.measurements_desired)


@pytest.mark.parametrize("scheme", ["pbvs", "pbvs_object", "2.5d", "moments"])
def test_given_is_taught_when_the_goal_is_known(scheme):
    """With the exact and desired depth modes the taught goal is the true one: given changes nothing (bit for bit,
    also through a wrong camera model). With the pose mode and a correct camera the goal's estimate is the true pose
    (to rounding): given converges like taught, to the same path within 1e-9."""
    for depth in ("exact", "desired"):
        a, b = (run(scheme, "f ×0.8", g, depth=depth, duration=2.0) for g in ("taught", "given"))
        np.testing.assert_array_equal(a.history.pose, b.history.pose)
        np.testing.assert_array_equal(a.measurements_desired, b.measurements_desired)
    a, b = (run(scheme, None, g) for g in ("taught", "given"))
    assert a.status.outcome == b.status.outcome == "converged"
    np.testing.assert_allclose(b.history.pose, a.history.pose, rtol=0, atol=1e-9)
    if scheme != "moments":  # the moments' false goal (docs/compare.md), taught or given
        assert b.metrics.final_translation_error < AT and b.metrics.final_rotation_error < 1e-5


@pytest.mark.parametrize("calibration", CALIBRATIONS)
@pytest.mark.parametrize("scheme", ["pbvs", "pbvs_object"])
def test_given_goal_keeps_the_calibration_bias(scheme, calibration):
    """PBVS (either translation) with a given goal ends where the current image's pose estimate equals the true goal
    pose; taught, at the goal. The target is fronto-parallel at Z* = 3 m from the goal. A focal length s times the
    true one gives the controller x' = X / (s Z): the image of the target at s times its depth, so the estimate is the
    goal where the camera is Z* / s from the target, Z* (1/s - 1) behind the goal along its optical axis (750 mm for
    s = 0.8, 600 mm ahead for s = 1.25). A principal point off by d = (du, dv) px shifts every normalised point by
    -d / f: the estimate is the target moved by -Z d / f, so the camera stops Z* d / f to the side, at
    (-Z* du / f, -Z* dv / f, 0) in the goal camera's frame (108.2 mm for (24, -16) px)."""
    scale, (du, dv), _ = compare.CALIBRATIONS[calibration]
    Z, f = compare.DEPTH, compare.FOCAL
    taught, given = (run(scheme, calibration, g) for g in ("taught", "given"))
    assert taught.status.outcome == given.status.outcome == "converged"
    assert taught.metrics.final_translation_error < AT and taught.metrics.final_rotation_error < 1e-5
    want = np.array([-Z * du / f, -Z * dv / f, -Z * (1.0 / scale - 1.0)])
    np.testing.assert_allclose(final_position(given), want, rtol=0, atol=AT)
    assert given.metrics.final_translation_error == pytest.approx(np.linalg.norm(want), abs=AT)
    assert given.metrics.final_rotation_error < 1e-5
    # the defining property: the final image's estimate is the given (true) goal pose
    np.testing.assert_allclose(estimate(given, given.history.uv[-1]), goal_cMo(given), rtol=0, atol=AT)


def orbit(ay_deg: float, ax_deg: float) -> np.ndarray:
    """A goal (world <- camera) turned about the target's centre by ay about y then ax about x: the target seen
    tilted."""
    T_o = np.asarray(compare.scenario().target.pose)
    ay, ax = np.radians(ay_deg), np.radians(ax_deg)
    Ry = np.array([[np.cos(ay), 0, np.sin(ay)], [0, 1, 0], [-np.sin(ay), 0, np.cos(ay)]])
    Rx = np.array([[1, 0, 0], [0, np.cos(ax), -np.sin(ax)], [0, np.sin(ax), np.cos(ax)]])
    T = np.eye(4)
    T[:3, :3] = Ry @ Rx
    T[:3, 3] = T_o[:3, 3] - T[:3, :3] @ T_o[:3, 3]
    return T


@pytest.mark.parametrize("calibration", CALIBRATIONS)
def test_given_goal_2_5d(calibration):
    """2.5-D takes x*, y* (its reference point's image) and Z* from the goal's image, taught either way, and only
    the rotation c*R from the goal pose: given, it converges where the current estimate's rotation is the true goal
    rotation, the reference point's image the goal's and its estimated depth the goal's.
    Fronto-parallel goal: the estimate of a planar target seen fronto-parallel through a wrong focal length or
    principal point is the true rotation (x' = X / (s Z) and x' = x - d / f are images of the same plane, unturned),
    so the given rotation is the taught one and 2.5-D ends at the goal.
    Tilted goal (25 deg about y, -15 deg about x): the goal's estimate is turned by some bias angle b; given, 2.5-D
    ends with the estimate turned to the true rotation, i.e. the camera turned by b from the goal (to first order: the
    bias at the final pose differs from the goal's by a relative amount of the order of b itself, <= 0.035 rad here,
    so 5 %), with its reference point's pixel at the goal's; taught, at the goal."""
    r = run("2.5d", calibration, "given")
    assert r.status.outcome == "converged"
    np.testing.assert_allclose(estimate(r, r.uv_desired)[:3, :3], goal_cMo(r)[:3, :3], rtol=0, atol=1e-9)
    assert r.metrics.final_translation_error < AT and r.metrics.final_rotation_error < 1e-5
    goal = orbit(25.0, -15.0)
    taught, given = (run("2.5d", calibration, g, goal=goal, duration=40.0) for g in ("taught", "given"))
    assert taught.status.outcome == given.status.outcome == "converged"
    assert taught.metrics.final_translation_error < AT and taught.metrics.final_rotation_error < 1e-4
    bias = angle(estimate(given, given.uv_desired)[:3, :3], goal_cMo(given)[:3, :3])
    assert 0.004 < bias < 0.04  # a real bias (0.42 deg, 0.28 deg, 1.99 deg), which the taught goal cancels
    assert given.metrics.final_rotation_error == pytest.approx(bias, rel=0.05)
    np.testing.assert_allclose(estimate(given, given.history.uv[-1])[:3, :3], goal_cMo(given)[:3, :3], rtol=0,
                               atol=1e-5)
    last = np.asarray(given.history.measured)[-1].reshape(-1, 2)[0]
    np.testing.assert_allclose(last, np.asarray(given.measured_desired)[0], rtol=0, atol=1e-3)  # pixels


def test_scenario_replace_takes_goal_pose():
    """Scenario.replace(goal_pose=) sets goal_pose_mode (goal_pose() is the goal's 4x4 pose), as sweep() and
    scenario files name it; a bad value is refused naming goal_pose."""
    from ibvs.study.scenario import builtin

    s = builtin("free").replace(goal_pose="given")
    assert s.goal_pose_mode == "given" and s.goal_pose().shape == (4, 4)
    with pytest.raises(ValueError, match="goal_pose"):
        builtin("free").replace(goal_pose="measured").validate()
