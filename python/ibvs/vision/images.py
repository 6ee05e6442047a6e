"""Cameras that have images and the images themselves: the OpenCV import, image sizes and checks
shared by the renderer, the trackers and the video writer."""

from __future__ import annotations

import math
from typing import Tuple

import numpy as np

from .._core import CameraModel

# What ibvs.vision re-exports (and documents); the other names here are its own helpers.
__all__ = ["image_camera", "check_image"]


def opencv():
    """The cv2 module, or an ImportError saying how to install it."""
    try:
        import cv2
    except ImportError as e:  # pragma: no cover - the test extra installs it
        raise ImportError(
            "ibvs.vision needs OpenCV (opencv-contrib-python-headless): "
            'pip install ".[vision]" from the ibvs repository root'
        ) from e
    return cv2


def check_real(x, name: str, lo: float = 0.0, hi: float = math.inf) -> float:
    """x as a float, or a TypeError (not a real number) or ValueError (outside [lo, hi]) naming it."""
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a real number, got {type(x).__name__}")
    x = float(x)
    if not (lo <= x <= hi):
        raise ValueError(f"{name} must be finite and in [{lo:g}, {hi:g}], got {x!r}")
    return x


def check_int(x, name: str, lo: int, hi: int) -> int:
    """x as an int in [lo, hi], or a ValueError naming it (a bool is not an int here)."""
    if isinstance(x, bool) or not isinstance(x, (int, np.integer)) or not lo <= x <= hi:
        raise ValueError(f"{name} must be an int in [{lo}, {hi}], got {x!r}")
    return int(x)


def camera_image_size(camera) -> Tuple[int, int]:
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
        camera_image_size(camera)
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
