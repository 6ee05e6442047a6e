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
