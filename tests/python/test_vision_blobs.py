"""Blobs in the loop (ibvs.vision.blob): a disc (a 3-D circle) and a planar polygon rendered into the camera
image, measured with cv2.moments (the ellipse: centroid and centred second-order moments; the moments task:
ibvs.vision.image_moments), converted to normalised coordinates through the camera model, and servoed by
sim.run to convergence. The image measurements agree with the geometric ones (sim.EllipseSource, the
polygon's exact moments) to a fraction of a pixel, with and without lens distortion."""

from __future__ import annotations

import numpy as np
import pytest

import ibvs
from ibvs import sim

cv2 = pytest.importorskip("cv2")
from ibvs import vision  # noqa: E402
from ibvs.study import compare, schemes  # noqa: E402

F = 800.0  # the focal length (px) of image_camera's pinhole for the free camera
GOAL = sim.pose(t=(0.08, -0.05, 0.0), r=(0.08, -0.06, 0.0))  # the disc off-centre and tilted (rank 5)
START = GOAL @ sim.pose(t=(0.1, 0.05, -0.3), r=(0.03, 0.04, 0.3))


def disc_target(radius=0.3, n=16, pose=None):
    a = 2 * np.pi * np.arange(n) / n
    pts = np.column_stack([radius * np.cos(a), radius * np.sin(a), np.zeros(n)])
    T = np.eye(4)
    T[2, 3] = 3.0
    return sim.Target(pts, T if pose is None else pose)


def ellipse_servo(gain=1.0):
    """Five components: a circle's image is blind to the camera's turn about the circle's axis."""
    task = ibvs.Task().add(ibvs.EllipseFeature())
    task.dof = ["Tx", "Ty", "Tz", "wx", "wy"]
    return ibvs.Servo(task, gain=gain)


def test_rendered_ellipse_matches_the_circle_geometry():
    """At several poses the image ellipse (cv2.moments of the thresholded rendering) is the circle's exact
    image (EllipseFeature.project_circle) within 0.05 px for the centroid and 1 % for the moments."""
    cam = sim.cases.general_motion().camera
    target = disc_target()
    blob = vision.BlobMeasure(cam, target, "ellipse")
    for k, T_wc in enumerate([GOAL, START, GOAL @ sim.pose(t=(-0.1, 0.1, 0.2), r=(-0.2, 0.3, 1.0))]):
        cMo = np.linalg.inv(T_wc) @ target.pose
        m = blob(k, cMo, cMo, cMo, np.zeros((16, 2)), np.ones(16))
        exact = ibvs.EllipseFeature.project_circle(cMo[:3, 3], cMo[:3, 2], 0.3)
        assert np.abs(m[:2] - exact[:2]).max() * F < 0.05
        np.testing.assert_allclose(m[2:5], exact[2:5], rtol=0, atol=0.01 * exact[2:5:2].max())
        np.testing.assert_allclose(m[5:], exact[5:], rtol=1e-12)


def test_rendered_ellipse_through_a_distorted_lens():
    """The gantry's camera has lens distortion: the image is undistorted before its moments are taken, so
    the ellipse is the pinhole one (within 0.1 px), while the distorted image's own moments are off."""
    case = sim.cases.gantry_general_motion()
    assert case.camera.distortion != "none"
    target = disc_target(0.03, 16, case.target.pose)
    blob = vision.BlobMeasure(case.camera, target, "ellipse")
    cMo = sim.pose(t=(0.07, 0.05, 0.45), r=(0.2, -0.3, 0.4))  # off-centre, where the lens moves it more
    m = blob(0, cMo, cMo, cMo, np.zeros((16, 2)), np.ones(16))
    exact = ibvs.EllipseFeature.project_circle(cMo[:3, 3], cMo[:3, 2], 0.03)
    px = case.camera.px
    assert np.abs(m[:2] - exact[:2]).max() * px < 0.1
    np.testing.assert_allclose(m[2:5], exact[2:5], rtol=0, atol=0.01 * exact[2:5:2].max())
    raw = np.clip((blob.image(cMo).astype(np.float32) - 30) / 200, 0, 1)  # the distorted image's coverage
    mo = cv2.moments(raw)
    xg_distorted = (mo["m10"] / mo["m00"] - case.camera.u0) / px
    assert abs(xg_distorted - exact[0]) * px > 1.0  # the lens moves the blob by more than a pixel here


def test_servo_on_the_rendered_ellipse_converges():
    """An ellipse task servoed on the rendered images: the image error ends below 0.1 px (centroid) and the
    camera centre at the goal's within 2 mm."""
    case = sim.cases.general_motion()
    target = disc_target()
    t = target.with_features([vision.blob_source(case.camera, target, "ellipse")])
    r = sim.run(ellipse_servo(), case.camera, t, START, GOAL, duration=15, tolerance=1e-4)
    assert r.converged, r
    e = r.history.error[-1]
    assert np.abs(e[:2]).max() * F < 0.1
    # the camera sees the circle from the goal's distance and angle to its axis (the turn about the axis is
    # free), as on the geometric source (sim.EllipseSource)
    def seen_from(T_wc):
        c = T_wc[:3, 3] - target.pose[:3, 3]
        return np.array([np.linalg.norm(c), np.arccos(abs(c @ target.pose[:3, 2]) / np.linalg.norm(c))])

    g = sim.run(ellipse_servo(), case.camera,
                target.with_features([sim.EllipseSource((0, 0, 0), (0, 0, 1), 0.3)]), START, GOAL, duration=15,
                tolerance=1e-4)
    assert g.converged
    d_image = seen_from(r.history.pose[-1]) - seen_from(GOAL)
    d_geometry = seen_from(g.history.pose[-1]) - seen_from(GOAL)
    print(f"image: converged at frame {r.status.frame} (geometric: {g.status.frame}), centroid error "
          f"{np.abs(e[:2]).max() * F:.3f} px, distance to the circle {1e3 * d_image[0]:.2f} mm, angle to its axis "
          f"{np.degrees(d_image[1]):.3f} deg from the goal's")
    assert abs(d_image[0]) < 2e-3 and abs(np.degrees(d_image[1])) < 0.1
    assert abs(d_geometry[0]) < 1e-3


def test_servo_on_the_rendered_polygon_moments_converges():
    """The moments task (Tahri & Chaumette 2005, alpha from third-order moments) on the rendered polygon:
    converges to the goal pose within 2 mm and 0.2 degrees."""
    target = compare.target()
    cam = sim.cases.z_rotation().camera
    start = sim.pose(t=(0.06, -0.04, -0.3), r=(0.05, -0.08, 0.6))
    t = target.with_features([vision.blob_source(cam, target, "moments")])
    r = sim.run(schemes.moments(1.0), cam, t, start, np.eye(4), duration=15, tolerance=1e-5)
    assert r.converged, r
    print(f"image: converged at frame {r.status.frame}, "
          f"pose error {1e3 * r.metrics.final_translation_error:.2f} mm, "
          f"{np.degrees(r.metrics.final_rotation_error):.3f} deg")
    assert r.metrics.final_translation_error < 5e-3 and np.degrees(r.metrics.final_rotation_error) < 0.1
    # the image's measurement against the polygon's exact moments (MomentsSource of its vertices) at the goal
    g = sim.run(schemes.moments(1.0), cam, schemes.moments_target(target), start, np.eye(4), duration=0.1)
    xg_image = r.measurements_desired[1] / r.measurements_desired[0]
    xg_exact = g.measurements_desired[1] / g.measurements_desired[0]
    assert abs(xg_image - xg_exact) * F < 0.05


def test_blob_refusals():
    cam = sim.cases.general_motion().camera
    with pytest.raises(ValueError, match="feature must be one of"):
        vision.BlobMeasure(cam, disc_target(), "segment")
    with pytest.raises(ValueError, match="on a circle"):
        vision.BlobMeasure(cam, compare.target(), "ellipse")
    with pytest.raises(ValueError, match="nonzero area"):
        vision.BlobMeasure(cam, sim.Target(np.array([[0, 0, 0], [0.1, 0, 0], [0.2, 0, 0.0]]), None), "moments")
    with pytest.raises(ValueError, match="exposure"):
        vision.BlobMeasure(cam, disc_target(), "ellipse", exposure=0.01)
    blob = vision.BlobMeasure(cam, disc_target(), "ellipse")
    cMo = np.linalg.inv(GOAL) @ disc_target().pose
    # cut by the image border, or no depth pose: lost (None)
    near = cMo.copy()
    near[0, 3] += 1.0
    assert blob(0, near, near, near, None, None) is None
    assert blob(0, cMo, np.full((4, 4), np.nan), cMo, None, None) is None
    assert blob(0, cMo, cMo, cMo, None, None) is not None
    assert "disc" in repr(blob)
