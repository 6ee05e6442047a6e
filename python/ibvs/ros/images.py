"""sensor_msgs/Image <-> numpy.

image(msg) reads mono8, mono16, rgb8, bgr8, rgba8 and bgra8 (and OpenCV's 8UC1 / 16UC1 names of the
mono ones), honouring the row step (padding at the end of each row) and the byte order of 16-bit
pixels (is_bigendian); gray8(msg) is the uint8 grayscale image the trackers take. image_msg(array)
writes mono8, mono16, rgb8 or rgba8, rows unpadded, in the machine's byte order.
"""

from __future__ import annotations

import sys

import numpy as np

from . import types as t

# What ibvs.ros re-exports (and documents); the other names here are its own helpers.
__all__ = ["ENCODINGS", "image", "gray8", "image_msg"]

#: encoding -> (channels, bytes per channel).
ENCODINGS = {"mono8": (1, 1), "8UC1": (1, 1), "mono16": (1, 2), "16UC1": (1, 2), "rgb8": (3, 1), "bgr8": (3, 1),
             "rgba8": (4, 1), "bgra8": (4, 1)}


def image(msg) -> np.ndarray:
    """The pixels of a sensor_msgs/Image as a numpy array: (height, width) uint8 or uint16 for the mono
    encodings, (height, width, 3 or 4) uint8 in the encoding's channel order otherwise (bgr8 stays
    B, G, R). A copy: it does not share the message's buffer. Errors name the field (an unknown
    encoding, a step shorter than a row, data shorter than height * step)."""
    what = "image"
    enc = t.text(msg, "encoding", what)
    if enc not in ENCODINGS:
        raise ValueError(f"{what}.encoding: {enc!r} is not one of {sorted(ENCODINGS)}")
    channels, size = ENCODINGS[enc]
    height, width = t.uint(msg, "height", what, 1), t.uint(msg, "width", what, 1)
    step = t.uint(msg, "step", what)
    row = width * channels * size
    if step < row:
        raise ValueError(f"{what}.step: {step} bytes is shorter than a row of {width} {enc} pixels ({row} bytes)")
    big = t.field(msg, "is_bigendian", what)
    if isinstance(big, bool) or not isinstance(big, (int, np.integer)) or int(big) not in (0, 1):
        raise ValueError(f"{what}.is_bigendian must be 0 or 1, got {big!r}")
    data = t.field(msg, "data", what)
    try:
        buf = np.frombuffer(data, dtype=np.uint8) if isinstance(data, (bytes, bytearray, memoryview)) \
            else np.asarray(data, dtype=np.uint8).reshape(-1)
    except (TypeError, ValueError):
        raise TypeError(f"{what}.data must be bytes or a uint8 sequence, got {type(data).__name__}") from None
    # The last row need not carry its padding.
    need = step * (height - 1) + row
    if buf.size < need:
        raise ValueError(f"{what}.data: {buf.size} bytes, fewer than the {need} of {height} rows of step {step}")
    rows = np.lib.stride_tricks.as_strided(buf, shape=(height, row), strides=(step, 1))
    if size == 2:
        dtype = np.dtype(">u2" if int(big) else "<u2")
        out = np.ascontiguousarray(rows).view(dtype).astype(np.uint16).reshape(height, width)
    else:
        out = np.array(rows, dtype=np.uint8)
        out = out.reshape(height, width) if channels == 1 else out.reshape(height, width, channels)
    return out


def gray8(msg) -> np.ndarray:
    """The (height, width) uint8 grayscale image of a sensor_msgs/Image (what ibvs.vision's trackers
    take): mono8 as it is, mono16 divided by 257 and rounded (65535 -> 255), colour images by ITU-R
    BT.601 luma (0.299 R + 0.587 G + 0.114 B, rounded; alpha ignored)."""
    enc = t.text(msg, "encoding", "image")
    a = image(msg)
    if a.ndim == 2 and a.dtype == np.uint8:
        return a
    if a.ndim == 2:
        return np.rint(a / 257.0).astype(np.uint8)
    rgb = a[..., :3].astype(np.float64)
    if enc.startswith("bgr"):
        rgb = rgb[..., ::-1]
    return np.clip(np.rint(rgb @ np.array([0.299, 0.587, 0.114])), 0, 255).astype(np.uint8)


def image_msg(array, types=None, frame_id: str = "camera", stamp_ns: int = 0, encoding: str | None = None):
    """A sensor_msgs/Image of a numpy array: (H, W) uint8 -> mono8, (H, W) uint16 -> mono16,
    (H, W, 3) uint8 -> rgb8 (or bgr8 if encoding says so), (H, W, 4) uint8 -> rgba8 (or bgra8)."""
    a = np.asarray(array)
    if a.ndim == 2 and a.dtype == np.uint8:
        default, allowed = "mono8", ("mono8",)
    elif a.ndim == 2 and a.dtype == np.uint16:
        default, allowed = "mono16", ("mono16",)
    elif a.ndim == 3 and a.dtype == np.uint8 and a.shape[2] in (3, 4):
        default = "rgb8" if a.shape[2] == 3 else "rgba8"
        allowed = ("rgb8", "bgr8") if a.shape[2] == 3 else ("rgba8", "bgra8")
    else:
        raise ValueError(f"array must be (H, W) uint8 or uint16, or (H, W, 3 or 4) uint8, got {a.shape} {a.dtype}")
    enc = default if encoding is None else encoding
    if enc not in allowed:
        raise ValueError(f"encoding: {enc!r} does not fit a {a.shape} {a.dtype} array (use one of {allowed})")
    h, w = a.shape[:2]
    if h < 1 or w < 1:
        raise ValueError(f"array must have at least one pixel, got shape {a.shape}")
    data = np.ascontiguousarray(a).reshape(-1).view(np.uint8)
    return t.make(types, "sensor_msgs/msg/Image", header=t.header(types, stamp_ns, frame_id), height=h, width=w,
                  encoding=enc, is_bigendian=int(sys.byteorder == "big"), step=int(w * a.itemsize *
                  (a.shape[2] if a.ndim == 3 else 1)), data=data)
