"""A Franka arm (FR3 or Panda) through franky-control (libfranka inside; extra `franka`:
pip install ".[franka]"): joint velocities as franky JointVelocityMotions, run asynchronously.

Each command is one JointVelocityMotion(dq, duration=hold) given to franky.Robot.move(..., asynchronous=True):
it replaces the running motion seamlessly (franky's own trajectory generator keeps the velocity, acceleration
and jerk within the robot's limits, scaled by relative_dynamics_factor) and holds dq for `hold` seconds after
reaching it, then ends: a loop that stops sending stops the arm within `hold` (a dead man's switch). stop()
sends a JointVelocityStopMotion (a braking motion) and waits for it at most stop_timeout, then preempts any
motion with franky.Robot.stop().

Tested end to end against franky-sim (libfranka's network protocol on MuJoCo, on a loopback address) in
tests/python/test_robot_franky.py; never run here against a real arm.
"""

from __future__ import annotations

import math
import time
from typing import Any, Optional

import numpy as np

from .base import JointState, Robot, RobotError
from .limits import Limits

__all__ = ["FrankyClock", "FrankyRobot", "franka_limits"]

INSTALL = 'pip install ".[franka]" from the ibvs repository root (franky-control)'

# Joint limits from Franka's datasheets (FR3: "Franka Research 3 - Robot and interface specifications";
# Panda: "Panda - Robot and interface specifications"): positions (rad). The velocity and acceleration
# limits are those franky-control 2 enforces (franky.Robot.joint_velocity_limit / joint_acceleration_limit).
_POSITIONS = {
    "fr3": ([-2.7437, -1.7837, -2.9007, -3.0421, -2.8065, 0.5445, -3.0159],
            [2.7437, 1.7837, 2.9007, -0.1518, 2.8065, 4.5169, 3.0159]),
    "panda": ([-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973],
              [2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973]),
}
_SPEED = [2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61]
_ACCELERATION = [15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0]


def franka_limits(model: str = "fr3", margin: float = 0.05, speed_factor: float = 0.5,
                  acceleration_factor: float = 0.5, workspace=None) -> Limits:
    """Limits for a Franka arm ("fr3" or "panda"): the datasheet's position range shrunk by `margin` rad at
    each end (room to brake), the speed and acceleration limits scaled by the factors (in (0, 1])."""
    if model not in _POSITIONS:
        raise ValueError(f"model must be one of {sorted(_POSITIONS)}, got {model!r}")
    for name, f in (("speed_factor", speed_factor), ("acceleration_factor", acceleration_factor)):
        if not (isinstance(f, (int, float)) and 0 < f <= 1):
            raise ValueError(f"{name} must be in (0, 1], got {f!r}")
    lo, hi = (np.array(a) for a in _POSITIONS[model])
    if not (isinstance(margin, (int, float)) and 0 <= margin < float(np.min(hi - lo)) / 2):
        raise ValueError(f"margin must be >= 0 and less than half the smallest range, got {margin!r}")
    return Limits(lo + margin, hi - margin, np.array(_SPEED) * speed_factor,
                  np.array(_ACCELERATION) * acceleration_factor, workspace)


def _franky():
    try:
        import franky
    except ImportError as e:
        raise ImportError(f"ibvs.robot.FrankyRobot needs franky-control: {INSTALL}") from e
    return franky


class FrankyClock:
    """The robot's own clock (libfranka's RobotState.time, s) as a Clock: a loop on it runs at the robot's
    pace, which is what a simulated arm (franky-sim slower than real time on a loaded machine) needs.
    sleep_until(t) polls until the robot's time reaches t; RobotError when it stops advancing for `stall`
    wall-clock seconds (the robot or its server is gone)."""

    def __init__(self, robot: "FrankyRobot", stall: float = 1.0) -> None:
        self.robot = robot
        self.stall = float(stall)

    def now(self) -> float:
        return self.robot._robot_time()

    def sleep_until(self, t: float) -> None:
        last, since = self.now(), time.monotonic()
        while last < t:
            time.sleep(min(0.001, max(t - last, 0.0)))
            now = self.now()
            if now > last:
                last, since = now, time.monotonic()
            elif time.monotonic() - since > self.stall:
                raise RobotError(f"{self.robot.name}: the robot's clock stopped at {last:.3f} s for "
                                 f"{self.stall:g} s (robot or server gone)")


class FrankyRobot(Robot):
    """A Franka arm through franky-control.

    host: the robot's (or franky-sim's) address. model: "fr3" or "panda" (default limits: franka_limits(model)).
    limits: Limits overriding them. rate: the command rate (Hz). hold: how long (s) each command is held
    after it is reached before the arm stops by itself (default 3 periods). relative_dynamics_factor: franky's
    scaling of its own velocity, acceleration and jerk limits (0, 1]. clock: None (time.monotonic), "robot"
    (FrankyClock: the robot's own time) or any Clock. realtime: require a real-time kernel (franky's
    RealtimeConfig.Enforce; False: Ignore, as a simulator or a development machine needs). stop_timeout:
    how long stop() waits for the braking motion. stale_after: the link is declared lost (RobotError) when
    the robot's state has not changed for this long on the wall clock (s, default one period): libfranka
    itself notices a dead server only after its ~1 s network timeout, and keeps returning the last state
    until then. kinematics, dry_run: as Robot's.
    """

    def __init__(self, host: str = "127.0.0.1", model: str = "fr3", limits: Optional[Limits] = None,
                 rate: float = 100.0, hold: Optional[float] = None, relative_dynamics_factor: float = 1.0,
                 clock: Any = None, realtime: bool = False, stop_timeout: float = 2.0,
                 stale_after: Optional[float] = None, kinematics: Any = None, dry_run: bool = False) -> None:
        if not isinstance(host, str) or not host:
            raise ValueError(f"host must be the robot's address, got {host!r}")
        if not (isinstance(relative_dynamics_factor, (int, float)) and 0 < relative_dynamics_factor <= 1):
            raise ValueError(f"relative_dynamics_factor must be in (0, 1], got {relative_dynamics_factor!r}")
        lim = franka_limits(model) if limits is None else limits
        if lim.n != 7:
            raise ValueError(f"limits must be for 7 joints, got {lim.n}")
        use_robot_clock = isinstance(clock, str) and clock == "robot"
        if isinstance(clock, str) and not use_robot_clock:
            raise ValueError(f"clock must be None, 'robot' or a Clock, got {clock!r}")
        super().__init__(f"franky {model} at {host}", lim, rate, kinematics, None if use_robot_clock else clock,
                         dry_run)
        if use_robot_clock:
            self.clock = FrankyClock(self)
        hold = 3.0 / self.rate if hold is None else hold
        if not (isinstance(hold, (int, float)) and math.isfinite(hold) and hold >= 1.0 / self.rate):
            raise ValueError(f"hold must be at least one period ({1.0 / self.rate:g} s), got {hold!r}")
        self.host = host
        self.hold = float(hold)
        self.relative_dynamics_factor = float(relative_dynamics_factor)
        self.realtime = bool(realtime)
        self.stop_timeout = float(stop_timeout)
        stale_after = 1.0 / self.rate if stale_after is None else stale_after
        if not (isinstance(stale_after, (int, float)) and math.isfinite(stale_after) and stale_after > 0):
            raise ValueError(f"stale_after must be a time > 0 (s), got {stale_after!r}")
        self.stale_after = float(stale_after)
        self._robot: Any = None
        self._moving = False  # a motion was started and not stopped since
        self._lost = False  # the link was declared lost: stop() sends nothing more
        self._seen = (math.nan, 0.0)  # (the robot's time of the last new state, wall-clock time it was seen)

    def _fail(self, what: str, e: BaseException) -> RobotError:
        return RobotError(f"{self.name}: {what}: {type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''}")

    def _connect(self) -> None:
        franky = _franky()
        config = franky.RealtimeConfig.Enforce if self.realtime else franky.RealtimeConfig.Ignore
        try:
            self._robot = franky.Robot(self.host, relative_dynamics_factor=self.relative_dynamics_factor,
                                       realtime_config=config)
        except Exception as e:
            raise self._fail("cannot connect", e) from None
        self._moving = self._lost = False
        self._seen = (math.nan, 0.0)

    def _robot_time(self) -> float:
        """The robot's time (s) from its latest state; RobotError when it cannot be read."""
        if self._robot is None:
            raise RobotError(f"{self.name}: not connected")
        try:
            return float(self._robot.state.time.to_sec())
        except Exception as e:
            raise self._fail("reading the robot's time", e) from None

    def _alive(self) -> None:
        """RobotError if the link was lost, a motion failed, or the robot's state is stale (stale_after)."""
        if self._lost:
            raise RobotError(f"{self.name}: the link to the robot was lost")
        try:
            if self._moving:
                self._robot.poll_motion()  # raises what went wrong in the running motion (a fault, a lost link)
            t_robot = float(self._robot.state.time.to_sec())
        except Exception as e:
            self._lost = True
            raise self._fail("the robot reports", e) from None
        wall = time.monotonic()
        if t_robot != self._seen[0]:
            self._seen = (t_robot, wall)
        elif wall - self._seen[1] > self.stale_after:
            self._lost = True
            raise RobotError(f"{self.name}: no new state from the robot for {wall - self._seen[1]:.3f} s "
                             f"(> stale_after {self.stale_after:g} s): the link is lost")

    def _read_state(self) -> JointState:
        self._alive()
        try:
            js = self._robot.current_joint_state
            q, dq = np.array(js.position, dtype=float), np.array(js.velocity, dtype=float)
        except Exception as e:
            self._lost = True
            raise self._fail("reading the joint state", e) from None
        return JointState(q, dq, self.clock.now())

    def _send(self, dq: np.ndarray) -> None:
        franky = _franky()
        self._alive()
        try:
            motion = franky.JointVelocityMotion(dq, duration=franky.Duration(int(round(self.hold * 1000))))
            self._robot.move(motion, asynchronous=True)
        except Exception as e:
            raise self._fail("sending joint velocities", e) from None
        self._moving = True

    def _halt(self) -> None:
        if self._robot is None or self._lost:  # a lost link: the arm's own watchdog stops it (libfranka's
            self._moving = False                # communication reflex); nothing can be sent
            return
        franky = _franky()
        try:
            if self._robot.is_in_control:
                self._robot.move(franky.JointVelocityStopMotion(), asynchronous=True)
                self._robot.join_motion(self.stop_timeout)
        finally:
            self._moving = False
            if self._robot.is_in_control:
                self._robot.stop()

    def _close(self) -> None:
        self._robot = None  # franky disconnects when its Robot is deleted
