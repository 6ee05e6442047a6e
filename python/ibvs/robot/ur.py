"""A Universal Robots arm through ur-rtde (extra `ur`: pip install ".[ur]"): joint velocities by speedJ.

Each command is RTDEControlInterface.speedJ(dq, acceleration, 0.0) (it returns at once; the controller
accelerates its leading joint at `acceleration` to dq and keeps that speed); the joints are read from
RTDEReceiveInterface (getActualQ, getActualQd, and getTimestamp: the controller's time, which must advance);
stop() is speedStop(deceleration). ur-rtde's own control script stops the arm when its watchdog sees no
command (ur-rtde's RTDEControlInterface.setWatchdog) - not set here; the loop's stop paths are.

NOT RUN against a UR controller or URSim here (neither runs on this machine): the command mapping and the
error paths are tested with injected stand-ins for the two interfaces (tests/python/test_robot_ur.py), the
connection error against a closed port on 127.0.0.1 with the real ur-rtde.
"""

from __future__ import annotations

import math
import threading
import time
from typing import Any, Callable, Optional

import numpy as np

from .base import JointState, Robot, RobotError
from .limits import Limits

__all__ = ["URRobot", "ur_limits"]

INSTALL = 'pip install ".[ur]" from the ibvs repository root (ur-rtde)'

# Joint ranges and speeds from Universal Robots' datasheets (UR3e/UR5e/UR10e/UR16e technical specifications):
# +-360 deg on every joint; speed (deg/s) per joint. The acceleration is this driver's choice (none is given
# per joint): pi rad/s^2 before the factor.
_SPEEDS_DEG = {
    "ur3e": [180, 180, 180, 360, 360, 360],
    "ur5e": [180, 180, 180, 180, 180, 180],
    "ur10e": [120, 120, 180, 180, 180, 180],
    "ur16e": [120, 120, 180, 180, 180, 180],
}


def ur_limits(model: str = "ur5e", margin: float = 0.05, speed_factor: float = 0.5, acceleration: float = math.pi,
              workspace=None) -> Limits:
    """Limits for a UR e-Series arm (model: "ur3e", "ur5e", "ur10e", "ur16e"): +-2 pi rad less `margin` on
    every joint, the datasheet speeds times speed_factor (0, 1], `acceleration` rad/s^2 on every joint."""
    if model not in _SPEEDS_DEG:
        raise ValueError(f"model must be one of {sorted(_SPEEDS_DEG)}, got {model!r}")
    if not (isinstance(speed_factor, (int, float)) and 0 < speed_factor <= 1):
        raise ValueError(f"speed_factor must be in (0, 1], got {speed_factor!r}")
    if not (isinstance(margin, (int, float)) and 0 <= margin < math.pi):
        raise ValueError(f"margin must be in [0, pi) rad, got {margin!r}")
    if not (isinstance(acceleration, (int, float)) and math.isfinite(acceleration) and acceleration > 0):
        raise ValueError(f"acceleration must be > 0 (rad/s^2), got {acceleration!r}")
    lim = np.full(6, 2 * math.pi - margin)
    return Limits(-lim, lim, np.radians(_SPEEDS_DEG[model]) * speed_factor, np.full(6, float(acceleration)),
                  workspace)


def _rtde_interfaces(host: str):
    """ur-rtde's (control, receive) interfaces connected to host."""
    try:
        import rtde_control
        import rtde_receive
    except ImportError as e:
        raise ImportError(f"ibvs.robot.URRobot needs ur-rtde: {INSTALL}") from e
    receive = rtde_receive.RTDEReceiveInterface(host)
    return rtde_control.RTDEControlInterface(host), receive


class URRobot(Robot):
    """A UR arm through ur-rtde's speedJ.

    host: the controller's address. model: for the default limits (ur_limits(model)); limits: Limits
    overriding them. rate: the command rate (Hz; the RTDE interface runs at 500 Hz on e-Series, 125 Hz on
    CB3). acceleration: speedJ's acceleration of the leading joint (rad/s^2; default the largest ddq_max).
    stale_after: the link is declared lost when the controller's timestamp has not changed for this long
    (s, default 3 periods). connect_timeout: how long connect() waits (s). interfaces: a callable host ->
    (control, receive) (default: ur-rtde's RTDEControlInterface and RTDEReceiveInterface; the tests inject
    stand-ins). clock, kinematics, dry_run: as Robot's.
    """

    def __init__(self, host: str = "127.0.0.1", model: str = "ur5e", limits: Optional[Limits] = None,
                 rate: float = 125.0, acceleration: Optional[float] = None, stale_after: Optional[float] = None,
                 connect_timeout: float = 5.0, interfaces: Optional[Callable[[str], Any]] = None,
                 clock: Any = None, kinematics: Any = None, dry_run: bool = False) -> None:
        if not isinstance(host, str) or not host:
            raise ValueError(f"host must be the controller's address, got {host!r}")
        lim = ur_limits(model) if limits is None else limits
        if lim.n != 6:
            raise ValueError(f"limits must be for 6 joints, got {lim.n}")
        super().__init__(f"ur-rtde {model} at {host}", lim, rate, kinematics, clock, dry_run)
        acc = float(np.max(lim.ddq_max)) if acceleration is None else acceleration
        stale = 3.0 / self.rate if stale_after is None else stale_after
        for name, x in (("acceleration", acc), ("stale_after", stale), ("connect_timeout", connect_timeout)):
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not (math.isfinite(x) and x > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {x!r}")
        self.host = host
        self.acceleration = float(acc)
        self.stale_after = float(stale)
        self.connect_timeout = float(connect_timeout)
        self._interfaces = _rtde_interfaces if interfaces is None else interfaces
        self._control: Any = None
        self._receive: Any = None
        self._lost = False
        self._seen = (math.nan, 0.0)  # (the controller's timestamp last seen changing, wall-clock time)

    def _fail(self, what: str, e: BaseException) -> RobotError:
        first = str(e).splitlines()[0] if str(e) else ""
        return RobotError(f"{self.name}: {what}: {type(e).__name__}: {first}")

    def _connect(self) -> None:
        made: dict = {}

        def make() -> None:  # in a thread: a host that does not answer would block for the TCP timeout
            try:
                made["pair"] = self._interfaces(self.host)
            except ImportError as e:
                made["import"] = e
            except Exception as e:
                made["error"] = e

        worker = threading.Thread(target=make, name=f"connect {self.host}", daemon=True)
        worker.start()
        worker.join(self.connect_timeout)
        if worker.is_alive():
            raise RobotError(f"{self.name}: cannot connect: no answer within {self.connect_timeout:g} s")
        if "import" in made:
            raise made["import"]
        if "error" in made:
            raise self._fail("cannot connect", made["error"])
        self._control, self._receive = made["pair"]
        self._lost = False
        self._seen = (math.nan, 0.0)

    def _alive(self) -> None:
        """RobotError if the link was lost: the interface reports it, or the controller's time is stale."""
        if self._lost:
            raise RobotError(f"{self.name}: the link to the controller was lost")
        try:
            connected = self._receive.isConnected() and self._control.isConnected()
            stamp = float(self._receive.getTimestamp())
        except Exception as e:
            self._lost = True
            raise self._fail("the controller reports", e) from None
        if not connected:
            self._lost = True
            raise RobotError(f"{self.name}: the RTDE connection to the controller is closed")
        wall = time.monotonic()
        if stamp != self._seen[0]:
            self._seen = (stamp, wall)
        elif wall - self._seen[1] > self.stale_after:
            self._lost = True
            raise RobotError(f"{self.name}: no new state from the controller for {wall - self._seen[1]:.3f} s "
                             f"(> stale_after {self.stale_after:g} s): the link is lost")

    def _read_state(self) -> JointState:
        self._alive()
        try:
            q = np.array(self._receive.getActualQ(), dtype=float)
            dq = np.array(self._receive.getActualQd(), dtype=float)
        except Exception as e:
            self._lost = True
            raise self._fail("reading the joints", e) from None
        if q.shape != (6,) or dq.shape != (6,):
            raise RobotError(f"{self.name}: the controller sent {q.size} joint positions and {dq.size} speeds, "
                             "not 6")
        return JointState(q, dq, self.now())

    def _send(self, dq: np.ndarray) -> None:
        self._alive()
        try:
            ok = self._control.speedJ([float(x) for x in dq], self.acceleration, 0.0)
        except Exception as e:
            raise self._fail("speedJ", e) from None
        if not ok:
            raise RobotError(f"{self.name}: speedJ refused by the controller (not in remote control, or a "
                             "protective stop)")

    def _halt(self) -> None:
        if self._control is not None and not self._lost:
            self._control.speedStop(self.acceleration)

    def _close(self) -> None:
        control, receive, self._control, self._receive = self._control, self._receive, None, None
        errors = []
        for interface in (control, receive):
            try:
                if interface is not None:
                    interface.disconnect()
            except Exception as e:
                errors.append(e)
        if errors:
            raise errors[0]
