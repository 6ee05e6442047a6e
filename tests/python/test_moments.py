"""ibvs.MomentsFeature from Python: its rows against central differences of the projection; the
polygon moments against OpenCV's contour moments; a binary image's moments (ibvs.vision.image_moments,
through cv2.moments) against the polygon's; the camera turned by 160 degrees about its axis turns
back without retreat; degenerate objects refused; every finite measurement answered with finite
numbers or refused (hypothesis)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ibvs
import ibvs.vision


NONE = np.zeros((0, 2))  # no image points: a task of the moments block only


def star(rng, n=6, size=0.15):
    t = 2 * np.pi * (np.arange(n) + 0.5 + rng.uniform(-0.3, 0.3, n)) / n
    r = size * rng.uniform(0.5, 1.0, n)
    return np.column_stack([r * np.cos(t), r * np.sin(t), np.zeros(n)])


def in_camera(T_wc, Pw):
    T = np.linalg.inv(T_wc)
    return Pw @ T[:3, :3].T + T[:3, 3]


@pytest.mark.parametrize("source", ["region", "points"])
@pytest.mark.parametrize("invariants", ["p", "s"])
def test_rows_are_the_derivative_of_the_projection(rng, source, invariants):
    f = ibvs.MomentsFeature(source, invariants)
    for _ in range(5):
        tilt = 0.3 * rng.uniform(-1, 1, 2)
        T = ibvs.se3_exp(np.r_[0.1 * rng.uniform(-1, 1, 2), 0.0, tilt, rng.uniform(-3, 3)])
        T[2, 3] = -rng.uniform(0.6, 2.0)
        P = in_camera(T, star(rng))
        m = ibvs.MomentsFeature.project(P, source, 0.02, 0.8)
        L = f.interaction(m)
        h, N = 1e-6, np.zeros((6, 6))
        for k in range(6):
            xi = np.zeros(6)
            xi[k] = h
            a = ibvs.MomentsFeature.project(in_camera(ibvs.se3_exp(xi), P), source, 0.02, 0.8)
            b = ibvs.MomentsFeature.project(in_camera(ibvs.se3_exp(-xi), P), source, 0.02, 0.8)
            N[:, k] = f.error(a, b) / (2 * h)
        assert np.allclose(L, N, rtol=0, atol=1e-5 * max(1.0, np.abs(L).max()))


def test_polygon_moments_match_opencv_contour_moments(rng):
    cv2 = pytest.importorskip("cv2")
    pts = np.array([[10, 20], [200, 35], [240, 180], [120, 90], [30, 160]], dtype=np.float64)
    ours = ibvs.MomentsFeature.of_polygon(pts)
    cv = cv2.moments(pts.astype(np.float32))
    for n in range(4):
        for j in range(n + 1):
            i = n - j
            assert ours[n * (n + 1) // 2 + j] == pytest.approx(cv[f"m{i}{j}"], rel=1e-12)


def test_binary_image_moments_through_cv2(rng):
    cv2 = pytest.importorskip("cv2")
    camera = ibvs.CameraModel(px=800.0, py=800.0, u0=320.0, v0=240.0)
    poly_px = np.array([[200.5, 150.5], [460.5, 180.5], [420.5, 330.5], [300.5, 250.5], [230.5, 320.5]])
    mask = np.zeros((480, 640), np.uint8)
    cv2.fillPoly(mask, [np.round(poly_px).astype(np.int32)], 255)
    ours = ibvs.vision.image_moments(mask, camera)
    # Exactly the pixel sums in normalised coordinates (each pixel one point at its centre, area 1/(px py)).
    rows, cols = np.nonzero(mask)
    x, y = (cols - 320.0) / 800.0, (rows - 240.0) / 800.0
    direct = [np.sum(x ** (n - j) * y**j) / 800.0**2 for n in range(5) for j in range(n + 1)]
    assert np.allclose(ours, direct, rtol=1e-9, atol=1e-15)
    xy = (poly_px - [320.0, 240.0]) / 800.0
    exact = ibvs.MomentsFeature.of_polygon(xy)
    assert ours[0] == pytest.approx(exact[0], rel=0.02)  # the area, to the pixel border
    assert ours[1] / ours[0] == pytest.approx(exact[1] / exact[0], abs=2e-3)  # the centre of gravity
    assert ours[2] / ours[0] == pytest.approx(exact[2] / exact[0], abs=2e-3)
    f = ibvs.MomentsFeature()
    m = ibvs.MomentsFeature.measure(ours, [0.0, 0.0, 1.0], "region", 0.0, 1.0)
    assert np.isfinite(f.interaction(m)).all() and f.value(m)[2] == pytest.approx(1.0)
    with pytest.raises(ValueError, match="distortion"):
        ibvs.vision.image_moments(mask, ibvs.CameraModel(px=800.0, py=800.0, u0=320.0, v0=240.0, kud=0.1))


def test_half_turn_about_the_axis_without_retreat(rng):
    P = star(rng)
    P[:, :2] -= P[:, :2].mean(axis=0)  # the points' centre of gravity on the optical axis
    Zd = 0.8
    task = ibvs.Task().add(ibvs.MomentsFeature("points"))
    servo = ibvs.Servo(task, gain=1.0)
    goal = np.eye(4)
    goal[2, 3] = -Zd
    md = ibvs.MomentsFeature.project(in_camera(goal, P), "points", 0.0, Zd)
    T = ibvs.se3_exp([0, 0, 0, 0, 0, np.deg2rad(160.0)])
    T[2, 3] = -Zd
    zs = []
    for _ in range(2000):
        m = ibvs.MomentsFeature.project(in_camera(T, P), "points", md[15], Zd)
        r = servo.update(NONE, np.zeros(0), NONE, measurements=[m], measurements_desired=[md])
        zs.append(T[2, 3])
        if r.error_norm < 1e-9:
            break
        T = T @ ibvs.se3_exp(r.velocity / 60.0)
    assert r.error_norm < 1e-9
    assert np.allclose(T, goal, atol=1e-8)
    assert np.ptp(zs) < 1e-9  # turned about its axis: no retreat


def test_degenerate_objects_are_refused():
    f = ibvs.MomentsFeature()
    line = np.array([[0.0, 0.0], [0.1, 0.05], [0.2, 0.1], [0.3, 0.15]])
    with pytest.raises(ValueError, match="zero area"):
        f.value(ibvs.MomentsFeature.measure(ibvs.MomentsFeature.of_polygon(line), [0, 0, 1], "region", 0.01))
    with pytest.raises(ValueError, match="flat"):
        ibvs.MomentsFeature("points").value(
            ibvs.MomentsFeature.measure(ibvs.MomentsFeature.of_points(line), [0, 0, 1], "points", 0.01, 1.0)
        )
    tri = np.array([[0.1, 0.0], [0.0, 0.1], [-0.05, -0.05]])
    m = ibvs.MomentsFeature.measure(ibvs.MomentsFeature.of_polygon(tri), [0, 0, 1], "region", 0.0, 1.0)
    edge = m.copy()
    edge[17] = -edge[19] * edge[0] / edge[1]  # 1/Z = A x + C is 0 at the centre of gravity
    with pytest.raises(ValueError, match="edge-on"):
        f.interaction(edge)
    square = np.array([[0.1, 0.1], [-0.1, 0.1], [-0.1, -0.1], [0.1, -0.1]])
    msq = ibvs.MomentsFeature.measure(ibvs.MomentsFeature.of_polygon(square), [0, 0, 1], "region", 0.0, 1.0)
    with pytest.raises(ValueError, match="undefined"):
        ibvs.MomentsFeature(alpha="second_order").value(msq)
    assert ibvs.MomentsFeature(rows=["xn", "yn", "an", "r1", "r2"]).value(msq).shape == (5,)
    with pytest.raises(ValueError, match="rows"):
        ibvs.MomentsFeature(rows=["theta"])
    with pytest.raises(ValueError, match="source"):
        ibvs.MomentsFeature("blob")
    with pytest.raises(ValueError, match="plane"):
        ibvs.MomentsFeature.project(np.array([[0, 0, 1.0], [0.1, 0, 1.0], [0, 0.1, 1.0], [0.1, 0.1, 2.0]]))
    assert repr(ibvs.MomentsFeature("points", "s", "second_order", ["alpha"])) == (
        "<ibvs feature moments(points, s, second_order, rows=alpha)>"
    )


_finite = st.floats(min_value=-1e12, max_value=1e12, allow_nan=False)


@settings(max_examples=200)
@given(st.lists(_finite, min_size=20, max_size=20), st.sampled_from(["region", "points"]))
def test_measurements_are_finite_or_refused(m, source):
    servo = ibvs.Servo(ibvs.Task().add(ibvs.MomentsFeature(source)), gain=1.0, damping=0.01)
    good = ibvs.MomentsFeature.project(
        np.array([[0.1, 0.0, 1.0], [0.0, 0.12, 1.0], [-0.1, -0.02, 1.0], [0.03, -0.1, 1.0]]), source
    )
    try:
        r = servo.update(NONE, np.zeros(0), NONE, measurements=[m], measurements_desired=[good])
    except ValueError as e:
        assert "measurements" in str(e)
        return
    assert np.isfinite(r.velocity).all() and np.isfinite(r.error).all() and np.isfinite(r.jacobian).all()


@settings(max_examples=200)
@given(st.lists(st.tuples(_finite, _finite, st.floats(-1e3, 1e3)), min_size=3, max_size=8),
       st.sampled_from(["region", "points"]))
def test_projected_objects_are_finite_or_refused(pts, source):
    P = np.array(pts, dtype=float)
    try:
        m = ibvs.MomentsFeature.project(P, source)
        L = ibvs.MomentsFeature(source).interaction(m)
    except ValueError as e:
        assert "moments" in str(e) or "measurement" in str(e)
        return
    assert np.isfinite(L).all() and np.isfinite(m).all()
