"""Target poses from images: the camera <- target pose of a planar target at each station, from its points in pixels
(dots, a chessboard's corners, a tag's corners), through the camera model and ibvs.PlanarPose.

    points = ibvs.calibration.tag_points(0.1)                     # a 10 cm tag's corners, cv2.aruco's order
    poses, kept = ibvs.calibration.target_poses(camera, detections, points)
    result = ibvs.calibrate_hand_eye(robot_poses[kept], poses)

PlanarPose: the homography of the normalised points (undistorted by camera.normalize) started, then Gauss-Newton
steps on the reprojection error in normalised coordinates. Numpy and the compiled core only (no OpenCV).
"""

from __future__ import annotations

import math

import numpy as np

from ..finite import finite_within

from .._core import CameraModel, PlanarPose

__all__ = ["tag_points", "target_pose", "target_poses"]


def tag_points(side: float) -> np.ndarray:
    """(4, 3) the outer corners of a square tag of `side` metres in its own frame (z = 0, centred), in cv2.aruco's
    order as the camera sees the tag from the front: top-left, top-right, bottom-right, bottom-left = (-,-), (+,-),
    (+,+), (-,+); the order of ibvs.sim.Target.square, ibvs.vision.Renderer(kind="tag") and TagDetector."""
    if isinstance(side, bool) or not isinstance(side, (int, float, np.integer, np.floating)):
        raise TypeError(f"side must be a real number (metres), got {type(side).__name__}")
    if not (math.isfinite(side) and 0 < side <= 1e3):
        raise ValueError(f"side must be a finite length in (0, 1000] metres, got {side!r}")
    h = float(side) / 2
    return np.array([[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]])


def _points(points) -> np.ndarray:
    if isinstance(points, (str, bytes)) or points is None:
        raise TypeError(f"points must be an (N, 3) array of numbers, got {type(points).__name__}")
    p = np.asarray(points)
    if p.dtype.kind not in "iuf":
        raise TypeError(f"points must hold real numbers, got {p.dtype}")
    if p.ndim != 2 or p.shape[1] != 3 or len(p) < 4:
        raise ValueError(f"points must have shape (N, 3) with N >= 4 (the target's points, metres), got {p.shape}")
    if not finite_within(p, 1e3):
        raise ValueError("points must be finite, within 1000 m")
    if not finite_within(p[:, 2], 1e-9):
        raise ValueError("points must lie in the target's z = 0 plane (a planar target)")
    return p.astype(float)


def _pixels(pixels, n: int, name: str) -> np.ndarray:
    pixels = getattr(pixels, "pixels", pixels)  # an ibvs.vision.Track
    if isinstance(pixels, (str, bytes)) or pixels is None:
        raise TypeError(f"{name} must be an (N, 2) array of pixels, got {type(pixels).__name__}")
    px = np.asarray(pixels)
    if px.dtype.kind not in "iuf":
        raise TypeError(f"{name} must hold real numbers, got {px.dtype}")
    if px.shape not in ((n, 2), (n, 1, 2)):
        raise ValueError(f"{name} must have shape ({n}, 2), one pixel per point of the target, got {px.shape}")
    return px.reshape(n, 2).astype(float)


def _pose(camera: CameraModel, px: np.ndarray, estimator: PlanarPose, name: str) -> np.ndarray:
    if np.isinf(px).any() or np.abs(px[np.isfinite(px)]).max(initial=0.0) > 1e7:
        raise ValueError(f"{name}: pixels must be finite (NaN for a point not measured) and within 1e7 px")
    try:
        uv = camera.normalize(px)
    except ValueError as e:
        raise ValueError(f"{name}: {e}") from None
    spread = np.linalg.svd(px - px.mean(0), compute_uv=False)  # in pixels: points seen on a line have no pose
    pose, depth, degenerate = estimator.estimate(uv)
    if not spread[1] > 1e-3 * spread[0] or degenerate or not np.isfinite(pose).all() or \
            not (np.asarray(depth) > 0).all():
        raise ValueError(f"{name}: no pose of the planar target fits these pixels (collinear points, the target seen "
                         "edge-on or from behind)")
    return np.asarray(pose, dtype=float)


def target_pose(camera: CameraModel, pixels, points) -> np.ndarray:
    """(4, 4) camera <- target: the pose of a planar target (points (N, 3) in its z = 0 plane, metres, N >= 4) whose
    points the camera sees at `pixels` (N, 2), or an ibvs.vision.Track. ValueError naming the argument when a pixel is
    not finite, the camera model cannot undistort it, or no pose fits (collinear points, seen edge-on)."""
    if not isinstance(camera, CameraModel):
        raise TypeError(f"camera must be an ibvs.CameraModel, got {type(camera).__name__}")
    p = _points(points)
    px = _pixels(pixels, len(p), "pixels")
    if not np.isfinite(px).all():
        raise ValueError("pixels must be finite: every point measured (target_poses drops stations with lost points)")
    return _pose(camera, px, PlanarPose(p), "pixels")


def target_poses(camera: CameraModel, detections, points, min_points: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """The target's pose at each station from its detections: (poses (M, 4, 4) camera <- target, kept (N,) bool).

    detections: one entry per station, each (N_points, 2) pixels with NaN rows for points not found (a tracker's
    or TagDetector's output; an ibvs.vision.Track is read by its .pixels), or None for a station where nothing was
    found. points: (N_points, 3) the target's points in its z = 0 plane (tag_points for a tag). A station is kept
    when at least min_points (>= 4) of its points were found and a pose fits them; kept[i] says which, so that
    robot_poses[kept] pairs with poses. Refuses (ValueError / TypeError naming the argument) detections of the
    wrong shape, infinite pixels, and no station kept.
    """
    if not isinstance(camera, CameraModel):
        raise TypeError(f"camera must be an ibvs.CameraModel, got {type(camera).__name__}")
    p = _points(points)
    if isinstance(min_points, bool) or not isinstance(min_points, (int, np.integer)):
        raise TypeError(f"min_points must be an int, got {type(min_points).__name__}")
    if not 4 <= min_points <= len(p):
        raise ValueError(f"min_points must be in [4, {len(p)}] (the target's points), got {min_points}")
    if isinstance(detections, (str, bytes)) or not hasattr(detections, "__len__"):
        raise TypeError(f"detections must be a sequence with one entry per station, got {type(detections).__name__}")
    poses, kept = [], np.zeros(len(detections), dtype=bool)
    for i, d in enumerate(detections):
        if d is None:
            continue
        px = _pixels(d, len(p), f"detections[{i}]")
        if np.isinf(px).any():
            raise ValueError(f"detections[{i}]: pixels must be finite (NaN for a point not found), got an infinity")
        found = np.isfinite(px).all(axis=1)
        if found.sum() < min_points:
            continue
        try:
            poses.append(_pose(camera, px[found], PlanarPose(p[found]), f"detections[{i}]"))
        except ValueError as e:
            if "no pose" not in str(e):
                raise
            continue  # this station's points admit no pose: dropped, as kept says
        kept[i] = True
    if not kept.any():
        raise ValueError(f"detections: no station has {min_points} points found with a pose fitting them")
    return np.array(poses), kept
