"""Reader of camera calibration files: what ibvs.CameraModel.from_yaml reads (read(path) -> K, dist, size).

Two layouts, both read with OpenCV's cv2.FileStorage (the ``vision`` extra):

* ROS ``camera_info`` YAML (camera_calibration / camera_info_manager)::

      image_width: 640
      image_height: 480
      camera_matrix: {rows: 3, cols: 3, data: [fx, 0, cx, 0, fy, cy, 0, 0, 1]}
      distortion_model: plumb_bob          # or equidistant (fisheye), rational_polynomial
      distortion_coefficients: {rows: 1, cols: 5, data: [k1, k2, p1, p2, k3]}

* OpenCV's own calibration output (cv::FileStorage YAML, XML or JSON, as written by OpenCV's
  calibration sample): the same keys, the matrices as ``!!opencv-matrix``, and an optional
  ``fisheye_model: 1`` instead of distortion_model.

* Mei's unified omnidirectional model (cv2.omnidir, Kalibr's "omni"): ``distortion_model: omnidir``
  (or ``mei``, ``omni``), ``xi: 1.2`` and distortion_coefficients (k1, k2, p1, p2).

The frame rate (the simulator's control period is 1 / fps) is rarely in such files: read(path, fps)
takes the fps given, else the file's own ``fps`` or ``frame_rate`` key, else DEFAULT_FPS with a
UserWarning that says so.

Why cv2.FileStorage and not PyYAML: OpenCV writes a ``%YAML:1.0`` directive and
``!!opencv-matrix`` tags that a standard YAML parser rejects, while FileStorage reads both
OpenCV's files and plain YAML such as ROS's (a header is added to a file that lacks one, as
older OpenCV releases require it). The renderer and tracker of ibvs use OpenCV anyway, so one
optional dependency covers both.
"""

from __future__ import annotations

import math
import os
import warnings

import numpy as np

#: The frame rate from_yaml uses when neither its fps= nor the file states one (with a warning).
DEFAULT_FPS = 60.0
#: Keys of a frame rate in a calibration file, in the order they are looked for.
FPS_KEYS = ("fps", "frame_rate")

_FISHEYE = ("equidistant", "fisheye")
_OMNIDIR = ("omnidir", "mei", "omni", "unified")
_PLUMB_BOB = ("plumb_bob", "radtan", "rational_polynomial", "none", "")


def _cv2():
    try:
        import cv2
    except ImportError as e:  # pragma: no cover - the test extra installs it
        raise ImportError(
            'CameraModel.from_yaml reads calibration files with OpenCV: '
            'pip install ".[vision]" from the ibvs repository root'
        ) from e
    return cv2


def _matrix(node, key: str, path: str) -> np.ndarray:
    """A {rows, cols, data} map (ROS) or an !!opencv-matrix (OpenCV) as a (rows, cols) array."""
    if node.empty() or node.isNone():
        raise ValueError(f"path: {path} has no '{key}'")
    if not node.isMap():
        raise ValueError(f"path: {path}: '{key}' must be a map with rows, cols and data")
    data = node.getNode("data")
    if not data.isSeq():
        raise ValueError(f"path: {path}: '{key}' has no data list")
    values = np.array([data.at(i).real() for i in range(data.size())], dtype=float)
    rows, cols = node.getNode("rows"), node.getNode("cols")
    if not (rows.isInt() or rows.isReal()) or not (cols.isInt() or cols.isReal()):
        raise ValueError(f"path: {path}: '{key}' needs integer rows and cols")
    r, c = int(rows.real()), int(cols.real())
    if r * c != values.size:
        raise ValueError(f"path: {path}: '{key}' has {values.size} values for {r}x{c}")
    return values.reshape(r, c)


def _number(fs, key: str, path: str) -> float:
    node = fs.getNode(key)
    if not (node.isInt() or node.isReal()):
        raise ValueError(f"path: {path} needs a number '{key}'")
    return float(node.real())


def _frame_rate(fs, path: str, fps):
    """The fps given, else the file's (FPS_KEYS), else DEFAULT_FPS with a UserWarning."""
    if fps is not None:
        return fps
    for key in FPS_KEYS:
        node = fs.getNode(key)
        if node.empty() or node.isNone():
            continue
        if not (node.isInt() or node.isReal()) or not (math.isfinite(node.real()) and node.real() > 0):
            raise ValueError(f"path: {path}: '{key}' must be a frame rate > 0 (frames per second)")
        return float(node.real())
    # stacklevel 3: past read(), the caller of CameraModel.from_yaml (the C++ binding has no Python frame)
    warnings.warn(f"CameraModel.from_yaml: {path} states no frame rate ({' or '.join(FPS_KEYS)}); the camera "
                  f"runs at {DEFAULT_FPS:g} fps (pass fps=... to say which)", UserWarning, stacklevel=3)
    return DEFAULT_FPS


def read(path, fps=None) -> dict:
    """K (3, 3), dist (n,), width, height, fisheye (bool), xi (omnidir, else None) and fps from a calibration file.

    fps: the frame rate to use (returned as given), or None: the file's fps or frame_rate, else
    DEFAULT_FPS with a UserWarning naming the file."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike, got {type(path).__name__}")
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise FileNotFoundError(f"path: no such calibration file: {path}")
    cv2 = _cv2()
    with open(path, "rb") as f:
        text = f.read().decode("utf-8", errors="replace")
    stripped = text.lstrip("\ufeff \t\r\n")
    if not stripped.startswith(("%YAML", "<?xml", "{")):  # plain YAML (ROS): add FileStorage's header
        text = "%YAML:1.0\n" + text
    try:
        fs = cv2.FileStorage(text, cv2.FILE_STORAGE_READ | cv2.FILE_STORAGE_MEMORY)
    except Exception as e:  # cv2.error, or SystemError wrapping it
        raise ValueError(f"path: {path} is not a YAML/XML/JSON file OpenCV can read: {e}") from None
    if not fs.isOpened():
        raise ValueError(f"path: {path} could not be read by cv2.FileStorage")
    try:
        K = _matrix(fs.getNode("camera_matrix"), "camera_matrix", path)
        if K.shape != (3, 3):
            raise ValueError(f"path: {path}: camera_matrix must be 3x3, got {K.shape[0]}x{K.shape[1]}")
        dnode = fs.getNode("distortion_coefficients")
        absent = dnode.empty() or dnode.isNone()
        dist = np.zeros(0) if absent else _matrix(dnode, "distortion_coefficients", path)
        model_node = fs.getNode("distortion_model")
        model = model_node.string().strip().lower() if model_node.isString() else ""
        fisheye_node = fs.getNode("fisheye_model")
        flag = (fisheye_node.isInt() or fisheye_node.isReal()) and fisheye_node.real() != 0
        if model and model not in _FISHEYE + _PLUMB_BOB + _OMNIDIR:
            raise ValueError(
                f"path: {path}: distortion_model '{model}' is not supported "
                "(plumb_bob, equidistant / fisheye, omnidir / mei with xi, or rational_polynomial with k4 = k5 = k6 = 0)"
            )
        xi = None
        if model in _OMNIDIR:
            xi = _number(fs, "xi", path)
        return {
            "K": K,
            "dist": dist.ravel(),
            "width": _number(fs, "image_width", path),
            "height": _number(fs, "image_height", path),
            "fisheye": model in _FISHEYE or bool(flag),
            "xi": xi,
            "fps": _frame_rate(fs, path, fps),
        }
    finally:
        fs.release()
