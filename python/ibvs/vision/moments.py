"""Image moments of a binary image, in normalised coordinates, for ibvs.MomentsFeature.

OpenCV's ``cv2.moments`` gives the raw pixel moments up to order 3 (m00 ... m03); the interaction
matrix of the third-order features needs order 4, which this module sums from the image itself.
Each white pixel counts as one point at its centre (u, v) = (column, row), as ``cv2.moments(...,
binaryImage=True)`` counts it, or, with weights=True, with its value as its weight (grey-level moments, as
``cv2.moments(..., binaryImage=False)``: e.g. each pixel's coverage by an anti-aliased blob, which makes the
moments far less sensitive to the pixel grid than a binary mask's); the moments are then taken to normalised
coordinates x = (u - u0) / px, y = (v - v0) / py with the area element du dv / (px py).
"""

from __future__ import annotations

from math import comb

import numpy as np

__all__ = ["image_moments"]


def image_moments(mask, camera, weights: bool = False) -> np.ndarray:
    """Moments m00, m10, m01, m20, m11, m02, m30, ..., m04 (15,) of the non-zero pixels of `mask`.

    mask: a 2-D image (any dtype; non-zero = the object; weights=True: each pixel weighs its value, finite and
    >= 0, e.g. a blob's coverage in [0, 1]); camera: an ibvs.CameraModel without
    distortion (a distorted image would first need undistorting: ValueError). The result is the
    ``moments`` argument of ibvs.MomentsFeature.measure(moments, plane, "region", ...).
    """
    import cv2

    img = np.asarray(mask)
    if img.ndim != 2 or img.size == 0:
        raise ValueError(f"mask must be a non-empty 2-D image, got shape {img.shape}")
    if camera.distortion != "none":
        raise ValueError("camera: image_moments needs an undistorted image (camera.distortion == 'none')")
    if weights:
        w = img.astype(np.float32)
        if not (np.isfinite(w).all() and (w >= 0).all()):
            raise ValueError("mask: weights must be finite and >= 0")
        cv = cv2.moments(w, binaryImage=False)
    else:
        w = (img != 0).astype(np.uint8)
        cv = cv2.moments(w, binaryImage=True)
    pix = np.zeros((5, 5))
    for i in range(4):
        for j in range(4 - i):
            pix[i, j] = cv[f"m{i}{j}"]
    rows, cols = np.nonzero(w)
    u, v = cols.astype(float), rows.astype(float)
    wk = w[rows, cols].astype(float)
    for i in range(5):  # order 4: beyond OpenCV's
        pix[i, 4 - i] = float(np.sum(wk * u**i * v ** (4 - i)))
    px, py, u0, v0 = camera.px, camera.py, camera.u0, camera.v0
    out = np.zeros(15)
    for n in range(5):
        for j in range(n + 1):
            i = n - j
            s = 0.0
            for k in range(i + 1):
                for ll in range(j + 1):
                    s += comb(i, k) * comb(j, ll) * (-u0) ** (i - k) * (-v0) ** (j - ll) * pix[k, ll]
            out[n * (n + 1) // 2 + j] = s / (px ** (i + 1) * py ** (j + 1))
    return out
