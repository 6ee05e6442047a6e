"""A robot's limits and THE one check every command passes before any adapter sends it.

Limit policy (docs/robots.md, "Limit policy"), for a joint-velocity command dq over one period dt = 1/rate:

1. Refused (ValueError naming the argument, nothing sent): a command of the wrong shape or not finite.
2. Clamped, direction kept: the whole vector is scaled by one factor s in (0, 1] - the largest s for which
   |s dq| <= dq_max and |s dq - last| <= ddq_max dt on every joint (last: the previous command, else the
   measured joint velocity). Command.clamped is True and Command.reason says which limit bound it.
3. Ramped: when no scaled command is reachable within one period's acceleration (a reversal, a sharp turn),
   the command moves from `last` towards the speed-scaled one by the largest fraction k that the
   acceleration allows on every joint (dq' = last + k (s_v dq - last)); Command.reason says so. This is the
   only case where the direction is not kept for one period; the next periods continue towards it.
4. Refused (LimitError, nothing sent): a command that would take a joint past its position limit within the
   next period (q + dq' dt outside [q_min, q_max] while moving outwards; a joint outside its limits may move
   back in), or, with a kinematics model and Limits.workspace, the camera past the workspace box within the
   next period while moving away from it. The adapter then stops the robot (Robot.send_joint_velocity).

Set q_min, q_max with a margin for braking: a refused command stops the robot, which decelerates at its own
controller's rate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Optional, Tuple

import numpy as np

__all__ = ["Command", "LimitError", "Limits", "check_command"]

#: A command within a limit to this relative rounding (a velocity computed at the limit) is not scaled.
ROUNDING = 1e-12


class LimitError(ValueError):
    """A command refused by the limits: it was not sent (and the robot was stopped)."""


def as_vector(x, name: str, n: Optional[int] = None, allow_inf: bool = False) -> np.ndarray:
    """x as a read-only float (n,) array, or a ValueError/TypeError naming `name`."""
    if isinstance(x, (str, bytes)) or x is None:
        raise TypeError(f"{name} must be an array of numbers, got {type(x).__name__}")
    try:
        a = np.array(x, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise TypeError(f"{name} must be an array of numbers: {e}") from None
    if a.ndim != 1 or a.size < 1 or (n is not None and a.size != n):
        want = f"({n},)" if n is not None else "(n,) with n >= 1"
        raise ValueError(f"{name} must have shape {want}, got {a.shape}")
    bad = np.isnan(a) if allow_inf else ~np.isfinite(a)
    if bad.any():
        raise ValueError(f"{name}[{int(np.flatnonzero(bad)[0])}] is {float(a[bad][0])}: must be finite")
    a.flags.writeable = False
    return a


@dataclass(frozen=True)
class Limits:
    """Per-joint limits in SI units (rad or m; per second; per second squared), validated on construction.

    q_min < q_max (±inf allowed for a joint without position limits), dq_max > 0 and ddq_max > 0 finite.
    workspace: None or (lo, hi), the box (3,) the camera's position (base frame, metres) must stay in; it is
    checked when the robot has a kinematics model.
    """

    q_min: np.ndarray
    q_max: np.ndarray
    dq_max: np.ndarray
    ddq_max: np.ndarray
    workspace: Optional[Tuple[np.ndarray, np.ndarray]] = None

    def __post_init__(self) -> None:
        q_min = as_vector(self.q_min, "q_min", allow_inf=True)
        n = q_min.size
        q_max = as_vector(self.q_max, "q_max", n, allow_inf=True)
        dq_max = as_vector(self.dq_max, "dq_max", n)
        ddq_max = as_vector(self.ddq_max, "ddq_max", n)
        if not (q_min < q_max).all():
            j = int(np.flatnonzero(~(q_min < q_max))[0])
            raise ValueError(f"q_min[{j}] = {q_min[j]} must be < q_max[{j}] = {q_max[j]}")
        for name, a in (("dq_max", dq_max), ("ddq_max", ddq_max)):
            if not (a > 0).all():
                j = int(np.flatnonzero(~(a > 0))[0])
                raise ValueError(f"{name}[{j}] = {a[j]} must be > 0")
        box = self.workspace
        if box is not None:
            if not isinstance(box, (tuple, list)) or len(box) != 2:
                raise ValueError("workspace must be None or (lo, hi), two (3,) arrays")
            lo, hi = as_vector(box[0], "workspace lo", 3), as_vector(box[1], "workspace hi", 3)
            if not (lo < hi).all():
                raise ValueError(f"workspace: lo {lo.tolist()} must be < hi {hi.tolist()} on every axis")
            box = (lo, hi)
        for name, value in (("q_min", q_min), ("q_max", q_max), ("dq_max", dq_max), ("ddq_max", ddq_max),
                            ("workspace", box)):
            object.__setattr__(self, name, value)

    @property
    def n(self) -> int:
        """The number of joints."""
        return int(self.q_min.size)

    def __repr__(self) -> str:
        fmt = (lambda a: np.array2string(a, precision=4, separator=", "))
        box = "" if self.workspace is None else f", workspace=({fmt(self.workspace[0])}, {fmt(self.workspace[1])})"
        return (f"Limits(q_min={fmt(self.q_min)}, q_max={fmt(self.q_max)}, dq_max={fmt(self.dq_max)}, "
                f"ddq_max={fmt(self.ddq_max)}{box})")


@dataclass(frozen=True)
class Command:
    """What was (or, in a dry run, would have been) sent: dq (n,) after the limits, clamped (True when dq
    differs from the request), reason (which limit, "" when none), requested: the dq asked for."""

    dq: np.ndarray
    clamped: bool = False
    reason: str = ""
    requested: Optional[np.ndarray] = field(default=None, repr=False)


def camera_position(kinematics: Any, q: np.ndarray) -> np.ndarray:
    """The camera's position (3,) in the base frame at q from a kinematics model: an ibvs.sim.Robot (a
    UrdfRobot, a Gantry: camera(q)) or any object with kinematics(q) -> (T_we, J) and an optional mount
    (end effector <- camera, default identity)."""
    if hasattr(kinematics, "camera"):
        T = np.asarray(kinematics.camera(q), dtype=float)
    else:
        T_we = np.asarray(kinematics.kinematics(q)[0], dtype=float)
        T = T_we @ np.asarray(getattr(kinematics, "mount", np.eye(4)), dtype=float)
    return T[:3, 3]


def _box_distance(p: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> float:
    """How far p lies outside the box [lo, hi] (0 inside)."""
    return float(np.linalg.norm(np.maximum(lo - p, 0.0) + np.maximum(p - hi, 0.0)))


def _scale_interval(dq: np.ndarray, last: np.ndarray, step: np.ndarray) -> Tuple[float, float]:
    """The interval of s with |s dq_j - last_j| <= step_j on every joint (lo > hi: empty)."""
    lo, hi = -math.inf, math.inf
    for d, l, a in zip(dq, last, step):
        if d == 0.0:
            if abs(l) > a:
                return 1.0, 0.0
            continue
        s1, s2 = (l - a) / d, (l + a) / d
        lo, hi = max(lo, min(s1, s2)), min(hi, max(s1, s2))
    return lo, hi


def check_command(dq, state, limits: Limits, dt: float, last_dq=None, kinematics: Any = None) -> Command:
    """THE limit check (module docstring): the joint velocities to send for the request dq (n,), given the
    JointState `state` (its q, and its dq when last_dq is None), the Limits, the period dt (s, 1/rate) and
    the previous command last_dq (n,) or None. kinematics: None or a model for the workspace check
    (camera_position). Returns a Command; raises ValueError (bad input, naming it) or LimitError (refused)."""
    with np.errstate(over="ignore", divide="ignore"):  # a subnormal joint speed gives an infinite bound: fine
        return _check(dq, state, limits, dt, last_dq, kinematics)


def _check(dq, state, limits, dt, last_dq, kinematics) -> Command:
    if not isinstance(limits, Limits):
        raise TypeError(f"limits must be an ibvs.robot.Limits, got {type(limits).__name__}")
    n = limits.n
    req = as_vector(dq, "dq", n)
    q = as_vector(state.q, "state.q", n)
    if isinstance(dt, bool) or not isinstance(dt, (int, float, np.integer, np.floating)) or not (
            math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a finite period > 0 (s), got {dt!r}")
    last = as_vector(state.dq if last_dq is None else last_dq, "state.dq" if last_dq is None else "last_dq", n)

    reasons = []
    # The velocity limit: one scale for all joints (direction kept).
    ratio = np.abs(req) / limits.dq_max
    s_v = 1.0 if np.all(ratio <= 1.0 + ROUNDING) else float(1.0 / ratio.max())  # dq validated finite above
    if s_v < 1.0:
        reasons.append(f"joint {int(np.argmax(ratio))} speed {req[int(np.argmax(ratio))]:.4g} > "
                       f"dq_max {limits.dq_max[int(np.argmax(ratio))]:.4g}")
    # The acceleration limit over one period from the last command.
    step = limits.ddq_max * dt
    lo, hi = _scale_interval(req, last, step)
    lo, hi = max(lo, 0.0), min(hi, s_v)
    if lo <= hi:
        s = s_v if hi >= s_v * (1.0 - ROUNDING) else hi
        out = s * req
        if s < s_v:
            reasons.append(f"acceleration over {dt:.4g} s > ddq_max (scaled by {s:.4g})")
    else:
        target = s_v * req
        change = np.abs(target - last)
        k = float(min(1.0, np.min(np.where(change > 0, step / np.where(change > 0, change, 1.0), np.inf))))
        out = last + k * (target - last)
        reasons.append(f"not reachable within ddq_max in {dt:.4g} s: ramped {k:.4g} of the way from the last command")
        # The last command may lie outside dq_max (a measured velocity): the speed limit comes first.
        over = np.abs(out) / limits.dq_max
        if np.any(over > 1.0):
            out = out / over.max()
    tiny = (np.abs(out) < 1e-300) & (out != 0.0)
    if tiny.any():  # no denormals to the robot: sent as 0, and said so
        out = np.where(tiny, 0.0, out)
        reasons.append(f"joint {int(np.flatnonzero(tiny)[0])} speed below 1e-300 sent as 0")

    # Position limits within the next period: refuse (moving outwards only).
    q_next = q + out * dt
    past = ((q_next > limits.q_max) & (out > 0)) | ((q_next < limits.q_min) & (out < 0))
    if past.any():
        j = int(np.flatnonzero(past)[0])
        raise LimitError(f"refused: joint {j} at {q[j]:.6g} moving {out[j]:.4g}/s would pass its limits "
                         f"[{limits.q_min[j]:.6g}, {limits.q_max[j]:.6g}] within {dt:.4g} s")
    if limits.workspace is not None and kinematics is not None:
        lo_b, hi_b = limits.workspace
        now_d = _box_distance(camera_position(kinematics, q), lo_b, hi_b)
        p_next = camera_position(kinematics, q_next)
        next_d = _box_distance(p_next, lo_b, hi_b)
        if next_d > 0.0 and next_d >= now_d:
            raise LimitError(f"refused: the camera would reach {np.round(p_next, 4).tolist()}, outside the "
                             f"workspace box within {dt:.4g} s")
    out.flags.writeable = False
    clamped = not np.array_equal(out, req)
    return Command(dq=out, clamped=clamped, reason="; ".join(reasons) if clamped else "", requested=req)
