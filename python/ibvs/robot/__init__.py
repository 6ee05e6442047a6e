"""ibvs.robot: robot drivers behind one protocol (docs/robots.md).

    import numpy as np, ibvs.robot as robots
    with robots.open_robot("franky", host="127.0.0.1") as robot:     # or "sim", "ur", "ros2_control", "mujoco"
        s = robot.state()                                             # JointState(q, dq, stamp)
        cmd = robot.send_joint_velocity(np.full(robot.n_joints, 0.01))  # checked by robot.limits first
        cmd.dq, cmd.clamped, cmd.reason                               # what was sent
    # leaving the block stops the robot, then disconnects

Every command passes check_command (the one limit check: velocity and acceleration scaled with the
direction kept, position limits and the workspace box refused: ibvs.robot.limits) before an adapter sends
it; a refused command or a failed send stops the robot; stop() and disconnect() never raise.
"""

from __future__ import annotations

from .base import JointState, Robot, RobotError
from .limits import Command, LimitError, Limits, check_command
from .registry import ROBOTS, open_robot

__all__ = [
    "Command",
    "JointState",
    "LimitError",
    "Limits",
    "ROBOTS",
    "Robot",
    "RobotError",
    "check_command",
    "open_robot",
]
