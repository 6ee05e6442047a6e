"""The renderer and the image in the loop with a wide lens (ibvs.vision.rays): a fisheye and Mei's
omnidirectional model drawn through each pixel's bearing, over their whole field of view (beyond 90
degrees off the axis); the image circle; the simulator's left_image with the lens's image circle; and
sim.run servoing spherical features from rendered fisheye and omnidirectional images with the dot
tracker, from a start where the target is more than 90 degrees off the axis.

What a rendered dot's centroid is compared with (as in test_vision.py): the area centroid of the dot's
image (its rim mapped through the lens by CameraModel.from_bearing, the shoelace formula), and, more
loosely, the pixel of its centre (from_bearing of the true 3-D centre): they differ by the perspective
and the lens's distortion of a finite disc, which grow far off the axis."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

cv2 = pytest.importorskip("cv2")

import ibvs
from ibvs import sim, vision

DEG = math.pi / 180


def fisheye():
    """A 640x480 equidistant fisheye, f = 140 px: 208 degrees across the sensor's height; its image
    circle (180 degrees off the axis, 353 px from the centre) cuts the sensor's corners."""
    K = np.array([[140.0, 0, 319.5], [0, 140.0, 239.5], [0, 0, 1]])
    return ibvs.CameraModel.from_opencv(K, [-0.02, 0.0, 0.0, 0.0], 640, 480, fisheye=True)


def omnidir():
    """A 640x480 Mei camera, xi = 1.6: its image circle (128.7 degrees off the axis, the fold) inside the
    sensor."""
    K = np.array([[250.0, 0, 319.5], [0, 250.0, 239.5], [0, 0, 1]])
    return ibvs.CameraModel.from_omnidir(K, 1.6, [-0.03, 0.005, 1e-4, -1e-4], 640, 480)


CAMERAS = {"fisheye": fisheye, "omnidir": omnidir}


def unit(angle, azimuth):
    s = math.sin(angle)
    return np.array([s * math.cos(azimuth), s * math.sin(azimuth), math.cos(angle)])


def facing(angle, azimuth, distance, tilt=(0.0, 0.0, 0.0)):
    """World <- target (the camera at the world origin): the target's centre `angle` off the optical
    axis at `distance`, its plate facing the camera (its z axis along the line of sight), then turned
    by tilt (rx, ry, rz) about its own axes."""
    z = unit(angle, azimuth)
    x = np.cross([0.3, 1.0, 0.1], z)
    x /= np.linalg.norm(x)
    T = np.eye(4)
    T[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    T[:3, 3] = distance * z
    return T @ sim.pose(r=tilt)


def dot_image_centroid(camera, T_ct, center, radius, n=4000):
    """Area centroid (pixels) of the image of the disc (center (x, y) in the target plane, radius m)."""
    phi = np.linspace(0, 2 * np.pi, n, endpoint=False)
    x, y = center[0] + radius * np.cos(phi), center[1] + radius * np.sin(phi)
    rim = np.column_stack([x, y, np.zeros(n), np.ones(n)])
    px = camera.from_bearing((T_ct @ rim.T)[:3].T)
    x, y = px[:, 0], px[:, 1]
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    cross = x * y1 - x1 * y
    area = cross.sum() / 2
    return np.array([((x + x1) * cross).sum(), ((y + y1) * cross).sum()]) / (6 * area)


# (angle off the axis, azimuth, tilt) of the target's centre: on the axis, 60 degrees, beyond 90 degrees
POSES = [
    (0.0, 0.0, (0.0, 0.0, 0.3)),
    (60 * DEG, 2.0, (0.4, -0.3, 0.0)),
    (95 * DEG, 0.6, (0.0, 0.0, 1.0)),
    (105 * DEG, -2.6, (-0.3, 0.3, 0.0)),
    (115 * DEG, 2.8, (0.0, 0.0, 0.0)),
]
# per camera: the target's side and distance (its dots' radius is a tenth of the side: 5 to 6 px on
# the axis; smaller dots have centroids a few hundredths of a pixel off), the widest start
SCENE = {"fisheye": (0.1, 0.25, 115 * DEG), "omnidir": (0.2, 0.4, 95 * DEG)}


@pytest.mark.parametrize("name", ["fisheye", "omnidir"])
def test_rendered_dots_are_at_their_images_beyond_90_degrees(name):
    camera = CAMERAS[name]()
    worst_area, worst_centre, widest = 0.0, 0.0, 0.0
    side, dist, widest_start = SCENE[name]
    for angle, az, tilt in POSES:
        if angle > widest_start:
            continue
        target = sim.Target.square(side, facing(angle, az, dist, tilt))
        r = vision.Renderer(camera, target, "dots")
        assert r.wide
        img = r.render(np.eye(4))
        P = np.asarray(target.world_points())
        proj = camera.from_bearing(P)
        tracker = vision.DotTracker(4, r.size, mask=r.mask)
        tracker.reset(proj)
        track = tracker.track(img)
        assert track.status == ("tracked",) * 4, (name, angle, track.status)
        T_ct = np.asarray(target.pose)
        for i, c in enumerate(np.asarray(target.points)[:, :2]):
            truth = dot_image_centroid(camera, T_ct, c, r.dot_radius)
            worst_area = max(worst_area, np.abs(track.pixels[i] - truth).max())
            worst_centre = max(worst_centre, np.abs(track.pixels[i] - proj[i]).max())
            widest = max(widest, math.acos(P[i, 2] / np.linalg.norm(P[i])))
    assert widest > 100 * DEG  # dots well behind the image plane were drawn and found
    # measured: 0.048 px (fisheye) and 0.039 px (omnidir) from the dots' image centroids, 0.19 px from
    # the pixels of their centres
    assert worst_area < 0.06, worst_area  # the rendered centroid is the dot image's centroid
    assert worst_centre < 0.25, worst_centre  # and a quarter of a pixel from from_bearing of its centre


@pytest.mark.parametrize("name", ["fisheye", "omnidir"])
def test_image_circle_is_black_and_is_the_models_domain(name):
    camera = CAMERAS[name]()
    target = sim.Target.square(0.1, facing(0.0, 0.0, 0.4))
    r = vision.Renderer(camera, target, "dots", noise=3.0)
    img = r.render(np.eye(4))
    W, H = r.size
    uu, vv = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    b = camera.to_bearing(np.column_stack([uu.ravel(), vv.ravel()]), invalid="nan")
    inside = np.isfinite(b[:, 0]).reshape(H, W)
    assert r.mask is not None and np.array_equal(r.mask > 0, inside)
    assert not inside.all() and inside.mean() > 0.3
    assert (img[~inside] == 0).all()  # no light outside the circle
    assert img[inside].mean() > 5  # the background with its noise inside
    # The simulator's rule (from_bearing inside the circle and on the sensor) and the renderer's mask
    # agree: every direction in the image has a pixel the renderer draws (to_bearing maps it), and every
    # pixel the renderer draws sees a direction the simulator calls in the image.
    rng = np.random.default_rng(3)
    d = rng.normal(size=(4000, 3))
    px = camera.from_bearing(d, invalid="nan")
    ok = np.isfinite(px[:, 0])
    seen = ok & np.all((px >= 0) & (px <= [W, H]), axis=1, where=ok[:, None])
    assert seen.sum() > 1000 and np.isfinite(camera.to_bearing(px[seen], invalid="nan")).all()
    back = camera.from_bearing(b[inside.ravel()], invalid="nan")  # the pixel centres (on the sensor) again
    grid = np.column_stack([uu.ravel(), vv.ravel()])[inside.ravel()]
    assert np.abs(back - grid).max() < 1e-9


def test_perspective_models_keep_the_pinhole_path():
    r = vision.Renderer(ibvs.CameraModel.afma6(), sim.Target.square(0.1, sim.pose(t=(0, 0, 0.5))), "dots")
    assert not r.wide and r.mask is None


def test_tag_through_the_fisheye():
    camera = fisheye()
    target = sim.Target.square(0.12, facing(30 * DEG, 0.5, 0.35, (0.2, 0.0, 0.0)))
    r = vision.Renderer(camera, target, "tag")
    img = r.render(np.eye(4))
    det = vision.TagDetector((0,), image_size=r.size).detect(img)
    proj = camera.from_bearing(np.asarray(target.world_points()))
    assert det.status == ("detected",) * 4
    # the detector fits straight edges to the fisheye's curved ones: its corners are close, not exact
    assert np.abs(det.pixels - proj).max() < 3.0


def test_motion_blur_and_defocus_through_the_fisheye():
    camera = fisheye()
    target = sim.Target.square(0.1, facing(100 * DEG, 0.4, 0.4))
    sharp = vision.Renderer(camera, target, "dots").render(np.eye(4))
    moving = vision.Renderer(camera, target, "dots", exposure=0.02, blur=1.0)
    img = moving.render(np.eye(4), twist=[0.0, 0.0, 0.0, 0.0, 3.0, 0.0])
    assert img.shape == sharp.shape and img.dtype == np.uint8
    assert (img > 100).sum() > 0 and (img > 100).sum() != (sharp > 100).sum()
    assert (img[moving.mask == 0] == 0).all()


def circular_fisheye(half):
    """A 1280x1024 equidistant lens whose image circle is `half` off the axis (its polynomial
    theta (1 + k1 theta^2) folds there: k1 = -1 / (3 half^2)), the circle inside the sensor."""
    K = np.array([[400.0, 0, 640], [0, 400.0, 512], [0, 0, 1]])
    return ibvs.CameraModel.from_opencv(K, [-1 / (3 * half**2), 0, 0, 0], 1280, 1024, fisheye=True)


def spherical_servo(kind=ibvs.SphericalPolarFeature, n=4):
    task = ibvs.Task()
    for _ in range(n):
        task.add(kind())
    return ibvs.Servo(task, gain=1.0)


def spherical_target(side, pose):
    t = sim.Target.square(side, pose)
    return t.with_features([sim.SphericalSource(i) for i in range(len(t))])


@pytest.mark.parametrize("half, seen", [(100 * DEG, True), (75 * DEG, False)])
def test_left_image_is_the_lens_image_circle(half, seen):
    """A target 91.5 to 99.5 degrees off the axis (behind the image plane: z < 0) is in the image of a
    200-degree lens and has left that of a 150-degree one (left_image at frame 0, not behind_camera)."""
    camera = circular_fisheye(half)
    assert camera.field_of_view == pytest.approx(2 * half)
    target = spherical_target(0.1, sim.pose(t=(0, 0, 1.0)))
    start = sim.pose(r=(0, 95.5 * DEG, 0))
    P = (np.linalg.inv(start) @ np.column_stack([target.world_points(), np.ones(4)]).T)[:3]
    angles = np.arccos(P[2] / np.linalg.norm(P, axis=0))
    assert (P[2] < 0).all() and angles.max() < 99.5 * DEG
    r = sim.run(spherical_servo(), camera, target, start, np.eye(4), duration=1 / 60)  # one frame
    if seen:
        assert (r.status.outcome, r.status.frame) == ("timeout", 0)
        b = r.history.measurements[0].reshape(4, 4)[:, :3]
        assert np.abs(b - (P / np.linalg.norm(P, axis=0)).T).max() < 1e-9  # the pixels' bearings
    else:
        assert (r.status.outcome, r.status.frame, r.status.point) == ("left_image", 0, 0)


def test_spherical_source_errors():
    with pytest.raises(ValueError, match="i"):
        sim.SphericalSource(-1)
    target = sim.Target.square(0.1, sim.pose(t=(0, 0, 1.0)))
    with pytest.raises(ValueError, match="not a target point"):
        target.with_features([sim.SphericalSource(4)])
    with pytest.raises(ValueError, match="cannot measure"):
        lines = target.with_features([sim.LineSource(0, 1)])
        sim.run(spherical_servo(n=1), fisheye(), lines, np.eye(4), np.eye(4))
    assert repr(sim.SphericalSource(2)) == "SphericalSource(2)" and sim.SphericalSource(2).i == 2


# The docs' 100-degree start (docs/wide.md): a 0.5 m square 1 m ahead of the goal camera, the camera
# turned 107 degrees away about its y axis (and moved): the target's centre 100.6 degrees off its axis.
START_100 = ibvs.se3_exp([0.05, -0.04, -0.2, 0.0, 107 * DEG, 0.3])


@pytest.mark.parametrize("name", ["fisheye", "omnidir"])
def test_image_in_the_loop_servoes_from_beyond_90_degrees(name):
    camera = CAMERAS[name]()
    target = spherical_target(0.5, sim.pose(t=(0, 0, 1.0)))
    c = np.linalg.inv(START_100) @ [0, 0, 1.0, 1]
    assert math.acos(c[2] / np.linalg.norm(c[:3])) > 100 * DEG  # no perspective camera sees it
    sensor = vision.ImageSensor.for_target(camera, target, "dots")
    assert sensor.detector._blind is not None  # the tracker knows the image circle
    r = sim.run(spherical_servo(), camera, target, START_100, np.eye(4), duration=40, vision=sensor,
                tolerance_px=0.05)
    assert r.status.outcome == "converged", r.status
    # every tracked dot within 0.05 px of where the tracker found it at the goal: the camera within
    # 5.0 mm and 0.18 deg of the goal (measured; a dot's centroid is not the pixel of its centre, and
    # the two differ by a little more at the end than at the goal)
    assert r.metrics.final_translation_error < 0.01 and r.metrics.final_rotation_error < 0.5 * DEG
    # the first frame's bearings: the tracked dots, beyond 90 degrees off the axis
    b0 = r.history.measurements[0].reshape(4, 4)[:, :3]
    assert (b0[:, 2] < 0).any()
    # the tracker's pixels over the run are the centroids of the dots' images (measured over every other
    # frame: within 0.09 px with the fisheye, 0.17 px with Mei's camera, whose dots 100 degrees off the
    # axis are 5 px across radially), which are up to 2.5 px from the pixels of the dots' centres when the
    # camera passes close to the 5 cm dots
    drift = np.abs(r.history.measured - r.history.projected).max(axis=(1, 2))
    points = np.asarray(target.points)
    worst = 0.0
    for k in sorted({0, int(np.argmax(drift)), *range(0, r.history.measured.shape[0], 10)}):
        T_ct = np.linalg.inv(r.history.pose[k]) @ np.asarray(target.pose)
        for i in range(4):
            truth = dot_image_centroid(camera, T_ct, points[i, :2], sensor.renderer.dot_radius)
            worst = max(worst, np.abs(r.history.measured[k, i] - truth).max())
    assert worst < 0.25, worst


_FISH_SMALL = ibvs.CameraModel.from_opencv(
    np.array([[18.0, 0, 39.5], [0, 18.0, 29.5], [0, 0, 1]]), [-0.02, 0, 0, 0], 80, 60, fisheye=True
)
_WIDE_RENDERERS = {
    k: vision.Renderer(_FISH_SMALL, sim.Target.square(0.1, sim.pose(t=(0, 0, 0.3))), k, noise=1.0, blur=0.5,
                       exposure=0.01)
    for k in vision.KINDS
}


@settings(max_examples=40, deadline=None)
@given(
    kind=st.sampled_from(vision.KINDS),
    t=st.tuples(*[st.floats(-2, 2, allow_nan=False)] * 3),
    r=st.tuples(*[st.floats(-4, 4, allow_nan=False)] * 3),
    twist=st.lists(st.floats(-50, 50), min_size=6, max_size=6),
)
def test_render_any_pose_through_the_fisheye_is_an_image(kind, t, r, twist):
    """Any finite pose (behind the plate, edge-on, around the camera): a uint8 image, black outside the
    image circle."""
    rend = _WIDE_RENDERERS[kind]
    img = rend.render(sim.pose(t=t, r=r), np.array(twist))
    assert img.dtype == np.uint8 and img.shape == (60, 80)
    assert (img[rend.mask == 0] == 0).all()


def test_tracker_mask_errors():
    with pytest.raises(ValueError, match="mask"):
        vision.DotTracker(4, (80, 60), mask=np.ones((80, 60), np.uint8))
    with pytest.raises(ValueError, match="mask"):
        vision.DotTracker(4, (80, 60), mask=np.ones((60, 80)))
    assert vision.DotTracker(4, (80, 60), mask=np.ones((60, 80), bool))._blind is None  # every pixel sees
