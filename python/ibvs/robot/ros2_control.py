"""An arm under ros2_control: joint velocities published as std_msgs/Float64MultiArray for a
velocity_controllers/JointGroupVelocityController (its joints' order), joint states fed from
sensor_msgs/JointState messages - through ibvs.ros's message conversions, so rclpy's classes and rosbags'
work alike.

The transport is injected: `publish` is any callable taking the message (an rclpy publisher's publish, a
list's append in the tests), and every sensor_msgs/JointState received goes to feed(msg) (an rclpy
subscription's callback). ros2_control_robot(node, ...) wires both on an rclpy node, as
ibvs.ros.ros2_node does for the servo node.

NOT RUN against a live ros2_control graph here (ROS 2 is not installed on this machine): the messages are
built and read with rosbags' classes in tests/python/test_robot_ros2_control.py.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Optional, Sequence

import numpy as np

from .base import JointState, Robot, RobotError
from .limits import Limits

__all__ = ["Ros2ControlRobot", "ros2_control_robot"]


class Ros2ControlRobot(Robot):
    """A ros2_control arm through a JointGroupVelocityController.

    joint_names: the controller's joints, in its order (the command's order; the joint states are read by
    name). publish: a callable taking a std_msgs/Float64MultiArray. limits: its Limits (the URDF's, e.g.
    from an ibvs.sim.UrdfRobot's q_min, q_max, qdot_max, and an acceleration). rate: the command rate (Hz).
    types: the message classes (ibvs.ros.types: None = rosbags' Humble typestore; rclpy's get_message on
    a node). stale_after: the joint states are lost (RobotError) when none arrived for this long (s,
    default 3 periods). clock, kinematics, dry_run: as Robot's. A JointState without velocities gives
    zero velocities (the limit check then starts from the last command).
    """

    def __init__(self, joint_names: Sequence[str], publish: Callable[[Any], Any], limits: Limits,
                 rate: float = 100.0, types: Any = None, stale_after: Optional[float] = None, clock: Any = None,
                 kinematics: Any = None, dry_run: bool = False) -> None:
        names = [str(n) for n in joint_names] if not isinstance(joint_names, str) else []
        if not names or len(set(names)) != len(names):
            raise ValueError(f"joint_names must be distinct joint names, got {joint_names!r}")
        if not callable(publish):
            raise TypeError(f"publish must be a callable taking a message, got {type(publish).__name__}")
        if not isinstance(limits, Limits) or limits.n != len(names):
            raise ValueError(f"limits must be an ibvs.robot.Limits for the {len(names)} joints")
        super().__init__(f"ros2_control {len(names)} joints", limits, rate, kinematics, clock, dry_run)
        stale = 3.0 / self.rate if stale_after is None else stale_after
        if isinstance(stale, bool) or not isinstance(stale, (int, float)) or not (math.isfinite(stale) and stale > 0):
            raise ValueError(f"stale_after must be a time > 0 (s), got {stale_after!r}")
        self.joint_names = names
        self.stale_after = float(stale)
        self.types = types
        self._publish = publish
        self._latest: Optional[JointState] = None

    def feed(self, msg) -> None:
        """Take a sensor_msgs/JointState (stamped on arrival with the robot's clock). A message that lacks one of
        the joints or is not finite raises ValueError naming the field (ibvs.ros.joint_positions)."""
        from ..ros import joint_positions
        from ..ros.types import floats

        q = joint_positions(msg, self.joint_names)
        vel = floats(msg, "velocity", "joint_states", finite=False)
        dq = np.zeros(len(q))
        if vel.size:
            have = [str(n) for n in msg.name]
            if vel.size != len(have):
                raise ValueError(f"joint_states.velocity: {vel.size} velocities for {len(have)} names")
            dq = vel[[have.index(n) for n in self.joint_names]]
            if not np.isfinite(dq).all():
                raise ValueError("joint_states.velocity: not finite")
        self._latest = JointState(q, dq, self.now())

    def _connect(self) -> None:
        self._latest = None  # states from before connecting are not trusted

    def _read_state(self) -> JointState:
        s = self._latest
        if s is None:
            raise RobotError(f"{self.name}: no joint state received yet (is /joint_states published?)")
        age = self.now() - s.stamp
        if age > self.stale_after:
            raise RobotError(f"{self.name}: the last joint state is {age:.3f} s old (> stale_after "
                             f"{self.stale_after:g} s): the joint states are lost")
        return s

    def _publish_velocities(self, dq: np.ndarray) -> None:
        from ..ros import float64_array

        try:
            self._publish(float64_array(dq, self.types))
        except Exception as e:
            raise RobotError(f"{self.name}: publishing the command: {type(e).__name__}: {e}") from None

    def _send(self, dq: np.ndarray) -> None:
        self._publish_velocities(dq)

    def _halt(self) -> None:
        self._publish_velocities(np.zeros(self.n_joints))

    def _close(self) -> None:
        pass


def ros2_control_robot(node, joint_names: Sequence[str], limits: Limits,
                       command_topic: str = "/forward_velocity_controller/commands",
                       joint_states_topic: str = "/joint_states", **options) -> Ros2ControlRobot:
    """A Ros2ControlRobot on an rclpy node: a publisher of std_msgs/Float64MultiArray on command_topic (the
    JointGroupVelocityController's commands) and a subscription to sensor_msgs/JointState on
    joint_states_topic feeding it; options as Ros2ControlRobot's. The node must be spun (rclpy.spin in a
    thread, or an executor) for the joint states to arrive. Needs ROS 2's rclpy (not run here)."""
    try:
        from rosidl_runtime_py.utilities import get_message
    except ImportError as e:
        raise ImportError("ros2_control_robot needs ROS 2 (rclpy, rosidl_runtime_py): source a ROS 2 install") from e
    pub = node.create_publisher(get_message("std_msgs/msg/Float64MultiArray"), command_topic, 10)
    robot = Ros2ControlRobot(joint_names, pub.publish, limits, types=get_message, **options)
    node.create_subscription(get_message("sensor_msgs/msg/JointState"), joint_states_topic, robot.feed, 10)
    return robot
