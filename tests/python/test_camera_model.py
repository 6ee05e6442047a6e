"""ibvs.CameraModel against OpenCV (cv2.projectPoints, cv2.fisheye.projectPoints), ViSP's formulas,
round trips over the whole image, the radius where each model stops being one-to-one, calibration
files (ROS camera_info and OpenCV FileStorage) and bad input."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ibvs

cv2 = pytest.importorskip("cv2")  # in the test extra: never skipped in CI

W, H = 640, 480
K = np.array([[600.5, 0.0, 320.25], [0.0, 601.0, 240.75], [0.0, 0.0, 1.0]])
PLUMB_BOB = np.array([-0.28, 0.07, 0.001, -0.0005, 0.01])  # a strong barrel lens
FISHEYE = np.array([-0.013, 0.021, -0.012, 0.003])
K_FISHEYE = np.array([[285.0, 0.0, 322.0], [0.0, 286.0, 238.5], [0.0, 0.0, 1.0]])


def pixel_grid(step=8.0):
    """Every `step` pixels over the whole sensor, edges and corners included."""
    u = np.append(np.arange(0.0, W, step), W)
    v = np.append(np.arange(0.0, H, step), H)
    return np.stack(np.meshgrid(u, v), -1).reshape(-1, 2)


def rays(n, half_angle, seed=0):
    """n normalised points (x, y) up to half_angle off the optical axis, and their 3D points (z = 1)."""
    rng = np.random.default_rng(seed)
    th = half_angle * np.sqrt(rng.uniform(0, 1, n))
    ph = rng.uniform(-np.pi, np.pi, n)
    uv = np.tan(th)[:, None] * np.stack([np.cos(ph), np.sin(ph)], -1)
    return uv, np.hstack([uv, np.ones((n, 1))])


def test_plumb_bob_matches_cv2_project_points():
    cam = ibvs.CameraModel.from_opencv(K, PLUMB_BOB, W, H)
    assert cam.distortion == "plumb_bob" and cam.coefficients == tuple(PLUMB_BOB)
    uv, P = rays(2000, np.radians(40))
    ref, _ = cv2.projectPoints(P, np.zeros(3), np.zeros(3), K, PLUMB_BOB)
    assert np.abs(cam.project(uv) - ref[:, 0]).max() < 1e-6
    # OpenCV's 4-coefficient form (k3 = 0) and its (1, 5) / (5, 1) shapes
    four = ibvs.CameraModel.from_opencv(K, PLUMB_BOB[:4].reshape(1, 4), W, H)
    ref4, _ = cv2.projectPoints(P, np.zeros(3), np.zeros(3), K, PLUMB_BOB[:4])
    assert np.abs(four.project(uv) - ref4[:, 0]).max() < 1e-6
    assert ibvs.CameraModel.from_opencv(K, PLUMB_BOB.reshape(5, 1), W, H) == cam


def test_fisheye_matches_cv2_fisheye_project_points():
    cam = ibvs.CameraModel.from_opencv(K_FISHEYE, FISHEYE, W, H, fisheye=True)
    assert cam.distortion == "equidistant" and cam.coefficients == tuple(FISHEYE)
    uv, P = rays(2000, np.radians(80))
    uv[0] = 0.0  # the optical axis itself
    P[0, :2] = 0.0
    ref, _ = cv2.fisheye.projectPoints(P[:, None, :], np.zeros(3), np.zeros(3), K_FISHEYE, FISHEYE)
    assert np.abs(cam.project(uv) - ref[:, 0]).max() < 1e-6


@pytest.mark.parametrize(
    "cam",
    [
        ibvs.CameraModel.from_opencv(K, PLUMB_BOB, W, H),
        ibvs.CameraModel.from_opencv(K, [0.12, -0.3, 0.002, 0.001, 0.2], W, H),  # pincushion + tangential
        ibvs.CameraModel.from_opencv(K_FISHEYE, FISHEYE, W, H, fisheye=True),
        ibvs.CameraModel.from_opencv(K, None, W, H),
    ],
    ids=["barrel", "pincushion", "fisheye", "none"],
)
def test_round_trip_over_the_whole_image(cam):
    px = pixel_grid()
    uv = cam.normalize(px)
    assert np.abs(cam.project(uv) - px).max() < 1e-6  # pixels -> normalised -> pixels
    assert np.abs(cam.normalize(cam.project(uv)) - uv).max() < 1e-9  # and the other way, normalised units


def test_newton_beats_opencv_default_undistortion():
    """cv2.undistortPoints' default fixed-point passes leave pixels of error at k1 = -0.28; ours do not."""
    cam = ibvs.CameraModel.from_opencv(K, PLUMB_BOB, W, H)
    px = pixel_grid(16)
    ours = np.abs(cam.project(cam.normalize(px)) - px).max()
    theirs = cv2.undistortPoints(px.reshape(-1, 1, 2), K, PLUMB_BOB)
    opencv = np.abs(cam.project(theirs) - px).max()
    assert ours < 1e-6 < opencv  # OpenCV's own default is far coarser (about 1e-2 px here)
    # Where OpenCV's iteration is run to convergence, both agree.
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-14)
    if hasattr(cv2, "undistortPointsIter"):  # OpenCV 4
        tight = cv2.undistortPointsIter(px.reshape(-1, 1, 2), K, PLUMB_BOB, None, None, crit)
    else:  # OpenCV 5: a criteria argument
        tight = cv2.undistortPoints(px.reshape(-1, 1, 2), K, PLUMB_BOB, criteria=crit)
    assert np.abs(cam.normalize(px) - tight[:, 0]).max() < 1e-8


def test_visp_formulas():
    cam = ibvs.CameraModel.afma6()
    assert cam.distortion == "visp" and cam.coefficients == (-0.2114, 0.2217)
    assert (cam.px, cam.py, cam.u0, cam.v0, cam.fps) == (1090.6, 1090.0, 310.1, 260.8, 60.0)
    assert cam.bounds == (0.0, 640.0, 0.0, 480.0) and (cam.width, cam.height) == (640.0, 480.0)
    x, y = 0.2, -0.1
    k = 1 - 0.2114 * (x * x + y * y)
    assert np.array_equal(cam.project([x, y]), [310.1 + 1090.6 * x * k, 260.8 + 1090.0 * y * k])
    u, v = 600.0, 20.0
    xu, yu = (u - 310.1) / 1090.6, (v - 260.8) / 1090.0
    kd = 1 + 0.2217 * (xu * xu + yu * yu)
    assert np.array_equal(cam.normalize([u, v]), [xu * kd, yu * kd])
    # separate calibrations: close (under a pixel over the sensor), not exact
    px = pixel_grid(40)
    err = np.abs(cam.project(cam.normalize(px)) - px).max()
    assert 1e-3 < err < 1.0
    # the projection is exactly OpenCV's plumb_bob with k1 = kud: the renderer's equivalent
    Kc, dist = cam.to_opencv()
    uv, P = rays(500, np.radians(15))
    ref, _ = cv2.projectPoints(P, np.zeros(3), np.zeros(3), Kc, dist)
    assert np.abs(cam.project(uv) - ref[:, 0]).max() < 1e-6
    assert ibvs.CameraModel.from_visp(1090.6, 1090.0, 310.1, 260.8, -0.2114, 0.2217, 640, 480) == cam
    assert ibvs.CameraModel(1090.6, 1090.0, 310.1, 260.8, -0.2114, 0.2217) == cam


def test_simulator_camera_is_the_camera_model():
    from ibvs import sim

    assert sim.Camera is ibvs.CameraModel
    assert sim.cases.gantry_general_motion().camera == ibvs.CameraModel.afma6()
    n = sim.Camera.normalized(0.3)
    assert n.bounds == (-0.3, 0.3, -0.3, 0.3) and n.distortion == "none" and n.coefficients == ()
    xy = np.array([[0.1, -0.2], [0.0, 0.25]])
    assert np.array_equal(n.project(xy), xy) and np.array_equal(n.normalize(xy), xy)
    assert "CameraModel(" in repr(n) and "visp" in repr(ibvs.CameraModel.afma6())


def test_simulator_ends_a_point_beyond_the_fold_as_left_image():
    """A point past the radius where the distortion folds lands back inside the image under the bare
    formula (cv2.projectPoints puts it near the centre): the simulator ends the episode as left_image
    for that point instead of servoing on a folded image."""
    from ibvs import sim

    cam = ibvs.CameraModel.from_opencv([[300, 0, 320], [0, 300, 240], [0, 0, 1]], [-0.5, 0, 0, 0], W, H)
    assert cam.max_radius == pytest.approx(1 / math.sqrt(1.5))
    # point 3 at x/z = 1.5, past the fold
    points = np.array([[0.1, 0.1, 2.0], [-0.1, 0.1, 2.0], [-0.1, -0.1, 2.0], [3.0, 0.0, 2.0]])
    folded, _ = cv2.projectPoints(points[3:], np.zeros(3), np.zeros(3), cam.K, np.array([-0.5, 0, 0, 0]))
    assert cam.contains(folded[0, 0])  # the bare formula would call it visible
    target = sim.Target(points)
    servo = ibvs.Servo(ibvs.Layout.cartesian(4), gain=1.0)
    r = sim.run(servo, cam, target, np.eye(4), sim.pose(t=(0, 0, -20)))
    assert (r.status.outcome, r.status.frame, r.status.point) == ("left_image", 0, 3)
    assert np.isfinite(r.history.twist).all()  # nothing non-finite reached the servo or the history


def radial_derivative(cam, r):
    """d rd / dr of the model's radial map at normalised radius r (by central differences of project)."""
    h = 1e-7 * max(r, 1.0)
    p = cam.project(np.array([[r + h, 0.0], [r - h, 0.0]]), invalid="nan")
    return (p[0, 0] - p[1, 0]) / (2 * h * cam.px)


@pytest.mark.parametrize(
    "cam, expected",
    [
        (ibvs.CameraModel.afma6(), 1 / math.sqrt(3 * 0.2114)),  # 1 + 3 kud r^2 = 0
        (ibvs.CameraModel.from_opencv(K, [-0.3, 0.0, 0.0, 0.0], W, H), 1 / math.sqrt(0.9)),
        (ibvs.CameraModel.from_opencv(K, [-0.4, 0.05, 0.0, 0.0], W, H),
         math.sqrt((1.2 - math.sqrt(0.44)) / 0.5)),  # 1 - 1.2 s + 0.25 s^2 = 0
        (ibvs.CameraModel.from_opencv(K_FISHEYE, [-0.3, 0.0, 0.0, 0.0], W, H, fisheye=True),
         math.tan(1 / math.sqrt(0.9))),
    ],
    ids=["visp", "k1", "plumb_bob", "fisheye"],
)
def test_max_radius_is_where_the_distortion_folds(cam, expected):
    r = cam.max_radius
    assert math.isfinite(r)
    if expected is not None:
        assert r == pytest.approx(expected, rel=1e-12)
    # increasing just inside, turning around at r: the derivative vanishes there
    assert radial_derivative(cam, 0.999 * r) > 0
    assert abs(radial_derivative(cam, 0.999999 * r)) < 1e-3
    with pytest.raises(ValueError, match=r"uv\[1\].*one-to-one.*radius"):
        cam.project(np.array([[0.0, 0.0], [1.0001 * r, 0.0]]))
    assert np.isnan(cam.project([[1.0001 * r, 0.0]], invalid="nan")).all()
    # a pixel beyond the image of max_radius has no inverse
    beyond = cam.project([0.99999 * r, 0.0])
    far = [2 * beyond[0] - cam.u0 + 1e3, cam.v0]
    if cam.distortion == "visp":  # normalize applies kdu (> 0 here): defined everywhere
        assert np.isfinite(cam.normalize(far)).all()
    else:
        with pytest.raises(ValueError, match=r"pixels = .*no inverse"):
            cam.normalize(far)
    if cam.distortion != "visp":
        assert cam.normalize(cam.project([0.9 * r, 0.0])) == pytest.approx([0.9 * r, 0.0], abs=1e-12)


def test_tangential_terms_fold_earlier():
    """With p1, p2 the fold moves off the radial one: inside max_radius, points past the sheet where the
    map's Jacobian determinant vanishes are refused both ways, and everything accepted round-trips."""
    cam = ibvs.CameraModel.from_opencv(K, [-0.4, 0.05, 0.0, -0.01], W, H)
    r = cam.max_radius
    # along +x the p2 term (6 p2 x in d xd / dx) turns the map around before the radial fold
    x = np.linspace(0.9 * r, 0.99999 * r, 2000)
    uv = np.stack([x, np.zeros_like(x)], -1)
    px = cam.project(uv, invalid="nan")
    ok = np.isfinite(px[:, 0])
    assert ok[0] and not ok[-1]
    assert np.all(np.diff(px[ok, 0]) > 0)  # strictly increasing where accepted: one-to-one
    back = cam.normalize(px[ok])
    assert np.abs(back - uv[ok]).max() < 1e-9


def test_no_fold_means_infinite_radius():
    assert ibvs.CameraModel.from_opencv(K, [0.1, 0.01, 0, 0, 0.001], W, H).max_radius == math.inf
    assert ibvs.CameraModel.normalized().max_radius == math.inf
    fe = ibvs.CameraModel.from_opencv(K_FISHEYE, [0.01, 0, 0, 0], W, H, fisheye=True)
    assert fe.max_radius == math.inf  # the whole half-space in front of the camera


def test_shapes():
    cam = ibvs.CameraModel.from_opencv(K, PLUMB_BOB, W, H)
    px = pixel_grid(80)
    uv = cam.normalize(px)
    assert uv.shape == px.shape
    assert np.array_equal(cam.normalize(px[:, None, :]), uv[:, None, :])  # OpenCV's (N, 1, 2)
    assert np.array_equal(cam.normalize(px[3]), uv[3])  # one point (2,)
    assert np.array_equal(cam.project(uv[:, None, :])[:, 0], cam.project(uv))
    assert cam.project(np.zeros((0, 2))).shape == (0, 2)
    assert cam.contains(px).all() and not cam.contains([-1.0, 5.0]) and cam.contains([0.0, 480.0])
    assert isinstance(cam.contains([1.0, 1.0]), bool)


def test_bad_input():
    cam = ibvs.CameraModel.from_opencv(K, PLUMB_BOB, W, H)
    with pytest.raises(ValueError, match=r"uv must have shape"):
        cam.project(np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"pixels must have shape"):
        cam.normalize(np.zeros((2, 2, 2)))
    with pytest.raises(TypeError, match="pixels"):
        cam.normalize("a")
    with pytest.raises(ValueError, match=r"pixels\[1\] is not finite"):
        cam.normalize([[1.0, 2.0], [np.nan, 2.0]])
    with pytest.raises(ValueError, match=r"invalid must be"):
        cam.project([0.0, 0.0], invalid="skip")
    with pytest.raises(ValueError, match="K must have shape"):
        ibvs.CameraModel.from_opencv(np.eye(2), PLUMB_BOB, W, H)
    skewed = K.copy()
    skewed[0, 1] = 0.5
    with pytest.raises(ValueError, match="skew"):
        ibvs.CameraModel.from_opencv(skewed, PLUMB_BOB, W, H)
    with pytest.raises(ValueError, match="dist"):
        ibvs.CameraModel.from_opencv(K, [0.1, 0.2, 0.3], W, H)
    with pytest.raises(ValueError, match=r"dist\[5\]"):
        ibvs.CameraModel.from_opencv(K, [0.1, 0.2, 0, 0, 0, 0.3, 0, 0], W, H)  # rational k4
    with pytest.raises(ValueError, match="fisheye"):
        ibvs.CameraModel.from_opencv(K, PLUMB_BOB, W, H, fisheye=True)
    with pytest.raises(ValueError, match="width"):
        ibvs.CameraModel.from_opencv(K, PLUMB_BOB, 0, H)
    with pytest.raises(ValueError, match="fx"):
        ibvs.CameraModel.from_opencv(np.diag([-1.0, 1.0, 1.0]), None, W, H)
    with pytest.raises(ValueError, match="dist must be finite"):
        ibvs.CameraModel.from_opencv(K, [np.nan, 0, 0, 0], W, H)
    with pytest.raises(ValueError, match="kud"):
        ibvs.CameraModel.from_visp(1000, 1000, 320, 240, math.inf, 0, W, H)
    with pytest.raises(ValueError, match="bounds"):
        ibvs.CameraModel.normalized(-1)
    with pytest.raises(ValueError, match="fps"):
        ibvs.CameraModel(1000, 1000, 320, 240, fps=0)


@pytest.mark.parametrize(
    "make, exc, name",
    [
        (lambda: ibvs.CameraModel.from_opencv(np.diag([1e-300, 1e-300, 1.0]), None, W, H), ValueError, "fx"),
        (lambda: ibvs.CameraModel.from_opencv(np.diag([1e300, 600, 1.0]), None, W, H), ValueError, "fx"),
        (lambda: ibvs.CameraModel(1000, 1e-300, 320, 240), ValueError, "fy"),
        (lambda: ibvs.CameraModel(1000, 1000, 1e300, 240), ValueError, "cx"),
        (lambda: ibvs.CameraModel.from_opencv(K, [1e300, 0, 0, 0, 0], W, H), ValueError, r"dist\[0\]"),
        (lambda: ibvs.CameraModel(1000, 1000, 320, 240, kud=2e4), ValueError, "kud"),
        (lambda: ibvs.CameraModel.normalized(1e8), ValueError, "bounds"),
        (lambda: ibvs.CameraModel.from_opencv(K, PLUMB_BOB, 2**40, H), ValueError, "width"),
        (lambda: ibvs.CameraModel.from_opencv(K, PLUMB_BOB, W, H, fps=1e12), ValueError, "fps"),
        (lambda: ibvs.CameraModel.from_opencv(K, PLUMB_BOB, True, H), TypeError, "width"),
        (lambda: ibvs.CameraModel.from_opencv(K, PLUMB_BOB, W, H, fisheye="no"), TypeError, "fisheye"),
        (lambda: ibvs.CameraModel.from_opencv(K, PLUMB_BOB, W, H, fisheye=0), TypeError, "fisheye"),
        (lambda: ibvs.CameraModel(1000, 1000, 320, 240, width=1 + 2j), TypeError, "width"),
        (lambda: ibvs.CameraModel(1000, 1000, 320, 240, fps="60"), TypeError, "fps"),
        (lambda: ibvs.CameraModel.normalized(True), TypeError, "bounds"),
    ],
)
def test_scale_limits_and_types_refused_by_name(make, exc, name):
    """Finite but absurd parameters (ibvs/limits.hpp: focal lengths in [1e-3, 1e7] px, principal point and
    image within 1e7 px, coefficients within 1e4, fps up to 1e6) and non-real or non-bool arguments are
    refused, naming the argument, instead of giving a camera whose normalize() overflows."""
    with pytest.raises(exc, match=name):
        make()


def test_to_opencv_round_trip():
    for cam in (
        ibvs.CameraModel.from_opencv(K, PLUMB_BOB, W, H),
        ibvs.CameraModel.from_opencv(K_FISHEYE, FISHEYE, W, H, fisheye=True),
        ibvs.CameraModel.from_opencv(K, None, W, H),
    ):
        Kc, dist = cam.to_opencv()
        assert np.array_equal(Kc, cam.K)
        assert ibvs.CameraModel.from_opencv(Kc, dist, W, H, fisheye=cam.distortion == "equidistant") == cam


def test_pickles():
    import pickle

    for cam in (
        ibvs.CameraModel.from_opencv(K, PLUMB_BOB, W, H, fps=30),
        ibvs.CameraModel.from_opencv(K_FISHEYE, FISHEYE, W, H, fisheye=True),
        ibvs.CameraModel.afma6(),
        ibvs.CameraModel.normalized(0.25),
    ):
        back = pickle.loads(pickle.dumps(cam))
        assert back == cam and back.max_radius == cam.max_radius and repr(back) == repr(cam)


# --- calibration files -------------------------------------------------------------------------

ROS_YAML = """\
image_width: 640
image_height: 480
camera_name: narrow_stereo
camera_matrix:
  rows: 3
  cols: 3
  data: [600.5, 0.0, 320.25, 0.0, 601.0, 240.75, 0.0, 0.0, 1.0]
distortion_model: {model}
distortion_coefficients:
  rows: 1
  cols: {n}
  data: [{coefficients}]
rectification_matrix:
  rows: 3
  cols: 3
  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]
projection_matrix:
  rows: 3
  cols: 4
  data: [600, 0, 320, 0, 0, 600, 240, 0, 0, 0, 1, 0]
"""


def ros_file(tmp_path, model="plumb_bob", coefficients=PLUMB_BOB, name="camera.yaml"):
    path = tmp_path / name
    values = ", ".join(repr(float(c)) for c in coefficients)
    path.write_text(ROS_YAML.format(model=model, n=len(coefficients), coefficients=values))
    return path


def test_from_ros_camera_info(tmp_path):
    cam = ibvs.CameraModel.from_yaml(ros_file(tmp_path), fps=60)
    assert cam == ibvs.CameraModel.from_opencv(K, PLUMB_BOB, W, H)
    fe = ibvs.CameraModel.from_yaml(str(ros_file(tmp_path, "equidistant", FISHEYE)), fps=30.0)
    assert fe.distortion == "equidistant" and fe.coefficients == tuple(FISHEYE) and fe.fps == 30.0
    rational = ibvs.CameraModel.from_yaml(ros_file(tmp_path, "rational_polynomial", [*PLUMB_BOB, 0, 0, 0]), fps=60)
    assert rational == cam


def test_from_yaml_says_which_frame_rate_it_uses(tmp_path):
    """The fps given, else the file's fps or frame_rate, else 60 with a warning naming the file (never silently)."""
    path = ros_file(tmp_path)
    with pytest.warns(UserWarning, match=r"states no frame rate .* runs at 60 fps \(pass fps=") as caught:
        assert ibvs.CameraModel.from_yaml(path).fps == 60.0
    assert len(caught) == 1 and str(path) in str(caught[0].message)
    assert caught[0].filename == __file__  # attributed to the caller of from_yaml
    for key, value in (("fps", "30"), ("frame_rate", "25.5")):
        path.write_text(ROS_YAML.format(model="plumb_bob", n=5, coefficients=", ".join(map(str, PLUMB_BOB)))
                        + f"{key}: {value}\n")
        assert ibvs.CameraModel.from_yaml(path).fps == float(value)  # no warning: the file says it
        assert ibvs.CameraModel.from_yaml(path, fps=90).fps == 90.0  # the argument wins
    for bad in ("0", "-30", "fast", ".nan"):
        path.write_text(ROS_YAML.format(model="plumb_bob", n=5, coefficients=", ".join(map(str, PLUMB_BOB)))
                        + f"fps: {bad}\n")
        with pytest.raises(ValueError, match="'fps' must be a frame rate > 0"):
            ibvs.CameraModel.from_yaml(path)
    with pytest.raises(TypeError, match="fps"):
        ibvs.CameraModel.from_yaml(path, fps="30")
    with pytest.raises(ValueError, match="fps"):
        ibvs.CameraModel.from_yaml(path, fps=-1.0)


@pytest.mark.parametrize("ext", ["yaml", "xml", "json"])
def test_from_opencv_file_storage(tmp_path, ext):
    """Files as OpenCV's calibration sample writes them (cv2.FileStorage, !!opencv-matrix)."""
    path = str(tmp_path / f"calib.{ext}")
    for fisheye, dist in ((0, PLUMB_BOB.reshape(1, 5)), (1, FISHEYE.reshape(4, 1))):
        fs = cv2.FileStorage(path, cv2.FILE_STORAGE_WRITE)
        fs.write("image_width", W)
        fs.write("image_height", H)
        fs.write("fisheye_model", fisheye)
        fs.write("camera_matrix", K)
        fs.write("distortion_coefficients", dist)
        fs.write("fps", 30)
        fs.release()
        cam = ibvs.CameraModel.from_yaml(path)
        assert cam == ibvs.CameraModel.from_opencv(K, dist, W, H, fisheye=bool(fisheye), fps=30)


def test_calibration_file_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="path"):
        ibvs.CameraModel.from_yaml(tmp_path / "missing.yaml")
    with pytest.raises(TypeError, match="path"):
        ibvs.CameraModel.from_yaml(3)
    with pytest.raises(ValueError, match="distortion_model 'kannala'"):
        ibvs.CameraModel.from_yaml(ros_file(tmp_path, "kannala", FISHEYE))
    no_width = tmp_path / "no_width.yaml"
    no_width.write_text(ros_file(tmp_path).read_text().replace("image_width: 640\n", ""))
    with pytest.raises(ValueError, match="image_width"):
        ibvs.CameraModel.from_yaml(no_width)
    no_k = tmp_path / "no_k.yaml"
    no_k.write_text("image_width: 640\nimage_height: 480\n")
    with pytest.raises(ValueError, match="camera_matrix"):
        ibvs.CameraModel.from_yaml(no_k)
    broken = tmp_path / "broken.yaml"
    broken.write_text("camera_matrix: [1, 2\n  rows: ]]\n")
    with pytest.raises(ValueError, match="path"):
        ibvs.CameraModel.from_yaml(broken)


def test_from_yaml_without_opencv_names_the_extra(tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "cv2", None)
    with pytest.raises(ImportError, match=r'pip install "\.\[vision\]" from the ibvs repository root'):
        ibvs.CameraModel.from_yaml(ros_file(tmp_path))


# --- properties --------------------------------------------------------------------------------

coefficient = st.floats(-0.5, 0.5, allow_nan=False)


@st.composite
def models(draw):
    f = draw(st.floats(200, 2000))
    cx, cy, aspect = draw(st.floats(200, 440)), draw(st.floats(150, 330)), draw(st.floats(0.9, 1.1))
    Kr = np.array([[f, 0, cx], [0, f * aspect, cy], [0, 0, 1]])
    kind = draw(st.sampled_from(["plumb_bob", "equidistant", "visp"]))
    if kind == "plumb_bob":
        d = [draw(coefficient), draw(coefficient), draw(st.floats(-2e-3, 2e-3)), draw(st.floats(-2e-3, 2e-3)),
             draw(coefficient)]
        return ibvs.CameraModel.from_opencv(Kr, d, W, H)
    if kind == "equidistant":
        d = [draw(st.floats(-0.1, 0.1)) for _ in range(4)]
        return ibvs.CameraModel.from_opencv(Kr, d, W, H, fisheye=True)
    return ibvs.CameraModel.from_visp(f, f * aspect, cx, cy, draw(coefficient), draw(coefficient), W, H)


finite = st.floats(-1e6, 1e6, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(models(), finite, finite)
def test_finite_or_refused(cam, a, b):
    """Any finite point is mapped to finite numbers or refused with a ValueError, both ways."""
    for f in (cam.project, cam.normalize):
        try:
            out = f([a, b])
        except ValueError as e:
            assert "one-to-one" in str(e) or "no inverse" in str(e)
        else:
            assert np.isfinite(out).all()


@settings(max_examples=300, deadline=None)
@given(models(), st.floats(0, 1), st.floats(-np.pi, np.pi))
def test_round_trip_inside_the_domain(cam, fraction, angle):
    """Inside max_radius (and 60 degrees), project then normalize returns the point (to 1e-6 px)."""
    r = fraction * min(0.9 * cam.max_radius, math.tan(math.radians(60)))
    uv = r * np.array([math.cos(angle), math.sin(angle)])
    px = cam.project(uv)
    if cam.distortion == "visp":  # kud and kdu are separate calibrations: the trip is approximate by design
        return
    back = cam.normalize(px)
    assert np.abs(cam.project(back) - px).max() < 1e-6
