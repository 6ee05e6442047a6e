"""Natural-feature episodes in the loop: sim.run(vision="klt" | "keypoints"), the klt and keypoints schemes
through ibvs.study (run_one, the sweep's run_episode) and `ibvs run --scheme klt`."""

import numpy as np
import pytest

cv2 = pytest.importorskip("cv2")

import ibvs
from ibvs import sim, vision
from ibvs.study import schemes

CAM = ibvs.CameraModel(300.0, 300.0, 159.5, 119.5, 0.0, 0.0, 320.0, 240.0, 30.0)
TARGET = sim.Target.square(0.2, sim.pose(t=(0, 0, 0.5)))
START = sim.pose(t=(0.04, -0.03, -0.08), r=(0.06, 0.04, 0.5))


@pytest.mark.parametrize("kind", ["klt", "keypoints"])
def test_natural_feature_episode_converges(kind):
    servo = schemes.make(kind, 2.0, 4)
    sensor = vision.ImageSensor.for_target(CAM, TARGET, kind, noise=1.0)
    r = sim.run(servo, CAM, TARGET, START, np.eye(4), duration=4.0, vision=sensor, tolerance_px=0.3)
    assert r.status.outcome == "converged", r.status
    assert r.metrics.final_translation_error < 2e-3 and r.metrics.final_rotation_error < np.radians(0.3)
    # the tracker's points against the true projections over the whole run
    err = np.abs(r.history.measured - r.history.projected).max()
    assert err < 0.5, err


def test_keypoints_target_out_of_sight_is_lost_feature():
    far = sim.pose(t=(0.0, 0.0, -6.0))  # the plate is 9 px wide: no keypoints match
    r = sim.run(schemes.make("keypoints", 1.0, 4), CAM, TARGET, far, np.eye(4), duration=1.0, vision="keypoints")
    assert r.status.outcome == "lost_feature" and r.status.frame == 0


def test_cli_scheme_klt_and_keypoints(capsys):
    """`ibvs run --scheme klt` (and keypoints) runs the paper's case through rendered images: the case's
    normalised camera becomes ibvs.vision.image_camera's 640x480 pinhole (1 s: not converged, exit 1)."""
    from ibvs.cli import main as cli

    for scheme, title in (("klt", "KLT"), ("keypoints", "keypoint-homography")):
        assert cli.main(["run", "--scheme", scheme, "--case", "x-translation", "--duration", "0.5"]) == 1
        out = capsys.readouterr().out
        assert title in out and "timeout" in out
    assert "klt" not in schemes.points_only() and schemes.sensor_for("cartesian", CAM, TARGET) is None


# --- dense schemes: photometric servoing and photometric moments, rendered at 160 x 120 ---

SMALL = ibvs.CameraModel(200.0, 200.0, 79.5, 59.5, 0.0, 0.0, 160.0, 120.0, 30.0)


@pytest.mark.parametrize("scheme, start", [
    ("photometric", sim.pose(t=(0.005, -0.003, -0.01), r=(0.005, 0.008, 0.03))),
    ("photometric_moments", sim.pose(t=(0.02, -0.01, 0.0), r=(0.0, 0.0, 0.3))),
])
def test_dense_scheme_episode_converges(scheme, start):
    cam, target = schemes.dense_target(scheme, SMALL, TARGET)
    # the weak directions (a translation across the axis against a tilt) end slowly: the pose is checked
    r = sim.run(schemes.make(scheme, 2.0, 4), cam, target, start, np.eye(4), duration=6.0, tolerance_px=0.05)
    assert r.status.outcome in ("converged", "timeout"), r.status
    assert r.metrics.final_translation_error < 2e-3 and r.metrics.final_rotation_error < np.radians(0.3)


def test_luminance_block_is_the_luminance_law():
    """One step of the Servo on the luminance block is LuminanceServo's twist times the Servo's gain."""
    measure = vision.PhotometricMeasure(SMALL, TARGET)
    goal = np.asarray(TARGET.pose)  # camera <- target at the goal (the camera at the world origin)
    cMo = np.linalg.inv(sim.pose(t=(0.004, 0.002, -0.01), r=(0.01, 0.0, 0.02))) @ np.asarray(TARGET.pose)
    plane_pose = goal
    assert np.array_equal(measure(-1, goal, plane_pose, goal, None, None), np.zeros(6))
    step = measure(3, cMo, cMo, goal, None, None)
    servo = ibvs.Servo(ibvs.Task().add(vision.luminance_block()), gain=0.7, damping=0.0)
    v = servo.update(np.zeros((0, 2)), np.zeros(0), np.zeros((0, 2)), measurements=[step],
                     measurements_desired=[np.zeros(6)]).velocity
    lum = ibvs.LuminanceServo(SMALL, 160, 120, plane=ibvs.sim.plane_in_camera(goal))
    lum.set_desired(measure.undistorted(measure.image(goal), measure.renderer.background))
    np.testing.assert_allclose(v, 0.7 * np.asarray(lum.update(measure.undistorted(measure.image(cMo), 10.0)).twist),
                               rtol=0, atol=1e-3 * np.abs(v).max())


def test_dense_textureless_goal_is_refused():
    flat = np.full((64, 64), 10, np.uint8)  # the plate as dark as the background: a uniform image, H singular
    target = TARGET.with_features([vision.photometric_source(SMALL, TARGET, "luminance", texture=flat)])
    start = sim.pose(t=(0.01, 0, 0))
    with pytest.raises(ValueError, match="goal: target sources.0. .*cannot be measured at the goal"):
        sim.run(schemes.make("photometric", 1.0, 4), SMALL, target, start, np.eye(4), duration=1.0)
    # a textured goal, then the plate out of sight (the camera turned away): lost_feature, no NaN twist
    target = TARGET.with_features([vision.photometric_source(SMALL, TARGET, "luminance")])
    away = sim.pose(r=(0.0, 1.2, 0.0))
    r = sim.run(schemes.make("photometric", 1.0, 4), SMALL, target, away, np.eye(4), duration=1.0)
    assert r.status.outcome in ("lost_feature", "left_image") and np.isfinite(r.history.twist[:-1]).all()


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

_MEASURES = {f: vision.PhotometricMeasure(SMALL, TARGET, f, noise=2.0) for f in vision.DENSE_FEATURES}
_GOAL = np.asarray(TARGET.pose)


@settings(max_examples=30, deadline=None)
@given(feature=st.sampled_from(vision.DENSE_FEATURES),
       t=st.tuples(*[st.floats(-1, 1, allow_nan=False)] * 3), r=st.tuples(*[st.floats(-4, 4, allow_nan=False)] * 3))
def test_dense_measure_of_any_pose_is_finite_or_lost(feature, t, r):
    """Any camera pose (behind the plate, edge-on, inside it): a finite measurement or None (lost), never NaN."""
    m = _MEASURES[feature]
    assert m(-1, _GOAL, _GOAL, _GOAL, None, None) is not None
    cMo = np.linalg.inv(sim.pose(t=t, r=r)) @ _GOAL
    out = m(1, cMo, cMo, _GOAL, None, None)
    assert out is None or np.isfinite(np.asarray(out)).all()


def test_sweep_episode_of_image_schemes():
    """The sweep's run_episode runs the image schemes through their sensor or dense source (1 s episodes of the
    free scenario: its normalised camera imaged by image_camera's 640x480 pinhole)."""
    from ibvs.study import sweep as sw
    from ibvs.study.scenario import builtin

    spec = sw.SweepSpec(builtin("free").replace(duration=1.0), episodes=1, schemes=("keypoints", "photometric"))
    for scheme in ("keypoints", "photometric"):
        row = sw.run_episode(spec, 0, scheme)
        assert row["scheme"] == scheme and row["outcome"] in sim.OUTCOMES and row["frame"] >= 0
        # as the sweep's workers receive it: the Scheme entry carries the sensor kind or dense feature
        again = sw.run_episode(spec, 0, scheme, factory=schemes.entry(scheme))
        assert {k: again[k] for k in ("outcome", "frame")} == {k: row[k] for k in ("outcome", "frame")}


def test_lost_target_ramps_the_twist_down():
    """The plate goes dark at frame 15 (the light goes out): the keypoint tracker reports every corner lost,
    and with keep_lost the servo ramps its twist to zero over its stop time before lost_feature."""

    class LightsOut(vision.ImageSensor):
        def measure(self, frame, pose, projected, twist):
            if frame == 15:
                self._lighting = (self._lighting[0], (0.0, 0.0))
            return super().measure(frame, pose, projected, twist)

    r0 = vision.Renderer(CAM, TARGET, "texture", noise=1.0)
    sensor = LightsOut(r0, vision.KeypointTracker(image_size=r0.size))
    start = sim.pose(t=(0.03, -0.02, -0.05), r=(0.0, 0.0, 0.3))
    servo = ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0, stop_time=0.5, period=1.0)  # the keypoints scheme's
    r = sim.run(servo, CAM, TARGET, start, np.eye(4), duration=4.0, vision=sensor, keep_lost=True, tolerance_px=0.1)
    assert r.status.outcome == "lost_feature" and r.status.frame > 15
    assert np.isnan(r.history.measured[15:]).all() and np.isfinite(r.history.measured[:15]).all()
    speed = np.linalg.norm(r.history.twist[14:r.status.frame + 1], axis=1)
    assert np.isfinite(speed).all() and speed[0] > 0.01 and speed[-1] == 0.0
    assert (np.diff(speed[1:]) <= 1e-12).all()  # a ramp down, no jump back up
