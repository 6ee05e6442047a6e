"""The renderer's wide-lens path: every sensor pixel's ray, intersected with the target's plane.

A fisheye or omnidirectional lens (CameraModel distortion "equidistant" or "omnidir") sees up to and
beyond 90 degrees off its axis, where no pinhole image exists to warp. Rays precomputes, once, the
unit bearing b of every sensor pixel's centre (CameraModel.to_bearing) and the image circle: the
pixels the model maps (inside its fold radius), the others receive no light. Per frame, the ray
through a pixel meets the target's z = 0 plane where

    lambda b = R (x, y, 0) + t = H (x, y, 1),   H = [r1 r2 t]   (R, t: camera <- target)

so (x, y, 1) ~ H^-1 b, in front of the camera when (H^-1 b)_z > 0 (lambda > 0). With S the map from a
texture level's texel indices to plane metres, M = S^-1 H^-1 gives each pixel's texel coordinates
(M b)_xy / (M b)_z: one cv2.transform and two divisions, then cv2.remap samples the texture (bilinear).
"""

from __future__ import annotations

import math
from typing import Optional, Tuple

import numpy as np

__all__: list = []  # helpers of ibvs.vision.renderer

#: The models the renderer draws through bearings (the others through a pinhole image and normalize).
WIDE_MODELS = ("equidistant", "omnidir")


class Rays:
    """Per-pixel bearings of a camera's sensor (float32, (height, width, 3); 0 outside the image
    circle) and the circle's mask (uint8, 255 inside)."""

    EDGE_SAMPLES = 64  # points per side of the plate's outline mapped to find the pixels it covers

    def __init__(self, camera, size: Tuple[int, int]):
        w, h = size
        self.camera, self.size = camera, size
        uu, vv = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
        b = camera.to_bearing(np.column_stack([uu.ravel(), vv.ravel()]), invalid="nan")
        inside = np.isfinite(b[:, 0])
        b[~inside] = 0.0
        self.bearings = np.ascontiguousarray(b.reshape(h, w, 3).astype(np.float32))
        self.mask = (inside.reshape(h, w) * 255).astype(np.uint8)
        self.everywhere = bool(inside.all())
        self._t = np.linspace(0.0, 1.0, self.EDGE_SAMPLES)

    def pixels_per_metre(self, H: np.ndarray, xy: np.ndarray) -> Optional[float]:
        """The smallest sqrt |det d pixel / d (x, y)| over the plane points xy (N, 2) that are imaged
        (central differences of 1 mm), or None when none is."""
        e = 1e-3
        steps = np.array([[e, 0], [-e, 0], [0, e], [0, -e]])
        q = (xy[:, None, :] + steps[None]).reshape(-1, 2)
        rays = np.column_stack([q, np.ones(len(q))]) @ H.T
        px = self.camera.from_bearing(rays, invalid="nan").reshape(-1, 4, 2)
        J = np.stack([px[:, 0] - px[:, 1], px[:, 2] - px[:, 3]], axis=-1) / (2 * e)  # (N, 2, 2)
        ppm = np.sqrt(np.abs(np.linalg.det(J)))
        ppm = ppm[np.isfinite(ppm)]
        return float(ppm.min()) if ppm.size else None

    def box(self, H: np.ndarray, corners: np.ndarray) -> Tuple[int, int, int, int]:
        """The sensor pixels (x0, y0, x1, y1) that can see the plate (corners (4, 3): its outline in the
        plane, homogeneous): the box of its outline's images plus a margin; the whole sensor when part of
        the outline is not imaged or the plate holds the direction opposite the axis (there the image of
        the outline need not enclose the plate's)."""
        W, Hs = self.size
        t = self._t[:, None]
        outline = np.concatenate([c0 + t * (c1 - c0) for c0, c1 in zip(corners, np.roll(corners, -1, 0))])
        px = self.camera.from_bearing(outline @ H.T, invalid="nan")
        back = np.linalg.solve(H, [0.0, 0.0, -1.0])  # the plane point on the ray -z, if it meets the plane
        lo, hi = corners[:, :2].min(0), corners[:, :2].max(0)
        holds_back = back[2] > 0 and np.all((back[:2] / back[2] >= lo) & (back[:2] / back[2] <= hi))
        if not np.isfinite(px).all() or holds_back:
            return 0, 0, W, Hs
        x0, y0 = np.clip(np.floor(px.min(0)) - 4, 0, [W, Hs]).astype(int)
        x1, y1 = np.clip(np.ceil(px.max(0)) + 5, 0, [W, Hs]).astype(int)
        return int(x0), int(y0), int(x1), int(y1)

    def maps(self, cv2, M: np.ndarray, box: Tuple[int, int, int, int]) -> Tuple[np.ndarray, np.ndarray]:
        """cv2.remap's maps over box: the texel coordinates (M b)_xy / (M b)_z of each pixel's bearing b,
        -1e6 (off the texture: the background) where the ray misses the plane in front of the camera."""
        x0, y0, x1, y1 = box
        x, y, z = cv2.split(cv2.transform(self.bearings[y0:y1, x0:x1], M.astype(np.float32)))
        miss = z <= 1e-12
        np.copyto(z, 1.0, where=miss)
        mx, my = cv2.divide(x, z), cv2.divide(y, z)
        np.copyto(mx, -1e6, where=miss)
        np.copyto(my, -1e6, where=miss)
        return mx, my
