"""sensor_msgs/CameraInfo <-> ibvs.CameraModel.

Distortion models: "plumb_bob" (d = k1, k2, p1, p2, k3), "rational_polynomial" (k1, k2, p1, p2, k3, k4,
k5, k6: read when k4 = k5 = k6 = 0, as plumb_bob; refused otherwise, CameraModel has no rational model),
"equidistant" (k1..k4, OpenCV's fisheye), "" or "none" (d empty or zeros), and "visp" (kud, kdu: ibvs's
name for ViSP's model, e.g. CameraModel.afma6(); ROS tools do not know it), and "omnidir" (xi, k1, k2, p1,
p2: Mei's unified model, CameraModel.from_omnidir; also not a ROS standard). A camera without
distortion is written as plumb_bob with five zeros, the ROS convention.

Binning and region of interest are honoured as image_geometry does: the image published is the ROI
(full image when its width and height are 0) divided by binning_x / binning_y (0 and 1 both mean
none), so fx' = fx / bx, cx' = (cx - x_offset) / bx (and likewise for y), and the sensor is
roi.width / bx by roi.height / by pixels (refused unless the division is exact). A rectified ROI
(roi.do_rectify) is refused: ibvs servoes on the raw image.
"""

from __future__ import annotations

import numpy as np

from .._core import CameraModel
from . import types as t

# What ibvs.ros re-exports (and documents); the other names here are its own helpers.
__all__ = ["DISTORTION_MODELS", "camera_model", "camera_info"]

#: The distortion models camera_model() reads (and camera_info() writes), with their number of coefficients.
DISTORTION_MODELS = {"plumb_bob": 5, "rational_polynomial": 8, "equidistant": 4, "visp": 2, "omnidir": 5, "": None,
                     "none": None}


def camera_model(msg, fps: float = 60.0) -> CameraModel:
    """The CameraModel of a sensor_msgs/CameraInfo (any class with its fields), at `fps` frames per
    second (a CameraInfo has no rate). Errors name the field: a distortion model or d of the wrong
    length, a non-finite or malformed k, a zero width or height, an inexact binning."""
    what = "camera_info"
    fps = t.real(fps, "fps")
    width, height = t.uint(msg, "width", what, 1), t.uint(msg, "height", what, 1)
    model = t.text(msg, "distortion_model", what)
    d = t.floats(msg, "d", what)
    k = t.floats(msg, "k", what, 9)
    if model not in DISTORTION_MODELS:
        raise ValueError(f"{what}.distortion_model: {model!r} is not one of {sorted(m for m in DISTORTION_MODELS if m)}")
    n = DISTORTION_MODELS[model]
    if n is None and d.size and np.any(d != 0):
        raise ValueError(f"{what}.d: distortion_model {model!r} has no coefficients, got {d.tolist()}")
    if n is not None and d.size != n:
        raise ValueError(f"{what}.d: distortion_model {model!r} has {n} coefficients, got {d.size}")
    if model == "rational_polynomial" and np.any(d[5:] != 0):
        raise ValueError(f"{what}.d: rational_polynomial with k4, k5, k6 = {d[5:].tolist()}: only their zero "
                         f"values (plumb_bob) are supported")
    K = k.reshape(3, 3)
    if not (K[0, 0] > 0 and K[1, 1] > 0) or K[1, 0] != 0 or K[2, 0] != 0 or K[2, 1] != 0 or K[2, 2] != 1:
        raise ValueError(f"{what}.k must be [fx, 0, cx, 0, fy, cy, 0, 0, 1] with fx, fy > 0, got {k.tolist()}")
    if K[0, 1] != 0:
        raise ValueError(f"{what}.k: skew k[1] must be 0 (skewed pixels are not supported), got {K[0, 1]!r}")
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    # The image actually published: the ROI (full image when 0 x 0), then the binning.
    roi = t.field(msg, "roi", what)
    bx = max(t.uint(msg, "binning_x", what), 1)
    by = max(t.uint(msg, "binning_y", what), 1)
    x0, y0 = t.uint(roi, "x_offset", f"{what}.roi"), t.uint(roi, "y_offset", f"{what}.roi")
    rw, rh = t.uint(roi, "width", f"{what}.roi"), t.uint(roi, "height", f"{what}.roi")
    if bool(t.field(roi, "do_rectify", f"{what}.roi")):
        raise ValueError(f"{what}.roi.do_rectify: a region of the rectified image is not supported (ibvs servoes "
                         f"on the raw image)")
    if rw == 0 and rh == 0:
        x0 = y0 = 0
        rw, rh = width, height
    if rw == 0 or rh == 0 or x0 + rw > width or y0 + rh > height:
        raise ValueError(f"{what}.roi: ({x0}, {y0}) + {rw} x {rh} does not fit the {width} x {height} image")
    if rw % bx or rh % by:
        raise ValueError(f"{what}.binning_x/binning_y: the {rw} x {rh} image is not divisible by {bx} x {by}")
    fx, cx, fy, cy = fx / bx, (cx - x0) / bx, fy / by, (cy - y0) / by
    w, h = rw // bx, rh // by
    Kb = [[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]]
    try:
        if model == "visp":
            return CameraModel.from_visp(fx, fy, cx, cy, float(d[0]), float(d[1]), float(w), float(h), fps)
        if model == "equidistant":
            return CameraModel.from_opencv(Kb, d, float(w), float(h), fisheye=True, fps=fps)
        if model == "omnidir":
            return CameraModel.from_omnidir(Kb, float(d[0]), d[1:5], float(w), float(h), fps)
        return CameraModel.from_opencv(Kb, d[:5] if d.size else None, float(w), float(h), fps=fps)
    except ValueError as e:
        raise ValueError(f"{what}: {e}") from None


def camera_info(model: CameraModel, types=None, frame_id: str = "camera", stamp_ns: int = 0):
    """A sensor_msgs/CameraInfo of a CameraModel with a pixel sensor [0, W] x [0, H] (W, H integers):
    K, D and its model (none as plumb_bob with zeros), R = identity, P = [K | 0], no binning, full ROI.
    types: see ibvs.ros.types (None: rosbags' Humble classes)."""
    if not isinstance(model, CameraModel):
        raise TypeError(f"model must be an ibvs.CameraModel, got {type(model).__name__}")
    u_min, u_max, v_min, v_max = model.bounds
    w, h = u_max - u_min, v_max - v_min
    if u_min != 0 or v_min != 0 or w != round(w) or h != round(h) or w < 1 or h < 1:
        raise ValueError(f"model: a CameraInfo describes a pixel sensor [0, width] x [0, height] with integer "
                         f"width and height, got bounds {model.bounds}")
    dist = model.distortion
    if dist == "none":
        name, d = "plumb_bob", np.zeros(5)
    else:
        name, d = {"plumb_bob": "plumb_bob", "equidistant": "equidistant", "visp": "visp", "omnidir": "omnidir"}[dist], \
            np.array(model.coefficients, dtype=np.float64)
    K = np.array([model.px, 0.0, model.u0, 0.0, model.py, model.v0, 0.0, 0.0, 1.0])
    P = np.array([model.px, 0.0, model.u0, 0.0, 0.0, model.py, model.v0, 0.0, 0.0, 0.0, 1.0, 0.0])
    roi = t.make(types, "sensor_msgs/msg/RegionOfInterest", x_offset=0, y_offset=0, height=0, width=0,
                 do_rectify=False)
    return t.make(types, "sensor_msgs/msg/CameraInfo", header=t.header(types, stamp_ns, frame_id),
                  height=int(h), width=int(w), distortion_model=name, d=d, k=K,
                  r=np.eye(3).reshape(-1), p=P, binning_x=0, binning_y=0, roi=roi)
