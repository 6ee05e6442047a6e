"""ros2 launch file of the ibvs servo node (ibvs-ros2-servo): `ros2 launch <this file> desired_pixels:=...`.

Remaps the node's inputs to a camera driver's topics and its twist output to moveit_servo's input.
Not run here (no ROS 2 on the machine that tests ibvs); tests/python/test_ros_node.py checks that it
compiles and names the node's executable and parameters.
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def generate_launch_description():
    args = {"camera": "/camera", "desired_pixels": "[380.0, 300.0, 260.0, 300.0, 260.0, 180.0, 380.0, 180.0]",
            "depth": "0.5", "scheme": "polar", "gain": "0.5", "tracker": "tag",
            "cmd_twist": "/servo_node/delta_twist_cmds"}
    declared = [DeclareLaunchArgument(name, default_value=value) for name, value in args.items()]
    camera = LaunchConfiguration("camera")
    node = Node(
        executable="ibvs-ros2-servo",
        name="ibvs_servo",
        output="screen",
        parameters=[{
            "desired_pixels": LaunchConfiguration("desired_pixels"),
            "depth": LaunchConfiguration("depth"),
            "scheme": LaunchConfiguration("scheme"),
            "gain": LaunchConfiguration("gain"),
            "tracker": LaunchConfiguration("tracker"),
            "output": "twist",
            "twist_frame": "camera",
            "lost_timeout": 0.2,
        }],
        remappings=[("image", [camera, "/image_raw"]), ("camera_info", [camera, "/camera_info"]),
                    ("cmd_twist", LaunchConfiguration("cmd_twist"))],
    )
    return LaunchDescription(declared + [node])
