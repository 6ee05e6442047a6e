"""Exact images of a textured plane for the photometric tests (no interpolation, no quantisation).

The plane is Z = depth in the world frame (the goal camera's frame: the goal camera looks at it
fronto-parallel from the origin). A camera at pose T (world <- camera, 4 x 4) sees, at pixel (u, v),
the texture at the point where the pixel's ray meets the plane: every pixel is the texture function
evaluated exactly there, so the images are smooth functions of the pose and their central differences
are limited only by the step (not by a renderer's interpolation or 8-bit levels).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

Texture = Callable[[np.ndarray, np.ndarray], np.ndarray]


def waves(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """A smooth, non-periodic-looking texture (metres in, intensities in about [30, 230] out): three
    plane waves of wavelengths 6-11 cm and a bump, so that every direction has gradient."""
    return (
        130.0
        + 40.0 * np.sin(2 * np.pi * (X / 0.11 + Y / 0.37) + 0.3)
        + 30.0 * np.sin(2 * np.pi * (Y / 0.09 - X / 0.29) + 1.1)
        + 20.0 * np.cos(2 * np.pi * (X + Y) / 0.07)
        + 30.0 * np.exp(-((X - 0.02) ** 2 + (Y + 0.03) ** 2) / 0.002)
    )


def ramp(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """Intensity linear in the plane's coordinates plus a gentle curvature: an image whose gradient the
    7-tap filter computes almost exactly (the filter is exact on linear ramps)."""
    return 120.0 + 300.0 * X - 200.0 * Y + 400.0 * X * Y + 150.0 * X * X


def patch(X: np.ndarray, Y: np.ndarray, half: float = 0.06) -> np.ndarray:
    """A textured patch on a black background: `waves` times a window that falls smoothly to 0 at
    |X|, |Y| = half (cos^2 taper over its outer 40 %), 0 outside: the zero-intensity border of
    photometric moments."""

    def window(t: np.ndarray) -> np.ndarray:
        a = np.clip((np.abs(t) - 0.6 * half) / (0.4 * half), 0.0, 1.0)
        return np.cos(0.5 * np.pi * a) ** 2

    w = window(X - 0.01) * window(Y + 0.005)
    return waves(X, Y) * w * (1.0 + 0.8 * np.clip(X / half, -1, 1))


def render(T: np.ndarray, K: np.ndarray, size: tuple[int, int], depth: float, texture: Texture) -> np.ndarray:
    """The image (height, width), float64, of the plane Z = depth seen by a camera at pose T."""
    w, h = size
    u, v = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    d = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], axis=-1) @ T[:3, :3].T
    s = (depth - T[2, 3]) / d[..., 2]
    return texture(T[0, 3] + s * d[..., 0], T[1, 3] + s * d[..., 1])


def plane_in_camera(T: np.ndarray, depth: float) -> np.ndarray:
    """(A, B, C) of 1/Z = A x + B y + C for the plane Z = depth seen from pose T."""
    n_c = T[:3, :3].T @ np.array([0.0, 0.0, 1.0])  # the plane's normal in the camera frame
    dist = depth - T[2, 3]  # n . (P - camera centre) for the plane's points
    return n_c / dist


def moved(T: np.ndarray, k: int, h: float) -> np.ndarray:
    """T moved by h along the camera-frame twist component k (0-2 translation, 3-5 rotation), exactly."""
    M = np.eye(4)
    if k < 3:
        M[k, 3] = h
    else:
        a = np.zeros(3)
        a[k - 3] = h
        th = np.linalg.norm(a)
        n = a / th
        S = np.array([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
        M[:3, :3] = np.eye(3) + np.sin(th) * S + (1 - np.cos(th)) * S @ S
    return T @ M
