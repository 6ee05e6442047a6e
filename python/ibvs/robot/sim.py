"""The kinematic simulator's robots behind the Robot protocol: an arm of ibvs.sim (the Afma6-like
sim.Gantry, any sim.UrdfRobot) or the free-flying camera, doing exactly what it is told.

Time is a SimClock: now() is the simulated time, sleep_until(t) moves it to t at once, so a loop on it runs
as fast as it computes. The joints integrate the commanded velocity exactly over time: a command sent at t0
holds until the next one (or for `hold` seconds, then the robot stops by itself, as a real driver's dead
man's switch does): q(t) = q(t0) + dq (t - t0). The free camera integrates its twist (camera frame) exactly
on SE(3): pose(t) = pose(t0) exp((t - t0) twist) (ibvs.se3_exp).
"""

from __future__ import annotations

import math
from typing import Any, Optional

import numpy as np

from .base import JointState, Robot
from .limits import Limits, _vector

__all__ = ["SimClock", "SimRobot"]


class SimClock:
    """Simulated time (s): now() is the time reached, sleep_until(t) advances it to t at once (never back)."""

    def __init__(self, start: float = 0.0) -> None:
        self.t = float(start)

    def now(self) -> float:
        return self.t

    def sleep_until(self, t: float) -> None:
        if not math.isfinite(t):
            raise ValueError(f"t must be a finite time (s), got {t!r}")
        self.t = max(self.t, float(t))


def _rotation_vector(R: np.ndarray) -> np.ndarray:
    """The rotation vector (axis times angle, rad) of a rotation matrix (the inverse of Rodrigues' formula)."""
    c = min(1.0, max(-1.0, (np.trace(R) - 1.0) / 2.0))
    angle = math.acos(c)
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if angle < 1e-6:
        return w / 2.0  # sin(angle) ~ angle
    if angle > math.pi - 1e-6:  # near pi: the axis from the diagonal of R = 2 a a^T - I
        a = np.sqrt(np.maximum((np.diag(R) + 1.0) / 2.0, 0.0))
        k = int(np.argmax(a))
        a = (R[:, k] + np.eye(3)[k]) / (2.0 * a[k])
        a /= np.linalg.norm(a)
        if w @ a < 0:
            a = -a
        return a * angle
    return w * (angle / (2.0 * math.sin(angle)))


class _FreeCamera:
    """The free camera's kinematics for the workspace check: q = (position, rotation vector)."""

    def camera(self, q) -> np.ndarray:
        from .. import se3_exp

        T = np.eye(4)
        T[:3, :3] = se3_exp(np.r_[0.0, 0.0, 0.0, q[3:]])[:3, :3]
        T[:3, 3] = q[:3]
        return T


class SimRobot(Robot):
    """A kinematic robot of ibvs.sim that does exactly what it is told.

    robot: an ibvs.sim.Robot (sim.Gantry.afma6(), a sim.UrdfRobot...) with q0 its start joints (n,); or None:
    the free camera at `pose` (4x4 world <- camera, default identity), whose 6 "joints" are its position and
    rotation vector and whose joint velocity is its twist (camera frame, m/s and rad/s, ibvs's order).
    limits: Limits; default: the robot's q_min, q_max, qdot_max (each finite, else pass limits) and ddq_max
    (default: the robot's qddot_max if set, else dq_max * rate: full speed within one period); the free
    camera's default: no position limits, 1 m/s and 1 rad/s, 10 m/s² and 10 rad/s².
    rate: the command rate (Hz). hold: how long a command holds before the robot stops by itself (s, default
    3 periods; inf: until the next). clock: a SimClock (default: a new one, from 0) or any Clock.
    kinematics: the robot itself (the free camera: its pose), for the workspace box and the loop.
    """

    def __init__(self, robot: Any = None, q0=None, pose=None, limits: Optional[Limits] = None, rate: float = 30.0,
                 ddq_max=None, hold: Optional[float] = None, clock: Any = None, dry_run: bool = False) -> None:
        from .. import sim

        if robot is not None and not isinstance(robot, sim.Robot):
            raise TypeError(f"robot must be an ibvs.sim.Robot (a Gantry, a UrdfRobot...) or None, "
                            f"got {type(robot).__name__}")
        if robot is None:
            T = np.eye(4) if pose is None else np.array(pose, dtype=float)
            if T.shape != (4, 4) or not np.isfinite(T).all():
                raise ValueError(f"pose must be a finite (4, 4) world <- camera pose, got shape {T.shape}")
            if q0 is not None:
                raise ValueError("q0 is for an arm: the free camera starts at `pose`")
            n, kin, name = 6, _FreeCamera(), "free camera"
            default = Limits(np.full(6, -np.inf), np.full(6, np.inf), np.ones(6),
                             np.full(6, 10.0) if ddq_max is None else ddq_max)
        else:
            if pose is not None:
                raise ValueError("pose is for the free camera: an arm starts at q0")
            n, kin, name = robot.dof, robot, repr(robot)
            if q0 is None:
                raise ValueError(f"q0 must be the robot's {n} start joints, got None")
            default = None
            if limits is None:
                speed = np.asarray(robot.qdot_max, dtype=float)
                if not np.isfinite(speed).all():
                    raise ValueError("the robot has no finite speed limit (qdot_max) on every joint: pass limits")
                acc = ddq_max
                if acc is None:
                    qdd = getattr(robot, "qddot_max", None)
                    qdd = None if qdd is None else np.asarray(qdd, dtype=float)
                    acc = qdd if qdd is not None and qdd.size == n and np.isfinite(qdd).all() else speed * rate
                default = Limits(robot.q_min, robot.q_max, speed, acc)
        super().__init__(f"sim {name}", default if limits is None else limits, rate, kin,
                         SimClock() if clock is None else clock, dry_run)
        if self.n_joints != n:
            raise ValueError(f"limits must be for {n} joints, got {self.n_joints}")
        self.robot = robot
        hold = 3.0 / self.rate if hold is None else hold
        if not (isinstance(hold, (int, float)) and hold >= 1.0 / self.rate):
            raise ValueError(f"hold must be at least one period ({1.0 / self.rate:g} s) or inf, got {hold!r}")
        self.hold = float(hold)
        if robot is None:
            self._pose = T
            self._q = np.r_[T[:3, 3], _rotation_vector(T[:3, :3])]
        else:
            self._q = _vector(q0, "q0", n).copy()
        self._dq = np.zeros(n)  # the velocity being executed
        self._t = self.clock.now()  # the time the state is integrated to
        self._until = self._t  # the current command ends (dead man's switch)

    def _advance(self) -> None:
        """Integrate the state exactly from self._t to now (the command holds until self._until)."""
        t = self.clock.now()
        if t <= self._t:
            return
        moving = max(0.0, min(t, self._until) - self._t)
        if moving > 0 and self._dq.any():
            if self.robot is None:
                from .. import se3_exp

                self._pose = self._pose @ se3_exp(self._dq * moving)
                self._q = np.r_[self._pose[:3, 3], _rotation_vector(self._pose[:3, :3])]
            else:
                self._q = self._q + self._dq * moving
        if t >= self._until:
            self._dq = np.zeros_like(self._dq)
        self._t = t

    def camera_pose(self) -> np.ndarray:
        """The camera's pose now (4x4 world <- camera; eye-to-hand: as ibvs.sim.Robot.camera)."""
        self._advance()
        return self._pose.copy() if self.robot is None else np.asarray(self.robot.camera(self._q))

    def _connect(self) -> None:
        self._advance()

    def _read_state(self) -> JointState:
        self._advance()
        return JointState(self._q.copy(), self._dq.copy(), self._t)

    def _send(self, dq: np.ndarray) -> None:
        self._advance()
        self._dq = np.array(dq, dtype=float)
        self._until = self._t + self.hold

    def _halt(self) -> None:
        self._advance()
        self._dq = np.zeros_like(self._dq)
        self._until = self._t

    def _close(self) -> None:
        pass
