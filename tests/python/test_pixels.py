"""Pixels in, twist out: Servo / PartitionedServo with a CameraModel (update_pixels), OpenCV's (N, 1, 2)
shape, the error in pixels, a closed loop on a distorted camera, and bad input."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ibvs

K = np.array([[600.0, 0.0, 320.0], [0.0, 601.0, 240.0], [0.0, 0.0, 1.0]])
DIST = np.array([-0.28, 0.07, 0.001, -0.0005, 0.01])
UV_DESIRED = np.array([[0.1, 0.1], [-0.1, 0.1], [-0.1, -0.1], [0.1, -0.1]])
UV = np.array([[0.16, 0.05], [-0.05, 0.16], [-0.16, -0.05], [0.05, -0.16]])


@pytest.fixture
def camera():
    return ibvs.CameraModel.from_opencv(K, DIST, 640, 480)


def laws(camera):
    return [
        ibvs.Servo(ibvs.Layout.stacked(4), gain=0.5, damping=0.01, camera=camera),
        ibvs.Servo.automatic_hybrid(4, gain=0.5, camera=camera),
        ibvs.PartitionedServo(4, gain=0.5, camera=camera),
    ]


def test_update_pixels_is_normalize_then_update(camera):
    px, pxd = camera.project(UV), camera.project(UV_DESIRED)
    for servo in laws(camera):
        assert servo.camera == camera
        r = servo.update_pixels(px, 0.6, pxd)
        twist, pixel_error = r.velocity.copy(), r.pixel_error
        ref = servo.update(camera.normalize(px), 0.6, camera.normalize(pxd))
        assert np.array_equal(twist, ref.velocity)
        assert pixel_error == pytest.approx(np.linalg.norm(px - pxd, axis=1).max(), rel=1e-15)
        assert math.isnan(ref.pixel_error)  # update() takes normalised points: no pixel error
        # OpenCV's (N, 1, 2), e.g. straight from cv2.findChessboardCorners or a tracker
        r3 = servo.update_pixels(px[:, None, :], 0.6, pxd[:, None, :])
        assert np.array_equal(r3.velocity, twist)


def test_normalised_calls_take_opencv_shape_too():
    servo = ibvs.Servo(ibvs.Layout.cartesian(4), gain=0.5)
    a = servo.update(UV, 0.6, UV_DESIRED).velocity.copy()
    assert np.array_equal(servo.update(UV[:, None, :], 0.6, UV_DESIRED[:, None, :]).velocity, a)


def test_closed_loop_in_pixels(camera):
    """A free-flying camera servoed from pixels of a distorted camera converges in the image to < 0.01 px."""
    # the points in the goal camera's frame
    P = np.array([[0.1, 0.1, 1.0], [-0.1, 0.1, 1.0], [-0.1, -0.1, 1.0], [0.1, -0.1, 1.0]])
    start = ibvs.se3_exp(np.array([0.05, -0.03, -0.2, 0.1, -0.08, 0.6]))

    def measure(T_wc):
        Pc = (np.linalg.inv(T_wc) @ np.c_[P, np.ones(4)].T).T[:, :3]
        return camera.project(Pc[:, :2] / Pc[:, 2:]), Pc[:, 2]

    pxd, zd = measure(np.eye(4))
    servo = ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0, camera=camera)
    T = start
    for _ in range(600):
        px, z = measure(T)
        r = servo.update_pixels(px, z, pxd, zd)
        if r.pixel_error < 0.01:
            break
        T = T @ ibvs.se3_exp(r.velocity / 60.0)
    assert r.pixel_error < 0.01
    assert np.abs(T - np.eye(4)).max() < 1e-3


def test_bad_input(camera):
    px, pxd = camera.project(UV), camera.project(UV_DESIRED)
    with pytest.raises(ValueError, match="camera"):
        ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0).update_pixels(px, 1.0, pxd)
    with pytest.raises(ValueError, match="camera"):
        ibvs.PartitionedServo(4, gain=1.0).update_pixels(px, 1.0, pxd)
    with pytest.raises(TypeError, match="camera"):
        ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0, camera="K.yaml")
    with pytest.raises(TypeError, match="camera"):
        ibvs.PartitionedServo(4, gain=1.0, camera=K)
    for servo in laws(camera):
        with pytest.raises(ValueError, match=r"pixels must have shape"):
            servo.update_pixels(px.T, 1.0, pxd)
        with pytest.raises(ValueError, match=r"pixels_desired must hold 4 points"):
            servo.update_pixels(px, 1.0, pxd[:3])
        with pytest.raises(ValueError, match=r"pixels\[2\] is not finite"):
            bad = px.copy()
            bad[2, 1] = np.nan
            servo.update_pixels(bad, 1.0, pxd)
        with pytest.raises(ValueError, match=r"depth\[0\]"):
            servo.update_pixels(px, [-1.0, 1.0, 1.0, 1.0], pxd)
    # a lens that folds (k1 = -0.4, k2 = 0.05): a pixel past the image of its fold radius has no inverse
    folding = ibvs.CameraModel.from_opencv(K, [-0.4, 0.05, 0.0, 0.0], 640, 480)
    far = folding.project(UV)
    far[1] = [5000.0, 240.0]
    for servo in laws(folding):
        with pytest.raises(ValueError, match=r"pixels\[1\] = .*no inverse"):
            servo.update_pixels(far, 1.0, folding.project(UV_DESIRED))


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-1e4, 1e4), min_size=8, max_size=8), st.floats(0.01, 100))
def test_update_pixels_finite_or_refused(values, depth):
    """Any finite pixels give a finite twist or a ValueError, on a lens that folds."""
    camera = ibvs.CameraModel.from_opencv(K, [-0.4, 0.05, 0.0, 0.0], 640, 480)
    servo = ibvs.Servo(ibvs.Layout.stacked(4), gain=0.5, damping=0.01, camera=camera)
    try:
        r = servo.update_pixels(np.reshape(values, (4, 2)), depth, camera.project(UV_DESIRED))
    except ValueError as e:
        assert "pixels" in str(e) or "uv" in str(e)
    else:
        assert np.isfinite(r.velocity).all() and np.isfinite(r.pixel_error)


def test_pixels_follow_the_normalised_limit():
    """Pixels are not bounded by |u|, |v| <= 10 themselves (they are hundreds); the point they normalise
    to is, with the error naming the pixel argument; update_pixels then agrees with validate."""
    camera = ibvs.CameraModel.from_opencv(K, np.zeros(5), 640, 480)  # no distortion: every pixel inverts
    px, pxd = camera.project(UV), camera.project(UV_DESIRED)
    assert np.all(np.abs(px) > 10)
    for servo in laws(camera):
        assert np.all(np.isfinite(servo.update_pixels(px, 0.6, pxd).velocity))
        far = pxd.copy()
        far[1] = (320.0 + 600.0 * 11, 240.0)  # u = 11: 85 degrees off the axis
        with pytest.raises(ValueError, match=r"pixels_desired\[1\] = .*normalises to \(11, 0\)"):
            servo.update_pixels(px, 0.6, far)
