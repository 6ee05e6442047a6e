"""Textured planar targets in the renderer (kind "texture") and the procedural texture.

What a rendered textured plate is compared with: the texture's own gray levels at the plate points
imaged at each pixel, i.e. an independent sampling (cv2.remap of the original texture image at the
texture coordinates of each pixel's ray met with the plate, computed here from CameraModel.normalize /
to_bearing and the pose, not through the renderer's pyramid, homography or lens maps). They differ by
the resampling (the renderer's 2048-texel copy of the image, its pyramid level, bilinear twice): a
median of about 1 gray level on the procedural texture, against tens for a one-pixel error of geometry."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

cv2 = pytest.importorskip("cv2")

import ibvs
from ibvs import sim, vision

SIDE = 0.2  # the plate: a 0.2 m square, its corners the target's 4 points


def pinhole(w=320, h=240, f=300.0):
    return ibvs.CameraModel(f, f, (w - 1) / 2, (h - 1) / 2, 0.0, 0.0, float(w), float(h))


def fisheye():
    K = np.array([[110.0, 0, 159.5], [0, 110.0, 119.5], [0, 0, 1]])
    return ibvs.CameraModel.from_opencv(K, [-0.02, 0.0, 0.0, 0.0], 320, 240, fisheye=True)


def omnidir():
    K = np.array([[180.0, 0, 159.5], [0, 180.0, 119.5], [0, 0, 1]])
    return ibvs.CameraModel.from_omnidir(K, 1.2, [-0.03, 0.005, 1e-4, -1e-4], 320, 240)


def afma6_small():
    """The Afma6's radial distortion on a 320x240 sensor (half its focal length and principal point)."""
    c = ibvs.CameraModel.afma6()
    K = np.array([[c.px / 2, 0, c.u0 / 2], [0, c.py / 2, c.v0 / 2], [0, 0, 1]])
    return ibvs.CameraModel.from_opencv(K, [-0.1, 0.05, 0.0, 0.0, 0.0], 320, 240)


CAMERAS = {"pinhole": pinhole, "distorted": afma6_small, "fisheye": fisheye, "omnidir": omnidir}


def expected_image(camera, target, pose_wc, tex):
    """Each pixel's gray level sampled from the texture image itself (float, NaN where the pixel's ray
    misses the plate or the lens does not image): ray -> plate point (x, y) -> texture pixel."""
    w, h = int(camera.bounds[1]), int(camera.bounds[3])
    uu, vv = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    pix = np.column_stack([uu.ravel(), vv.ravel()])
    if camera.distortion in ("equidistant", "omnidir"):
        rays = camera.to_bearing(pix, invalid="nan")
    else:
        rays = np.column_stack([camera.normalize(pix, invalid="nan"), np.ones(len(pix))])
    T = np.linalg.inv(np.asarray(target.pose)) @ pose_wc  # target <- camera
    d = rays @ T[:3, :3].T
    o = T[:3, 3]
    lam = -o[2] / d[:, 2]
    p = o[None, :2] + lam[:, None] * d[:, :2]
    p[~(lam > 0)] = np.nan
    xy = np.asarray(target.points)[:, :2]
    lo, hi = xy.min(0), xy.max(0)
    th, tw = tex.shape
    # texture pixel c is centred on lo + (c + 0.5) (hi - lo) / tw along x
    mx = ((p[:, 0] - lo[0]) / (hi[0] - lo[0]) * tw - 0.5).reshape(h, w).astype(np.float32)
    my = ((p[:, 1] - lo[1]) / (hi[1] - lo[1]) * th - 0.5).reshape(h, w).astype(np.float32)
    inside = (mx > 1) & (mx < tw - 2) & (my > 1) & (my < th - 2)
    mx[~np.isfinite(mx)] = -10
    my[~np.isfinite(my)] = -10
    out = cv2.remap(tex.astype(np.float32), mx, my, cv2.INTER_LINEAR).astype(float)
    out[~inside] = np.nan
    return out


def viewing(distance=0.35, tilt=(0.0, 0.0, 0.0), shift=(0.0, 0.0)):
    """World <- camera: the camera at the world origin is the identity; the target is placed instead."""
    return np.eye(4), sim.Target.square(SIDE, sim.pose(t=(shift[0], shift[1], distance), r=tilt))


@pytest.mark.parametrize("name", list(CAMERAS))
@pytest.mark.parametrize("tilt", [(0.0, 0.0, 0.0), (0.35, -0.25, 0.6)])
def test_textured_plate_is_the_texture_seen_through_the_lens(name, tilt):
    cam = CAMERAS[name]()
    wide = name in ("fisheye", "omnidir")
    # about one texel per pixel or more (the reference samples the texture without prefiltering)
    n = 96 if wide else 256
    tex = vision.texture((n, n), seed=3)
    pose, target = viewing(0.2 if wide else 0.3, tilt)
    img = vision.Renderer(cam, target, "texture", texture=tex).render(pose).astype(float)
    ref = expected_image(cam, target, pose, tex)
    ok = np.isfinite(ref)
    assert ok.sum() > 5000, "the plate fills a good part of the image"
    err = np.abs(img[ok] - ref[ok])
    assert np.median(err) < 2.0 and np.percentile(err, 95) < 8.0, (np.median(err), np.percentile(err, 95))
    # the comparison sees geometry: the same plate one pixel's worth of plate further along x is far off
    moved = viewing(0.2 if wide else 0.3, tilt, (SIDE / n, 0.0))[1]  # one texel along x
    shifted = expected_image(cam, moved, pose, tex)
    both = ok & np.isfinite(shifted)
    assert np.median(np.abs(img[both] - shifted[both])) > 2 * np.median(err)


def test_texture_file_png_and_jpeg_and_colour(tmp_path):
    cam = pinhole()
    pose, target = viewing()
    tex = vision.texture((128, 96), seed=1)
    colour = np.dstack([tex, tex, tex])  # BGR of the same gray
    cv2.imwrite(str(tmp_path / "t.png"), colour)
    cv2.imwrite(str(tmp_path / "t.jpg"), tex, [cv2.IMWRITE_JPEG_QUALITY, 95])
    from_array = vision.Renderer(cam, target, "texture", texture=tex).render(pose)
    from_png = vision.Renderer(cam, target, "texture", texture=tmp_path / "t.png").render(pose)
    from_jpg = vision.Renderer(cam, target, "texture", texture=str(tmp_path / "t.jpg")).render(pose)
    assert np.array_equal(from_array, from_png)
    assert np.abs(from_array.astype(int) - from_jpg).mean() < 2.0
    assert not np.array_equal(from_array, vision.Renderer(cam, target, "texture").render(pose))


def test_procedural_texture_is_seeded_and_rich_in_gradients():
    a, b, c = vision.texture((320, 240), 5), vision.texture((320, 240), 5), vision.texture((320, 240), 6)
    assert a.dtype == np.uint8 and a.shape == (240, 320) and np.array_equal(a, b) and not np.array_equal(a, c)
    assert a.min() >= 20 and a.max() <= 235
    # gradients at several scales: strong at full resolution, at 1/4 and at 1/16 (the image shrunk)
    for shrink in (1, 4, 16):
        s = cv2.resize(a, (320 // shrink, 240 // shrink), interpolation=cv2.INTER_AREA).astype(np.float32)
        g = np.hypot(cv2.Sobel(s, cv2.CV_32F, 1, 0) / 8, cv2.Sobel(s, cv2.CV_32F, 0, 1) / 8)
        assert np.median(g) > 1.0 * shrink**0.5, (shrink, np.median(g))
    # corners for keypoints and KLT everywhere in the picture
    pts = cv2.goodFeaturesToTrack(a, 200, 0.01, 8)
    assert len(pts) >= 100 and np.ptp(pts[:, 0, 0]) > 250 and np.ptp(pts[:, 0, 1]) > 180


def test_lighting_change_and_noise():
    cam = pinhole()
    pose, target = viewing()
    base = vision.Renderer(cam, target, "texture").render(pose).astype(float)
    r = vision.Renderer(cam, target, "texture", gain=1.2, offset=-10.0)
    lit = r.render(pose).astype(float)
    unsat = base * 1.2 - 10 < 254
    assert np.abs(lit[unsat] - (1.2 * base[unsat] - 10)).max() <= 1.0  # both rounded to 8 bits
    r.set_lighting(1.0, 0.0)
    assert np.array_equal(r.render(pose), base.astype(np.uint8))
    noisy = vision.Renderer(cam, target, "texture", noise=4.0, seed=2, gain=0.8)
    d = noisy.render(pose).astype(float) - np.round(0.8 * base)
    assert 3.0 < d.std() < 5.0 and abs(d.mean()) < 0.3
    assert "gain=0.8" in repr(noisy)


def test_texture_bad_input(tmp_path):
    cam = pinhole()
    _, target = viewing()
    with pytest.raises(ValueError, match="texture: no image file"):
        vision.Renderer(cam, target, "texture", texture=tmp_path / "missing.png")
    (tmp_path / "bad.png").write_bytes(b"not an image")
    with pytest.raises(ValueError, match="texture: cv2.imread"):
        vision.Renderer(cam, target, "texture", texture=tmp_path / "bad.png")
    for bad, err in (
        (np.full((8, 8), np.nan), ValueError),
        (np.full((8, 8), 300.0), ValueError),
        (np.zeros((1, 8)), ValueError),
        (np.zeros((4, 4, 2)), ValueError),
        (np.zeros((4, 4), bool), TypeError),
        ([[1, 2], [3, 4]], TypeError),
    ):
        with pytest.raises(err, match="texture"):
            vision.Renderer(cam, target, "texture", texture=bad)
    with pytest.raises(ValueError, match="texture: only kind"):
        vision.Renderer(cam, target, "dots", texture=np.zeros((4, 4)))
    line = sim.Target(np.array([[0.0, 0, 0], [0.1, 0, 0], [0.2, 0, 0]]), sim.pose(t=(0, 0, 0.5)))
    with pytest.raises(ValueError, match="target: a textured plate"):
        vision.Renderer(cam, line, "texture")
    for name, value in (("gain", -1.0), ("gain", math.nan), ("offset", 300.0), ("offset", "1")):
        with pytest.raises((TypeError, ValueError), match=name):
            vision.Renderer(cam, target, "texture", **{name: value})
    for bad in ((8, 8), (16,), (16.0, 16), "ab"):
        with pytest.raises(ValueError, match="size"):
            vision.texture(bad)
    with pytest.raises(TypeError, match="seed"):
        vision.texture((32, 32), seed=-1)


@settings(max_examples=25, deadline=None)
@given(
    shape=st.tuples(st.integers(2, 40), st.integers(2, 40)),
    fill=st.floats(allow_nan=True, allow_infinity=True),
    gain=st.floats(0, 100),
    offset=st.floats(-255, 255),
)
def test_any_texture_array_renders_or_is_refused(shape, fill, gain, offset):
    cam = ibvs.CameraModel(120.0, 120.0, 40.0, 30.0, 0.0, 0.0, 80.0, 60.0)
    target = sim.Target.square(0.1, sim.pose(t=(0, 0, 0.4), r=(0.2, 0.1, 0.3)))
    arr = np.full(shape, fill)
    try:
        r = vision.Renderer(cam, target, "texture", texture=arr, gain=gain, offset=offset)
    except ValueError as e:
        assert "texture" in str(e) and not (np.isfinite(fill) and 0 <= fill <= 255)
    else:
        img = r.render(np.eye(4))
        assert img.dtype == np.uint8 and img.shape == (60, 80)
