"""The renderer: grayscale images of a planar target as the simulated camera sees it.

Rendering (per frame: one homography warp of a precomputed texture, one precomputed remap for the
lens): the plate is a texture in the target's z = 0 plane (texture column along the target's x,
row along its y, seen from the side of the target's -z axis), kept as a pyramid of resolutions
(halvings by area averaging) from which the level closest to one texel per image pixel at the
target's centre is warped (bilinear) into an ideal pinhole image, then remapped through the
camera's distortion: each sensor pixel reads the pinhole image at CameraModel.normalize of its
centre. A fisheye or omnidirectional lens (distortion "equidistant" or "omnidir") has no pinhole
image beyond 90 degrees: it is drawn through bearings instead (ibvs.vision.rays: each pixel's ray,
CameraModel.to_bearing, met with the target's plane, then one remap of the texture), and the
pixels outside its image circle (where to_bearing refuses) are black (0, without noise). A textured
plate (kind "texture": any image, or ibvs.vision.texture's procedural one) is the same pyramid built from
the image resampled to the plate's texels. A lighting change (gain, offset) scales and shifts the scene's
gray levels (plate and background) before the sensor noise and the 8-bit quantisation. Dots are
drawn with anti-aliased edges (coverage of each texel), so that the intensity
centroid of a rendered dot is the area centroid of the dot's image (see tests/python/test_vision.py:
that, not the projection of the dot's centre, is what a centroid can be compared with; they differ
by the perspective and distortion of a finite disc, up to about 0.1 px at 15 px radius).
"""

from __future__ import annotations

import math
from typing import Optional, Tuple

import numpy as np

from ..finite import finite_within

from .._core import se3_exp
from .._core import sim as _sim
from .images import camera_image_size, check_real, opencv
from .rays import WIDE_MODELS, Rays
from .tag import TAG_DICTIONARIES
from .textures import load_texture
from .textures import texture as procedural_texture

# What ibvs.vision re-exports (and documents); the other names here are its own helpers.
__all__ = ["KINDS", "Renderer"]

#: What the renderer draws: white dots on a dark plate, a square fiducial tag, or one white blob on a dark
#: plate: the disc whose rim holds the target's points ("disc") or the polygon whose vertices they are
#: ("polygon"), for image moments and ellipses (ibvs.vision.blob), or a textured plate: an image spanning
#: the rectangle of the target's points ("texture"), for natural features and photometric servoing.
KINDS = ("dots", "tag", "disc", "polygon", "texture")


class Renderer:
    """Grayscale images of a planar target as the camera sees it.

    Renderer(camera, target, kind="dots", dot_radius=None, tag_id=0, dictionary="apriltag_36h11",
             blur=0.0, exposure=0.0, noise=0.0, seed=0, texture=None, gain=1.0, offset=0.0)
      camera       an ibvs.CameraModel with a pixel sensor (any distortion); images are its size
      target       an ibvs.sim.Target whose points lie in its z = 0 plane
      kind         "dots": a white dot (radius dot_radius, m; default a tenth of the smallest
                   distance between points) at every point, on a dark plate;
                   "tag": a square marker of `dictionary` (AprilTag 36h11) with id tag_id whose
                   outer corners are the target's 4 points, in cv2.aruco's order (top-left,
                   top-right, bottom-right, bottom-left as seen by the camera: (-,-), (+,-),
                   (+,+), (-,+) in the target frame, the order of Target.square), on a white plate;
                   "disc": one white disc on a dark plate, the disc whose rim holds the target's points
                   (its centre their mean, its radius their distance from it: points on a circle);
                   "polygon": one white filled polygon whose vertices are the target's points, in order;
                   "texture": the image `texture` spanning the axis-aligned rectangle of the target's
                   points (e.g. Target.square(side): its corners are the image's corners; image column
                   along the target's x, row along its y, pixel (0, 0) at the (-, -) corner) on a dark
                   plate; the image is resampled to the texture's 2048 texels along its longer side
                   (square texels: the shorter side is stretched by at most half a texel to fit)
      texture      kind "texture": a path to an image file (cv2.imread: PNG, JPEG, ...; colour becomes
                   gray), a numpy array (2-D gray or (h, w, 3) BGR, gray levels in [0, 255]), or None:
                   ibvs.vision.texture() (procedural, 512x512, seed 0)
      blur         defocus: std (px) of a Gaussian blur, 0 = sharp
      exposure     motion blur: exposure time (s) over which render(pose, twist) averages the
                   camera moving with `twist` (5 sub-frames), 0 = none
      noise        sensor noise: std of additive Gaussian noise in gray levels, then 8-bit quantisation
      seed         of the noise (a numpy default_rng); reseed() restarts it
      gain, offset a lighting change: every gray level g of the scene becomes gain g + offset before
                   the noise (set_lighting changes it between frames)
      background   gray level around the plate (default: the kind's, 10 for dots, blobs and textures, 90
                   for a tag), e.g. 0 for photometric moments (a plate seen whole on a black background)
    A fisheye or omnidirectional camera (distortion "equidistant" or "omnidir": wide is True) is drawn
    through each pixel's bearing, over its whole field of view (beyond 90 degrees off the axis); mask
    is then its image circle (255 inside; the pixels outside are black), or None when every pixel sees.
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
        texture=None,
        gain: float = 1.0,
        offset: float = 0.0,
        background: Optional[float] = None,
    ):
        cv2 = opencv()
        self.size = camera_image_size(camera)
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
        self.blur = check_real(blur, "blur", 0.0, 100.0)
        self.exposure = check_real(exposure, "exposure", 0.0, 10.0)
        self.noise = check_real(noise, "noise", 0.0, 255.0)
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise TypeError(f"seed must be a non-negative int, got {seed!r}")
        self.reseed(int(seed))
        self.set_lighting(gain, offset)
        if texture is not None and kind != "texture":
            raise ValueError(f"texture: only kind 'texture' has one, got kind {kind!r}")
        xy = np.asarray(target.points)[:, :2]
        if kind == "dots":
            d = np.linalg.norm(xy[:, None] - xy[None], axis=-1)
            closest = d[~np.eye(len(xy), dtype=bool)].min() if len(xy) > 1 else 0.1
            if closest <= 0:
                raise ValueError("target: two points coincide; their dots cannot be drawn apart")
            self.dot_radius = (
                0.1 * closest if dot_radius is None else check_real(dot_radius, "dot_radius", 0.0, 10.0)
            )
            if not (0 < self.dot_radius < 0.5 * closest):
                raise ValueError(
                    f"dot_radius must be in (0, {0.5 * closest:g}) m "
                    "(half the smallest distance between points), "
                    f"got {self.dot_radius!r}"
                )
            lo, hi = xy.min(0) - 3 * self.dot_radius, xy.max(0) + 3 * self.dot_radius
            self.background = self.BACKGROUND
        elif kind in ("disc", "polygon"):
            self.dot_radius = None
            self._disc = _disc_of(xy) if kind == "disc" else None
            flat = len(xy) < 3 or abs(_shoelace(xy)) <= 1e-12 * max(np.ptp(xy), 1e-300) ** 2
            if kind == "polygon" and flat:
                raise ValueError("target: a polygon needs 3 or more points enclosing a nonzero area")
            margin = 0.15 * max(float(np.ptp(xy, axis=0).max()), 1e-9)
            lo, hi = xy.min(0) - margin, xy.max(0) + margin
            self.background = self.BACKGROUND
        elif kind == "texture":
            self.dot_radius = None
            lo, hi = xy.min(0), xy.max(0)
            if not np.all(hi - lo > 1e-9 * max(float(np.abs(xy).max()), 1.0)):
                raise ValueError(
                    "target: a textured plate is the rectangle of the target's points, which needs a nonzero "
                    "width and height in its z = 0 plane"
                )
            self._image = procedural_texture() if texture is None else load_texture(texture, "texture")
            self.background = self.BACKGROUND
        else:
            self.dot_radius = None
            if isinstance(tag_id, bool) or not isinstance(tag_id, (int, np.integer)) or tag_id < 0:
                raise TypeError(f"tag_id must be a non-negative int, got {tag_id!r}")
            if dictionary not in TAG_DICTIONARIES:
                raise ValueError(f"dictionary must be one of {tuple(TAG_DICTIONARIES)}, got {dictionary!r}")
            side = _tag_side(xy)
            self.tag_id, self.dictionary = int(tag_id), dictionary
            dic = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, TAG_DICTIONARIES[dictionary]))
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
        if background is not None:
            self.background = check_real(background, "background", 0.0, 255.0)
        self._build_texture(cv2, lo, hi, xy)
        self.wide = camera.distortion in WIDE_MODELS
        self._rays = Rays(camera, self.size) if self.wide else None
        #: (height, width) uint8, 255 where the lens images (inside a wide lens's image circle), or None
        #: (every pixel: a perspective model)
        self.mask = None if self._rays is None or self._rays.everywhere else self._rays.mask
        self._build_lens()
        self._target_pose = np.asarray(target.pose, dtype=np.float64)
        self._centre = np.append(xy.mean(0), 1.0)
        self._level_points = np.vstack([xy, xy.mean(0)])  # where a wide lens's texture level is chosen
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

    def set_lighting(self, gain: float = 1.0, offset: float = 0.0) -> None:
        """A lighting change from the next frame on: every gray level g of the scene becomes gain g + offset
        (before the sensor noise and the 8-bit quantisation, which saturates)."""
        self.gain = check_real(gain, "gain", 0.0, 100.0)
        self.offset = check_real(offset, "offset", -255.0, 255.0)

    def _lit(self, level: float) -> float:
        return self.gain * level + self.offset

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
        background = self._lit(self.background)
        if self.noise == 0:
            return None, np.full((H, W), int(np.clip(round(background), 0, 255)), np.uint8)
        if self._noise_table is None or self._noise_table[1] != (self.noise, background):
            table = self._rng.standard_normal((2 * H, 2 * W), dtype=np.float32)
            table *= np.float32(self.noise)
            quantised = cv2.add(table, np.full_like(table, background), dtype=cv2.CV_8U)
            self._noise_table = (table, (self.noise, background), quantised)
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
        elif self.kind == "disc":  # the dots' coverage, for one disc
            (x, y), R = self._disc
            tex = np.full((rows, cols), self.PLATE, np.float32)
            cx, cy, rad = (x - lo[0]) / d0 - 0.5, (y - lo[1]) / d0 - 0.5, R / d0
            cc, rr = np.meshgrid(np.arange(cols), np.arange(rows))
            cover = np.clip(0.5 + rad - np.hypot(cc - cx, rr - cy), 0.0, 1.0)
            tex += (self.DOT - self.PLATE) * cover.astype(np.float32)
        elif self.kind == "texture":  # the image resampled onto the plate's texels, top-left at lo
            tex = np.full((rows, cols), self.background, np.float32)
            n_c = min(max(int(round(extent[0] / d0)), 1), cols)
            n_r = min(max(int(round(extent[1] / d0)), 1), rows)
            img = self._image
            shrink = n_c < img.shape[1] or n_r < img.shape[0]
            tex[:n_r, :n_c] = np.clip(
                cv2.resize(img, (n_c, n_r), interpolation=cv2.INTER_AREA if shrink else cv2.INTER_CUBIC), 0, 255
            )
        elif self.kind == "polygon":  # anti-aliased fill, vertices to 1/256 texel
            mask = np.zeros((rows, cols), np.uint8)
            v = np.round(((xy - lo) / d0 - 0.5) * 256).astype(np.int32)
            cv2.fillPoly(mask, [v.reshape(-1, 1, 2)], 255, lineType=cv2.LINE_AA, shift=8)
            tex = self.PLATE + (self.DOT - self.PLATE) / 255.0 * mask.astype(np.float32)
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
        if cam.distortion == "none" or self.wide:
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
    def _plane(self, pose_wc: np.ndarray) -> Optional[np.ndarray]:
        """H = [r1 r2 t]: target plane (x, y, 1) -> the point in the camera frame (R, t: camera <- target),
        or None when the camera sees the plate's blank back (it is behind the plate's plane, or on it)."""
        T_wt = self._target_pose
        R_cw = pose_wc[:3, :3].T  # rigid inverse
        R = R_cw @ T_wt[:3, :3]
        t = R_cw @ (T_wt[:3, 3] - pose_wc[:3, 3])
        # the camera centre in the target frame is -R^T t: in front when its z < 0 (edge-on: no image)
        if not np.isfinite(t).all() or (R[:, 2] @ t) <= 1e-12 * max(1.0, float(np.linalg.norm(t))):
            return None
        return np.column_stack([R[:, 0], R[:, 1], t])

    def _homography(self, pose_wc: np.ndarray) -> Optional[np.ndarray]:
        """Target plane (x, y, 1) -> pinhole pixel, or None when the camera sees the plate's blank back."""
        H = self._plane(pose_wc)
        return None if H is None else self._K_pinhole @ H

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
        cv2 = opencv()
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
        if self.wide:
            return self._finish(cv2, self._region_wide(cv2, poses))
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
        return self._finish(cv2, region)

    def _region_wide(self, cv2, poses):
        """The plate through a wide lens: ((x0, y0, x1, y1), float32 gray levels) of the sensor pixels it
        may cover, the mean over the exposure's poses, or None when no pose sees its front."""
        Hs = [self._plane(p) for p in poses]
        visible = [H for H in Hs if H is not None]
        if not visible:
            return None
        rays = self._rays
        boxes = [rays.box(H, self._corners) for H in visible]
        box = tuple(int(f(v)) for f, v in zip((min, min, max, max), zip(*boxes)))
        if not (box[2] > box[0] and box[3] > box[1]):
            return None
        # one texture level for the frame: about 0.7 image pixel per texel or more at the target's point
        # imaged smallest (a wide lens's scale varies much over a plate; finer texels there would alias)
        ppm = rays.pixels_per_metre(visible[0], self._level_points)
        level = 0 if ppm is None else int(
            np.clip(math.ceil(math.log2(0.7 / max(ppm * self._d0, 1e-12))), 0, self.LEVELS - 1)
        )
        d = self._d0 * 2**level
        S = np.array([[d, 0, self._origin[0] + 0.5 * d], [0, d, self._origin[1] + 0.5 * d], [0, 0, 1.0]])
        pixels = None
        for H in visible:
            mx, my = rays.maps(cv2, np.linalg.inv(H @ S), box)
            img = cv2.remap(self._pyramid[level], mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                            borderValue=float(self.background))
            pixels = img if pixels is None else pixels + img
        if len(Hs) > 1:  # motion blur: sub-frames seeing the plate's back see the background
            pixels += float(self.background) * (len(Hs) - len(visible))
            pixels *= 1.0 / len(Hs)
        return box, pixels

    def _finish(self, cv2, region) -> np.ndarray:
        """The frame from the plate's region (or None): blur, noise, 8-bit quantisation, the image circle."""
        out = self._finish_rect(cv2, region)
        if self._rays is not None and not self._rays.everywhere:
            cv2.bitwise_and(out, self._rays.mask, dst=out)
        return out

    def _finish_rect(self, cv2, region) -> np.ndarray:
        """The sensor's frame: the background with the plate's region, blurred, noisy, quantised."""
        W, H = self.size
        noise, out = self._noise(cv2)
        if region is not None and (self.gain != 1 or self.offset != 0):
            box, pixels = region
            region = (box, pixels * np.float32(self.gain) + np.float32(self.offset))
        if self.blur > 0:  # defocus spreads the plate over the background: the whole frame in float
            img = np.full((H, W), self._lit(self.background), np.float32)
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
            if self.kind == "tag"
            else f"disc r={self._disc[1]:g} m"
            if self.kind == "disc"
            else f"texture {self._image.shape[1]}x{self._image.shape[0]}"
            if self.kind == "texture"
            else f"polygon of {len(self.target)} vertices"
        )
        light = "" if (self.gain, self.offset) == (1.0, 0.0) else f", gain={self.gain:g}, offset={self.offset:g}"
        return (
            f"Renderer({what}, {self.size[0]}x{self.size[1]}, blur={self.blur:g} px, "
            f"exposure={self.exposure:g} s, "
            f"noise={self.noise:g}{light})"
        )


def _shoelace(xy: np.ndarray) -> float:
    """The signed area of the polygon whose vertices are xy (N, 2), in order."""
    x, y = xy[:, 0], xy[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _disc_of(xy: np.ndarray) -> Tuple[np.ndarray, float]:
    """The centre and radius of the circle through the points xy (N, 2), N >= 3, or a clear error."""
    if len(xy) < 3:
        raise ValueError(f"target: a disc's rim needs 3 or more points, the target has {len(xy)}")
    c = xy.mean(0)
    r = np.linalg.norm(xy - c, axis=1)
    R = float(r.mean())
    if not (R > 0) or not finite_within(r - R, 1e-9 * R):
        raise ValueError(
            "target: a disc's points must lie on a circle about their mean in the target's z = 0 plane "
            "(e.g. evenly spaced on its rim)"
        )
    return c, R


def _tag_side(xy: np.ndarray) -> float:
    """The side of the square the 4 points form in cv2.aruco's corner order, or a clear error."""
    if len(xy) != 4:
        raise ValueError(f"target: a tag has 4 corners; the target has {len(xy)} points")
    side = np.linalg.norm(xy[1] - xy[0])
    c = xy.mean(0)
    expected = c + side / 2 * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]])
    if not (side > 0) or not finite_within(xy - expected, 1e-9 * max(side, 1.0)):
        raise ValueError(
            "target: a tag's points must be the corners of an axis-aligned square in the target's "
            "z = 0 plane, "
            "in the order (-,-), (+,-), (+,+), (-,+) (Target.square)"
        )
    return float(side)


def lighting_pair(renderer: Renderer, lighting):
    """((goal gain, offset), (episode gain, offset)): the renderer's own, then `lighting` (checked)."""
    goal = (renderer.gain, renderer.offset)
    if lighting is None:
        return goal, goal
    if not isinstance(lighting, (tuple, list)) or len(lighting) != 2:
        raise ValueError(f"lighting must be None or (gain, offset), got {lighting!r}")
    renderer.set_lighting(*lighting)  # checks it
    episode = (renderer.gain, renderer.offset)
    renderer.set_lighting(*goal)
    return goal, episode
