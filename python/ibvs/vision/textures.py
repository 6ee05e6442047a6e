"""Textures for planar targets: the built-in procedural texture and the loading of any image as one.

texture(size, seed) draws a deterministic grayscale picture rich in gradients at several scales (for
photometric servoing, KLT points and keypoint matching) so that tests and docs need no downloaded file:
white noise smoothed by Gaussians of three widths (fine grain, blotches, shading), plus filled
discs, rectangles and line segments of random gray levels (sharp corners and edges for keypoints),
contrast-stretched to [20, 235]. Its content depends only on (size, seed) and OpenCV's drawing (the
same on every machine for the same OpenCV).
"""

from __future__ import annotations

import os
from typing import Tuple

import numpy as np

from ..finite import finite_within
from .images import opencv

# What ibvs.vision re-exports (and documents); the other names here are its own helpers.
__all__ = ["texture", "load_texture"]


def _size(size) -> Tuple[int, int]:
    if (
        not isinstance(size, (tuple, list))
        or len(size) != 2
        or not all(isinstance(s, (int, np.integer)) and not isinstance(s, bool) and 16 <= s <= 8192 for s in size)
    ):
        raise ValueError(f"size must be (width, height), ints in [16, 8192], got {size!r}")
    return int(size[0]), int(size[1])


def texture(size=(512, 512), seed: int = 0) -> np.ndarray:
    """A procedural grayscale texture, uint8 (height, width): smoothed noise at three scales plus random
    filled shapes (discs, rectangles, lines); the same picture for the same (size, seed)."""
    cv2 = opencv()
    w, h = _size(size)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise TypeError(f"seed must be a non-negative int, got {seed!r}")
    rng = np.random.default_rng(int(seed))
    s = min(w, h)
    img = np.zeros((h, w), np.float32)
    for sigma, weight in ((0.006 * s, 0.6), (0.03 * s, 1.0), (0.12 * s, 1.0)):  # fine, blotches, shading
        layer = cv2.GaussianBlur(rng.standard_normal((h, w)).astype(np.float32), (0, 0), max(sigma, 0.7),
                                 borderType=cv2.BORDER_REFLECT)
        img += np.float32(weight / max(float(layer.std()), 1e-12)) * layer
    img = (img - img.min()) / max(float(np.ptp(img)), 1e-12) * 255.0
    shapes = np.full((h, w), -1.0, np.float32)  # -1: no shape drawn here
    for _ in range(12):
        gray = float(rng.uniform(0, 255))
        cx, cy = (float(v) for v in rng.uniform([0, 0], [w, h]))
        r = float(rng.uniform(0.03, 0.1)) * s
        kind = int(rng.integers(0, 3))
        if kind == 0:
            cv2.circle(shapes, (int(cx), int(cy)), int(r), gray, -1, cv2.LINE_AA)
        elif kind == 1:
            a = float(rng.uniform(0, np.pi))
            box = cv2.boxPoints(((cx, cy), (2 * r, 1.3 * r), np.degrees(a))).astype(np.int32)
            cv2.fillPoly(shapes, [box], gray, cv2.LINE_AA)
        else:
            dx, dy = r * 2 * np.cos(rng.uniform(0, np.pi)), r * 2 * np.sin(rng.uniform(0, np.pi))
            cv2.line(shapes, (int(cx - dx), int(cy - dy)), (int(cx + dx), int(cy + dy)), gray,
                     max(int(0.012 * s), 1), cv2.LINE_AA)
    drawn = shapes >= 0
    img[drawn] = 0.35 * img[drawn] + 0.65 * shapes[drawn]  # the shapes keep a little of the grain
    img = cv2.GaussianBlur(img, (0, 0), 0.6)  # no edge sharper than a pixel: the texture resamples well
    img = 20.0 + (img - img.min()) / max(float(np.ptp(img)), 1e-12) * 215.0
    return np.round(img).astype(np.uint8)


def load_texture(source, name: str = "texture") -> np.ndarray:
    """A texture as a 2-D float32 array of gray levels in [0, 255]: source a path to an image file (PNG, JPEG,
    anything cv2.imread reads; colour is converted to gray) or a numpy array (2-D gray, or (h, w, 3) BGR;
    uint8 or float in [0, 255], finite), at least 2x2 pixels. Errors name `name`."""
    cv2 = opencv()
    if isinstance(source, (str, os.PathLike)):
        path = os.fspath(source)
        if not os.path.isfile(path):
            raise ValueError(f"{name}: no image file at {path!r}")
        img = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise ValueError(f"{name}: cv2.imread cannot read {path!r} as an image")
        return img.astype(np.float32)
    if not isinstance(source, np.ndarray):
        raise TypeError(f"{name} must be a path to an image file or a numpy array, got {type(source).__name__}")
    img = source
    if img.dtype.kind not in "uif" or img.dtype == np.bool_:
        raise TypeError(f"{name} must have a numeric dtype (uint8 or float gray levels), got {img.dtype}")
    if img.ndim == 3 and img.shape[2] in (3, 4):
        img = cv2.cvtColor(np.ascontiguousarray(img[:, :, :3]).astype(np.float32), cv2.COLOR_BGR2GRAY)
    if img.ndim != 2 or img.shape[0] < 2 or img.shape[1] < 2:
        raise ValueError(f"{name} must be a 2-D (height, width) or (height, width, 3) image of at least 2x2 "
                         f"pixels, got shape {source.shape}")
    img = img.astype(np.float32)
    if not (finite_within(img, np.inf) and np.all((img >= 0) & (img <= 255))):
        raise ValueError(f"{name}: gray levels must be finite and in [0, 255]")
    return img
