"""The testbed behind the loop's three interfaces: a Clock, a Robot, a FrameSource.

    clock = PhysicsClock(world)            # now() = the simulated time; sleep_until(t) steps the physics to t
    robot = MujocoRobot(world)             # commands through ibvs.robot.check_command to the velocity actuators
    source = MujocoCamera(world, latency=0.05)

MujocoCamera models a camera triggered at its rate: frame k is exposed at k / rate (the scene as it
was then: the world keeps the joints' recent history) and delivered `latency` seconds later; read()
waits for the next frame by stepping the world, as a real camera's read blocks. A reader that falls
behind gets the newest frame delivered (the skipped ones are dropped: their indices are missing).
"""

from __future__ import annotations

import math
from typing import Optional

import numpy as np

from ...loop.clock import Clock
from ...robot import JointState, Limits, Robot
from ...vision.sources import Frame, FrameSource
from .world import World

__all__ = ["PhysicsClock", "MujocoRobot", "MujocoCamera"]

#: The Panda's joint acceleration limits, rad/s^2 (Franka Control Interface documentation, "Limits for Panda").
PANDA_DDQ_MAX = (15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0)
#: Other arms (the URDF gives none): rad/s^2 for every joint.
DEFAULT_DDQ_MAX = 10.0


def _world(world) -> World:
    if not isinstance(world, World):
        raise TypeError(f"world must be an ibvs.sim.physics.World, got {type(world).__name__}")
    return world


def _case_world(case: str, arm: str, width: int, height: int, fps: float) -> World:
    """A World for ibvs.sim.cases.<case>(arm) seen by testbed_camera(width, height, fps), at the case's start."""
    from .. import cases
    from .world import testbed_camera

    make = getattr(cases, case, None) if isinstance(case, str) else None
    if make is None or not callable(make) or case.startswith("_"):
        raise ValueError(f"case must name a function of ibvs.sim.cases (e.g. 'arm_general_motion'), got {case!r}")
    try:
        c = make(arm)
    except (TypeError, ValueError) as e:
        raise ValueError(f"case {case!r} with arm {arm!r}: {e}") from None
    if c.robot is None or not hasattr(c.robot, "example_name"):
        raise ValueError(f"case {case!r}: not an arm of example-robot-data")
    world = World(c.robot, c.target, testbed_camera(width, height, fps))
    world.reset(c.start)
    world.case = c
    return world


class PhysicsClock(Clock):
    """The world's simulated time: now() is it; sleep_until(t) steps the physics to t (at once when past)."""

    def __init__(self, world: World):
        self.world = _world(world)

    def now(self) -> float:
        return self.world.time

    def sleep_until(self, t: float) -> None:
        if not math.isfinite(t):
            raise ValueError(f"t must be finite, got {t!r}")
        self.world.step_to(t)


class MujocoRobot(Robot):
    """The testbed's arm as an ibvs.robot.Robot: send_joint_velocity checks the command with
    ibvs.robot.check_command (the one limit check, period 1/rate) and hands what it allows to the velocity
    actuators; state() reads qpos/qvel, stamped with the simulated time (clock: a PhysicsClock).

    world    the World; None: one built from `case` (a function of ibvs.sim.cases taking the arm's name, e.g.
             "arm_general_motion") on `arm` ("panda", "ur5"), seen by testbed_camera(width, height, fps), its
             joints at the case's start (what an `ibvs servo` config's [robot] table can name)
    limits   an ibvs.robot.Limits; default: the URDF's position and velocity limits, PANDA_DDQ_MAX for the
             Panda (DEFAULT_DDQ_MAX for other arms)
    rate     Hz of the commands (the limit check's period; default the camera's frame rate: one command a frame)
    dry_run  check and return commands, send none
    clock    None or this world's PhysicsClock (the robot's clock is always its world's: self.clock)
    """

    def __init__(self, world: Optional[World] = None, limits: Optional[Limits] = None,
                 rate: Optional[float] = None, dry_run: bool = False, clock=None,
                 case: str = "arm_general_motion", arm: str = "panda", width: int = 320, height: int = 240,
                 fps: float = 30.0):
        if world is None:
            world = _case_world(case, arm, width, height, fps)
        self.world = _world(world)
        if clock is not None and not (isinstance(clock, PhysicsClock) and clock.world is world):
            raise TypeError("clock: the mujoco robot keeps its world's time (PhysicsClock); give none")
        arm = world.robot
        if limits is None:
            ddq = PANDA_DDQ_MAX if arm.example_name == "panda" else (DEFAULT_DDQ_MAX,) * arm.dof
            limits = Limits(np.asarray(arm.q_min, float), np.asarray(arm.q_max, float),
                            np.asarray(arm.qdot_max, float), np.asarray(ddq, float))
        super().__init__(f"mujoco:{arm.example_name or arm.frame_name}", limits,
                         world.camera.fps if rate is None else rate, kinematics=arm, clock=PhysicsClock(world),
                         dry_run=dry_run)
        if self.n_joints != arm.dof:
            raise ValueError(f"limits: {self.n_joints} joints for an arm of {arm.dof}")

    def _connect(self) -> None:
        """Nothing to open: the world is in this process."""

    def _read_state(self) -> JointState:
        return JointState(self.world.q, self.world.dq, self.world.time)

    def _send(self, dq: np.ndarray) -> None:
        self.world.command(dq)

    def _halt(self) -> None:
        self.world.command(np.zeros(self.n_joints))

    def _close(self) -> None:
        """Nothing to close (the world outlives the robot: World.close frees its renderer)."""


class MujocoCamera(FrameSource):
    """The world's camera as an ibvs.vision.sources.FrameSource (see the module's docstring).

    world     the World (its camera model: world.camera)
    rate      frames per second (default: the camera model's fps)
    latency   s from exposure to delivery (>= 0; the world keeps World(history=...) seconds of the past)
    start     time of frame 0's exposure (default: the world's time at open())
    """

    def __init__(self, world: World, rate: Optional[float] = None, latency: float = 0.0,
                 start: Optional[float] = None):
        self.world = _world(world)
        self.camera = world.camera
        self.rate = float(world.camera.fps if rate is None else rate)
        if not (math.isfinite(self.rate) and self.rate > 0):
            raise ValueError(f"rate must be a positive number (Hz), got {rate!r}")
        if isinstance(latency, bool) or not isinstance(latency, (int, float)) or not 0 <= latency < 60:
            raise ValueError(f"latency must be a number of seconds in [0, 60), got {latency!r}")
        if latency > world.history - 2.0 / self.rate:
            raise ValueError(f"latency {latency!r} s: the world keeps {world.history:g} s of the past; build "
                             f"it with World(..., history=) longer than the latency plus two frames")
        self.latency = float(latency)
        self._start = start
        self._next = 0
        self._open = False

    def open(self) -> None:
        if self._start is None:
            self._start = self.world.time
        self._open = True

    def read(self, timeout: float) -> Optional[Frame]:
        """The next frame (its stamp the exposure time), stepping the world to its delivery; None when it is
        not delivered within timeout seconds (the world then stepped by timeout)."""
        if not self._open:
            raise RuntimeError("MujocoCamera: open() it first")
        if not (isinstance(timeout, (int, float)) and timeout >= 0):
            raise ValueError(f"timeout must be a non-negative number of seconds, got {timeout!r}")
        now = self.world.time
        # the newest frame delivered by now, if later than the next one: the ones between are dropped
        newest = math.floor((now - self.latency - self._start) * self.rate + 1e-9)
        k = max(self._next, newest)
        exposure = self._start + k / self.rate
        delivery = exposure + self.latency
        if delivery > now + timeout + 1e-12:
            # waited timeout (at least one physics step, so that a caller polling with tiny timeouts advances)
            self.world.step_to(max(now + timeout, now + self.world.timestep))
            return None
        self.world.step_to(delivery)
        image = self.world.render(self.world.q_at(exposure))
        self._next = k + 1
        return Frame(image, exposure, k)

    def close(self) -> None:
        self._open = False

    def __repr__(self) -> str:
        w = self.world
        return f"MujocoCamera({w.width}x{w.height}, {self.rate:g} Hz, latency {self.latency:g} s)"
