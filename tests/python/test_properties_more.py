"""Property-based tests (hypothesis) of the public Python functions test_properties.py does not
cover: area_scale, segment_angle and their Jacobians, singular_values, PartitionedServo,
Servo.update_pixels, joint_velocities / JointMapping and ibvs.sim.run. The rule is the same:
every input is answered with finite numbers or refused with ValueError/TypeError naming the
argument; the refusals are the documented limits (docs/conventions.md, "Scale limits")."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ibvs
from ibvs import sim

from test_properties import COORD, DEPTH, finite, points, valid_depths, valid_points, hostile_arrays

# Entries of matrices and twists: plausible, or anything from subnormal to 1e300.
ENTRY = st.one_of(st.floats(-2.0, 2.0), st.floats(allow_nan=True, allow_infinity=True, width=64),
                  st.sampled_from([0.0, 5e-324, 1e-300, 1e-150, 1e150, 1e300]))


def refused_by_name(e: Exception, *names: str) -> bool:
    """A ValueError/TypeError whose message names one of the arguments (as a word: "i" is not "is")."""
    return isinstance(e, (ValueError, TypeError)) and any(re.search(rf"(?<![\w.]){re.escape(n)}\b", str(e))
                                                          for n in names)


def assert_finite_episode(r) -> None:
    """A sim.run result ended in one of the outcomes, with finite errors and measurements on every frame that has
    an error norm, and finite twists on every frame."""
    assert r.status.outcome in sim.OUTCOMES
    h = r.history
    ok = np.isfinite(h.error_norm)
    assert np.isfinite(h.error[ok]).all() and np.isfinite(h.measurements[ok]).all()
    assert np.isfinite(h.twist).all()

@settings(max_examples=80)
@given(points(4), hostile_arrays(np.float64, 4, elements=DEPTH), st.integers(-1, 4), st.integers(-1, 4))
def test_area_and_segment_features_finite_or_refused(uv, z, i, j):
    # segment_angle refuses what its Jacobian refuses, but for the depths only the Jacobian takes
    def refusal(call):
        try:
            call()
        except (ValueError, TypeError) as e:
            return str(e)
        return None

    if valid_depths(z):
        assert refusal(lambda: ibvs.segment_angle(uv, i, j)) == refusal(lambda: ibvs.segment_angle_jacobian(uv, z, i, j))
    for name, call in [
        ("area_scale", lambda: ibvs.area_scale(uv)),
        ("area_scale_jacobian", lambda: ibvs.area_scale_jacobian(uv, z)),
        ("segment_angle", lambda: ibvs.segment_angle(uv, i, j)),
        ("segment_angle_jacobian", lambda: ibvs.segment_angle_jacobian(uv, z, i, j)),
    ]:
        try:
            out = call()
        except (ValueError, TypeError) as e:
            assert refused_by_name(e, "uv", "depth", "i", "j"), (name, e)
            # refused only beyond the limits, for a bad segment (i, j) or a degenerate image
            segment = "segment" in name
            bad_ij = segment and not (0 <= i < 4 and 0 <= j < 4 and i != j)
            degenerate = "coincide" in str(e) or "no area" in str(e) or "area" in str(e)
            assert (not valid_points(uv) or ("jacobian" in name and not valid_depths(z)) or bad_ij
                    or degenerate), (name, uv, z, i, j, e)
            continue
        assert finite(out), (name, uv, z, i, j, out)
        assert valid_points(uv), (name, "accepted points beyond the limit", uv)
        if "jacobian" in name:
            assert valid_depths(z), (name, "accepted depths beyond the limit", z)


@settings(max_examples=80)
@given(st.integers(1, 16), st.data())
def test_singular_values_finite_or_refused(m, data):
    J = data.draw(hostile_arrays(np.float64, (m, 6), elements=ENTRY))
    try:
        s = ibvs.singular_values(J)
    except ValueError as e:
        assert "J" in str(e)
        assert not (np.isfinite(J).all() and np.abs(J).max() <= 1e150), (J, e)
        return
    assert finite(s) and (s >= 0).all() and np.all(np.diff(s) <= 0)
    assert np.allclose(s, np.linalg.svd(J, compute_uv=False), rtol=1e-9, atol=1e-12 * max(1.0, np.abs(J).max()))


@settings(max_examples=80)
@given(points(4), hostile_arrays(np.float64, 4, elements=DEPTH), points(4),
       st.sampled_from([0.0, 1e-9, 0.05]), st.sampled_from([0.5, 1e250]))
def test_partitioned_servo_finite_or_refused(uv, z, uvd, damping, gain):
    servo = ibvs.PartitionedServo(4, gain=gain, damping=damping)
    try:
        r = servo.update(uv, z, uvd)
    except (ValueError, TypeError) as e:
        assert refused_by_name(e, "uv", "depth", "uv_desired"), e
        # beyond the limits, or a geometry without the partitioned features: the segment's two points on
        # top of each other (its angle undefined), points enclosing no area (no area feature)
        degenerate = "coincide" in str(e) or "no area" in str(e)
        assert degenerate or not (valid_points(uv) and valid_points(uvd) and valid_depths(z)), e
        return
    assert valid_points(uv) and valid_points(uvd) and valid_depths(z)
    assert finite(r.velocity), (uv, z, uvd, r.velocity)


CAMERA = ibvs.CameraModel.from_opencv(np.array([[600.0, 0, 320], [0, 601, 240], [0, 0, 1]]),
                                      [-0.28, 0.07, 0.001, -0.0005, 0.01], 640, 480)
PIXEL = st.one_of(st.floats(0.0, 640.0), st.floats(allow_nan=True, allow_infinity=True, width=64),
                  st.sampled_from([-1e6, 1e300, 5e-324]))


@settings(max_examples=80)
@given(hostile_arrays(np.float64, (4, 2), elements=PIXEL), hostile_arrays(np.float64, 4, elements=DEPTH))
def test_update_pixels_finite_or_refused(px, z):
    servo = ibvs.Servo(ibvs.Layout.stacked(4), gain=0.5, camera=CAMERA)
    goal = np.array([[270.0, 190], [370, 190], [370, 290], [270, 290]])
    try:
        r = servo.update_pixels(px, z, goal)
    except (ValueError, TypeError) as e:
        assert refused_by_name(e, "pixels", "depth"), e
        return
    assert finite(px) and valid_depths(z)
    assert finite(r.velocity)


@settings(max_examples=80)
@given(hostile_arrays(np.float64, 6, elements=ENTRY), st.integers(1, 8), st.data(),
       st.sampled_from([0.0, 1e-6, 0.1]), st.sampled_from([None, 0.5]))
def test_joint_velocities_finite_or_refused(twist, n, data, damping, max_speed):
    J = data.draw(hostile_arrays(np.float64, (6, n), elements=ENTRY))
    try:
        qdot = ibvs.joint_velocities(twist, np.eye(4), J, damping=damping,
                                     max_joint_speed=None if max_speed is None else np.full(n, max_speed))
    except (ValueError, TypeError) as e:
        assert refused_by_name(e, "twist", "jacobian"), e
        # only non-finite entries, or magnitudes whose pseudoinverse or product overflows
        entries = np.abs(np.concatenate([twist, J.ravel()]))
        assert not np.isfinite(entries).all() or entries.max() > 1e100 or entries[entries > 0].min() < 1e-100, e
        return
    assert qdot.shape == (n,) and finite(qdot), (twist, J, qdot)
    if max_speed is not None:
        assert np.abs(qdot).max() <= max_speed * (1 + 1e-12)


CASE = sim.cases.general_motion()
SERVO = ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0)
RUN_NUMBER = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=64), st.integers(-3, 3),
                       st.sampled_from([True, 1j, "1", None, 1e300, 1e-300]))


# sim.run's documented ranges (its docstring): round(duration * fps) frames in [1, 1e7], ...
VALID = {
    "duration": lambda x: 0 < x < np.inf and 1 <= math.floor(x * CASE.camera.fps + 0.5) <= 1e7,
    "noise": lambda x: 0 <= x < np.inf,
    "tolerance": lambda x: x is None or 0 <= x < np.inf,
    "tolerance_px": lambda x: x is None or 0 < x < np.inf,
    "depth_scale": lambda x: 1e-3 <= x <= 1e3,
    "boundary_margin": lambda x: 0 <= x < np.inf,
    "boundary_gain": lambda x: 0 <= x < np.inf,
    "standoff_ratio": lambda x: 0 <= x < np.inf,
    "max_depth_ratio": lambda x: 1 < x,
    "max_error_ratio": lambda x: 1 < x,
    "latency": lambda x: isinstance(x, int) and 0 <= x <= 1000,
    "seed": lambda x: isinstance(x, int) and 0 <= x < 2**64,
    "turn": lambda x: math.isnan(x) or abs(x) <= 1.25 * math.pi,
}


@settings(max_examples=60)
@given(st.sampled_from(["duration", "noise", "tolerance", "tolerance_px", "depth_scale", "boundary_margin",
                        "boundary_gain", "standoff_ratio", "max_depth_ratio", "max_error_ratio", "latency", "seed",
                        "turn"]),
       RUN_NUMBER)
def test_sim_run_arguments_finite_or_refused(name, value):
    """One argument of sim.run at a time, anything; a short run (at most 0.2 s simulated)."""
    kwargs = dict(duration=0.2)
    kwargs[name] = value
    if name == "duration" and isinstance(value, (int, float)) and not isinstance(value, bool) and value > 0.2:
        kwargs[name] = 0.2  # long runs are the CLI tests' business; the limits are the same
    try:
        r = sim.run(SERVO, CASE.camera, CASE.target, CASE.start, CASE.goal, **kwargs)
    except (ValueError, TypeError) as e:
        assert name in str(e), (name, value, e)
        real = isinstance(value, (int, float)) and not isinstance(value, bool)
        assert not real or not VALID[name](kwargs[name]), (name, value, "refused inside the documented range", e)
        return
    optional = name in ("tolerance", "tolerance_px")  # None: not tested (tolerance: 1e-4 without tolerance_px)
    assert not isinstance(value, (bool, complex, str)) and (value is not None or optional), (name, value)
    assert VALID[name](kwargs[name]), (name, value, "accepted outside the documented range")
    assert np.isfinite(r.history.twist).all() and np.isfinite(r.metrics.path_length), (name, value)


@settings(max_examples=40)
@given(st.one_of(st.text(max_size=8), RUN_NUMBER, st.sampled_from(["taught", "given", "Taught", " given", b"given"])))
def test_sim_run_goal_pose_taught_given_or_refused(value):
    """sim.run's goal_pose: "taught" or "given" run; anything else is refused by name (ValueError for another
    string, TypeError for another type)."""
    try:
        r = sim.run(SERVO, CASE.camera, CASE.target, CASE.start, CASE.goal, duration=0.1, goal_pose=value)
    except (ValueError, TypeError) as e:
        assert "goal_pose" in str(e), (value, e)
        assert value not in ("taught", "given"), (value, e)
        assert isinstance(e, ValueError) == isinstance(value, str), (value, e)
        return
    assert value in ("taught", "given") and np.isfinite(r.history.twist).all(), value


GANTRY = sim.cases.gantry_general_motion().robot


@settings(max_examples=80)
@given(hostile_arrays(np.float64, 6, elements=ENTRY))
def test_robot_helpers_finite_or_refused(q):
    """The gantry's kinematic helpers at any joint values: finite answers, or q refused by name."""
    for name, call in [
        ("camera", lambda: GANTRY.camera(q)),
        ("kinematics", lambda: GANTRY.kinematics(q)),
        ("end_effector", lambda: GANTRY.end_effector(q)),
        ("jacobian", lambda: GANTRY.jacobian(q)),
        ("manipulability", lambda: GANTRY.manipulability(q)),
        ("joint_velocity", lambda: GANTRY.joint_velocity(q, np.full(6, 0.1))),
        ("outside_limits", lambda: GANTRY.outside_limits(q)),
    ]:
        try:
            out = call()
        except ValueError as e:
            assert "q" in str(e) or "kinematics" in str(e), (name, e)
            assert not np.isfinite(q).all() or name == "joint_velocity", (name, q, e)
            continue
        assert np.isfinite(q).all(), (name, "accepted", q)
        assert all(finite(x) for x in (out if isinstance(out, tuple) else (out,))), (name, q, out)


INDEX = st.one_of(st.integers(-2, 6), st.none(), st.floats(allow_nan=True, width=64), st.sampled_from(["0", True]))


@settings(max_examples=80)
@given(INDEX, INDEX, INDEX, hostile_arrays(np.float64, 6, elements=ENTRY))
def test_line_sources_finite_or_refused(i, j, k, twist):
    """sim.LineSource(i, j, k) on the paper's target (anything for the indices), then a short line-task
    episode from any start (twist of the camera from the goal): refused with ValueError/TypeError naming
    the argument, or finite measurements and errors, ending in one of the outcomes."""
    case = sim.cases.general_motion()
    try:
        target = case.target.with_features([sim.LineSource(i, j, k)])
    except (ValueError, TypeError) as e:
        assert refused_by_name(e, "i", "j", "k", "line", "sources[0]"), e
        return
    assert all(isinstance(x, int) and not isinstance(x, bool) for x in (i, j)) and len({i, j, k}) == 3 or k is None
    task = ibvs.Task().add(ibvs.LineFeature())
    if not (np.all(np.isfinite(twist)) and np.abs(twist).max() <= 2.0):
        return  # start poses from se3_exp's documented domain
    start = ibvs.se3_exp(twist)
    try:
        r = sim.run(ibvs.Servo(task, gain=1.0), case.camera, target, start, case.goal, duration=0.1,
                    stop_on_singular=False)
    except ValueError as e:
        assert refused_by_name(e, "start", "goal"), e
        return
    assert_finite_episode(r)


ARGUMENT = st.one_of(st.integers(-2, 6), st.none(), st.floats(allow_nan=True, width=64),
                     st.sampled_from(["region", "points", "desired_camera", "object", "polygon", "", True]))


@settings(max_examples=80)
@given(st.sampled_from(["moments", "pbvs", "2.5d"]), ARGUMENT, hostile_arrays(np.float64, 6, elements=ENTRY),
       st.sampled_from(["exact", "pose", "estimated", "desired"]), st.floats(1e-3, 1e3),
       st.sampled_from(["taught", "given"]))
def test_pose_and_moments_sources_finite_or_refused(kind, arg, twist, depth, scale, goal_pose):
    """sim.MomentsSource / PbvsSource / Point25DSource of any argument on the compared (asymmetric) target,
    then a short episode of its task from any start, any depth mode and scale, the goal taught or given: refused
    with ValueError / TypeError naming the argument, or finite measurements and errors, ending in one of the
    outcomes."""
    from ibvs.study import compare

    make = {"moments": (sim.MomentsSource, ibvs.MomentsFeature, "source"),
            "pbvs": (sim.PbvsSource, ibvs.PbvsFeature, "target"),
            "2.5d": (sim.Point25DSource, lambda *_: ibvs.Point25DFeature(), "i")}[kind]
    try:
        source = make[0](arg)
        target = compare.target().with_features([source])
        block = make[1](arg) if kind != "2.5d" else make[1]()
    except (ValueError, TypeError) as e:
        assert refused_by_name(e, make[2], "sources"), e
        return
    if not (np.all(np.isfinite(twist)) and np.abs(twist).max() <= 2.0):
        return
    try:
        r = sim.run(ibvs.Servo(ibvs.Task().add(block), gain=1.0), sim.Camera.normalized(0.3),
                    target, ibvs.se3_exp(twist) @ np.eye(4), np.eye(4), duration=0.1, depth=depth,
                    depth_scale=scale, stop_on_singular=False, goal_pose=goal_pose)
    except ValueError as e:
        assert refused_by_name(e, "start", "goal"), e
        return
    assert_finite_episode(r)


# ------------------------------------------------------------------ sim.MiscalibratedCamera


@settings(max_examples=80)
@given(st.floats(0.5, 2.0), st.floats(-100.0, 100.0), st.floats(-100.0, 100.0), st.floats(-0.5, 0.5),
       hostile_arrays(np.float64, (4, 2), elements=st.one_of(st.floats(-1e4, 1e4), ENTRY)),
       st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-2, 2), st.booleans(), st.text()))
def test_miscalibrated_camera_any_believed_model_pixels_and_noise(scale, du, dv, k1, pixels, noise):
    """Any believed model (focal scale, principal point offset, distortion) and any pixels the episode hands it:
    finite pixels or NaN rows (a point lost), never an exception; the noise finite >= 0 or refused by name."""
    K = np.array([[800.0, 0.0, 240.0], [0.0, 800.0, 240.0], [0.0, 0.0, 1.0]])
    camera = ibvs.CameraModel.from_opencv(K, None, 480, 480)
    K_hat = np.array([[800 * scale, 0, 240 + du], [0, 800 * scale, 240 + dv], [0, 0, 1]])
    believed = ibvs.CameraModel.from_opencv(K_hat, [k1, 0.0, 0.0, 0.0], 480, 480)
    try:
        sensor = sim.MiscalibratedCamera(camera, believed, noise=noise)
    except (ValueError, TypeError) as e:
        assert refused_by_name(e, "noise"), str(e)
        return
    assert math.isfinite(sensor.noise) and sensor.noise >= 0
    sensor.reset(3)
    out = np.asarray(sensor.measure(0, np.eye(4), pixels, np.zeros(6)))
    assert out.shape == (4, 2)
    rows_ok = np.isfinite(out).all(axis=1) | np.isnan(out).all(axis=1)
    assert rows_ok.all(), out
    if noise == 0 and k1 == 0:  # a pinhole believed model: the affine map K K_hat^-1 of the finite pixels
        want = (pixels - [240 + du, 240 + dv]) / scale + 240
        ok = np.isfinite(pixels).all(axis=1) & np.isfinite(out).all(axis=1)
        np.testing.assert_allclose(out[ok], want[ok], rtol=1e-9, atol=1e-6)
