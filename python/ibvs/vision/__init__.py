"""ibvs.vision: the image in the loop. What the simulated camera sees of a planar target, and
the dots or the tag found in it (OpenCV; extra ``ibvs[vision]``).

    renderer = Renderer(camera, target, kind="dots")     # white dots on a dark plate, or kind="tag"
    image = renderer.render(pose_wc)                     # uint8 (height, width), the camera's lens
    tracker = DotTracker(len(target))
    tracker.reset(initial_pixels)                        # the user's clicks on the dots
    track = tracker.track(image)                         # pixels (N, 2), NaN rows = lost, status per point
    sensor = ImageSensor(renderer, tracker)              # for ibvs.sim.run(..., vision=sensor)

Pixel coordinates are OpenCV's (and CameraModel's, cv2.projectPoints'): the centre of the pixel in
column c and row r is (u, v) = (c, r). A camera for images has a pixel sensor whose bounds are
[0, width] x [0, height] with integer width and height.

Rendering (per frame: one homography warp of a precomputed texture, one precomputed remap for the
lens): the plate is a texture in the target's z = 0 plane (texture column along the target's x,
row along its y, seen from the side of the target's -z axis), kept as a pyramid of resolutions
(halvings by area averaging) from which the level closest to one texel per image pixel at the
target's centre is warped (bilinear) into an ideal pinhole image, then remapped through the
camera's distortion: each sensor pixel reads the pinhole image at CameraModel.normalize of its
centre. Dots are drawn with anti-aliased edges (coverage of each texel), so that the intensity
centroid of a rendered dot is the area centroid of the dot's image (see tests/python/test_vision.py:
that, not the projection of the dot's centre, is what a centroid can be compared with; they differ
by the perspective and distortion of a finite disc, up to about 0.1 px at 15 px radius).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Optional, Tuple

import numpy as np

from .._core import CameraModel, se3_exp
from .._core import sim as _sim

__all__ = [
    "DotTracker",
    "ImageSensor",
    "Renderer",
    "TagDetector",
    "Track",
    "draw_points",
    "image_camera",
    "write_video",
]

KINDS = ("dots", "tag")
_TAG_DICTIONARIES = {"apriltag_36h11": "DICT_APRILTAG_36h11", "aruco_4x4_50": "DICT_4X4_50"}


def _cv2():
    try:
        import cv2
    except ImportError as e:  # pragma: no cover - the test extra installs it
        raise ImportError(
            "ibvs.vision needs OpenCV (opencv-python-headless): "
            'pip install ".[vision]" from the ibvs repository root'
        ) from e
    return cv2


def _real(x, name: str, lo: float = 0.0, hi: float = math.inf) -> float:
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a real number, got {type(x).__name__}")
    x = float(x)
    if not (lo <= x <= hi):
        raise ValueError(f"{name} must be finite and in [{lo:g}, {hi:g}], got {x!r}")
    return x


def _image_size(camera) -> Tuple[int, int]:
    """(width, height) of a camera that can have images: pixel bounds [0, W] x [0, H], W and H integers."""
    if not isinstance(camera, CameraModel):
        raise TypeError(f"camera must be an ibvs.CameraModel, got {type(camera).__name__}")
    u_min, u_max, v_min, v_max = camera.bounds
    w, h = u_max - u_min, v_max - v_min
    if (
        u_min != 0
        or v_min != 0
        or w != round(w)
        or h != round(h)
        or not (16 <= w <= 8192 and 16 <= h <= 8192)
    ):
        raise ValueError(
            "camera must have a pixel sensor [0, width] x [0, height] with integer width and height "
            "in [16, 8192] "
            f"to render images, got bounds {camera.bounds} (a normalised camera has no pixels)"
        )
    return int(w), int(h)


def image_camera(camera) -> CameraModel:
    """The camera itself if it has pixels; for a normalised camera (the paper's free-flying cases)
    a 640x480 pinhole with f = 800 px and the principal point at the centre, whose sensor spans
    the same +-0.3 normalised units vertically (+-0.4 horizontally), at the same fps."""
    if not isinstance(camera, CameraModel):
        raise TypeError(f"camera must be an ibvs.CameraModel, got {type(camera).__name__}")
    try:
        _image_size(camera)
        return camera
    except ValueError:
        return CameraModel(800.0, 800.0, 320.0, 240.0, 0.0, 0.0, 640.0, 480.0, camera.fps)


def check_image(image, size: Tuple[int, int], name: str = "image") -> np.ndarray:
    """The image as a 2-D uint8 array of the given (width, height), or a clear error."""
    if not isinstance(image, np.ndarray):
        raise TypeError(f"{name} must be a numpy array (a grayscale uint8 image), got {type(image).__name__}")
    if image.dtype != np.uint8:
        raise TypeError(f"{name} must have dtype uint8 (an 8-bit grayscale image), got {image.dtype}")
    if image.ndim != 2 or image.shape != (size[1], size[0]):
        raise ValueError(
            f"{name} must have shape (height, width) = ({size[1]}, {size[0]}), got {image.shape}"
        )
    return image


# ---------------------------------------------------------------------------------------------
# Renderer


class Renderer:
    """Grayscale images of a planar target as the camera sees it.

    Renderer(camera, target, kind="dots", dot_radius=None, tag_id=0, dictionary="apriltag_36h11",
             blur=0.0, exposure=0.0, noise=0.0, seed=0)
      camera       an ibvs.CameraModel with a pixel sensor (any distortion); images are its size
      target       an ibvs.sim.Target whose points lie in its z = 0 plane
      kind         "dots": a white dot (radius dot_radius, m; default a tenth of the smallest
                   distance between points) at every point, on a dark plate;
                   "tag": a square marker of `dictionary` (AprilTag 36h11) with id tag_id whose
                   outer corners are the target's 4 points, in cv2.aruco's order (top-left,
                   top-right, bottom-right, bottom-left as seen by the camera: (-,-), (+,-),
                   (+,+), (-,+) in the target frame, the order of Target.square), on a white plate
      blur         defocus: std (px) of a Gaussian blur, 0 = sharp
      exposure     motion blur: exposure time (s) over which render(pose, twist) averages the
                   camera moving with `twist` (5 sub-frames), 0 = none
      noise        sensor noise: std of additive Gaussian noise in gray levels, then 8-bit quantisation
      seed         of the noise (a numpy default_rng); reseed() restarts it
    """

    DOT, PLATE, BACKGROUND = 230.0, 30.0, 10.0  # gray levels for dots
    WHITE, BLACK, TAG_BACKGROUND = 220.0, 25.0, 90.0  # for tags
    BASE_TEXELS = 2048  # texels along the plate's longer side at the finest level
    LEVELS = 7  # pyramid levels (each halves the resolution)
    MOTION_SAMPLES = 5

    def __init__(
        self,
        camera,
        target,
        kind: str = "dots",
        dot_radius: Optional[float] = None,
        tag_id: int = 0,
        dictionary: str = "apriltag_36h11",
        blur: float = 0.0,
        exposure: float = 0.0,
        noise: float = 0.0,
        seed: int = 0,
    ):
        cv2 = _cv2()
        self.size = _image_size(camera)
        self.camera = camera
        if not isinstance(target, _sim.Target):
            raise TypeError(f"target must be an ibvs.sim.Target, got {type(target).__name__}")
        if not target.planar:
            raise ValueError(
                "target: the renderer draws planar targets only (all points in the target's z = 0 plane)"
            )
        if kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
        self.target, self.kind = target, kind
        self.blur = _real(blur, "blur", 0.0, 100.0)
        self.exposure = _real(exposure, "exposure", 0.0, 10.0)
        self.noise = _real(noise, "noise", 0.0, 255.0)
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise TypeError(f"seed must be a non-negative int, got {seed!r}")
        self.reseed(int(seed))
        xy = np.asarray(target.points)[:, :2]
        if kind == "dots":
            d = np.linalg.norm(xy[:, None] - xy[None], axis=-1)
            closest = d[~np.eye(len(xy), dtype=bool)].min() if len(xy) > 1 else 0.1
            if closest <= 0:
                raise ValueError("target: two points coincide; their dots cannot be drawn apart")
            self.dot_radius = (
                0.1 * closest if dot_radius is None else _real(dot_radius, "dot_radius", 0.0, 10.0)
            )
            if not (0 < self.dot_radius < 0.5 * closest):
                raise ValueError(
                    f"dot_radius must be in (0, {0.5 * closest:g}) m "
                    "(half the smallest distance between points), "
                    f"got {self.dot_radius!r}"
                )
            lo, hi = xy.min(0) - 3 * self.dot_radius, xy.max(0) + 3 * self.dot_radius
            self.background = self.BACKGROUND
        else:
            self.dot_radius = None
            if isinstance(tag_id, bool) or not isinstance(tag_id, (int, np.integer)) or tag_id < 0:
                raise TypeError(f"tag_id must be a non-negative int, got {tag_id!r}")
            if dictionary not in _TAG_DICTIONARIES:
                raise ValueError(f"dictionary must be one of {tuple(_TAG_DICTIONARIES)}, got {dictionary!r}")
            side = _tag_side(xy)
            self.tag_id, self.dictionary = int(tag_id), dictionary
            dic = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, _TAG_DICTIONARIES[dictionary]))
            if self.tag_id >= dic.bytesList.shape[0]:
                raise ValueError(
                    f"tag_id must be < {dic.bytesList.shape[0]} for {dictionary}, got {self.tag_id}"
                )
            modules, quiet = dic.markerSize + 2, 2  # black border included; a white quiet zone of 2 modules
            per_module = 16 * int(math.ceil(self.BASE_TEXELS / (16 * (modules + 2 * quiet))))
            self._tag = (side, dic, modules, per_module, quiet)
            self._d0 = side / (modules * per_module)
            lo = xy.min(0) - quiet * side / modules
            hi = lo + (modules + 2 * quiet) * side / modules
            self.background = self.TAG_BACKGROUND
        self._build_texture(cv2, lo, hi, xy)
        self._build_lens()
        self._target_pose = np.asarray(target.pose, dtype=np.float64)
        self._centre = np.append(xy.mean(0), 1.0)
        rows, cols = self._pyramid[0].shape
        o, ex, ey = self._origin, cols * self._d0, rows * self._d0
        self._corners = np.array(
            [[o[0], o[1], 1], [o[0] + ex, o[1], 1], [o[0] + ex, o[1] + ey, 1], [o[0], o[1] + ey, 1]]
        )
        cam = camera
        self._K_pinhole = np.array(
            [[cam.px, 0, cam.u0 + self._shift[0]], [0, cam.py, cam.v0 + self._shift[1]], [0, 0, 1.0]]
        )
        t = np.linspace(0.0, 1.0, 16)
        self._edge_t = t

    def reseed(self, seed: int) -> None:
        """Restart the noise generator: the images that follow depend on the seed only."""
        self._rng = np.random.default_rng(seed)
        self._noise_table = None  # drawn from the new generator at the next noisy frame

    def _noise(self, cv2) -> Tuple[Optional[np.ndarray], np.ndarray]:
        """This frame's sensor noise (height, width), float32 (None without noise), and the background with
        that noise, quantised to uint8 (a fresh array: the frame is drawn into it).

        The noise is a window at a random offset into a table of (2 height, 2 width) normals drawn once per
        seed. Within a frame the values are independent normals of std `noise`; from frame to frame a pixel
        reads an unrelated table entry (the same one only when two frames draw the same offset, 1 in 300,000
        at 640x480). Drawing fresh normals every frame costs 1.5 ms at 640x480; the window costs a copy."""
        W, H = self.size
        if self.noise == 0:
            return None, np.full((H, W), round(self.background), np.uint8)
        if self._noise_table is None or self._noise_table[1] != (self.noise, self.background):
            table = self._rng.standard_normal((2 * H, 2 * W), dtype=np.float32)
            table *= np.float32(self.noise)
            quantised = cv2.add(table, np.full_like(table, self.background), dtype=cv2.CV_8U)
            self._noise_table = (table, (self.noise, self.background), quantised)
        dy, dx = (int(i) for i in self._rng.integers(0, [H + 1, W + 1]))
        table, _, quantised = self._noise_table
        return table[dy : dy + H, dx : dx + W], quantised[dy : dy + H, dx : dx + W].copy()

    # -- set-up (allocates; once) --
    def _build_texture(self, cv2, lo, hi, xy) -> None:
        extent = hi - lo
        step = 2 ** (self.LEVELS - 1)
        d0 = (
            self._d0 if self.kind == "tag" else extent.max() / self.BASE_TEXELS
        )  # metres per texel at level 0
        cols = int(math.ceil(extent[0] / d0 / step - 1e-9)) * step
        rows = int(math.ceil(extent[1] / d0 / step - 1e-9)) * step
        self._origin = lo  # texel (c, r) of level l covers origin + [c, c + 1] * d_l along x (same for y)
        self._d0 = d0
        if self.kind == "dots":
            tex = np.full((rows, cols), self.PLATE, np.float32)
            rad = self.dot_radius / d0
            for x, y in xy:
                cx, cy = (x - lo[0]) / d0 - 0.5, (y - lo[1]) / d0 - 0.5  # texel-index coordinates
                c0, c1 = int(max(cx - rad - 2, 0)), int(min(cx + rad + 3, cols))
                r0, r1 = int(max(cy - rad - 2, 0)), int(min(cy + rad + 3, rows))
                cc, rr = np.meshgrid(np.arange(c0, c1), np.arange(r0, r1))
                # coverage of each texel by the disc: the signed distance of its centre to the edge, in texels
                cover = np.clip(0.5 + rad - np.hypot(cc - cx, rr - cy), 0.0, 1.0)
                tex[r0:r1, c0:c1] += (self.DOT - self.PLATE) * cover.astype(np.float32)
        else:
            # the marker's modules fall on whole texels: no resampling of the marker itself
            side, dic, modules, per_module, quiet = self._tag
            marker = cv2.aruco.generateImageMarker(dic, self.tag_id, modules * per_module)
            tex = np.full((rows, cols), self.TAG_BACKGROUND, np.float32)  # the texture's padding
            plate = (modules + 2 * quiet) * per_module
            tex[:plate, :plate] = self.WHITE
            o = quiet * per_module
            tex[o : o + modules * per_module, o : o + modules * per_module] = np.where(
                marker > 127, self.WHITE, self.BLACK
            )
        self._pyramid = [tex.astype(np.float32)]
        for _ in range(1, self.LEVELS):
            t = self._pyramid[-1]
            self._pyramid.append(
                cv2.resize(t, (t.shape[1] // 2, t.shape[0] // 2), interpolation=cv2.INTER_AREA)
            )

    def _build_lens(self) -> None:
        """The remap from the sensor to an ideal pinhole image with the camera's K (shifted to hold it)."""
        w, h = self.size
        cam = self.camera
        self._map = None
        self._shift = np.zeros(2)
        self._pinhole_size = (w, h)
        if cam.distortion == "none":
            return
        uu, vv = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
        pix = np.stack([uu.ravel(), vv.ravel()], 1)
        xy = cam.normalize(pix, invalid="nan")
        m = np.stack([cam.px * xy[:, 0] + cam.u0, cam.py * xy[:, 1] + cam.v0], 1)
        ok = np.isfinite(m).all(1)
        # the pinhole image covers the map's range (at most 3x the sensor around it)
        lo = np.maximum(np.floor(m[ok].min(0)) - 2, [-w, -h])
        hi = np.minimum(np.ceil(m[ok].max(0)) + 2, [2 * w, 2 * h])
        m[~ok] = -1e6
        self._shift = -lo
        self._pinhole_size = (int(hi[0] - lo[0]) + 1, int(hi[1] - lo[1]) + 1)
        m = m - lo
        self._map = (m[:, 0].reshape(h, w).astype(np.float32), m[:, 1].reshape(h, w).astype(np.float32))

    # -- per frame --
    def _homography(self, pose_wc: np.ndarray) -> Optional[np.ndarray]:
        """Target plane (x, y, 1) -> pinhole pixel, or None when the camera sees the plate's blank back
        (it is behind the plate's plane, or on it)."""
        T_wt = self._target_pose
        R_cw = pose_wc[:3, :3].T  # rigid inverse
        R = R_cw @ T_wt[:3, :3]
        t = R_cw @ (T_wt[:3, 3] - pose_wc[:3, 3])
        # the camera centre in the target frame is -R^T t: in front when its z < 0
        if (R[:, 2] @ t) <= 0 or not np.isfinite(t).all():
            return None
        Hp = self._K_pinhole @ np.column_stack([R[:, 0], R[:, 1], t])
        return Hp

    def _box(self, Hp: np.ndarray) -> Optional[Tuple[int, int, int, int]]:
        """The pinhole image's box (x0, y0, x1, y1) holding the plate, or None (the whole image) when
        part of the plate is behind the camera."""
        p = self._corners @ Hp.T
        if not (p[:, 2] > 1e-9).all():
            return None
        q = p[:, :2] / p[:, 2:]
        W, H = self._pinhole_size
        x0, y0 = np.clip(np.floor(q.min(0)) - 2, 0, [W, H]).astype(int)
        x1, y1 = np.clip(np.ceil(q.max(0)) + 3, 0, [W, H]).astype(int)
        return int(x0), int(y0), int(x1), int(y1)

    def _warp(self, cv2, Hp: np.ndarray, box: Tuple[int, int, int, int]) -> np.ndarray:
        """The pinhole image (float32) of the plate over box, from the pyramid level whose texels are
        about 0.7 image pixel or more at the target's centre."""
        p = Hp @ self._centre
        level = 0
        if p[2] > 1e-9:
            J = (Hp[:2, :2] * p[2] - np.outer(p[:2], Hp[2, :2])) / p[2] ** 2  # d pixel / d (x, y), px per m
            ppm = math.sqrt(abs(np.linalg.det(J)))
            level = int(np.clip(math.ceil(math.log2(0.7 / max(ppm * self._d0, 1e-12))), 0, self.LEVELS - 1))
        d = self._d0 * 2**level
        S = np.array([[d, 0, self._origin[0] + 0.5 * d], [0, d, self._origin[1] + 0.5 * d], [0, 0, 1.0]])
        x0, y0, x1, y1 = box
        shift = np.array([[1.0, 0, -x0], [0, 1, -y0], [0, 0, 1]])
        return cv2.warpPerspective(
            self._pyramid[level],
            shift @ Hp @ S,
            (x1 - x0, y1 - y0),
            flags=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=float(self.background),
        )

    def _sensor_box(self, box: Tuple[int, int, int, int]) -> Tuple[int, int, int, int]:
        """The sensor pixels whose lens map reads the pinhole box (its boundary through the distortion,
        sampled, plus a margin); the whole sensor when part of it cannot be mapped."""
        W, H = self.size
        if self._map is None:
            return box
        x0, y0, x1, y1 = box
        t = self._edge_t
        u = np.concatenate([x0 + (x1 - x0) * t, x0 + (x1 - x0) * t, np.full_like(t, x0), np.full_like(t, x1)])
        v = np.concatenate([np.full_like(t, y0), np.full_like(t, y1), y0 + (y1 - y0) * t, y0 + (y1 - y0) * t])
        cam = self.camera
        xy = np.empty((4 * len(t), 2))
        xy[:, 0] = (u - self._shift[0] - cam.u0) / cam.px
        xy[:, 1] = (v - self._shift[1] - cam.v0) / cam.py
        px = cam.project(xy, invalid="nan")
        if not np.isfinite(px).all():
            return 0, 0, W, H
        sx0, sy0 = np.clip(np.floor(px.min(0)) - 3, 0, [W, H]).astype(int)
        sx1, sy1 = np.clip(np.ceil(px.max(0)) + 4, 0, [W, H]).astype(int)
        return int(sx0), int(sy0), int(sx1), int(sy1)

    def render(self, pose_wc, twist=None) -> np.ndarray:
        """The camera's uint8 image (height, width) at world <- camera pose_wc (4, 4); twist (6,) the camera's
        velocity during the exposure (motion blur, with exposure > 0)."""
        cv2 = _cv2()
        pose_wc = np.asarray(pose_wc, dtype=np.float64)
        if pose_wc.shape != (4, 4) or not np.isfinite(pose_wc).all():
            raise ValueError(f"pose_wc must be a finite 4x4 pose, got shape {pose_wc.shape}")
        poses = [pose_wc]
        if self.exposure > 0 and twist is not None:
            v = np.asarray(twist, dtype=np.float64)
            if v.shape != (6,) or not np.isfinite(v).all():
                raise ValueError(f"twist must be a finite (6,) camera twist, got shape {v.shape}")
            if np.any(v != 0):  # the exposure ends at the capture: poses over [-exposure, 0]
                poses += [
                    pose_wc @ se3_exp(v * (-self.exposure * j / (self.MOTION_SAMPLES - 1)))
                    for j in range(1, self.MOTION_SAMPLES)
                ]
        W, H = self.size
        region = None  # the sensor pixels the plate covers: ((x0, y0, x1, y1), float32 gray levels)
        Hs = [Hp for Hp in (self._homography(p) for p in poses)]
        visible = [Hp for Hp in Hs if Hp is not None]
        if visible:
            # only the part of the images the plate covers is drawn (the union over the exposure)
            boxes = [self._box(Hp) for Hp in visible]
            Wp, Hpix = self._pinhole_size
            if any(b is None for b in boxes):
                box = (0, 0, Wp, Hpix)
            else:
                box = tuple(int(f(v)) for f, v in zip((min, min, max, max), zip(*boxes)))
            if box[2] > box[0] and box[3] > box[1]:
                pin = self._warp(cv2, visible[0], box)
                if (
                    len(Hs) > 1
                ):  # motion blur: the mean over the exposure (sub-frames seeing the back: background)
                    for Hp in visible[1:]:
                        pin += self._warp(cv2, Hp, box)
                    pin += float(self.background) * (len(Hs) - len(visible))
                    pin *= 1.0 / len(Hs)
                sx0, sy0, sx1, sy1 = self._sensor_box(box)
                if sx1 > sx0 and sy1 > sy0:
                    if self._map is None:
                        pixels = pin[sy0 - box[1] : sy1 - box[1], sx0 - box[0] : sx1 - box[0]]
                    else:
                        pixels = cv2.remap(
                            pin,
                            self._map[0][sy0:sy1, sx0:sx1] - np.float32(box[0]),
                            self._map[1][sy0:sy1, sx0:sx1] - np.float32(box[1]),
                            cv2.INTER_LINEAR,
                            borderMode=cv2.BORDER_CONSTANT,
                            borderValue=float(self.background),
                        )
                    region = ((sx0, sy0, sx1, sy1), pixels)
        noise, out = self._noise(cv2)
        if self.blur > 0:  # defocus spreads the plate over the background: the whole frame in float
            img = np.full((H, W), self.background, np.float32)
            if region is not None:
                (sx0, sy0, sx1, sy1), pixels = region
                img[sy0:sy1, sx0:sx1] = pixels
            img = cv2.GaussianBlur(img, (0, 0), self.blur)
            # noise, then 8-bit quantisation in one pass: cv2.add into CV_8U rounds to nearest (ties to even)
            # and saturates to [0, 255]
            return cv2.add(img, 0.0 if noise is None else noise, dtype=cv2.CV_8U)
        # sharp: the background with its noise comes quantised with the noise table; only the plate's region
        # is added and quantised here (the same sums and rounding as over the whole frame)
        if region is not None:
            (sx0, sy0, sx1, sy1), pixels = region
            n = 0.0 if noise is None else noise[sy0:sy1, sx0:sx1]
            out[sy0:sy1, sx0:sx1] = cv2.add(pixels, n, dtype=cv2.CV_8U)
        return out

    def __repr__(self) -> str:
        what = (
            f"dots r={self.dot_radius:g} m"
            if self.kind == "dots"
            else f"tag {self.dictionary} id {self.tag_id}"
        )
        return (
            f"Renderer({what}, {self.size[0]}x{self.size[1]}, blur={self.blur:g} px, "
            f"exposure={self.exposure:g} s, "
            f"noise={self.noise:g})"
        )


def _tag_side(xy: np.ndarray) -> float:
    """The side of the square the 4 points form in cv2.aruco's corner order, or a clear error."""
    if len(xy) != 4:
        raise ValueError(f"target: a tag has 4 corners; the target has {len(xy)} points")
    side = np.linalg.norm(xy[1] - xy[0])
    c = xy.mean(0)
    expected = c + side / 2 * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]])
    if not (side > 0) or np.abs(xy - expected).max() > 1e-9 * max(side, 1.0):
        raise ValueError(
            "target: a tag's points must be the corners of an axis-aligned square in the target's "
            "z = 0 plane, "
            "in the order (-,-), (+,-), (+,+), (-,+) (Target.square)"
        )
    return float(side)


# ---------------------------------------------------------------------------------------------
# Trackers


@dataclass(frozen=True)
class Track:
    """One frame's detection: pixels (N, 2) (NaN rows: not measured), status per point ("tracked",
    "detected", "lost_gate": no dot wholly inside its tracking gate, "lost_border": touches or
    left the image, "not_found": tag not detected, "conflict": the blob was already another
    point's), and the detection time (s)."""

    pixels: np.ndarray
    status: Tuple[str, ...]
    seconds: float

    @property
    def lost(self) -> Tuple[int, ...]:
        """Indices of the points not measured this frame."""
        return tuple(i for i, s in enumerate(self.status) if s not in ("tracked", "detected"))


class DotTracker:
    """Bright dots on a dark background, tracked frame to frame.

    DotTracker(n_points, image_size, threshold=None, gate=10.0, min_area=4)
      image_size  (width, height) of the images (e.g. Renderer.size)
      threshold   gray level separating dots from the plate; None: Otsu's on the first image
      gate        px added to 1.5 dot radii: the half-side of the square searched around each
                  point's predicted position (constant-velocity prediction from its last two positions)
      min_area    px; smaller blobs are ignored (noise)
    reset(pixels) starts the tracks at guesses (N, 2) (a user clicking on the dots); track(image)
    finds each dot in its gate: threshold, connected components, the blob nearest the prediction,
    its sub-pixel intensity centroid (background-subtracted, over the blob grown by 2 px). A dot is
    lost when its blob touches the image border or its gate, or no blob is in its gate; a blob
    already taken by another point is refused ("conflict"): correspondences never swap.
    """

    def __init__(
        self,
        n_points: int,
        image_size,
        threshold: Optional[float] = None,
        gate: float = 10.0,
        min_area: int = 4,
    ):
        if (
            isinstance(n_points, bool)
            or not isinstance(n_points, (int, np.integer))
            or not 1 <= n_points <= 1000
        ):
            raise ValueError(f"n_points must be an int in [1, 1000], got {n_points!r}")
        if (
            not isinstance(image_size, (tuple, list))
            or len(image_size) != 2
            or not all(isinstance(s, (int, np.integer)) and 16 <= s <= 8192 for s in image_size)
        ):
            raise ValueError(f"image_size must be (width, height), ints in [16, 8192], got {image_size!r}")
        self.n = int(n_points)
        self.size = (int(image_size[0]), int(image_size[1]))
        self.threshold = None if threshold is None else _real(threshold, "threshold", 0.0, 255.0)
        self.gate = _real(gate, "gate", 1.0, 1000.0)
        if isinstance(min_area, bool) or not isinstance(min_area, (int, np.integer)) or min_area < 1:
            raise ValueError(f"min_area must be an int >= 1, got {min_area!r}")
        self.min_area = int(min_area)
        self._last = self._prev = None

    def reset(self, pixels) -> None:
        """Start tracking at the guesses pixels (N, 2)."""
        p = np.asarray(pixels, dtype=np.float64)
        if p.shape != (self.n, 2) or not np.isfinite(p).all():
            raise ValueError(
                f"pixels must be {self.n} finite guesses, shape ({self.n}, 2), got shape {p.shape}"
            )
        self._last, self._prev = p.copy(), None
        self._radius = np.full(self.n, np.nan)
        self._level = self.threshold

    def track(self, image) -> Track:
        """The dots in this image (see the class)."""
        cv2 = _cv2()
        image = check_image(image, self.size)
        if self._last is None:
            raise ValueError("reset(pixels) must start the tracks before track(image)")
        t0 = time.perf_counter()
        if self._level is None:
            self._level = float(cv2.threshold(image, 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU)[0])
        W, H = self.size
        pred = self._last if self._prev is None else 2 * self._last - self._prev
        out = np.full((self.n, 2), np.nan)
        status = ["lost_gate"] * self.n
        taken: list = []
        kernel = np.ones((5, 5), np.uint8)
        for i in range(self.n):
            if not np.isfinite(pred[i]).all():
                continue
            r = self._radius[i]
            g = (1.5 * r if np.isfinite(r) else 4 * self.gate) + self.gate
            x0, y0 = int(math.floor(pred[i, 0] - g)), int(math.floor(pred[i, 1] - g))
            x1, y1 = int(math.ceil(pred[i, 0] + g)) + 1, int(math.ceil(pred[i, 1] + g)) + 1
            cx0, cy0, cx1, cy1 = max(x0, 0), max(y0, 0), min(x1, W), min(y1, H)
            if cx1 - cx0 < 2 or cy1 - cy0 < 2:
                status[i] = "lost_border"
                continue
            roi = image[cy0:cy1, cx0:cx1]
            binary = (roi > self._level).astype(np.uint8)
            count, labels, stats, cents = cv2.connectedComponentsWithStats(binary, connectivity=8)
            # the blob (of at least min_area pixels) whose centroid is nearest the prediction
            dist = np.hypot(cents[1:, 0] + cx0 - pred[i, 0], cents[1:, 1] + cy0 - pred[i, 1])
            dist[stats[1:, cv2.CC_STAT_AREA] < self.min_area] = np.inf
            if dist.size == 0 or not np.isfinite(dist.min()):
                continue
            best = int(np.argmin(dist)) + 1
            bx, by, bw, bh = stats[best, :4]
            gx0, gy0, gx1, gy1 = bx + cx0, by + cy0, bx + bw + cx0, by + bh + cy0  # blob box, image pixels
            if gx0 <= 0 or gy0 <= 0 or gx1 >= W or gy1 >= H:
                status[i] = "lost_border"
                continue
            if gx0 <= cx0 or gy0 <= cy0 or gx1 >= cx1 or gy1 >= cy1:
                status[i] = "lost_gate"
                continue
            blob = (labels == best).astype(np.uint8)
            grown = cv2.dilate(blob, kernel)
            others = (labels > 0) & (blob == 0)
            bg_pixels = roi[(grown == 0) & ~others]
            bg = float(np.median(bg_pixels)) if bg_pixels.size else 0.0
            w = np.where((grown > 0) & ~others, np.maximum(roi.astype(np.float64) - bg, 0.0), 0.0)
            total = w.sum()
            if not total > 0:
                continue
            ys, xs = np.indices(w.shape)
            c = np.array([(w * xs).sum() / total + cx0, (w * ys).sum() / total + cy0])
            if any(np.hypot(*(c - out[j])) < 1.0 for j in taken):
                status[i] = "conflict"
                continue
            out[i] = c
            taken.append(i)
            status[i] = "tracked"
            self._radius[i] = math.sqrt(stats[best, cv2.CC_STAT_AREA] / math.pi)
        self._prev, self._last = self._last, np.where(np.isfinite(out), out, np.nan)
        return Track(out, tuple(status), time.perf_counter() - t0)


class TagDetector:
    """Square fiducial markers found by cv2.aruco, their corners as the servo's points.

    TagDetector(ids=(0,), dictionary="apriltag_36h11", refine=True, image_size=None, decimate=2)
      ids       the tags whose corners are the points, in this order: point 4 k + j is corner j of
                tag ids[k], corners in cv2.aruco's order (top-left, top-right, bottom-right,
                bottom-left of the marker: the order of ibvs.sim.Target.square)
      refine    sub-pixel corners: cv2.cornerSubPix on the full-resolution image
      decimate  1 or 2: cv2.aruco searches an image shrunk this many times (area average), as
                AprilTag's own decimation (faster); a tag not found there is searched again at
                full resolution
    detect(image) -> Track: status "detected" or "not_found" per corner.
    """

    def __init__(
        self,
        ids: Sequence[int] = (0,),
        dictionary: str = "apriltag_36h11",
        refine: bool = True,
        image_size=None,
        decimate: int = 2,
    ):
        cv2 = _cv2()
        ids = tuple(ids) if isinstance(ids, (tuple, list)) else None
        if (
            not ids
            or any(isinstance(i, bool) or not isinstance(i, (int, np.integer)) or i < 0 for i in ids)
            or len(set(ids)) != len(ids)
        ):
            raise ValueError(f"ids must be a non-empty sequence of distinct non-negative ints, got {ids!r}")
        if dictionary not in _TAG_DICTIONARIES:
            raise ValueError(f"dictionary must be one of {tuple(_TAG_DICTIONARIES)}, got {dictionary!r}")
        self.ids, self.dictionary = tuple(int(i) for i in ids), dictionary
        self.size = None if image_size is None else tuple(image_size)
        if decimate not in (1, 2) or isinstance(decimate, bool):
            raise ValueError(f"decimate must be 1 or 2, got {decimate!r}")
        self.decimate, self.refine = int(decimate), bool(refine)
        aruco = cv2.aruco
        params = aruco.DetectorParameters()
        # cv2.aruco drops a candidate close to another one (within minMarkerDistanceRate of its
        # perimeter, 0.125 by default): the contour of the tag's white plate cut by the image border
        # is such a neighbour, and the tag was lost (test_tag_episode_plate_at_the_border).
        params.minMarkerDistanceRate = 0.02
        self._detector = aruco.ArucoDetector(
            aruco.getPredefinedDictionary(getattr(aruco, _TAG_DICTIONARIES[dictionary])), params
        )

    @property
    def n_points(self) -> int:
        return 4 * len(self.ids)

    def reset(self, pixels=None) -> None:
        """Nothing to reset: every frame is detected on its own (symmetry with DotTracker)."""

    def detect(self, image) -> Track:
        if self.size is not None:
            image = check_image(image, self.size)
        elif not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 2:
            raise TypeError("image must be a 2-D uint8 numpy array (grayscale)")
        cv2 = _cv2()
        t0 = time.perf_counter()
        out = np.full((self.n_points, 2), np.nan)
        status = ["not_found"] * self.n_points
        h, w = image.shape
        for scale in sorted({self.decimate, 1}, reverse=True):
            small = (
                image
                if scale == 1
                else cv2.resize(image, (w // scale, h // scale), interpolation=cv2.INTER_AREA)
            )
            corners, found, _ = self._detector.detectMarkers(small)
            for c, i in zip(corners, np.asarray(found).ravel() if found is not None else ()):
                k = self.ids.index(int(i)) if int(i) in self.ids else -1
                if k < 0 or status[4 * k] == "detected":
                    continue
                # pixel c of the shrunk image is centred on scale c + (scale - 1) / 2 of the full one
                out[4 * k : 4 * k + 4] = (
                    np.asarray(c, dtype=np.float64).reshape(4, 2) * scale + (scale - 1) / 2
                )
                status[4 * k : 4 * k + 4] = ["detected"] * 4
            if "not_found" not in status:
                break
        found_rows = np.isfinite(out[:, 0])
        if self.refine and found_rows.any():
            c = out[found_rows].astype(np.float32).reshape(-1, 1, 2)
            crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 40, 0.001)
            out[found_rows] = cv2.cornerSubPix(image, c, (5, 5), (-1, -1), crit).reshape(-1, 2)
        return Track(out, tuple(status), time.perf_counter() - t0)

    track = detect


# ---------------------------------------------------------------------------------------------
# The sensor of an image episode


class ImageSensor(_sim.Sensor):
    """The simulator's measurement through images: ibvs.sim.run(..., vision=ImageSensor(renderer, detector)).

    Each frame: renderer.render(pose, twist) -> detector (a DotTracker, started at frames -1 (goal)
    and 0 from the true projections, as a user clicks on the dots; or a TagDetector) -> pixels, NaN
    for a lost point (the episode then ends as lost_feature). The renderer's noise is reseeded with
    the run's seed. keep_frames=True keeps every image (frames[k] is frame k; goal_image the goal's)
    for a video; render_seconds and detect_seconds hold each frame's times.
    """

    def __init__(self, renderer: Renderer, detector, keep_frames: bool = False):
        super().__init__()
        if not isinstance(renderer, Renderer):
            raise TypeError(f"renderer must be an ibvs.vision.Renderer, got {type(renderer).__name__}")
        if not isinstance(detector, (DotTracker, TagDetector)):
            raise TypeError(
                f"detector must be an ibvs.vision.DotTracker or TagDetector, got {type(detector).__name__}"
            )
        n = detector.n if isinstance(detector, DotTracker) else detector.n_points
        if n != len(renderer.target):
            raise ValueError(f"detector: it measures {n} points but the target has {len(renderer.target)}")
        if isinstance(detector, DotTracker) and detector.size != renderer.size:
            raise ValueError(
                f"detector: image_size {detector.size} differs from the camera's {renderer.size}"
            )
        self.renderer, self.detector, self.keep_frames = renderer, detector, bool(keep_frames)
        self.frames: list = []
        self.goal_image = None
        self.render_seconds: list = []
        self.detect_seconds: list = []

    @classmethod
    def for_target(cls, camera, target, kind: str = "dots", keep_frames: bool = False, **renderer_options):
        """The default image sensor: Renderer(camera, target, kind, **renderer_options) and a DotTracker
        (dots) or a TagDetector of tag 0 (tag)."""
        r = Renderer(camera, target, kind, **renderer_options)
        if kind == "dots":
            det = DotTracker(len(target), r.size)
        else:
            det = TagDetector((r.tag_id,), r.dictionary, image_size=r.size)
        return cls(r, det, keep_frames)

    def reset(self, seed: int) -> None:
        self.renderer.reseed(seed)
        self.frames, self.goal_image = [], None
        self.render_seconds, self.detect_seconds = [], []

    def measure(self, frame: int, pose, projected, twist) -> np.ndarray:
        t0 = time.perf_counter()
        image = self.renderer.render(pose, twist)
        self.render_seconds.append(time.perf_counter() - t0)
        if isinstance(self.detector, DotTracker):
            if frame <= 0:
                self.detector.reset(projected)
            track = self.detector.track(image)
        else:
            track = self.detector.detect(image)
        self.detect_seconds.append(track.seconds)
        if self.keep_frames:
            if frame < 0:
                self.goal_image = image
            else:
                self.frames.append(image)
        return track.pixels


# ---------------------------------------------------------------------------------------------
# Video


def draw_points(image, detected=None, desired=None) -> np.ndarray:
    """An RGB copy of a grayscale image with the detected points (green crosses, numbered) and the
    desired ones (red circles)."""
    cv2 = _cv2()
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 2:
        raise TypeError("image must be a 2-D uint8 numpy array (grayscale)")
    rgb = cv2.cvtColor(image, cv2.COLOR_GRAY2RGB)
    sh = 4  # fixed-point bits: sub-pixel drawing
    if desired is not None:
        for u, v in np.asarray(desired, dtype=np.float64).reshape(-1, 2):
            if np.isfinite([u, v]).all():
                cv2.circle(
                    rgb, (int(round(u * 16)), int(round(v * 16))), 6 * 16, (255, 60, 60), 1, cv2.LINE_AA, sh
                )
    if detected is not None:
        for i, (u, v) in enumerate(np.asarray(detected, dtype=np.float64).reshape(-1, 2)):
            if np.isfinite([u, v]).all():
                cv2.drawMarker(rgb, (int(round(u)), int(round(v))), (60, 255, 60), cv2.MARKER_CROSS, 10, 1)
                cv2.putText(
                    rgb,
                    str(i),
                    (int(round(u)) + 5, int(round(v)) - 5),
                    cv2.FONT_HERSHEY_SIMPLEX,
                    0.4,
                    (60, 255, 60),
                    1,
                    cv2.LINE_AA,
                )
    return rgb


def write_video(path, frames, detected=None, desired=None, fps: float = 60.0) -> str:
    """Write the frames (uint8 grayscale) with the detected points (K, N, 2) and the desired ones (N, 2)
    drawn: an MP4 through imageio-ffmpeg when installed (extra ibvs[video]); otherwise, or for a .gif
    path, a GIF (Pillow, which comes with matplotlib); PNG frames in a directory for any other path
    or without Pillow. A fallback says so on stdout. Returns the path written."""
    import pathlib

    path = pathlib.Path(path)
    frames = list(frames)
    if not frames:
        raise ValueError("frames must hold at least one image")
    fps = _real(fps, "fps", 0.1, 1000.0)
    rgb = [draw_points(f, None if detected is None else detected[k], desired) for k, f in enumerate(frames)]
    if path.suffix.lower() == ".mp4":
        try:
            import imageio_ffmpeg
        except ImportError:
            gif = path.with_suffix(".gif")
            print(f"imageio-ffmpeg is not installed (pip install '.[video]'): writing {gif} instead")
            path = gif
        else:
            h, w = rgb[0].shape[:2]
            writer = imageio_ffmpeg.write_frames(str(path), (w, h), fps=fps, macro_block_size=1)
            writer.send(None)
            for f in rgb:
                writer.send(np.ascontiguousarray(f))
            writer.close()
            return str(path)
    if path.suffix.lower() == ".gif":
        try:
            from PIL import Image
        except ImportError:  # Pillow comes with matplotlib (ibvs[plot]); without it, PNG frames
            path = path.with_suffix("")
            print(f"Pillow is not installed (pip install '.[plot]'): writing PNG frames into {path}/ instead")
        else:
            ims = [Image.fromarray(f) for f in rgb]
            ims[0].save(path, save_all=True, append_images=ims[1:], duration=int(round(1000 / fps)), loop=0)
            return str(path)
    cv2 = _cv2()
    path.mkdir(parents=True, exist_ok=True)
    for k, f in enumerate(rgb):
        cv2.imwrite(str(path / f"frame_{k:05d}.png"), cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
    return str(path)
