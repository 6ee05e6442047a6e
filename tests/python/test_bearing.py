"""Wide field of view: CameraModel.to_bearing / from_bearing against OpenCV (cv2.fisheye below 90
degrees, cv2.omnidir everywhere), round trips over the whole image, Mei's model from cv2.omnidir's
outputs and from a YAML file, the reported field of view, bad input; the spherical feature blocks
(finite differences, stacking, refusals) and a servo from fisheye pixels to a target 100 degrees
off the axis."""

import math
import pickle

import numpy as np
import pytest

import ibvs

cv2 = pytest.importorskip("cv2")  # in the test extra (opencv-contrib: cv2.omnidir): never skipped in CI

W, H = 1280, 1024
K_FISH = np.array([[300.0, 0.0, 641.5], [0.0, 300.5, 511.25], [0.0, 0.0, 1.0]])
FISHEYE = np.array([-0.013, 0.02, -0.012, 0.002])
K_OMNI = np.array([[700.0, 0.0, 640.5], [0.0, 701.0, 512.5], [0.0, 0.0, 1.0]])
XI, D_OMNI = 1.6, np.array([-0.2, 0.05, 1e-4, 2e-4])


def directions(n, max_angle, seed=0):
    """n unit vectors uniformly up to max_angle off the optical axis (z)."""
    rng = np.random.default_rng(seed)
    a = np.arccos(1.0 - rng.uniform(0, 1, n) * (1.0 - np.cos(max_angle)))
    p = rng.uniform(-np.pi, np.pi, n)
    return np.stack([np.sin(a) * np.cos(p), np.sin(a) * np.sin(p), np.cos(a)], -1)


def grid(step=16.0):
    u = np.append(np.arange(0.0, W, step), W)
    v = np.append(np.arange(0.0, H, step), H)
    return np.stack(np.meshgrid(u, v), -1).reshape(-1, 2)


@pytest.fixture
def fish():
    return ibvs.CameraModel.from_opencv(K_FISH, FISHEYE, W, H, fisheye=True)


@pytest.fixture
def omni():
    return ibvs.CameraModel.from_omnidir(K_OMNI, XI, D_OMNI, W, H)


def test_fisheye_matches_cv2_below_90_degrees(fish):
    b = directions(2000, math.radians(89.0)) * np.random.default_rng(1).uniform(0.1, 10, (2000, 1))
    ref, _ = cv2.fisheye.projectPoints(b[:, None, :], np.zeros(3), np.zeros(3), K_FISH, FISHEYE)
    assert np.abs(fish.from_bearing(b) - ref[:, 0]).max() < 1e-6
    # and the bearing back from OpenCV's pixels
    back = fish.to_bearing(ref[:, 0])
    assert np.abs(back - b / np.linalg.norm(b, axis=1, keepdims=True)).max() < 1e-9


def test_omnidir_matches_cv2_everywhere(omni):
    assert omni.distortion == "omnidir" and omni.coefficients == (XI, *D_OMNI) and omni.xi == XI
    b = directions(2000, 0.999 * omni.max_angle, seed=2) * 3.0
    ref, _ = cv2.omnidir.projectPoints(b[None], np.zeros(3), np.zeros(3), K_OMNI, XI, D_OMNI)
    ours = omni.from_bearing(b, invalid="nan")
    ok = ~np.isnan(ours[:, 0])
    assert ok.mean() > 0.95  # refused only where the tangential terms fold, next to max_angle
    assert np.abs(ours[ok] - ref[0][ok]).max() < 1e-6
    # OpenCV's xi as cv2.omnidir.calibrate returns it ((1, 1) array) and D as (1, 4)
    assert ibvs.CameraModel.from_omnidir(K_OMNI, np.array([[XI]]), D_OMNI[None], W, H) == omni
    K, xi, D = omni.to_opencv()
    assert np.array_equal(K, K_OMNI) and xi == XI and np.array_equal(D, D_OMNI)


def test_omnidir_xi_below_one_sees_behind():
    cam = ibvs.CameraModel.from_omnidir(K_OMNI * [[0.5], [0.5], [1]], 0.8, [-0.05, 0.01, 2e-4, -1e-4], W, H)
    assert math.isclose(cam.max_angle, math.acos(-0.8), rel_tol=1e-12)
    b = directions(1000, 0.99 * cam.max_angle, seed=3)
    ref, _ = cv2.omnidir.projectPoints(b[None], np.zeros(3), np.zeros(3), cam.K, 0.8, np.array(cam.coefficients[1:]))
    # near acos(-xi) the pixels run to ~1e8 (an asymptote): 1e-6 px, or 1e-12 relative out there
    assert (np.abs(cam.from_bearing(b) - ref[0]) <= 1e-6 + 1e-12 * np.abs(ref[0])).all()


@pytest.mark.parametrize("name", ["plumb_bob", "fisheye", "omni", "pinhole"])
def test_round_trip_over_the_whole_image(name, fish, omni):
    cam = {"fisheye": fish, "omni": omni,
           "plumb_bob": ibvs.CameraModel.from_opencv(K_FISH * [[2], [2], [1]], [-0.28, 0.07, 1e-3, -5e-4, 0.0], W, H),
           "pinhole": ibvs.CameraModel.from_opencv(K_OMNI, None, W, H)}[name]
    px = grid()
    b = cam.to_bearing(px, invalid="nan")
    ok = ~np.isnan(b[:, 0])
    # every pixel inside the image circle maps
    rd = np.hypot((px[:, 0] - cam.u0) / cam.px, (px[:, 1] - cam.v0) / cam.py)
    assert ok[rd < 0.999 * cam.fold_radius].all()
    assert np.allclose(np.linalg.norm(b[ok], axis=1), 1.0, atol=1e-15, rtol=0)
    assert np.abs(cam.from_bearing(b[ok]) - px[ok]).max() < 1e-9
    # bearings beyond 90 degrees exist exactly for the wide models
    assert (b[ok][:, 2] < 0).any() == (name in ("fisheye", "omni"))


def test_field_of_view(fish, omni):
    assert fish.max_angle == pytest.approx(math.pi) and fish.field_of_view > math.radians(200)
    assert omni.max_angle <= math.acos(-1 / XI) + 1e-12
    assert omni.fold_radius < math.inf and omni.field_of_view == pytest.approx(2 * omni.max_angle)
    pin = ibvs.CameraModel.from_opencv(K_OMNI, None, W, H)
    assert pin.max_angle == pytest.approx(math.pi / 2) and pin.fold_radius == math.inf
    assert pin.field_of_view == pytest.approx(2 * math.atan(math.hypot(W / 2 + 0.5, H / 2 + 0.5) / 700), rel=1e-3)


def test_bad_input(fish, omni):
    with pytest.raises(ValueError, match=r"bearings\[1\] has zero length"):
        fish.from_bearing([[0, 0, 1], [0, 0, 0]])
    with pytest.raises(ValueError, match=r"bearings\[0\] is not finite"):
        fish.from_bearing([[np.nan, 0, 1]])
    with pytest.raises(ValueError, match=r"bearings\[0\] lies .* beyond .*max_angle"):
        omni.from_bearing([[0, 0, -1]])
    with pytest.raises(ValueError, match=r"pixels\[1\] = .* beyond the image circle"):
        omni.to_bearing([[640, 512], [640 + 3 * omni.fold_radius * omni.px, 512]])
    with pytest.raises(ValueError, match=r"bearings must have shape \(N, 3\)"):
        fish.from_bearing(np.zeros((2, 2)))
    with pytest.raises(ValueError, match="invalid must be"):
        fish.to_bearing([1.0, 2.0], invalid="skip")
    out = omni.to_bearing([[640, 512], [1e9, 512]], invalid="nan")
    assert np.isfinite(out[0]).all() and np.isnan(out[1]).all()
    assert fish.to_bearing([641.5, 511.25]).tolist() == [0.0, 0.0, 1.0]  # one point: (3,)
    with pytest.raises(ValueError, match="xi must be finite and in"):
        ibvs.CameraModel.from_omnidir(K_OMNI, -1.0, D_OMNI, W, H)
    with pytest.raises(ValueError, match="D must hold 4"):
        ibvs.CameraModel.from_omnidir(K_OMNI, 1.0, [0.1], W, H)
    with pytest.raises(ValueError, match="skew"):
        ibvs.CameraModel.from_omnidir(K_OMNI + [[0, 0.3, 0], [0, 0, 0], [0, 0, 0]], 1.0, D_OMNI, W, H)


def test_omnidir_yaml_pickle_repr(tmp_path, omni):
    path = tmp_path / "omni.yaml"
    k = K_OMNI.ravel()
    path.write_text(
        f"image_width: {W}\nimage_height: {H}\nxi: {XI}\ndistortion_model: omnidir\n"
        f"camera_matrix: {{rows: 3, cols: 3, data: [{', '.join(str(float(x)) for x in k)}]}}\n"
        f"distortion_coefficients: {{rows: 1, cols: 4, data: [{', '.join(str(float(x)) for x in D_OMNI)}]}}\n"
    )
    assert ibvs.CameraModel.from_yaml(path, fps=60) == omni
    path.write_text(path.read_text().replace(f"xi: {XI}\n", ""))
    with pytest.raises(ValueError, match="needs a number 'xi'"):
        ibvs.CameraModel.from_yaml(path, fps=60)
    assert pickle.loads(pickle.dumps(omni)) == omni
    assert "distortion=omnidir, xi=1.6" in repr(omni)


# --- spherical feature blocks -------------------------------------------------------------------

def _moved(P, twist):
    T = np.linalg.inv(ibvs.se3_exp(twist))
    return T[:3, :3] @ P + T[:3, 3]


@pytest.mark.parametrize("kind", [ibvs.SphericalPointFeature, ibvs.SphericalPolarFeature])
def test_spherical_interaction_by_finite_differences(kind):
    f = kind()
    rng = np.random.default_rng(4)
    for P in directions(50, math.radians(175), seed=5) * rng.uniform(0.3, 5, (50, 1)):
        m = ibvs.SphericalPointFeature.measure(P)
        L = f.interaction(m)
        h = 1e-6
        for j in range(6):
            t = np.zeros(6)
            t[j] = h
            a, b = (ibvs.SphericalPointFeature.measure(_moved(P, s * t)) for s in (1, -1))
            fd = f.error(a, b) / (2 * h)  # the wrapped difference
            assert np.abs(fd - L[:, j]).max() < 1e-6 * (1 + np.abs(L[:, j]).max())


def test_spherical_stack_and_refusals():
    task = ibvs.Task(ibvs.Layout.cartesian(1)).add(ibvs.SphericalPolarFeature(), 2.0).add(ibvs.SphericalPointFeature())
    assert task.rows == 2 + 2 + 3 and task.measurement_size == 8
    assert repr(ibvs.SphericalPolarFeature(0.01)) == "<ibvs feature spherical_polar(min_sin=0.01)>"
    f = ibvs.SphericalPointFeature()
    with pytest.raises(ValueError, match="unit vector"):
        f.value([0, 0, 0, 1])
    with pytest.raises(ValueError, match=r"measurement\[3\]"):
        f.value([0, 0, 1, -1])
    with pytest.raises(ValueError, match="min_sin"):
        ibvs.SphericalPolarFeature(0.0)
    cam = ibvs.CameraModel.from_opencv(K_FISH, FISHEYE, W, H, fisheye=True)
    with pytest.raises(ValueError, match=r"distance\[0\]"):
        ibvs.spherical_measurements(cam, [[640, 512]], [0.0])
    with pytest.raises(ValueError, match="one value per pixel"):
        ibvs.spherical_measurements(cam, [[640, 512]], [1.0, 2.0])
    m = ibvs.spherical_measurements(cam, [[640, 512], [1e7, 0]], [1.0, 1.0], invalid="nan")
    assert np.isfinite(m[0]).all() and np.isnan(m[1]).all()


@pytest.mark.parametrize("kind", [ibvs.SphericalPointFeature, ibvs.SphericalPolarFeature])
def test_servo_from_fisheye_pixels_100_degrees_off_axis(kind, fish):
    """The target starts 100 degrees off the optical axis (no perspective camera sees it): servoed
    from the fisheye's pixels through the lens model, to the goal pose."""
    Pw = np.array([[-0.25, -0.25, 1.0], [0.25, -0.25, 1.0], [0.25, 0.25, 1.0], [-0.25, 0.25, 1.0]])
    task = ibvs.Task()
    for _ in range(4):
        task.add(kind())
    servo = ibvs.Servo(task, gain=1.0)

    def measure(T_wc):
        T = np.linalg.inv(T_wc)
        P = Pw @ T[:3, :3].T + T[:3, 3]
        px = fish.from_bearing(P)  # what the camera sees
        return ibvs.spherical_measurements(fish, px, np.linalg.norm(P, axis=1)).ravel()

    goal = measure(np.eye(4))
    T = ibvs.se3_exp([0.05, -0.04, -0.2, 0.0, math.radians(107), 0.3])
    Tc = np.linalg.inv(T)
    centre = Tc[:3, :3] @ Pw.mean(0) + Tc[:3, 3]
    assert math.degrees(math.acos(centre[2] / np.linalg.norm(centre))) > 100
    none = np.zeros((0, 2))
    for _ in range(4000):
        r = servo.update(none, np.zeros(0), none, measurements=measure(T), measurements_desired=goal)
        if r.error_norm < 1e-9:
            break
        T = T @ ibvs.se3_exp(r.velocity / 60)
    assert r.error_norm < 1e-9
    assert np.abs(T - np.eye(4)).max() < 1e-6


def test_omnidir_camera_info_round_trip(omni):
    pytest.importorskip("rosbags")
    from ibvs import ros

    msg = ros.camera_info(omni)
    assert msg.distortion_model == "omnidir" and list(msg.d) == [XI, *D_OMNI]
    assert ros.camera_model(msg) == omni
