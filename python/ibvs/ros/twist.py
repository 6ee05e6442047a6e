"""geometry_msgs/Twist and TwistStamped <-> the camera twist (Tx, Ty, Tz, wx, wy, wz).

ibvs's twist is the camera's velocity in the camera frame (m/s, rad/s). twist_msg writes it as it is
(frame_id the camera's optical frame), or, given base_T_camera (4x4, base <- camera), the same motion
expressed in the base frame's axes: linear = R v and angular = R w, R the rotation of base_T_camera
(the velocity of the camera's origin; moveit_servo takes a TwistStamped in any frame it can look up
in tf, so the camera frame itself is usually simplest).
"""

from __future__ import annotations

import numpy as np

from . import types as t

# What ibvs.ros re-exports (and documents); the other names here are its own helpers.
__all__ = ["twist_msg", "twist_of"]


def _twist6(twist) -> np.ndarray:
    v = np.asarray(twist, dtype=np.float64)
    if v.shape != (6,) or not np.isfinite(v).all():
        raise ValueError(f"twist must be 6 finite numbers (Tx, Ty, Tz, wx, wy, wz), got {np.asarray(twist)!r}")
    return v


def _rotation(T, name: str) -> np.ndarray:
    T = np.asarray(T, dtype=np.float64)
    if T.shape != (4, 4) or not np.isfinite(T).all():
        raise ValueError(f"{name} must be a finite 4x4 transform, got shape {T.shape}")
    R = T[:3, :3]
    if not np.allclose(R.T @ R, np.eye(3), atol=1e-9) or abs(np.linalg.det(R) - 1) > 1e-9:
        raise ValueError(f"{name}: its rotation is not orthonormal with determinant 1")
    return R


def twist_msg(twist, types=None, frame_id: str = "camera", stamp_ns: int = 0, base_T_camera=None,
              stamped: bool = True):
    """A geometry_msgs/TwistStamped (stamped=False: a Twist) of a camera twist (6,), in the camera frame
    or, with base_T_camera, in the base frame's axes (see the module docstring)."""
    v = _twist6(twist)
    if base_T_camera is not None:
        R = _rotation(base_T_camera, "base_T_camera")
        v = np.concatenate([R @ v[:3], R @ v[3:]])
    x = [float(a) for a in v]
    tw = t.make(types, "geometry_msgs/msg/Twist",
                linear=t.make(types, "geometry_msgs/msg/Vector3", x=x[0], y=x[1], z=x[2]),
                angular=t.make(types, "geometry_msgs/msg/Vector3", x=x[3], y=x[4], z=x[5]))
    if not stamped:
        return tw
    return t.make(types, "geometry_msgs/msg/TwistStamped", header=t.header(types, stamp_ns, frame_id), twist=tw)


def twist_of(msg) -> np.ndarray:
    """(6,) (Tx, Ty, Tz, wx, wy, wz) of a geometry_msgs/Twist or TwistStamped (in its own frame)."""
    what = "twist"
    tw = t.field(msg, "twist", what) if hasattr(msg, "twist") else msg
    out = []
    for part in ("linear", "angular"):
        vec = t.field(tw, part, what)
        for axis in "xyz":
            out.append(t.real(t.field(vec, axis, f"{what}.{part}"), f"{what}.{part}.{axis}"))
    return np.array(out)
