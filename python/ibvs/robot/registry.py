"""open_robot(kind, **options): a driver by name (what `ibvs servo` configs name), imported lazily so that
an optional library is needed only by the driver that uses it."""

from __future__ import annotations

import importlib
import inspect

from .base import Robot

__all__ = ["ROBOTS", "open_robot"]

#: kind -> "module:factory" of every driver.
ROBOTS = {
    "sim": "ibvs.robot.sim:SimRobot",
    "franky": "ibvs.robot.franky:FrankyRobot",
    "ur": "ibvs.robot.ur:URRobot",
    "ros2_control": "ibvs.robot.ros2_control:Ros2ControlRobot",
    "mujoco": "ibvs.sim.physics:MujocoRobot",
}


def open_robot(kind: str, **options) -> Robot:
    """A Robot of `kind` (one of ROBOTS) built with `options` (its constructor's keywords); not connected yet.
    ValueError for an unknown kind or option; ImportError naming the extra when its library is missing."""
    if not isinstance(kind, str) or kind not in ROBOTS:
        raise ValueError(f"robot kind must be one of {sorted(ROBOTS)}, got {kind!r}")
    module, name = ROBOTS[kind].split(":")
    factory = getattr(importlib.import_module(module), name)
    params = inspect.signature(factory).parameters
    if not any(p.kind is p.VAR_KEYWORD for p in params.values()):
        unknown = sorted(set(options) - set(params))
        if unknown:
            known = ", ".join(k for k in params if k != "self")
            raise ValueError(f"robot kind {kind!r}: unknown option(s) {', '.join(unknown)} (its options: {known})")
    robot = factory(**options)
    if not isinstance(robot, Robot):
        raise TypeError(f"{ROBOTS[kind]} made a {type(robot).__name__}, not an ibvs.robot.Robot")
    return robot
