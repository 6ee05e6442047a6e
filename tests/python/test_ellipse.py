"""ibvs.EllipseFeature from Python: its interaction matrix against central differences of its own
projection (a 3-D circle re-projected after small camera motions); project_circle against the
moments OpenCV measures on the circle's rendered image (measure_moments with cv2.moments' dict);
a loop closed on the rendered image (blob moments every frame); the refusals. tests/cpp/test_ellipse.cpp
checks the rows against ViSP's transcription of Chaumette 2004 and project_circle against exact
polygon moments."""

from __future__ import annotations

import numpy as np
import pytest

import ibvs

cv2 = pytest.importorskip("cv2")

CAMERA = ibvs.CameraModel(600.0, 600.0, 320.0, 240.0, width=640, height=480)


def moved(P, xi, direction=False):
    """Camera-frame point (or direction) seen from the camera moved by twist xi."""
    T = np.linalg.inv(ibvs.se3_exp(xi))
    return T[:3, :3] @ P + (0.0 if direction else T[:3, 3])


def random_circle(rng):
    depth = rng.uniform(0.5, 5.0)
    centre = np.append(rng.uniform(-0.4, 0.4, 2), 1.0) * depth
    normal = np.append(rng.uniform(-1, 1, 2), -1.0 - abs(rng.uniform(-1, 1)))
    return centre, normal, rng.uniform(0.02, 0.25) * depth


def test_ellipse_interaction_is_the_derivative_of_its_projection(rng):
    ellipse, checked = ibvs.EllipseFeature(), 0
    for _ in range(100):
        c, n, r = random_circle(rng)
        try:
            m = ibvs.EllipseFeature.project_circle(c, n, r)
        except ValueError:  # partly out of the normalised-coordinate limits
            continue
        L, h, Ln = ellipse.interaction(m), 1e-6, np.zeros((5, 6))
        for k in range(6):
            xi = np.zeros(6)
            xi[k] = h
            a = ibvs.EllipseFeature.project_circle(moved(c, xi), moved(n, xi, True), r)
            b = ibvs.EllipseFeature.project_circle(moved(c, -xi), moved(n, -xi, True), r)
            Ln[:, k] = (a[:5] - b[:5]) / (2 * h)
        assert np.allclose(L, Ln, rtol=0, atol=1e-7 * max(1.0, np.abs(L).max()))
        checked += 1
    assert checked > 90


def render(centre, normal, radius, camera=CAMERA, points=720):
    """The circle's image as OpenCV would segment it: a filled polygon of its projected points (sub-pixel)."""
    e1 = np.cross(normal, [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(normal / np.linalg.norm(normal), e1)
    t = np.linspace(0, 2 * np.pi, points, endpoint=False)
    X = centre + radius * (np.cos(t)[:, None] * e1 + np.sin(t)[:, None] * e2)
    px = camera.project(X[:, :2] / X[:, 2:])
    image = np.zeros((int(camera.height), int(camera.width)), np.uint8)
    cv2.fillPoly(image, [np.round(px * 256).astype(np.int32)], 255, lineType=cv2.LINE_8, shift=8)
    return image


def test_projection_is_what_opencv_measures(rng):
    """cv2.moments of the rendered circle against project_circle: within the pixel grid's resolution."""
    for _ in range(10):
        c = np.array([rng.uniform(-0.2, 0.2), rng.uniform(-0.15, 0.15), 1.0]) * rng.uniform(0.8, 2.0)
        n = np.append(rng.uniform(-0.6, 0.6, 2), -1.0)
        r = rng.uniform(0.08, 0.15) * c[2]
        m = ibvs.EllipseFeature.project_circle(c, n, r)
        b = ibvs.EllipseFeature.measure_moments(cv2.moments(render(c, n, r), binaryImage=True), m[5:], CAMERA)
        size = np.sqrt(m[2] + m[4])  # ~ the ellipse's radius
        assert np.abs(b[:2] - m[:2]).max() < 0.2 / 600  # centroid within 0.2 pixel
        assert np.abs(b[2:5] - m[2:5]).max() < 0.03 * size**2  # moments within 3 %
        assert np.array_equal(b[5:], m[5:])
    # The 6 values in the documented order are the same as the dict.
    mo = cv2.moments(render(c, n, r), binaryImage=True)
    six = [mo[k] for k in ("m00", "m10", "m01", "mu20", "mu11", "mu02")]
    assert np.array_equal(ibvs.EllipseFeature.measure_moments(six, m[5:], CAMERA),
                          ibvs.EllipseFeature.measure_moments(mo, m[5:], CAMERA))


def test_loop_closed_on_the_rendered_image():
    """A disc seen obliquely; every frame the blob's moments of the rendered image (wz left out): the camera
    ends where it sees the circle as at the goal (the goal pose turned about the circle's axis), to what
    the pixel grid can tell."""
    world_c, world_n, radius = np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, -1.0]), 0.12
    goal = ibvs.se3_exp([0.15, -0.05, 0.0, 0.05, -0.15, 0.0])

    def seen(T_wc):
        T = np.linalg.inv(T_wc)
        return T[:3, :3] @ world_c + T[:3, 3], T[:3, :3] @ world_n

    def measure(T_wc):
        c, n = seen(T_wc)
        plane = ibvs.EllipseFeature.project_circle(c, n, radius)[5:]  # the plane from the true pose
        return ibvs.EllipseFeature.measure_moments(cv2.moments(render(c, n, radius), binaryImage=True), plane, CAMERA)

    task = ibvs.Task().add(ibvs.EllipseFeature())
    task.dof = ["Tx", "Ty", "Tz", "wx", "wy"]
    servo = ibvs.Servo(task, gain=1.0)
    none, none_z = np.zeros((0, 2)), np.zeros(0)
    goal_m = measure(goal)
    T = goal @ ibvs.se3_exp([0.05, -0.04, -0.2, 0.08, -0.08, 0.3])
    first = None
    for _ in range(600):
        r = servo.update(none, none_z, none, measurements=[measure(T)], measurements_desired=[goal_m])
        first = r.error_norm if first is None else first
        T = T @ ibvs.se3_exp(r.velocity / 30)
    (c, n), (cg, ng) = seen(T), seen(goal)
    assert r.error_norm < 1e-3 * first
    assert np.linalg.norm(c - cg) < 5e-3 and np.linalg.norm(n - ng) < 2e-2  # 5 mm, 1 degree
    assert r.velocity[5] == 0.0


def test_refusals():
    ellipse = ibvs.EllipseFeature()
    good = [0.1, -0.1, 0.01, 0.002, 0.005, 0.0, 0.0, 0.5]
    assert np.isfinite(ellipse.interaction(good)).all()
    for i, bad, why in [(0, np.inf, r"\[0\]: is not finite"), (2, 0.0, r"\[2\]: n20 and n02"),
                        (3, 0.008, "zero or negative area"), (5, -5.0, "edge-on"), (7, -0.5, "edge-on or behind"),
                        (1, -11.0, r"\[1\]: the centroid")]:
        m = list(good)
        m[i] = bad
        with pytest.raises(ValueError, match=why):
            ellipse.value(m)
    with pytest.raises(ValueError, match="radius"):
        ibvs.EllipseFeature.project_circle([0, 0, 2], [0, 0, 1], 0.0)
    with pytest.raises(ValueError, match="edge-on"):
        ibvs.EllipseFeature.project_circle([0, 0, 2], [1, 0, 0], 0.1)
    with pytest.raises(ValueError, match="in front of the camera"):
        ibvs.EllipseFeature.project_circle([0, 0, 0.05], [1, 0, 1], 0.1)
    with pytest.raises(ValueError, match="m00"):
        ibvs.EllipseFeature.measure_moments(cv2.moments(np.zeros((10, 10), np.uint8)), [0, 0, 1], CAMERA)
    with pytest.raises(ValueError, match="mu11"):
        ibvs.EllipseFeature.measure_moments({"m00": 1.0, "m10": 0, "m01": 0, "mu20": 1, "mu02": 1}, [0, 0, 1])
    with pytest.raises(ValueError, match="undistort"):
        ibvs.EllipseFeature.measure_moments([1, 320, 240, 1, 0, 1], [0, 0, 1], ibvs.CameraModel.afma6())
    with pytest.raises(TypeError, match="camera"):
        ibvs.EllipseFeature.measure_moments([1, 320, 240, 1, 0, 1], [0, 0, 1], camera="pinhole")
    with pytest.raises(ValueError, match="zero or negative area"):
        ibvs.EllipseFeature.measure_moments([1, 0, 0, 1, 1, 1], [0, 0, 1])  # a segment
    servo = ibvs.Servo(ibvs.Task().add(ibvs.EllipseFeature()), gain=1.0)
    flat = list(good)
    flat[3] = 0.008
    with pytest.raises(ValueError, match=r"measurements\[0\]: zero or negative area"):
        servo.update(np.zeros((0, 2)), np.zeros(0), np.zeros((0, 2)), measurements=[flat], measurements_desired=[good])
