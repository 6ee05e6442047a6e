"""Joints: sensor_msgs/JointState in; joint velocities out as trajectory_msgs/JointTrajectory (one
point, for a joint trajectory controller) or std_msgs/Float64MultiArray (ros2_control's
velocity_controllers/JointGroupVelocityController, in its joints' order)."""

from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

from . import types as t

# What ibvs.ros re-exports (and documents); the other names here are its own helpers.
__all__ = ["joint_positions", "joint_trajectory", "float64_array", "array_of"]


def joint_positions(msg, names: Optional[Sequence[str]] = None) -> np.ndarray:
    """The positions of a sensor_msgs/JointState, in the order of `names` (default: the message's).
    A JointState lists its joints in any order and may hold others: every name asked for must be there
    (an error names the missing joint); positions must be finite."""
    what = "joint_states"
    have = [str(n) for n in t.field(msg, "name", what)]
    pos = t.floats(msg, "position", what, finite=False)
    if len(pos) != len(have):
        raise ValueError(f"{what}.position: {len(pos)} positions for {len(have)} names")
    if names is None:
        names = have
    index = {n: i for i, n in enumerate(have)}
    out = np.empty(len(names))
    for j, n in enumerate(names):
        if n not in index:
            raise ValueError(f"{what}.name: joint {n!r} is not in the message (it has {have})")
        out[j] = pos[index[n]]
        if not np.isfinite(out[j]):
            raise ValueError(f"{what}.position: joint {n!r} is {out[j]!r}")
    return out


def _qdot(qdot) -> np.ndarray:
    q = np.asarray(qdot, dtype=np.float64).reshape(-1)
    if q.size < 1 or not np.isfinite(q).all():
        raise ValueError(f"qdot must be finite joint velocities, got {np.asarray(qdot)!r}")
    return q


def joint_trajectory(qdot, names: Sequence[str], types=None, stamp_ns: int = 0, positions=None,
                     time_from_start: float = 0.0, frame_id: str = ""):
    """A trajectory_msgs/JointTrajectory of one point: velocities qdot for joints `names`, positions
    (optional: e.g. q + qdot dt) and time_from_start (s)."""
    q = _qdot(qdot)
    names = [str(n) for n in names]
    if len(names) != q.size:
        raise ValueError(f"names: {len(names)} joint names for {q.size} velocities")
    p = np.zeros(0) if positions is None else np.asarray(positions, dtype=np.float64).reshape(-1)
    if p.size not in (0, q.size) or not np.isfinite(p).all():
        raise ValueError(f"positions must be {q.size} finite numbers or None")
    tfs = t.to_ns(t.real(time_from_start, "time_from_start"))
    point = t.make(types, "trajectory_msgs/msg/JointTrajectoryPoint", positions=p, velocities=q,
                   accelerations=np.zeros(0), effort=np.zeros(0),
                   time_from_start=t.make(types, "builtin_interfaces/msg/Duration", sec=tfs // t.NS,
                                          nanosec=tfs % t.NS))
    return t.make(types, "trajectory_msgs/msg/JointTrajectory", header=t.header(types, stamp_ns, frame_id),
                  joint_names=names, points=[point])


def float64_array(values, types=None, label: str = "joints"):
    """A std_msgs/Float64MultiArray of a 1-D (n,) or 2-D (rows, cols) array, its layout labelled
    (a 2-D array's dimensions are `label` and "xy" for points: what /ibvs/features holds)."""
    a = np.asarray(values, dtype=np.float64)
    if a.ndim not in (1, 2):
        raise ValueError(f"values must be 1-D or 2-D, got shape {a.shape}")
    labels = [label] if a.ndim == 1 else [label, "xy" if a.shape[1] == 2 else "columns"]
    dims, stride = [], a.size
    for size, lab in zip(a.shape, labels):
        dims.append(t.make(types, "std_msgs/msg/MultiArrayDimension", label=lab, size=int(size), stride=int(stride)))
        stride //= max(int(size), 1)
    layout = t.make(types, "std_msgs/msg/MultiArrayLayout", dim=dims, data_offset=0)
    return t.make(types, "std_msgs/msg/Float64MultiArray", layout=layout, data=a.reshape(-1).copy())


def array_of(msg) -> np.ndarray:
    """The data of a std_msgs/Float64MultiArray, shaped by its layout's dimensions (flat without them)."""
    what = "array"
    data = t.floats(msg, "data", what, finite=False)
    dims = list(t.field(t.field(msg, "layout", what), "dim", f"{what}.layout"))
    shape = tuple(int(t.field(d, "size", f"{what}.layout.dim")) for d in dims)
    if shape and int(np.prod(shape)) == data.size:
        return data.reshape(shape)
    if shape:
        raise ValueError(f"{what}.layout: dimensions {shape} do not hold its {data.size} numbers")
    return data
