"""The servo as a ROS 2 node (rclpy): `ibvs-ros2-servo`, or ros2 launch with launch/servo.launch.py.

A thin wrapper of ibvs.ros.node.ServoNodeCore, which holds all the logic (tested without ROS): this
module declares the parameters (NodeParams' fields, plus urdf for the joint velocity outputs),
subscribes to image, camera_info and joint_states, publishes the core's command on cmd_twist,
joint_velocities or joint_trajectory (remap them: moveit_servo's delta_twist_cmds, a
JointGroupVelocityController's commands), and runs the watchdog on a timer. rclpy is imported in
main() only: this module imports without ROS. Not run here (no ROS 2 on the machine that tests
ibvs): see docs/ros.md.

    ros2 run ... / ibvs-ros2-servo --ros-args -p desired_pixels:="[380.,300.,260.,300.,260.,180.,380.,180.]" \\
        -p depth:=0.5 -r image:=/camera/image_raw -r camera_info:=/camera/camera_info
"""

from __future__ import annotations

import dataclasses
import sys

from .node import NodeParams, ServoNodeCore

#: The topic each output is published on (before remapping).
COMMAND_TOPICS = {"twist": "cmd_twist", "joint_velocities": "joint_velocities", "joint_trajectory": "joint_trajectory"}


def _declare(node, descriptor) -> NodeParams:
    """NodeParams from the node's ROS parameters (declared with NodeParams' defaults, dynamically typed:
    depth is one number or a list)."""
    defaults = NodeParams()
    values = {}
    for f in dataclasses.fields(NodeParams):
        default = getattr(defaults, f.name)
        if default is None or (isinstance(default, (tuple, list)) and not default):
            # ROS parameters need a type: empty lists and None are declared by their use
            default = {"desired_pixels": [0.0], "initial_pixels": [0.0], "eMc": [0.0], "joint_names": [""],
                       "max_joint_speed": 0.0, "tag_ids": [0]}.get(f.name, default)
        elif isinstance(default, tuple):
            default = list(default)
        values[f.name] = node.declare_parameter(f.name, default, descriptor).value
    for name, unset in (("initial_pixels", [0.0]), ("eMc", [0.0]), ("joint_names", [""]), ("max_joint_speed", 0.0)):
        if values[name] == unset:
            values[name] = None if name != "joint_names" else ()
    node.declare_parameter("urdf", "")
    for name in ("tag_ids", "joint_names", "desired_pixels", "initial_pixels", "eMc"):
        if values[name] is not None:
            values[name] = list(values[name])
    return NodeParams(**values)


def main(argv=None) -> int:
    """Run the node until shut down (Ctrl-C)."""
    try:
        import rclpy
        from rcl_interfaces.msg import ParameterDescriptor
        from rclpy.node import Node
        from rosidl_runtime_py.utilities import get_message
    except ImportError:
        print("ibvs-ros2-servo needs ROS 2 (rclpy): source your ROS 2 installation (e.g. "
              "/opt/ros/humble/setup.bash) in a Python environment where ibvs is installed", file=sys.stderr)
        return 2
    rclpy.init(args=sys.argv if argv is None else argv)
    node = Node("ibvs_servo")
    params = _declare(node, ParameterDescriptor(dynamic_typing=True))
    jacobian = None
    if params.output != "twist":
        from ..sim import UrdfRobot

        robot = UrdfRobot(node.get_parameter("urdf").value, params.mount_frame, params.eMc)
        jacobian = lambda q: robot.kinematics(q)[1]  # noqa: E731 - the mount frame's Jacobian, own frame
    clock = lambda: node.get_clock().now().nanoseconds  # noqa: E731
    core = ServoNodeCore(params, clock, jacobian=jacobian, types=get_message)
    kind = {"twist": "geometry_msgs/msg/TwistStamped", "joint_velocities": "std_msgs/msg/Float64MultiArray",
            "joint_trajectory": "trajectory_msgs/msg/JointTrajectory"}[params.output]
    pub = node.create_publisher(get_message(kind), COMMAND_TOPICS[params.output], 10)

    def publish(msg):
        if msg is not None:
            pub.publish(msg)
        if core.last_error:
            node.get_logger().warn(core.last_error, throttle_duration_sec=1.0)

    node.create_subscription(get_message("sensor_msgs/msg/CameraInfo"), "camera_info", core.on_camera_info, 1)
    node.create_subscription(get_message("sensor_msgs/msg/Image"), "image", lambda m: publish(core.on_image(m)), 1)
    node.create_subscription(get_message("sensor_msgs/msg/JointState"), "joint_states", core.on_joint_state, 10)
    node.create_timer(0.02, lambda: publish(core.tick()) if core.state in ("ramping", "stopped") else None)
    try:
        rclpy.spin(node)
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
