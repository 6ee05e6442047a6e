"""A simulated episode written as a ROS 2 bag: ibvs.sim.run(..., record="run.mcap"), ibvs run --record.

The bag is written after the run, from the Result's history (and the rendered frames of an image
episode), each message stamped at its frame's simulated time, start_ns + k / fps. Topics (TOPICS):

  /camera/image_raw        sensor_msgs/Image mono8      the frame the tracker saw (image episodes)
  /camera/camera_info      sensor_msgs/CameraInfo       every frame (cameras with a pixel sensor)
  /ibvs/goal/image_raw     sensor_msgs/Image mono8      the goal's image, once (teach by showing)
  /ibvs/features           std_msgs/Float64MultiArray   (N, 2) measured pixels (NaN: lost), every frame
  /ibvs/features_desired   std_msgs/Float64MultiArray   (N, 2) the goal's measured pixels, once
  /ibvs/cmd_twist          geometry_msgs/TwistStamped   the commanded twist, camera frame, frames the
                                                        servo ran
  /joint_states            sensor_msgs/JointState       with a robot: q and the applied qdot
  /tf                      tf2_msgs/TFMessage           world <- camera_optical_frame, world <- target,
                                                        with a robot world <- its camera mount frame
  /ibvs/config             std_msgs/String              JSON, once: what replay needs (ibvs.ros.config)

Frames: "world" (the simulator's world, a robot's base), "camera_optical_frame" (x right, y down,
z forward: ibvs's camera frame), "target". Without a pixel sensor (the normalised camera of the free
world, run without vision) there is no camera_info and no image.
"""

from __future__ import annotations

import math
from typing import Any, Dict, Optional

import numpy as np

from .. import __version__
from . import config as cfg
from . import types as t
from .bag import BagWriter
from .cameras import camera_info
from .images import image_msg
from .joints import float64_array
from .tf import tf_message
from .twist import twist_msg

# What ibvs.ros re-exports (and documents); the other names here are its own helpers.
__all__ = ["TOPICS", "record"]

#: The topics of a recorded episode (see the module docstring).
TOPICS = {"image": "/camera/image_raw", "camera_info": "/camera/camera_info", "goal_image": "/ibvs/goal/image_raw",
          "features": "/ibvs/features", "features_desired": "/ibvs/features_desired", "twist": "/ibvs/cmd_twist",
          "joint_states": "/joint_states", "tf": "/tf", "config": "/ibvs/config"}
#: Frame names of the recorded messages.
WORLD, CAMERA, TARGET = "world", "camera_optical_frame", "target"


class Recording:
    """What sim.run(record=path) does around the run: before it, check that rosbags is there and the
    directory exists, and (an image sensor) have the sensor keep its frames and run it through a proxy
    (`sensor`) that notes the true projections the tracker is started from at frames -1 (the goal) and
    0; after it, write(result, servo, options)."""

    def __init__(self, path, sensor=None):
        from pathlib import Path

        t.typestore()  # rosbags is there, before any simulation
        self.path = Path(path)
        parent = self.path.parent if str(self.path.parent) else Path(".")
        if not parent.is_dir():
            raise FileNotFoundError(f"record: directory {str(parent)!r} does not exist")
        self.resets: list = []
        self.sensor = sensor
        if sensor is not None and hasattr(sensor, "detector"):  # an ibvs.vision.ImageSensor
            sensor.keep_frames = True
            self.sensor = _NotingSensor(sensor, self.resets)

    def write(self, result, servo=None, options: Optional[Dict[str, Any]] = None) -> Dict[str, int]:
        """Write the run's bag (see record())."""
        return record(result, self.path, servo=servo, options=options, resets=self.resets)


def _noting_sensor_class():
    from .._core import sim as _sim

    class NotingSensor(_sim.Sensor):
        """An image sensor that also notes the true projections of frames -1 and 0 (the tracker's start)."""

        def __init__(self, inner, resets):
            super().__init__()
            self.inner, self.resets = inner, resets

        def reset(self, seed: int) -> None:
            self.resets.clear()
            self.inner.reset(seed)

        def measure(self, frame: int, pose, projected, twist):
            if frame <= 0:
                self.resets.append(np.array(projected, dtype=np.float64))
            return self.inner.measure(frame, pose, projected, twist)

    return NotingSensor


def _NotingSensor(inner, resets):
    return _noting_sensor_class()(inner, resets)


def _sensor_spec(sensor, resets) -> Optional[Dict[str, Any]]:
    """The image sensor's renderer kind, tracker options and starting guesses (None without one)."""
    if sensor is None or not hasattr(sensor, "detector"):
        return None
    det = sensor.detector
    spec: Dict[str, Any] = {"kind": sensor.renderer.kind, "detector": type(det).__name__}
    if spec["detector"] == "DotTracker":
        spec.update(threshold=det.threshold, gate=det.gate, min_area=det.min_area)
    else:
        spec.update(ids=list(det.ids), dictionary=det.dictionary, refine=det.refine, decimate=det.decimate)
    spec["resets"] = [None if r is None else cfg.array(r) for r in resets]
    return spec


def _spec(servo) -> Optional[Dict[str, Any]]:
    """The servo's spec, or None for a servo /ibvs/config cannot describe (replay then takes a scheme)."""
    try:
        return None if servo is None else cfg.servo_spec(servo)
    except (TypeError, ValueError):
        return None


def _config(result, servo, options, resets) -> Dict[str, Any]:
    h = result.history
    robot = result.robot
    c: Dict[str, Any] = {
        "ibvs_version": __version__, "topics": TOPICS, "frames": len(h), "fps": result.camera.fps,
        "camera": cfg.camera_spec(result.camera), "servo_text": result.servo,
        "servo": _spec(servo),
        "target": None if result.target is None else {"points": cfg.array(result.target.points),
                                                       "pose": cfg.array(result.target.pose),
                                                       "planar": bool(result.target.planar)},
        "options": dict(options or {}), "goal": cfg.array(result.goal), "uv_desired": cfg.array(result.uv_desired),
        "depth_desired": cfg.array(result.depth_desired),
        "measured_desired": None if result.measured_desired is None else cfg.array(result.measured_desired),
        "outcome": {"outcome": result.status.outcome, "frame": result.status.frame, "point": result.status.point,
                    "joint": result.status.joint},
        "vision": _sensor_spec(result.sensor, resets),
        "robot": None if robot is None else {"dof": robot.dof, "joint_names": _joint_names(robot),
                                             "mount": cfg.array(robot.mount), "frame": _mount_frame(robot)},
    }
    return c


def _joint_names(robot) -> list:
    names = getattr(robot, "joint_names", None)
    return list(names) if names else [f"joint{i + 1}" for i in range(robot.dof)]


def _mount_frame(robot) -> str:
    return str(getattr(robot, "frame_name", None) or "end_effector")


def _has_pixels(camera) -> bool:
    u0, u1, v0, v1 = camera.bounds
    return u0 == 0 and v0 == 0 and u1 == round(u1) and v1 == round(v1) and u1 >= 16 and v1 >= 16


def record(result, path, servo=None, options: Optional[Dict[str, Any]] = None, resets=(),
           start_ns: int = 0) -> Dict[str, int]:
    """Write an episode's Result as a ROS 2 bag at path (.mcap: one MCAP file; else a rosbag2 directory),
    atomically (see ibvs.ros.bag.BagWriter); returns {topic: message count}. servo (the servo run) and
    options (sim.run's depth, latency, noise...) go into /ibvs/config for replay; sim.run(record=...)
    passes both. Stamps: start_ns + the frame's simulated time."""
    h = result.history
    camera = result.camera
    ts = t.typestore()
    pixels = _has_pixels(camera)
    frames = list(getattr(result.sensor, "frames", None) or [])
    goal_image = getattr(result.sensor, "goal_image", None)
    config = _config(result, servo, options, list(resets))
    info = camera_info(camera, ts, CAMERA) if pixels else None
    robot = result.robot
    names = _joint_names(robot) if robot is not None else None
    mount_inv = np.linalg.inv(robot.mount) if robot is not None else None
    target_pose = None if result.target is None else np.asarray(result.target.pose)
    with BagWriter(path, ts) as bag:
        t0 = int(start_ns)
        bag.write(TOPICS["config"], t.make(ts, "std_msgs/msg/String", data=cfg.dumps(config)), t0)
        if goal_image is not None:
            bag.write(TOPICS["goal_image"], image_msg(goal_image, ts, CAMERA, t0), t0)
        if result.measured_desired is not None:
            bag.write(TOPICS["features_desired"], float64_array(result.measured_desired, ts, "points"), t0)
        for k in range(len(h)):
            ns = t0 + t.to_ns(h.time[k])
            if k < len(frames):
                bag.write(TOPICS["image"], image_msg(frames[k], ts, CAMERA, ns), ns)
            if info is not None:
                info.header.stamp = t.time_msg(ts, ns)
                bag.write(TOPICS["camera_info"], info, ns)
            if h.measured is not None and not np.isnan(h.measured[k]).all():
                bag.write(TOPICS["features"], float64_array(h.measured[k], ts, "points"), ns)
            if math.isfinite(h.error_norm[k]):  # the servo ran at this frame
                bag.write(TOPICS["twist"], twist_msg(h.twist[k], ts, CAMERA, ns), ns)
            if robot is not None:
                bag.write(TOPICS["joint_states"], t.make(
                    ts, "sensor_msgs/msg/JointState", header=t.header(ts, ns, WORLD), name=names,
                    position=np.array(h.q[k], dtype=np.float64), velocity=np.array(h.qdot[k], dtype=np.float64),
                    effort=np.zeros(0)), ns)
            poses = {(WORLD, CAMERA): h.pose[k]}
            if target_pose is not None:
                poses[(WORLD, TARGET)] = target_pose
            if robot is not None:
                poses[(WORLD, _mount_frame(robot))] = h.pose[k] @ mount_inv
            bag.write(TOPICS["tf"], tf_message(poses, ts, ns), ns)
        return dict(bag.counts)
