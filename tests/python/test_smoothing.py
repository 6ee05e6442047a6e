"""Smooth starts and switches, acceleration limits and lost points from Python: Servo(decay_rate=...,
max_*_acceleration=..., cartesian_near_goal=..., stop_time=...), Servo.update(valid=...), and the
simulator's keep_lost, with points and through images (a dot hidden for 10 frames)."""

import math

import numpy as np
import pytest

import ibvs
from ibvs import sim
from ibvs.sim import cases


def paper_points(start=(0.1, -0.08, -0.3, 0.1, -0.08, 0.6)):
    """The paper's square at 3 m seen from the identity (goal) and from se3_exp(start)."""
    P = np.array([[-0.25, -0.25, 3.0], [0.25, -0.25, 3.0], [0.25, 0.25, 3.0], [-0.25, 0.25, 3.0]])

    def look(T):
        Tcw = np.linalg.inv(T)
        pc = (Tcw[:3, :3] @ P.T).T + Tcw[:3, 3]
        return pc[:, :2] / pc[:, 2:], pc[:, 2].copy()

    return look(np.eye(4)), look(ibvs.se3_exp(np.array(start)))


def test_continuous_law_starts_from_rest_and_follows_eq17():
    (uvd, zd), (uv, z) = paper_points()
    mu, dt = 5.0, 0.01
    smooth = ibvs.Servo(ibvs.Layout.stacked(4), gain=1.0, decay_rate=mu, period=dt)
    plain = ibvs.Servo(ibvs.Layout.stacked(4), gain=1.0)
    v0 = plain.update(uv, z, uvd, zd).velocity
    first = smooth.update(uv, z, uvd, zd)
    assert np.array_equal(first.velocity, np.zeros(6)) and first.law_switched
    for k in range(1, 20):  # a fixed image: v_law (1 - exp(-mu k dt))
        r = smooth.update(uv, z, uvd, zd)
        assert not r.law_switched
        np.testing.assert_allclose(r.velocity, v0 * (1 - math.exp(-mu * k * dt)), rtol=0, atol=1e-14)
    smooth.reset(twist=np.full(6, 0.01))
    np.testing.assert_array_equal(smooth.update(uv, z, uvd, zd).velocity, np.full(6, 0.01))
    assert smooth.decay_rate == mu and smooth.period == dt and "Servo(" in repr(smooth)


def test_acceleration_limits_in_an_episode():
    c = cases.general_motion()
    a_lin, a_ang = 0.3, 0.6
    servo = ibvs.Servo(ibvs.Layout.stacked(4), gain=1.0, decay_rate=4.0, max_linear_acceleration=a_lin,
                       max_angular_acceleration=a_ang, period=1.0)  # the episode uses 1 / fps
    r = sim.run(servo, c.camera, c.target, c.start, c.goal, duration=60.0, tolerance=1e-4)
    assert r.status.outcome == "converged", r
    tw = np.vstack([np.zeros(6), r.history.twist])
    dv = np.diff(tw, axis=0) * c.camera.fps
    assert np.linalg.norm(dv[:, :3], axis=1).max() <= a_lin * (1 + 1e-9)
    assert np.linalg.norm(dv[:, 3:], axis=1).max() <= a_ang * (1 + 1e-9)
    assert np.array_equal(r.history.twist[0], np.zeros(6))  # a start from rest
    assert servo.period == 1.0  # the caller's servo is not modified


def test_automatic_switch_is_continuous():
    c = cases.z_rotation()
    jumps = {}
    for mu in (0.0, 6.0):
        servo = ibvs.Servo(ibvs.Layout.polar(4), gain=1.0, cartesian_near_goal=0.02, decay_rate=mu, period=1.0)
        r = sim.run(servo, c.camera, c.target, c.start, c.goal, duration=30.0, tolerance=1e-6)
        assert r.status.outcome == "converged", r
        dv = np.linalg.norm(np.diff(r.history.twist, axis=0), axis=1)
        jumps[mu] = dv[len(dv) // 10:].max()  # after the start (the jump at the switch itself: test_smoothing.cpp)
    assert jumps[6.0] < 0.5 * jumps[0.0], jumps


def test_valid_leaves_lost_points_out():
    (uvd, zd), (uv, z) = paper_points()
    servo = ibvs.Servo(ibvs.Layout.cartesian(4), gain=0.7)
    three = ibvs.Servo(ibvs.Layout.cartesian(3), gain=0.7)
    keep = [0, 1, 3]
    ref = three.update(uv[keep], z[keep], uvd[keep], zd[keep])
    lost_uv, lost_z = uv.copy(), z.copy()
    lost_uv[2], lost_z[2] = np.nan, np.nan
    r = servo.update(lost_uv, lost_z, uvd, zd, valid=np.array([True, True, False, True]))
    assert r.status == ibvs.Status.ok and r.lost_points == 1
    np.testing.assert_allclose(r.velocity, ref.velocity, rtol=1e-10, atol=1e-14)
    # all valid is the plain step, bit for bit
    assert np.array_equal(servo.update(uv, z, uvd, zd, valid=np.ones(4, bool)).velocity,
                          servo.update(uv, z, uvd, zd).velocity)
    # too few: features_lost, the twist ramps to zero over stop_time
    ramp = ibvs.Servo(ibvs.Layout.cartesian(4), gain=0.7, stop_time=0.1, period=0.02)
    v = ramp.update(uv, z, uvd, zd).velocity
    for k in range(1, 7):
        r = ramp.update(lost_uv, lost_z, uvd, zd, valid=np.array([True, False, False, True]))
        assert r.status == ibvs.Status.features_lost and r.lost_points == 2
        np.testing.assert_allclose(r.velocity, v * max(0.0, 1 - k * 0.2), atol=1e-14)


def test_bad_input_is_refused_naming_the_argument():
    (uvd, zd), (uv, z) = paper_points()
    L = ibvs.Layout.cartesian(4)
    for kw, word in [
        (dict(decay_rate=-1.0, period=0.01), "decay_rate"),
        (dict(decay_rate=float("nan"), period=0.01), "decay_rate"),
        (dict(decay_rate=1.0), "period"),
        (dict(max_linear_acceleration=0.0, period=0.01), "max_linear_acceleration"),
        (dict(max_angular_acceleration=-1.0, period=0.01), "max_angular_acceleration"),
        (dict(cartesian_near_goal=-0.1), "cartesian_near_goal"),
        (dict(stop_time=float("inf"), period=0.01), "stop_time"),
        (dict(stop_time=1.0), "period"),
    ]:
        with pytest.raises(ValueError, match=word):
            ibvs.Servo(L, gain=1.0, **kw)
    with pytest.raises(TypeError, match="decay_rate"):
        ibvs.Servo(L, gain=1.0, decay_rate="fast")
    s = ibvs.Servo(L, gain=1.0)
    with pytest.raises(TypeError, match="valid"):
        s.update(uv, z, uvd, zd, valid=[1, 0, 1, 1])
    with pytest.raises(ValueError, match="valid"):
        s.update(uv, z, uvd, zd, valid=np.ones(3, bool))
    bad = uv.copy()
    bad[0] = np.nan  # a valid point must be finite
    with pytest.raises(ValueError, match=r"uv\[0\]"):
        s.update(bad, z, uvd, zd, valid=np.array([True, True, False, True]))
    with pytest.raises(ValueError, match="twist"):
        s.reset(twist=np.full(6, np.nan))


class _Hide(sim.Sensor):
    """The projections with points `drop` lost (NaN) over frames [start, stop)."""

    def __init__(self, drop, start, stop):
        super().__init__()
        self.drop, self.start, self.stop = list(drop), start, stop

    def reset(self, seed):
        pass

    def measure(self, frame, pose, projected, twist):
        out = np.array(projected)
        if self.start <= frame < self.stop:
            out[self.drop] = np.nan
        return out


def test_keep_lost_with_points():
    c = cases.general_motion()
    servo = ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0, stop_time=0.5, period=1.0)
    kw = dict(duration=30.0, tolerance=1e-6)
    hidden = _Hide([2], 20, 30)
    assert sim.run(servo, c.camera, c.target, c.start, c.goal, vision=hidden, **kw).status.outcome == "lost_feature"
    r = sim.run(servo, c.camera, c.target, c.start, c.goal, vision=hidden, keep_lost=True, **kw)
    assert r.status.outcome == "converged", r
    gone = sim.run(servo, c.camera, c.target, c.start, c.goal, vision=_Hide([0, 1, 3], 20, 10**9), keep_lost=True,
                   **kw)
    assert gone.status.outcome == "lost_feature" and gone.status.point == 0
    assert abs(gone.status.frame - (20 + round(0.5 * c.camera.fps) - 1)) <= 1
    with pytest.raises(TypeError, match="keep_lost"):
        sim.run(servo, c.camera, c.target, c.start, c.goal, keep_lost=1)
    with pytest.raises(ValueError, match="keep_lost"):
        sim.run(servo, c.camera, c.target, c.start, c.goal, keep_lost=True, depth="pose")
    with pytest.raises(ValueError, match="keep_lost"):
        sim.run(ibvs.PartitionedServo(4, gain=1.0), c.camera, c.target, c.start, c.goal, keep_lost=True)


def test_image_episode_dot_occluded_for_10_frames():
    """A dot painted over for frames 10-19 of an image episode: the tracker loses it, the servo runs on
    the other three, the tracker finds it again where the others carried it, and the episode converges."""
    pytest.importorskip("cv2")
    from ibvs import vision

    c = cases.general_motion()
    cam = vision.image_camera(ibvs.CameraModel.normalized(0.3))

    class Occluded(vision.ImageSensor):
        def measure(self, frame, pose, projected, twist):
            image = self.renderer.render(pose, twist)
            if 10 <= frame < 20:  # a dark disc of 3 dot radii over dot 1
                u, v = np.asarray(projected)[1]
                yy, xx = np.ogrid[: image.shape[0], : image.shape[1]]
                image = image.copy()
                image[(xx - u) ** 2 + (yy - v) ** 2 <= 30.0**2] = 10
            if frame <= 0:
                self.detector.reset(projected)
            track = self.detector.track(image)
            self.lost_frames = getattr(self, "lost_frames", []) + ([frame] if 1 in track.lost else [])
            return track.pixels

    base = vision.ImageSensor.for_target(cam, c.target, "dots")
    sensor = Occluded(base.renderer, base.detector)
    servo = ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0, stop_time=0.5, period=1.0)
    r = sim.run(servo, cam, c.target, c.start, c.goal, duration=12.0, tolerance_px=0.5, vision=sensor,
                keep_lost=True)
    assert sensor.lost_frames == list(range(10, 20)), sensor.lost_frames
    assert r.status.outcome == "converged", r
    assert np.isnan(r.history.measured[10:20, 1]).all() and np.isfinite(r.history.measured[20:, 1]).all()
    assert r.metrics.final_translation_error < 1e-2  # 0.5 px of the 640x480 camera: 3.9 mm here
