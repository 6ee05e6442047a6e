"""Photometric visual servoing (issue 36): LuminanceServo's interaction matrix against ViSP's formula
(vpFeatureLuminance, written again here from the formula) row by row and against central differences of
exact images of a textured plane; its twist against the law computed in double here; closed loops from
small displacements; refusals. Images: tests/python/textured_plane.py."""

from __future__ import annotations

import numpy as np
import pytest
from textured_plane import moved, plane_in_camera, ramp, render, waves

import ibvs

W, H_, F = 160, 120, 200.0
K = np.array([[F, 0.0, 79.5], [0.0, F, 59.5], [0.0, 0.0, 1.0]])
DEPTH = 0.5


def camera() -> ibvs.CameraModel:
    return ibvs.CameraModel(px=F, py=F, u0=K[0, 2], v0=K[1, 2])


def pose(t=(0.0, 0.0, 0.0), r=(0.0, 0.0, 0.0)) -> np.ndarray:
    return ibvs.se3_exp(np.r_[t, r])


def visp_interaction(image: np.ndarray, plane, border: int = 10) -> np.ndarray:
    """vpFeatureLuminance's rows, from its formula: the gradient by the 7-tap filter (2047, 913, 112) / 8418
    times p_x, p_y; x = (j - u0) / p_x at pixel (i, j); ViSP's constant Z generalised to 1/Z = A x + B y + C."""
    I = np.asarray(image, float)
    rows = []
    for i in range(border, I.shape[0] - border):
        for j in range(border, I.shape[1] - border):
            dx = (2047 * (I[i, j + 1] - I[i, j - 1]) + 913 * (I[i, j + 2] - I[i, j - 2])
                  + 112 * (I[i, j + 3] - I[i, j - 3])) / 8418.0
            dy = (2047 * (I[i + 1, j] - I[i - 1, j]) + 913 * (I[i + 2, j] - I[i - 2, j])
                  + 112 * (I[i + 3, j] - I[i - 3, j])) / 8418.0
            Ix, Iy = F * dx, F * dy
            x, y = (j - K[0, 2]) / F, (i - K[1, 2]) / F
            zi = plane[0] * x + plane[1] * y + plane[2]
            rows.append([Ix * zi, Iy * zi, -(x * Ix + y * Iy) * zi, -Ix * x * y - (1 + y * y) * Iy,
                         (1 + x * x) * Ix + Iy * x * y, Iy * x - Ix * y])
    return np.array(rows)


@pytest.mark.parametrize("plane", [(0.0, 0.0, 1 / DEPTH), (0.3, -0.2, 1.8)])
def test_interaction_is_visps_formula_row_by_row(plane):
    T = pose((0.004, -0.003, 0.01), (0.02, -0.015, 0.05))
    image = render(T, K, (W, H_), DEPTH, waves)
    servo = ibvs.LuminanceServo(camera(), W, H_, plane=plane)
    L = servo.interaction(image)
    Lv = visp_interaction(image, plane)
    assert L.shape == Lv.shape == (servo.pixels, 6) == ((W - 20) * (H_ - 20), 6)
    scale = np.abs(Lv).max(axis=0)
    assert np.abs(L - Lv).max(axis=0) / scale == pytest.approx(np.zeros(6), abs=1e-13)
    assert np.array_equal(servo.intensities(image), image[10:-10, 10:-10].ravel())
    # uint8 images are the same feature (converted exactly)
    u8 = np.clip(image, 0, 255).astype(np.uint8)
    assert np.allclose(servo.interaction(u8), visp_interaction(u8, plane), rtol=0, atol=1e-9 * scale.max())


def test_smoothing_is_a_normalised_gaussian_before_the_filter():
    cv2 = pytest.importorskip("cv2", reason="OpenCV (the test extra) checks the pre-smoothing")
    image = render(pose((0.003, 0.0, 0.0)), K, (W, H_), DEPTH, waves)
    servo = ibvs.LuminanceServo(camera(), W, H_, smoothing=1.2, border=10)
    k = cv2.getGaussianKernel(2 * 4 + 1, 1.2).astype(np.float32).astype(float).ravel()  # radius ceil(3 sigma) = 4
    smooth = cv2.sepFilter2D(image, cv2.CV_64F, k, k, borderType=cv2.BORDER_REPLICATE)
    assert np.allclose(servo.intensities(image), smooth[10:-10, 10:-10].ravel(), rtol=1e-6)
    Lv = visp_interaction(smooth, (0, 0, 1.0))
    assert np.abs(servo.interaction(image) - Lv).max() <= 1e-6 * np.abs(Lv).max()
    with pytest.raises(ValueError, match="border"):
        ibvs.LuminanceServo(camera(), W, H_, smoothing=1.2, border=6)  # needs 3 + 4


def fd_columns(T: np.ndarray, texture, h: float, border: int = 10) -> np.ndarray:
    cols = []
    for k in range(6):
        plus = render(moved(T, k, h), K, (W, H_), DEPTH, texture)
        minus = render(moved(T, k, -h), K, (W, H_), DEPTH, texture)
        cols.append(((plus - minus) / (2 * h))[border:-border, border:-border].ravel())
    return np.array(cols).T


@pytest.mark.parametrize("texture,tol", [(ramp, 2e-4), (waves, 4e-2)])
def test_interaction_against_finite_differences(texture, tol):
    """dI/dt at every grid pixel under each camera twist component (central differences of exact renders
    of the plane, step 1e-5) against L_I's column, at a pose off the goal (tilted plane: A, B != 0).
    The accuracy rendering allows is the 7-tap filter's: exact on a linear ramp (a ramp texture seen
    through the plane's homography: 2e-4 relative), and for a texture of wavelength lambda it measures
    the derivative of a sinusoid short by ~0.5 (2 pi / lambda)^2 (about 2 % for the waves' shortest
    ~30 px): 4e-2 relative. Everything else (the formula, the depth plane) agrees to the step's 1e-8."""
    T = pose((0.01, -0.006, -0.02), (0.06, -0.05, 0.1))
    plane = plane_in_camera(T, DEPTH)
    image = render(T, K, (W, H_), DEPTH, texture)
    L = ibvs.LuminanceServo(camera(), W, H_, plane=plane).interaction(image)
    fd = fd_columns(T, texture, 1e-5)
    rel = np.linalg.norm(L - fd, axis=0) / np.linalg.norm(fd, axis=0)
    assert (rel < tol).all(), rel
    if texture is ramp:
        assert rel.max() > 1e-9  # a real comparison (the filter is not exact through the homography)


def law(L: np.ndarray, e: np.ndarray, mu: float, gain: float) -> np.ndarray:
    Hm = L.T @ L
    return -gain * np.linalg.solve(Hm + mu * np.diag(np.diag(Hm)), L.T @ e)


@pytest.mark.parametrize("jacobian", ["desired", "current", "mean"])
@pytest.mark.parametrize("mu", [0.01, 0.0])
def test_twist_is_the_law_computed_in_double(jacobian, mu):
    """The servo never forms L_I (row sums of polynomial moments, in float): its twist is the law
    v = -gain (H + mu diag H)^-1 L^T e computed here from L_I in double, to float accuracy."""
    plane = (0.2, -0.1, 1 / DEPTH)
    goal = render(pose(), K, (W, H_), DEPTH, waves)
    cur = render(pose((0.004, 0.002, -0.006), (0.01, -0.02, 0.03)), K, (W, H_), DEPTH, waves)
    servo = ibvs.LuminanceServo(camera(), W, H_, jacobian=jacobian, mu=mu, gain=0.7, plane=plane,
                                law="levenberg_marquardt" if mu else "gauss_newton")
    servo.set_desired(goal)
    r = servo.update(cur)
    assert r.ok and r.status == "ok" and r.pixels == servo.pixels
    Lc, Ld = servo.interaction(cur), servo.interaction(goal)
    L = {"current": Lc, "desired": Ld, "mean": 0.5 * (Lc + Ld)}[jacobian]
    e = servo.intensities(cur) - servo.intensities(goal)
    v = law(L, e, mu, 0.7)
    assert np.linalg.norm(r.twist - v) <= 2e-5 * np.linalg.norm(v)
    assert r.error_rms == pytest.approx(np.sqrt(np.mean(e ** 2)), rel=1e-5)


def closed_loop(servo, T, steps, dt=0.5, texture=waves, size=(W, H_)):
    for _ in range(steps):
        r = servo.update(render(T, K, size, DEPTH, texture))
        if not r.ok:
            return T, r
        T = T @ ibvs.se3_exp(r.twist * dt)
    return T, r


@pytest.mark.parametrize("jacobian", ["desired", "current", "mean"])
def test_closed_loop_reaches_the_goal(jacobian):
    """From 1-2 cm and 1-3 degrees off (the plane 0.5 m away, 160 x 120 images) to the goal pose, as ViSP's
    example runs it: Levenberg-Marquardt (mu 0.01) first, then Gauss-Newton (mu = 0). The pose error at the
    end is below 1e-8 (m, rad) for each J. Levenberg-Marquardt alone crawls in the nearly degenerate
    direction (x translation against y rotation: the pose error still ~1 mm after 60 steps, 0.04 after 200)."""
    servo = ibvs.LuminanceServo(camera(), W, H_, jacobian=jacobian, plane=(0, 0, 1 / DEPTH))
    servo.set_desired(render(pose(), K, (W, H_), DEPTH, waves))
    T0 = pose((0.012, -0.01, 0.02), np.deg2rad([1.0, -1.5, 3.0]))
    T, r = closed_loop(servo, T0, 20)
    assert r.ok and 1e-3 < np.abs(T[:3, 3]).max() < 0.5 * np.abs(T0[:3, 3]).max()
    servo.set_mu(0.0)
    assert servo.mu == 0.0
    T, r = closed_loop(servo, T, 30)
    assert r.ok
    assert np.abs(T[:3, 3]).max() < 1e-8 and np.abs(T[:3, :3] - np.eye(3)).max() < 1e-8, T
    assert r.error_rms < 1e-3
    with pytest.raises(ValueError, match="mu must be in"):
        servo.set_mu(-1.0)


def test_textureless_and_saturated_images_give_a_status_and_no_twist():
    goal = render(pose(), K, (W, H_), DEPTH, waves)
    servo = ibvs.LuminanceServo(camera(), W, H_, jacobian="current")
    servo.set_desired(goal)
    flat = np.full((H_, W), 77.0)
    r = servo.update(flat)
    assert r.status == "textureless" and not r.ok and np.array_equal(r.twist, np.zeros(6))
    assert np.isfinite(r.error_rms)
    stripes = np.tile(np.sin(np.arange(W) / 5.0) * 50 + 100, (H_, 1))  # gradient along u only: rank 3 at most
    assert servo.update(stripes).status == "textureless"
    sat = np.full((H_, W), 255, np.uint8)
    sat[:, 70:90] = (stripes[:, 70:90]).astype(np.uint8)  # blown out but for a band of vertical stripes
    r = servo.update(sat)
    assert r.status == "saturated" and np.array_equal(r.twist, np.zeros(6))
    assert servo.update(np.zeros((H_, W), np.uint8)).status == "saturated"
    with pytest.raises(ValueError, match="image has too little texture"):
        servo.set_desired(flat)


@pytest.mark.parametrize("bad,exc,match", [
    (np.zeros((H_, W + 1)), ValueError, r"image: must be 120 x 160 \(rows x columns\), got 120 x 161"),
    (np.zeros((H_, W, 3), np.uint8), ValueError, "image must be a 2-D grey image"),
    (np.zeros((H_, W), complex), TypeError, "image must be an array of real numbers"),
    ("image", TypeError, "image must be an array of real numbers"),
])
def test_bad_images_are_refused_naming_the_argument(bad, exc, match):
    servo = ibvs.LuminanceServo(camera(), W, H_)
    servo.set_desired(render(pose(), K, (W, H_), DEPTH, waves))
    for call in (servo.update, servo.set_desired, servo.interaction):
        with pytest.raises(exc, match=match):
            call(bad)


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf, 1e7])
def test_non_finite_or_huge_pixels_are_refused(value):
    servo = ibvs.LuminanceServo(camera(), W, H_)
    goal = render(pose(), K, (W, H_), DEPTH, waves)
    servo.set_desired(goal)
    bad = goal.copy()
    bad[3, 150] = value  # in the border: still refused (validate reads the whole image)
    with pytest.raises(ValueError, match=r"image\[3, 150\]: must be finite and within \+-1e\+06"):
        servo.update(bad)
    with pytest.raises(ValueError, match=r"image\[3, 150\]"):
        servo.set_desired(bad)
    with pytest.raises(ValueError, match=r"image\[3, 150\]"):
        ibvs.photometric_moments(camera(), bad)


def test_update_before_set_desired_is_refused():
    servo = ibvs.LuminanceServo(camera(), W, H_)
    assert not servo.has_desired
    with pytest.raises(ValueError, match="set_desired"):
        servo.update(np.zeros((H_, W)))


@pytest.mark.parametrize("kwargs,match", [
    (dict(border=2), "border must be >= 3"),
    (dict(border=80), "width and height must leave a grid"),
    (dict(smoothing=-1.0), "smoothing must be within"),
    (dict(smoothing=float("nan")), "smoothing must be within"),
    (dict(gain=0.0), "gain must be in"),
    (dict(mu=-1.0), "mu must be in"),
    (dict(plane=(0.0, 0.0, 0.0)), "1/Z = A x \\+ B y \\+ C must be within"),
    (dict(plane=(5.0, 0.0, 1.0)), "1/Z = A x \\+ B y \\+ C must be within"),  # crosses 0 over the grid
    (dict(plane=(0.0, 0.0)), "plane must be"),
    (dict(jacobian="later"), "jacobian must be"),
    (dict(law="newton"), "law must be"),
    (dict(min_conditioning=1.0), "min_conditioning must be in"),
])
def test_bad_options_are_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        ibvs.LuminanceServo(camera(), W, H_, **kwargs)


def test_distorted_camera_is_refused():
    cam = ibvs.CameraModel(px=F, py=F, u0=80.0, v0=60.0, kud=0.1)
    with pytest.raises(ValueError, match="camera must be a pinhole without distortion"):
        ibvs.LuminanceServo(cam, W, H_)
    with pytest.raises(ValueError, match="camera must be a pinhole without distortion"):
        ibvs.photometric_moments(cam, np.zeros((H_, W)))


def test_repr_and_properties():
    s = ibvs.LuminanceServo(camera(), W, H_, jacobian="mean", smoothing=0.5)
    assert (s.width, s.height, s.border, s.jacobian, s.law) == (W, H_, 10, "mean", "levenberg_marquardt")
    assert repr(s).startswith("LuminanceServo(160x120, border 10, 14000 pixels, J mean")
    s.set_desired(render(pose(), K, (W, H_), DEPTH, waves))
    assert "status='ok'" in repr(s.update(render(pose((0.001, 0, 0)), K, (W, H_), DEPTH, waves)))


def test_interaction_against_the_simulators_8bit_renderer():
    """The same check on the package's own renderer (ibvs.vision.Renderer, kind "texture": the procedural
    texture on a 0.6 m plate, warped by a homography with bilinear resampling, 8-bit output), with the
    servo's Gaussian pre-smoothing (sigma 1 px). Its 8-bit levels and resampling bound the accuracy: each
    column's step is the one that suits it (the image moves ~1.6 px), and the columns agree to 5 % for the
    translations across the axis and the rotations about the image axes, 30 % for tz and wz (whose motion
    vanishes at the image centre, so fewer pixels carry them above the 8-bit noise)."""
    pytest.importorskip("cv2", reason="the renderer needs OpenCV (the vision extra)")
    from ibvs import sim, vision

    cam = ibvs.CameraModel(px=F, py=F, u0=K[0, 2], v0=K[1, 2], width=W, height=H_)
    renderer = vision.Renderer(cam, sim.Target.square(0.6, sim.pose(t=(0.0, 0.0, DEPTH))), "texture")
    T = ibvs.se3_exp([0.005, -0.004, -0.01, 0.03, -0.02, 0.05])
    servo = ibvs.LuminanceServo(cam, W, H_, plane=plane_in_camera(T, DEPTH), smoothing=1.0)
    L = servo.interaction(renderer.render(T))
    steps, tol = (4e-3, 4e-3, 1.6e-2, 8e-3, 8e-3, 1.6e-2), (0.05, 0.05, 0.3, 0.05, 0.05, 0.3)
    for k in range(6):
        h = steps[k]
        fd = (servo.intensities(renderer.render(moved(T, k, h)))
              - servo.intensities(renderer.render(moved(T, k, -h)))) / (2 * h)
        rel = np.linalg.norm(L[:, k] - fd) / np.linalg.norm(fd)
        assert rel < tol[k], (k, rel)
