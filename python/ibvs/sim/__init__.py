"""ibvs.sim: closed-loop simulation of a servo on a free-flying camera, an Afma6-like gantry or any arm.

The whole loop runs in C++ (one call per episode); this module configures it and
returns the history as numpy arrays.

    import numpy as np, ibvs, ibvs.sim as sim
    servo = ibvs.Servo(ibvs.Layout.polar(4), gain=1.0)
    case = sim.cases.z_rotation()
    result = sim.run(servo, case.camera, case.target, case.start, case.goal, duration=case.duration)
    result.status.outcome, result.metrics.camera_retreat, result.history.twist
    fig = result.plot()                  # a matplotlib Figure (ibvs.viz.episode)
    result.animate("run.gif", speed=2)   # camera view and 3D scene (ibvs.viz.animate)

A robot carries the camera: sim.Gantry.afma6(), or any arm from its URDF (sim.UrdfRobot, Pinocchio);
sim.solve_ik(robot, camera_pose, q0) finds its joints for a camera pose (sim.ik). sim.collect_hand_eye moves an
arm through calibration stations (sim.hand_eye); sim.MiscalibratedRobot drives one with a wrong eMc;
sim.MiscalibratedCamera gives the servo the image through wrong intrinsics.

Frames and conventions are those of ibvs (camera x right, y down, z forward;
twist (Tx, Ty, Tz, wx, wy, wz) in the camera frame). Poses are 4x4 world <- camera;
a robot's base frame is the world frame.
"""

from __future__ import annotations

from . import cases
from .episode import Camera, FeatureSource, Gantry, LineSource, Robot, Sensor, Target, run
from .episode import MomentsSource, PbvsSource, Point25DSource
from .episode import SphericalSource
from .episode import EllipseSource, FunctionSource, SegmentSource, plane_in_camera
from .hand_eye import HandEyeData, HandEyeScene, collect_hand_eye, hand_eye_scene
from .ik import IKResult, solve_ik
from .miscalibrated import MiscalibratedCamera, MiscalibratedRobot
from .poses import pose, pose_deg, rotation
from .result import OUTCOMES, History, Metrics, Result, RunStatus
from .urdf import UrdfRobot, example_robot_urdf

__all__ = [
    "Camera",
    "EllipseSource",
    "FeatureSource",
    "FunctionSource",
    "Gantry",
    "HandEyeData",
    "HandEyeScene",
    "History",
    "IKResult",
    "LineSource",
    "Metrics",
    "MiscalibratedCamera",
    "MiscalibratedRobot",
    "MomentsSource",
    "OUTCOMES",
    "PbvsSource",
    "Point25DSource",
    "Result",
    "Robot",
    "RunStatus",
    "SegmentSource",
    "Sensor",
    "SphericalSource",
    "Target",
    "UrdfRobot",
    "cases",
    "collect_hand_eye",
    "example_robot_urdf",
    "hand_eye_scene",
    "plane_in_camera",
    "pose",
    "pose_deg",
    "rotation",
    "run",
    "solve_ik",
]
