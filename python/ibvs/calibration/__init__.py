"""ibvs.calibration: hand-eye calibration, where the camera is on the robot (eye-in-hand, eMc) or in the cell
(eye-to-hand, bMc), from robot poses and the target's poses at a few stations; OpenCV's solvers underneath.

    import ibvs
    poses, kept = ibvs.calibration.target_poses(camera, detections, ibvs.calibration.tag_points(0.1))
    result = ibvs.calibrate_hand_eye(robot_poses[kept], poses, mount="eye_in_hand", method="park")
    print(result)                                   # eMc, and the residuals of every station
    servo_mapping = ibvs.JointMapping(7, result.eMc)

ibvs.sim.collect_hand_eye moves a simulated arm through stations and returns such data with the truth
(docs/hand-eye.md). Importing this package needs numpy only: OpenCV (the vision extra) is imported by
calibrate_hand_eye when it runs.

Modules: hand_eye (calibrate_hand_eye, HandEyeResult, METHODS, the conventions), image_poses (target_pose,
target_poses, tag_points), rigid (pose checks, pose_error); this package re-exports their public names.
"""

from __future__ import annotations

from .hand_eye import (
    DEFAULT_METHOD,
    HAND_EYE_METHODS,
    METHODS,
    MOUNTS,
    ROBOT_WORLD_METHODS,
    HandEyeResult,
    calibrate_hand_eye,
)
from .rigid import pose_error
from .image_poses import tag_points, target_pose, target_poses

__all__ = [
    "DEFAULT_METHOD",
    "HAND_EYE_METHODS",
    "METHODS",
    "MOUNTS",
    "ROBOT_WORLD_METHODS",
    "HandEyeResult",
    "calibrate_hand_eye",
    "pose_error",
    "tag_points",
    "target_pose",
    "target_poses",
]
