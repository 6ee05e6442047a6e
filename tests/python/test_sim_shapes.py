"""sim.run servoes segment and circle tasks: sim.SegmentSource (an image segment between target points) and
sim.EllipseSource (the image ellipse of a 3-D circle fixed to the target). Segment and ellipse tasks converge
on the free camera (every depth mode), the gantry and a Panda arm; the segment measurements are
SegmentFeature.measure of the controller's points and depths; the circle's image ellipse agrees with an
independent computation (the second-order moments of the filled polygon of 3600 projected rim points, and
cv2.fitEllipse of them); degenerate set-ups are refused (ValueError naming the argument) or end the
episode as lost_feature; sim.FunctionSource's callable is called, checked and its errors raised."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import ibvs
from ibvs import sim

EDGES = [sim.SegmentSource(i, (i + 1) % 4) for i in range(4)]
CIRCLE_GOAL = sim.pose(t=(0.08, -0.05, 0.0), r=(0.08, -0.06, 0.0))  # the circle off-centre and tilted: rank 5


def segment_task(n=4, normalized=True, layout=None):
    task = ibvs.Task(layout)
    for _ in range(n):
        task.add(ibvs.SegmentFeature(normalized))
    return task


def ellipse_task():
    task = ibvs.Task()
    task.add(ibvs.EllipseFeature())
    return task


def rim(radius, n=8):
    a = 2 * np.pi * np.arange(n) / n
    return np.column_stack([radius * np.cos(a), radius * np.sin(a), np.zeros(n)])


def circle_target(pose, radius, n=8):
    """n points evenly on the rim of a circle of `radius` in the target's z = 0 plane, with its EllipseSource."""
    return sim.Target(rim(radius, n), pose, features=[sim.EllipseSource((0, 0, 0), (0, 0, 1), radius)])


def camera_from_world(T_wc):
    return np.linalg.inv(T_wc)


@pytest.mark.parametrize("depth", ["exact", "desired", "pose", "estimated"])
def test_segments_free_camera_converge(depth):
    case = sim.cases.general_motion()
    r = sim.run(ibvs.Servo(segment_task(), gain=1.0), case.camera, case.target.with_features(EDGES), case.start,
                case.goal, duration=30, depth=depth, tolerance=1e-5)
    assert r.converged, r
    assert r.metrics.final_translation_error < 1e-3 and np.degrees(r.metrics.final_rotation_error) < 0.1
    assert r.history.measurements.shape == (len(r.history), 24) and "segment" in r.servo


def test_plain_segments_and_points_converge():
    case = sim.cases.general_motion()
    task = segment_task(normalized=False, layout=ibvs.Layout.cartesian(4))
    r = sim.run(ibvs.Servo(task, gain=1.0), case.camera, case.target.with_features(EDGES), case.start, case.goal,
                duration=30, tolerance=1e-5)
    assert r.converged, r
    assert r.metrics.final_translation_error < 1e-3


def test_segments_gantry_converge():
    case = sim.cases.gantry_general_motion()
    r = sim.run(ibvs.Servo(segment_task(), gain=2.0), case.camera, case.target.with_features(EDGES), case.start,
                case.goal, robot=case.robot, duration=case.duration, tolerance=1e-5)
    assert r.converged, r
    assert np.degrees(r.metrics.final_rotation_error) < 0.1 and r.metrics.final_translation_error < 1e-3


def test_segments_panda_converge():
    pytest.importorskip("pinocchio")
    case = sim.cases.arm_general_motion("panda")
    r = sim.run(ibvs.Servo(segment_task(), gain=1.0), case.camera, case.target.with_features(EDGES), case.start,
                case.goal, robot=case.robot, duration=case.duration, depth="pose", tolerance=1e-5)
    assert r.converged, r
    assert r.metrics.final_translation_error < 1e-3
    assert np.all(r.history.q >= case.robot.q_min) and np.all(r.history.q <= case.robot.q_max)


def ellipse_servo(gain=1.0):
    """An ellipse task controlling five components: the circle's image is blind to the camera turning about the
    circle's axis (a sixth would make J 5x6, singular), so wz is left out (docs/features.md)."""
    task = ellipse_task()
    task.dof = ["Tx", "Ty", "Tz", "wx", "wy"]
    return ibvs.Servo(task, gain=gain)


def seen_from(T_wc, target):
    """The camera centre's distance from the circle's centre and its angle from the circle's axis: what the
    circle's image fixes."""
    c = T_wc[:3, 3] - target.pose[:3, 3]
    return np.linalg.norm(c), np.arccos(abs(c @ target.pose[:3, 2]) / np.linalg.norm(c))


@pytest.mark.parametrize("depth", ["exact", "desired", "pose", "estimated"])
def test_circle_free_camera_converges(depth):
    case = sim.cases.general_motion()
    target = circle_target(case.target.pose, 0.3)
    start = CIRCLE_GOAL @ sim.pose(t=(0.1, 0.05, -0.3), r=(0.03, 0.04, 0.3))
    r = sim.run(ellipse_servo(), case.camera, target, start, CIRCLE_GOAL, duration=30, depth=depth, tolerance=1e-6)
    assert r.converged, r
    assert r.history.error_norm[-1] < 1e-6
    # the camera sees the circle from the goal's distance and angle (its turn about the axis is free)
    np.testing.assert_allclose(seen_from(r.history.pose[-1], target), seen_from(CIRCLE_GOAL, target), atol=1e-4)


def test_circle_with_a_cross_gantry_converges():
    """A disc with two diameters marked on it (an ellipse and two segments) on the gantry: the diameters fix
    the turn about the axis; the camera reaches the goal pose."""
    case = sim.cases.gantry_general_motion()
    target = sim.Target(rim(0.05, 8), case.target.pose,
                        features=[sim.EllipseSource((0, 0, 0), (0, 0, 1), 0.05), sim.SegmentSource(0, 4),
                                  sim.SegmentSource(2, 6)])
    task = ellipse_task().add(ibvs.SegmentFeature()).add(ibvs.SegmentFeature())
    r = sim.run(ibvs.Servo(task, gain=2.0), case.camera, target, case.start, case.goal, robot=case.robot,
                duration=case.duration, tolerance=1e-5)
    assert r.converged, r
    assert np.degrees(r.metrics.final_rotation_error) < 0.01 and r.metrics.final_translation_error < 1e-4


def test_segment_measurements_are_segment_feature_measure():
    case = sim.cases.gantry_general_motion()  # distorted camera: uv are the undistorted measured points
    latency = 2
    r = sim.run(ibvs.Servo(segment_task(), gain=2.0), case.camera, case.target.with_features(EDGES), case.start,
                case.goal, robot=case.robot, duration=2.0, noise=0.3, latency=latency, depth="estimated")
    h = r.history
    assert len(h) > 100
    for k in range(0, len(h) - 1, 7):
        for b, src in enumerate(EDGES):
            m = ibvs.SegmentFeature.measure(h.uv[k, src.i], h.uv[k, src.j], h.depth[k, src.i], h.depth[k, src.j])
            np.testing.assert_allclose(h.measurements[k, 6 * b:6 * b + 6], m, rtol=0, atol=1e-15)
    m = ibvs.SegmentFeature.measure(r.uv_desired[0], r.uv_desired[1], r.depth_desired[0], r.depth_desired[1])
    np.testing.assert_allclose(r.measurements_desired[:6], m, rtol=0, atol=1e-15)


def polygon_moments(xy):
    """m00, xg, yg, n20, n11, n02 of the filled polygon xy (N, 2) by Green's theorem, in float64."""
    x, y = xy[:, 0], xy[:, 1]
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    c = x * y1 - x1 * y
    a = c.sum() / 2
    xg = ((x + x1) * c).sum() / (6 * a)
    yg = ((y + y1) * c).sum() / (6 * a)
    m20 = ((x * x + x * x1 + x1 * x1) * c).sum() / 12
    m02 = ((y * y + y * y1 + y1 * y1) * c).sum() / 12
    m11 = ((x * y1 + 2 * x * y + 2 * x1 * y1 + x1 * y) * c).sum() / 24
    return a, xg, yg, m20 / a - xg * xg, m11 / a - xg * yg, m02 / a - yg * yg


def test_circle_image_is_the_ellipse_of_its_projected_rim():
    cv2 = pytest.importorskip("cv2")
    case = sim.cases.general_motion()
    radius = 0.3
    target = circle_target(case.target.pose, radius)
    start = CIRCLE_GOAL @ sim.pose(t=(0.1, 0.05, -0.3), r=(0.03, 0.04, 0.5))
    r = sim.run(ellipse_servo(), case.camera, target, start, CIRCLE_GOAL, duration=2, latency=1)
    h = r.history
    dense = rim(radius, 3600)
    worst = 0.0
    for k in range(0, len(h) - 1, 13):
        T_co = camera_from_world(h.pose[max(0, k - 1)]) @ target.pose  # the frame the controller sees
        P = dense @ T_co[:3, :3].T + T_co[:3, 3]
        xy = P[:, :2] / P[:, 2:]
        a, xg, yg, n20, n11, n02 = polygon_moments(xy)
        # the ellipse's centred moments n = S / 4 of its semi-axes' matrix S
        m = h.measurements[k]
        np.testing.assert_allclose(m[:5], [xg, yg, n20, n11, n02], rtol=2e-6, atol=1e-9)
        # its area pi sqrt(det S) = 4 pi sqrt(n20 n02 - n11^2)
        assert np.isclose(a, 4 * np.pi * np.sqrt(m[2] * m[4] - m[3] ** 2), rtol=2e-6)
        # cv2.fitEllipse of the rim (in pixels of a 1000 px focal length): centre and axes
        (cx, cy), (d1, d2), ang = cv2.fitEllipse((1000 * xy).astype(np.float32))
        R = np.array([[np.cos(np.radians(ang)), -np.sin(np.radians(ang))],
                      [np.sin(np.radians(ang)), np.cos(np.radians(ang))]])
        S = R @ np.diag([(d1 / 2000) ** 2, (d2 / 2000) ** 2]) @ R.T
        np.testing.assert_allclose(m[:2], [cx / 1000, cy / 1000], rtol=0, atol=2e-5)
        np.testing.assert_allclose([m[2], m[3], m[4]], [S[0, 0] / 4, S[0, 1] / 4, S[1, 1] / 4], rtol=0,
                                   atol=1e-5 * S.max())
        # the plane: the target's z = 0 plane from the true pose
        n = T_co[:3, 2]
        np.testing.assert_allclose(m[5:], n / (n @ T_co[:3, 3]), rtol=1e-12, atol=1e-12)
        worst = max(worst, abs(m[0] - xg))
    assert worst < 1e-6


def test_circle_plane_from_each_depth_mode():
    case = sim.cases.general_motion()
    target = circle_target(case.target.pose, 0.3)
    start = CIRCLE_GOAL @ sim.pose(t=(0.1, 0.05, -0.3), r=(0.03, 0.04, 0.3))
    for depth, scale in (("exact", 1.3), ("desired", 1.0)):
        r = sim.run(ellipse_servo(), case.camera, target, start, CIRCLE_GOAL, duration=0.5, depth=depth,
                    depth_scale=scale)
        for k in (0, len(r.history) // 2):
            T = r.goal if depth == "desired" else r.history.pose[k]
            T_co = camera_from_world(T) @ target.pose
            T_co[:3, 3] *= scale
            np.testing.assert_allclose(r.history.measurements[k, 5:], sim.plane_in_camera(T_co), rtol=1e-12)


def test_sources_pickle_and_repr():
    src = [sim.SegmentSource(0, 2), sim.EllipseSource((0.1, 0, 0), (0, 0, 2), 0.25)]
    t = sim.Target(rim(0.25, 4) + [0.1, 0, 0], np.eye(4), features=src)
    assert repr(t.features[0]) == "SegmentSource(0, 2)"
    assert repr(t.features[1]) == "EllipseSource((0.1, 0.0, 0.0), (0.0, 0.0, 1.0), 0.25)"
    u = pickle.loads(pickle.dumps(t))
    assert [repr(f) for f in u.features] == [repr(f) for f in t.features]
    assert t.features[0].size == 6 and t.features[1].size == 8 and t.features[1].radius == 0.25
    np.testing.assert_array_equal(t.features[1].normal, [0, 0, 1])
    assert "segment(0, 2)" in repr(t) and "circle" in repr(t)


def test_bad_inputs_refused():
    case = sim.cases.general_motion()
    with pytest.raises(ValueError, match="radius"):
        sim.EllipseSource((0, 0, 0), (0, 0, 1), 0.0)
    with pytest.raises(ValueError, match="radius"):
        sim.EllipseSource((0, 0, 0), (0, 0, 1), -1.0)
    with pytest.raises(ValueError, match="radius"):
        sim.EllipseSource((0, 0, 0), (0, 0, 1), float("nan"))
    with pytest.raises(ValueError, match="normal"):
        sim.EllipseSource((0, 0, 0), (0, 0, 0), 1.0)
    with pytest.raises(ValueError, match="centre"):
        sim.EllipseSource((0, np.inf, 0), (0, 0, 1), 1.0)
    with pytest.raises(ValueError, match="centre must hold 3"):
        sim.EllipseSource((0, 0), (0, 0, 1), 1.0)
    with pytest.raises(ValueError, match="distinct"):
        sim.SegmentSource(2, 2)
    with pytest.raises(ValueError):
        sim.SegmentSource(-1, 2)
    with pytest.raises(TypeError, match="i must be an int"):
        sim.SegmentSource(0.5, 1)
    with pytest.raises(ValueError, match="not a target point"):
        case.target.with_features([sim.SegmentSource(0, 4)])
    twice = np.vstack([case.target.points, case.target.points[:1]])
    with pytest.raises(ValueError, match=r"points i = 0 and j = 4 coincide"):
        sim.Target(twice, case.target.pose, features=[sim.SegmentSource(0, 4)])
    with pytest.raises(ValueError, match="cannot measure the task's block 0"):
        sim.run(ellipse_servo(), case.camera, case.target.with_features(EDGES[:1]), case.start, case.goal)
    # a circle seen edge-on at the goal (the camera in its plane) cannot be measured
    target = circle_target(case.target.pose, 0.3)
    edge_on = np.array([[0, 0, 1, -2.0], [1, 0, 0, 0], [0, 1, 0, 3.0], [0, 0, 0, 1]], dtype=float)
    with pytest.raises(ValueError, match=r"sources\[0\] \(circle.*cannot be measured at the goal"):
        sim.run(ellipse_servo(), case.camera, target, case.start, edge_on)


def test_source_that_stops_measuring_is_lost_feature():
    """A FunctionSource whose callable answers None (cannot measure: e.g. the circle turned edge-on) ends the
    episode with lost_feature naming the block, at that frame."""
    case = sim.cases.general_motion()
    target = circle_target(case.target.pose, 0.3)
    calls = []

    def until_5(frame, cMo, depth_pose, goal, uv, depth):
        calls.append(frame)
        return ibvs.EllipseFeature.project_circle(cMo[:3, 3], cMo[:3, 2], 0.3) if frame < 5 else None

    t = target.with_features([sim.FunctionSource(ibvs.EllipseFeature(), until_5)])
    r = sim.run(ellipse_servo(), case.camera, t, CIRCLE_GOAL @ sim.pose(t=(0.05, 0, 0)), CIRCLE_GOAL, duration=1)
    assert r.status.outcome == "lost_feature" and r.status.feature == 0 and r.status.frame == 5
    assert calls == [-1, 0, 1, 2, 3, 4, 5]


def test_function_source_errors_are_raised():
    case = sim.cases.general_motion()
    target = circle_target(case.target.pose, 0.3)

    def boom(frame, *args):
        if frame == 3:
            raise RuntimeError("boom at 3")
        return ibvs.EllipseFeature.project_circle(args[0][:3, 3], args[0][:3, 2], 0.3)

    t = target.with_features([sim.FunctionSource(ibvs.EllipseFeature(), boom)])
    start = CIRCLE_GOAL @ sim.pose(t=(0.05, 0, 0))
    with pytest.raises(RuntimeError, match="boom at 3"):
        sim.run(ellipse_servo(), case.camera, t, start, CIRCLE_GOAL, duration=1)
    t = target.with_features([sim.FunctionSource(ibvs.EllipseFeature(), lambda *a: np.zeros(5))])
    with pytest.raises(ValueError, match="must return 8 values"):
        sim.run(ellipse_servo(), case.camera, t, start, CIRCLE_GOAL, duration=1)
    with pytest.raises(TypeError, match="measure must be callable"):
        sim.FunctionSource(ibvs.EllipseFeature(), 3)
    with pytest.raises(TypeError, match="feature must be an ibvs.Feature"):
        sim.FunctionSource("ellipse", boom)
    assert repr(sim.FunctionSource(ibvs.EllipseFeature(), boom)) == "FunctionSource(ellipse)"
    with pytest.raises(ValueError, match="cannot measure the task's block 0"):
        sim.run(ibvs.Servo(segment_task(1), gain=1.0), case.camera, t, start, CIRCLE_GOAL, duration=1)


def test_plane_in_camera():
    T = sim.pose(t=(0.1, -0.2, 2.0), r=(0.2, 0.1, -0.3))
    A, B, C = sim.plane_in_camera(T)
    # three points of the target's z = 0 plane seen from T satisfy 1/Z = A x + B y + C
    for p in ([0, 0, 0], [0.3, -0.1, 0], [-0.2, 0.4, 0]):
        q = T[:3, :3] @ p + T[:3, 3]
        assert np.isclose(1 / q[2], A * q[0] / q[2] + B * q[1] / q[2] + C, rtol=1e-12)
    with pytest.raises(ValueError, match="through the camera centre"):
        sim.plane_in_camera(np.eye(4))
