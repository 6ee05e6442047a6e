"""tf2_msgs/TFMessage <-> 4x4 poses.

transforms(msg) -> {(parent, child): 4x4 parent <- child}; tf_message({(parent, child): T}) the other
way. Rotations go through unit quaternions (x, y, z, w) as ROS writes them.
"""

from __future__ import annotations

from typing import Dict, Tuple

import numpy as np

from . import types as t

# What ibvs.ros re-exports (and documents); the other names here are its own helpers.
__all__ = ["quaternion", "rotation", "transforms", "tf_message"]


def quaternion(R) -> np.ndarray:
    """(x, y, z, w) of a rotation matrix, w >= 0 (the largest of the four candidates solved first:
    accurate for every rotation)."""
    R = np.asarray(R, dtype=np.float64)
    tr = np.trace(R)
    cand = np.array([tr, R[0, 0], R[1, 1], R[2, 2]])
    i = int(np.argmax(cand))
    if i == 0:
        s = 2.0 * np.sqrt(1.0 + tr)
        q = np.array([(R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s, s / 4])
    elif i == 1:
        s = 2.0 * np.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2])
        q = np.array([s / 4, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s, (R[2, 1] - R[1, 2]) / s])
    elif i == 2:
        s = 2.0 * np.sqrt(1.0 - R[0, 0] + R[1, 1] - R[2, 2])
        q = np.array([(R[0, 1] + R[1, 0]) / s, s / 4, (R[1, 2] + R[2, 1]) / s, (R[0, 2] - R[2, 0]) / s])
    else:
        s = 2.0 * np.sqrt(1.0 - R[0, 0] - R[1, 1] + R[2, 2])
        q = np.array([(R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, s / 4, (R[1, 0] - R[0, 1]) / s])
    q /= np.linalg.norm(q)
    return -q if q[3] < 0 else q


def rotation(q) -> np.ndarray:
    """The rotation matrix of a quaternion (x, y, z, w), normalised first (it must not be zero)."""
    q = np.asarray(q, dtype=np.float64)
    big = np.abs(q).max() if q.size else 0.0
    if not (np.isfinite(q).all() and big > 0):
        raise ValueError(f"quaternion must be finite and non-zero, got {q.tolist()}")
    q = q / big  # scaled first: the norm of 1e300 or 1e-300 components neither overflows nor underflows
    x, y, z, w = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def transforms(msg) -> Dict[Tuple[str, str], np.ndarray]:
    """{(parent, child): 4x4 parent <- child} of a tf2_msgs/TFMessage (the last one of a pair repeated)."""
    what = "tf"
    out = {}
    for i, ts in enumerate(t.field(msg, "transforms", what)):
        w = f"{what}.transforms[{i}]"
        parent = t.text(t.field(ts, "header", w), "frame_id", f"{w}.header")
        child = t.text(ts, "child_frame_id", w)
        tr = t.field(ts, "transform", w)
        p, q = t.field(tr, "translation", f"{w}.transform"), t.field(tr, "rotation", f"{w}.transform")
        T = np.eye(4)
        T[:3, 3] = [t.real(t.field(p, a, f"{w}.transform.translation"), f"{w}.transform.translation.{a}")
                    for a in "xyz"]
        quat = [t.real(t.field(q, a, f"{w}.transform.rotation"), f"{w}.transform.rotation.{a}") for a in "xyzw"]
        try:
            T[:3, :3] = rotation(quat)
        except ValueError as e:
            raise ValueError(f"{w}.transform.rotation: {e}") from None
        out[(parent, child)] = T
    return out


def tf_message(poses: Dict[Tuple[str, str], np.ndarray], types=None, stamp_ns: int = 0):
    """A tf2_msgs/TFMessage of {(parent, child): 4x4 parent <- child}, all stamped stamp_ns."""
    items = []
    for (parent, child), T in poses.items():
        T = np.asarray(T, dtype=np.float64)
        if T.shape != (4, 4) or not np.isfinite(T).all():
            raise ValueError(f"poses[({parent!r}, {child!r})] must be a finite 4x4 transform")
        q = quaternion(T[:3, :3])
        tr = t.make(types, "geometry_msgs/msg/Transform",
                    translation=t.make(types, "geometry_msgs/msg/Vector3", x=float(T[0, 3]), y=float(T[1, 3]),
                                       z=float(T[2, 3])),
                    rotation=t.make(types, "geometry_msgs/msg/Quaternion", x=float(q[0]), y=float(q[1]),
                                    z=float(q[2]), w=float(q[3])))
        items.append(t.make(types, "geometry_msgs/msg/TransformStamped", header=t.header(types, stamp_ns, parent),
                            child_frame_id=str(child), transform=tr))
    return t.make(types, "tf2_msgs/msg/TFMessage", transforms=items)
