"""The one robot protocol every driver implements: connect, joint state with its stamp, joint velocities
checked by the limits, stop, disconnect.

An adapter implements five small hooks (_connect, _read_state, _send, _halt, _close); the public methods
here wrap them so that every adapter checks every command with check_command before sending, stops the
robot when a command is refused or sending fails, and stops before disconnecting. stop() and disconnect()
never raise (they record the failure in `last_error`).
"""

from __future__ import annotations

import abc
import math
import time
from dataclasses import dataclass
from typing import Any, Optional

import numpy as np

from .limits import Command, Limits, _vector, check_command

__all__ = ["JointState", "Robot", "RobotError"]


class RobotError(RuntimeError):
    """The link to the robot is lost, its server died or it reports a fault: the loop stops on it."""


@dataclass(frozen=True)
class JointState:
    """Joint positions q (n,) and velocities dq (n,), finite, measured at `stamp` (seconds on the robot's
    clock: the loop's Clock)."""

    q: np.ndarray
    dq: np.ndarray
    stamp: float

    def __post_init__(self) -> None:
        q = _vector(self.q, "q")
        dq = _vector(self.dq, "dq", q.size)
        if isinstance(self.stamp, bool) or not isinstance(self.stamp, (int, float, np.integer, np.floating)) \
                or not math.isfinite(self.stamp):
            raise ValueError(f"stamp must be a finite time (s), got {self.stamp!r}")
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "dq", dq)
        object.__setattr__(self, "stamp", float(self.stamp))


class _MonotonicClock:
    """time.monotonic as a Clock (now, sleep_until): the default for a driver of a real robot."""

    def now(self) -> float:
        return time.monotonic()

    def sleep_until(self, t: float) -> None:
        delay = t - time.monotonic()
        if delay > 0:
            time.sleep(delay)


class Robot(abc.ABC):
    """A robot that takes joint-velocity commands at `rate` Hz (abstract: see the adapters).

    name: what it is; limits: its Limits (n_joints = limits.n); rate: the command rate it accepts (Hz; the
    limit check's period is 1/rate); kinematics: None or a model giving the camera's pose from q (an
    ibvs.sim.UrdfRobot...) for the workspace check and for mapping twists to joints; clock: the Clock its
    stamps are on (now(), sleep_until(t); default time.monotonic); dry_run: check and return commands but
    send nothing (the state is still read from the robot).
    """

    def __init__(self, name: str, limits: Limits, rate: float, kinematics: Any = None, clock: Any = None,
                 dry_run: bool = False) -> None:
        if not isinstance(limits, Limits):
            raise TypeError(f"limits must be an ibvs.robot.Limits, got {type(limits).__name__}")
        if isinstance(rate, bool) or not isinstance(rate, (int, float, np.integer, np.floating)) or not (
                math.isfinite(rate) and rate > 0):
            raise ValueError(f"rate must be a finite command rate > 0 (Hz), got {rate!r}")
        self.name = str(name)
        self.limits = limits
        self.n_joints = limits.n
        self.rate = float(rate)
        self.kinematics = kinematics
        self.clock = _MonotonicClock() if clock is None else clock
        self.dry_run = bool(dry_run)
        self.connected = False
        self.last_command: Optional[Command] = None
        self.last_error: Optional[BaseException] = None  # what stop()/disconnect() swallowed, if anything
        self._last_dq: Optional[np.ndarray] = None  # None: take the measured velocity (after a stop)

    # --- the hooks an adapter implements -------------------------------------------------------------
    @abc.abstractmethod
    def _connect(self) -> None:
        """Open the link (raise RobotError on failure)."""

    @abc.abstractmethod
    def _read_state(self) -> JointState:
        """The current JointState (raise RobotError when the link is lost)."""

    @abc.abstractmethod
    def _send(self, dq: np.ndarray) -> None:
        """Send checked joint velocities dq (raise RobotError on failure)."""

    @abc.abstractmethod
    def _halt(self) -> None:
        """Command zero velocity / stop the motion (may raise: stop() catches)."""

    @abc.abstractmethod
    def _close(self) -> None:
        """Close the link (may raise: disconnect() catches)."""

    # --- the protocol -------------------------------------------------------------------------------
    def connect(self) -> None:
        """Open the link to the robot (RobotError if it cannot be reached). Idempotent."""
        if not self.connected:
            self._connect()
            self.connected = True
            self._last_dq = None

    def _require(self) -> None:
        if not self.connected:
            raise RobotError(f"{self.name}: not connected (call connect() first)")

    def state(self) -> JointState:
        """The joint state now; RobotError when the link is lost."""
        self._require()
        return self._read_state()

    def send_joint_velocity(self, dq, state: Optional[JointState] = None) -> Command:
        """Check dq (n,) by the limits (check_command, period 1/rate, from the last command) and send it;
        returns the Command sent. A refused command (LimitError, or ValueError for bad input) or a failed send
        (RobotError) stops the robot and re-raises. state: the JointState to check against (default: read
        now)."""
        self._require()
        try:
            if state is None:
                state = self._read_state()
            cmd = check_command(dq, state, self.limits, 1.0 / self.rate, self._last_dq, self.kinematics)
            if not self.dry_run:
                self._send(np.array(cmd.dq))
        except BaseException:
            self.stop()
            raise
        self._last_dq = cmd.dq
        self.last_command = cmd
        return cmd

    def stop(self) -> None:
        """Zero velocity now. Idempotent; never raises (a failure is kept in last_error)."""
        self._last_dq = None
        if not self.connected:
            return
        try:
            self._halt()
        except Exception as e:  # a dead link is already stopped by the robot's own watchdog
            self.last_error = e

    def disconnect(self) -> None:
        """stop(), then close the link. Idempotent; never raises."""
        if not self.connected:
            return
        self.stop()
        try:
            self._close()
        except Exception as e:
            self.last_error = e
        self.connected = False

    def __enter__(self) -> "Robot":
        self.connect()
        return self

    def __exit__(self, *exc) -> None:
        self.disconnect()

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}, {self.n_joints} joints, {self.rate:g} Hz)"
