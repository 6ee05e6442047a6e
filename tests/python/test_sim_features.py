"""sim.run servoes any ibvs.Task: a target carries one feature source per feature block
(sim.Target(points, pose, features=[sim.LineSource(i, j), ...])). A line-only task and a
points + lines task converge on the free camera, the gantry and a Panda arm; the simulator's line
measurements are LineFeature.measure of the controller's points with the plane of the true pose;
the history records the task's error and the blocks' measurements; bad set-ups are refused."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import ibvs
from ibvs import sim

EDGES = [sim.LineSource(i, (i + 1) % 4) for i in range(4)]


def line_task(layout=None, n=4):
    task = ibvs.Task(layout)
    for _ in range(n):
        task.add(ibvs.LineFeature())
    return task


TASKS = {"lines": lambda: line_task(), "points+lines": lambda: line_task(ibvs.Layout.cartesian(4))}


def plane_through(P):
    """(A, B, C) of 1/Z = A x + B y + C through three camera-frame points P (3, 3), solved from
    their (x, y, 1/Z)."""
    M = np.column_stack([P[:, 0] / P[:, 2], P[:, 1] / P[:, 2], np.ones(3)])
    return np.linalg.solve(M, 1.0 / P[:, 2])


def camera_points(target, T_wc):
    Tcw = np.linalg.inv(T_wc)
    return target.world_points() @ Tcw[:3, :3].T + Tcw[:3, 3]


@pytest.mark.parametrize("kind", sorted(TASKS))
@pytest.mark.parametrize("depth", ["exact", "estimated"])
def test_free_camera_converges(kind, depth):
    case = sim.cases.general_motion()
    task = TASKS[kind]()
    r = sim.run(ibvs.Servo(task, gain=1.0), case.camera, case.target.with_features(EDGES), case.start, case.goal,
                duration=30, depth=depth, tolerance=1e-5)
    assert r.converged, r
    assert r.metrics.final_translation_error < 1e-3
    h = r.history
    assert h.error.shape == (len(h), task.rows) and h.measurements.shape == (len(h), task.measurement_size)
    assert h.error_norm[-1] < 1e-5 and np.isclose(h.error_norm[-1], np.linalg.norm(h.error[-1]))
    assert r.measurements_desired.shape == (task.measurement_size,)
    assert "line" in r.servo and "x6" in r.servo


@pytest.mark.parametrize("kind", sorted(TASKS))
def test_gantry_converges(kind):
    case = sim.cases.gantry_general_motion()
    r = sim.run(ibvs.Servo(TASKS[kind](), gain=2.0), case.camera, case.target.with_features(EDGES), case.start,
                case.goal, robot=case.robot, duration=case.duration, tolerance=1e-5)
    assert r.converged, r
    assert np.degrees(r.metrics.final_rotation_error) < 0.1


@pytest.mark.parametrize("kind", sorted(TASKS))
def test_panda_converges(kind):
    pytest.importorskip("pinocchio")
    case = sim.cases.arm_general_motion("panda")
    r = sim.run(ibvs.Servo(TASKS[kind](), gain=1.0), case.camera, case.target.with_features(EDGES), case.start,
                case.goal, robot=case.robot, duration=case.duration, depth="pose", tolerance=1e-5)
    assert r.converged, r
    assert r.metrics.final_translation_error < 1e-3
    assert np.all(r.history.q >= case.robot.q_min) and np.all(r.history.q <= case.robot.q_max)


def test_line_measurements_are_line_feature_measure_of_the_points():
    case = sim.cases.gantry_general_motion()  # the distorted camera: uv are the undistorted measured points
    target = case.target.with_features(EDGES)
    latency = 2
    r = sim.run(ibvs.Servo(line_task(), gain=2.0), case.camera, target, case.start, case.goal, robot=case.robot,
                duration=2.0, noise=0.3, latency=latency, depth_scale=1.25)
    h = r.history
    assert len(h) > 100
    for k in range(0, len(h) - 1, 7):
        seen = max(0, k - latency)
        plane = plane_through(camera_points(target, h.pose[seen])[:3]) / 1.25
        for b, src in enumerate(EDGES):
            m = ibvs.LineFeature.measure(h.uv[k, src.i], h.uv[k, src.j], plane)
            np.testing.assert_allclose(h.measurements[k, 5 * b:5 * b + 5], m, rtol=0, atol=1e-12)
    # the goal's: the desired points, the goal's plane
    plane = plane_through(camera_points(target, r.goal)[:3])
    m = ibvs.LineFeature.measure(r.uv_desired[0], r.uv_desired[1], plane)
    np.testing.assert_allclose(r.measurements_desired[:5], m, rtol=0, atol=1e-12)
    # and the task error is LineFeature.error of those measurements
    k = len(h) // 2
    e = ibvs.LineFeature().error(h.measurements[k, :5], r.measurements_desired[:5])
    np.testing.assert_allclose(h.error[k, :2], e, rtol=0, atol=1e-15)


def test_points_only_unchanged_by_the_task_path():
    """A Servo of a Task of points only is the Servo of its Layout in the loop, bit for bit."""
    case = sim.cases.general_motion()
    a = sim.run(ibvs.Servo(ibvs.Layout.stacked(4), gain=1.0), case.camera, case.target, case.start, case.goal)
    b = sim.run(ibvs.Servo(ibvs.Task(ibvs.Layout.stacked(4)), gain=1.0), case.camera, case.target, case.start,
                case.goal)
    assert np.array_equal(a.history.twist, b.history.twist) and a.status == b.status
    assert a.history.measurements.shape == (len(a.history), 0)


def test_weighted_task_and_dof():
    case = sim.cases.x_translation()
    task = ibvs.Task(ibvs.Layout.cartesian(4))
    for _ in EDGES:
        task.add(ibvs.LineFeature(), 2.0)
    task.dof = ["Tx", "Ty", "Tz"]
    r = sim.run(ibvs.Servo(task, gain=1.0), case.camera, case.target.with_features(EDGES), case.start, case.goal,
                duration=20, tolerance=1e-6)
    assert r.converged, r
    assert np.abs(r.history.twist[:, 3:]).max() == 0.0
    # the recorded error is the weighted task error: the line rows twice LineFeature.error
    k = 10
    e = ibvs.LineFeature().error(r.history.measurements[k, :5], r.measurements_desired[:5])
    np.testing.assert_allclose(r.history.error[k, 8:10], 2.0 * e, rtol=0, atol=1e-15)


def test_non_planar_target_line_through_a_third_point():
    case = sim.cases.general_motion()
    pts = case.target.points.copy()
    pts[2, 2] = 0.1  # point 2 off the plane
    with pytest.raises(ValueError, match="third point"):
        sim.Target(pts, case.target.pose, features=[sim.LineSource(1, 2)])
    target = sim.Target(pts, case.target.pose, features=[sim.LineSource(1, 2, 0), sim.LineSource(0, 1),
                                                         sim.LineSource(2, 3, 0), sim.LineSource(3, 0)])
    r = sim.run(ibvs.Servo(line_task(), gain=1.0), case.camera, target, case.start, case.goal, duration=30,
                tolerance=1e-5)
    assert r.converged, r


def test_target_features_pickle_and_repr():
    t = sim.Target.paper().with_features(EDGES + [sim.LineSource(0, 2, 1)])
    assert [repr(f) for f in t.features] == ["LineSource(0, 1)", "LineSource(1, 2)", "LineSource(2, 3)",
                                              "LineSource(3, 0)", "LineSource(0, 2, 1)"]
    u = pickle.loads(pickle.dumps(t))
    assert [repr(f) for f in u.features] == [repr(f) for f in t.features]
    assert np.array_equal(u.points, t.points) and "line(0, 1)" in repr(t)
    assert t.features[4].k == 1 and t.features[0].k is None and t.features[0].size == 5
    assert sim.Target.paper().features == [] and len(sim.Target.paper().with_features([]).features) == 0


def test_lost_feature_names_the_block():
    # a line whose plane passes through the camera centre cannot be measured: a camera that starts in
    # the target's plane (looking along +x at the plate edge-on) is refused at the goal
    case = sim.cases.general_motion()
    edge_on = np.array([[0, 0, 1, -2.0], [1, 0, 0, 0], [0, 1, 0, 3.0], [0, 0, 0, 1]], dtype=float)
    with pytest.raises(ValueError, match=r"sources\[0\] \(line\(0, 1\)\) cannot be measured at the goal"):
        sim.run(ibvs.Servo(line_task(), gain=1.0), case.camera, case.target.with_features(EDGES), case.start, edge_on)
    assert sim.RunStatus("lost_feature", 3, feature=1).feature == 1


def test_bad_inputs_refused():
    case = sim.cases.general_motion()
    target = case.target.with_features(EDGES)
    run = lambda servo, t: sim.run(servo, case.camera, t, case.start, case.goal, duration=0.1)  # noqa: E731
    with pytest.raises(ValueError, match="distinct"):
        sim.LineSource(1, 1)
    with pytest.raises(TypeError, match="i must be an int"):
        sim.LineSource(0.5, 1)
    with pytest.raises(ValueError):
        sim.LineSource(-1, 1)
    with pytest.raises(ValueError, match="not a target point"):
        case.target.with_features([sim.LineSource(0, 4)])
    with pytest.raises(TypeError, match=r"features\[1\] must be an ibvs.sim.FeatureSource"):
        case.target.with_features([EDGES[0], (1, 2)])
    with pytest.raises(TypeError, match="features must be a sequence"):
        sim.Target(case.target.points, features="lines")
    with pytest.raises(ValueError, match="4 feature source"):
        run(ibvs.Servo(line_task(n=3), gain=1.0), target)
    with pytest.raises(ValueError, match="0 feature source"):
        run(ibvs.Servo(line_task(), gain=1.0), case.target)
    with pytest.raises(ValueError, match="PartitionedServo"):
        run(ibvs.PartitionedServo(4, 1.0), target)
    with pytest.raises(ValueError, match="points but the target has 4"):
        run(ibvs.Servo(line_task(ibvs.Layout.cartesian(3)), gain=1.0), target)
    two = sim.Target(case.target.points[:2], case.target.pose, features=[sim.LineSource(0, 1)])
    with pytest.raises(ValueError, match="3 non-collinear"):
        sim.run(ibvs.Servo(line_task(n=1), gain=1.0), case.camera, two, case.start, case.goal, depth="estimated")
    with pytest.raises(ValueError, match="record"):
        sim.run(ibvs.Servo(line_task(), gain=1.0), case.camera, target, case.start, case.goal, record="x.mcap")
