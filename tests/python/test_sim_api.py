"""ibvs.sim API: models, results, events, reproducibility and argument errors."""

import numpy as np
import pytest

import ibvs
import ibvs.sim as sim
from ibvs.sim import pose


def servo(layout=None, gain=1.0):
    return ibvs.Servo(layout or ibvs.Layout.cartesian(4), gain=gain)


def test_camera_presets():
    c = sim.Camera.afma6()
    assert (c.px, c.py, c.u0, c.v0, c.fps) == (1090.6, 1090.0, 310.1, 260.8, 60.0)
    assert c.distortion == "visp" and c.coefficients == (-0.2114, 0.2217)  # (kud, kdu)
    assert c.bounds == (0.0, 640.0, 0.0, 480.0)
    n = sim.Camera.normalized(bounds=0.3)
    assert n.bounds == (-0.3, 0.3, -0.3, 0.3)
    xy = np.array([[0.1, -0.05], [0.0, 0.0]])
    assert np.array_equal(n.project(xy), xy)
    uv = c.project(xy)
    assert np.allclose(c.normalize(uv), xy, atol=1e-3)  # kud / kdu: close, not exact
    assert "CameraModel(" in repr(c)


def test_target_and_gantry():
    t = sim.Target.paper()
    assert len(t) == 4 and t.planar
    assert np.allclose(np.abs(t.world_points()), [[0.25, 0.25, 3.0]] * 4)
    sq = sim.Target.square(0.1)
    assert np.allclose(np.ptp(sq.points, axis=0), [0.1, 0.1, 0.0])
    g = sim.Gantry.afma6()
    q = np.array([0.1, -0.2, 0.05, 0.3, 0.7, -0.4])
    J = g.jacobian(q)
    assert abs(np.linalg.det(J)) == pytest.approx(g.manipulability(q)) == pytest.approx(abs(np.cos(0.7)))
    v = np.array([0.01, 0.02, -0.03, 0.1, -0.2, 0.05])
    assert np.allclose(J @ g.joint_velocity(q, v), v)
    # FK vs Jacobian by central differences (one column)
    h = 1e-6
    dq = np.zeros(6)
    dq[3] = h
    D = np.linalg.inv(g.camera(q)) @ (g.camera(q + dq) - g.camera(q - dq)) / (2 * h)
    assert np.allclose([D[0, 3], D[1, 3], D[2, 3], D[2, 1], D[0, 2], D[1, 0]], J[:, 3], atol=1e-8)


def test_result_shapes_and_seeded_noise():
    case = sim.cases.general_motion()
    kw = dict(duration=2.0, noise=1e-3, seed=3)
    a = sim.run(servo(ibvs.Layout.stacked(4)), case.camera, case.target, case.start, case.goal, **kw)
    b = sim.run(servo(ibvs.Layout.stacked(4)), case.camera, case.target, case.start, case.goal, **kw)
    c = sim.run(servo(ibvs.Layout.stacked(4)), case.camera, case.target, case.start, case.goal, **{**kw, "seed": 4})
    h = a.history
    k = len(h)
    assert k == 120 and a.status.outcome == "timeout" and a.status.frame == 119
    assert h.time.shape == (k,) and h.pose.shape == (k, 4, 4) and h.twist.shape == (k, 6)
    assert h.uv.shape == (k, 4, 2) and h.rtheta.shape == (k, 4, 2) and h.depth.shape == (k, 4)
    assert h.error.shape == (k, 16) and h.error_norm.shape == (k,) and h.sigma_min.shape == (k,)
    assert h.q is None and h.qdot is None
    assert np.allclose(h.time[1], 1 / 60)
    assert np.array_equal(a.history.uv, b.history.uv)
    assert not np.array_equal(a.history.uv, c.history.uv)
    assert np.allclose(h.rtheta[..., 0], np.hypot(h.uv[..., 0], h.uv[..., 1]))
    assert np.allclose(h.error_norm, np.linalg.norm(h.error, axis=1))


def test_latency_and_depth_modes_on_gantry():
    case = sim.cases.gantry_general_motion()
    s = servo(ibvs.Layout.polar(4), gain=2.0)
    r = sim.run(s, case.camera, case.target, case.start, case.goal, robot=case.robot, duration=15, latency=3,
                tolerance=1e-5)
    assert r.converged
    assert np.array_equal(r.history.uv[3], r.history.uv[0]) and not np.array_equal(r.history.uv[4], r.history.uv[0])
    for depth in ("pose", "desired"):
        r = sim.run(s, case.camera, case.target, case.start, case.goal, robot=case.robot, duration=15, depth=depth,
                    tolerance=1e-5)
        assert r.converged, (depth, r)
    r = sim.run(s, case.camera, case.target, case.start, case.goal, robot=case.robot, duration=0.5, depth="desired")
    assert np.allclose(r.history.depth, r.depth_desired)


def test_left_image_reported_with_point_index():
    big = sim.Target(np.array([[-0.8, -0.8, 0], [0.8, -0.8, 0], [0.8, 0.8, 0], [-0.8, 0.8, 0]]), pose(t=(0, 0, 3)))
    cam = sim.Camera.normalized(0.3)
    r = sim.run(servo(ibvs.Layout.polar(4)), cam, big, pose(r=(0, 0, np.pi / 2)), np.eye(4), duration=20)
    assert r.status.outcome == "left_image" and r.status.frame > 0 and 0 <= r.status.point < 4
    T_cw = np.linalg.inv(r.history.pose[-1])
    p = (T_cw @ np.r_[big.world_points()[r.status.point], 1.0])[:3]
    assert np.abs(p[:2] / p[2]).max() > 0.3
    # at frame 0, a point already outside: index of the first one outside
    cam01 = sim.Camera.normalized(0.1)
    r = sim.run(servo(), cam01, sim.Target.paper(), pose(t=(-0.06, 0, 0)), pose(t=(0, 0, -0.5)), duration=1)
    assert (r.status.outcome, r.status.frame, r.status.point) == ("left_image", 0, 1)


def test_behind_camera_reported():
    # The camera goes through the tilted target (a collision with the plate, test_sim_faces.py); with
    # a non-planar target (no faces) and no standoff the event is a point behind the camera.
    pts = sim.Target.paper().points.copy()
    pts[0, 2] = 0.01
    tilted = sim.Target(pts, pose(t=(0, 0, 3), r=(-0.3, 0, 0)))
    r = sim.run(servo(gain=4.0), sim.Camera.normalized(1e3), tilted, np.eye(4), pose(t=(0, 0, 2.4)), duration=10,
                latency=20, standoff_ratio=0.0)
    assert r.status.outcome == "behind_camera" and 0 <= r.status.point < 4
    T_cw = np.linalg.inv(r.history.pose[-1])
    assert (T_cw @ np.r_[tilted.world_points()[r.status.point], 1.0])[2] < 1e-3


def test_argument_errors_name_the_argument():
    case = sim.cases.general_motion()
    args = (case.camera, case.target, case.start, case.goal)
    with pytest.raises(TypeError, match="servo"):
        sim.run("not a servo", *args)
    with pytest.raises(ValueError, match="start"):
        sim.run(servo(), case.camera, case.target, np.eye(3), case.goal)
    with pytest.raises(ValueError, match="goal"):
        sim.run(servo(), case.camera, case.target, case.start, pose(t=(0, 0, 5)))
    with pytest.raises(ValueError, match="depth"):
        sim.run(servo(), *args, depth="magic")
    with pytest.raises(ValueError, match="duration"):
        sim.run(servo(), *args, duration=-1)
    with pytest.raises(ValueError, match="noise"):
        sim.run(servo(), *args, noise=-1)
    with pytest.raises(TypeError, match="latency"):
        sim.run(servo(), *args, latency=1.5)
    with pytest.raises(ValueError, match="points"):
        sim.run(servo(ibvs.Layout.polar(3)), *args)
    with pytest.raises(TypeError, match="robot"):
        sim.run(servo(), *args, robot="afma6")
    g = sim.cases.gantry_general_motion()
    with pytest.raises(ValueError, match="start"):
        sim.run(servo(), g.camera, g.target, np.ones(6), g.goal, robot=g.robot)
    with pytest.raises(ValueError, match="pose depth mode"):
        bent = sim.Target(np.array([[0, 0, 0.01], [1, 0, 0], [1, 1, 0], [0, 1, 0]]), pose(t=(0, 0, 3)))
        sim.run(servo(), case.camera, bent, case.start, case.goal, depth="pose")
