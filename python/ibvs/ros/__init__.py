"""ibvs.ros: ROS 2 messages, bags and a servo node, without a ROS installation.

    import ibvs.ros as ros
    camera = ros.camera_model(camera_info_msg)          # sensor_msgs/CameraInfo -> ibvs.CameraModel
    gray = ros.gray8(image_msg)                          # sensor_msgs/Image -> uint8 (H, W) for the trackers
    msg = ros.twist_msg(result.velocity)                 # -> geometry_msgs/TwistStamped, camera frame
    sim.run(..., record="run.mcap")                      # an episode as a ROS 2 bag (MCAP)
    rep = ros.replay("run.mcap")                         # the tracker and the servo over a bag, offline
    core = ros.ServoNodeCore(ros.NodeParams(...), clock) # the servo node's logic (ibvs-ros2-servo runs it)

Conversions are duck-typed on message fields: rclpy's classes and rosbags' typestore classes work
alike; functions that build a message take `types` (None: rosbags' ROS 2 Humble classes; see
ibvs.ros.types). Bags are read and written with rosbags (the `ros` extra: pip install ".[ros]"
from the ibvs repository root); importing ibvs.ros needs nothing beyond ibvs.

Modules: types (message classes, fields, stamps), cameras, images, twist, joints, tf (the
conversions), bag (BagWriter, messages, topics), config (/ibvs/config), recorder (an episode as a bag),
replayer (a bag through a tracker and the servo), node (ServoNodeCore), ros2_node (the rclpy wrapper,
imported by nobody here), launch/servo.launch.py (a ros2 launch file). docs/ros.md has the topics.
"""

from __future__ import annotations

from .bag import BagWriter, messages, topics
from .cameras import DISTORTION_MODELS, camera_info, camera_model
from .config import servo_from_spec, servo_spec
from .images import ENCODINGS, gray8, image, image_msg
from .joints import array_of, float64_array, joint_positions, joint_trajectory
from .node import OUTPUTS, NodeParams, ServoNodeCore
from .recorder import TOPICS, record
from .replayer import DEPTH_MODES, REPLAY_TWIST_TOPIC, Replay, recorded_twists, replay, write_bag
from .tf import quaternion, rotation, tf_message, transforms
from .twist import twist_msg, twist_of

__all__ = [
    "BagWriter",
    "DEPTH_MODES",
    "DISTORTION_MODELS",
    "ENCODINGS",
    "NodeParams",
    "OUTPUTS",
    "REPLAY_TWIST_TOPIC",
    "Replay",
    "ServoNodeCore",
    "TOPICS",
    "array_of",
    "camera_info",
    "camera_model",
    "float64_array",
    "gray8",
    "image",
    "image_msg",
    "joint_positions",
    "joint_trajectory",
    "messages",
    "quaternion",
    "record",
    "recorded_twists",
    "replay",
    "rotation",
    "servo_from_spec",
    "servo_spec",
    "tf_message",
    "topics",
    "transforms",
    "twist_msg",
    "twist_of",
]
