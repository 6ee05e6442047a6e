"""The servo node's logic, without ROS: ServoNodeCore takes messages and a clock and returns messages.

    core = ServoNodeCore(NodeParams(desired_pixels=goal_px, depth=0.5), clock=lambda: now_ns)
    core.on_camera_info(info_msg)                 # sensor_msgs/CameraInfo (any class with its fields)
    core.on_joint_state(joint_state_msg)          # for output="joint_velocities"
    out = core.on_image(image_msg)                # -> the command to publish (or None before camera_info)
    out = core.tick()                             # the watchdog, at a fixed rate: ramps down without images

Each image: the tracker (dots or tag) finds the points, the camera model normalises them, the servo
(a scheme of ibvs.study.schemes with the gain, damping and speed limits) computes the camera twist,
which goes out as a geometry_msgs/TwistStamped (in the camera frame, or at the mount frame of eMc:
moveit_servo's input) or, through ibvs.JointMapping and the arm's Jacobian, as joint velocities
(std_msgs/Float64MultiArray for ros2_control's JointGroupVelocityController, or a one-point
trajectory_msgs/JointTrajectory).

The lost-feature stop: when the features are lost (a point not tracked, the tag not found), or an
image is malformed, or no image comes, the last good twist is ramped down linearly to zero over
lost_timeout seconds (tick() keeps ramping between images), then the command is zero ("stopped");
the servo resumes with the next image in which every point is found (a dot tracker that lost a dot
must be restarted: reset()). A malformed message never raises: its error, naming the field, is in
last_error and counted in bad_messages.

ibvs.ros.ros2_node wraps this class in an rclpy node (ibvs-ros2-servo); the wrapper only moves
messages, parameters and the clock in and out. The servo loop (ibvs.loop) runs the same logic on arrays:
set_camera(CameraModel), twist_of_image(gray image, stamp), ramp_twist(), joint_velocities(twist) are
what on_camera_info, on_image and tick do between the messages. With a latency predictor
(ibvs.loop.latency.FeaturePredictor: `predictor`) the points are predicted over the capture-to-command
delay before the servo runs, and the servo keeps its own depths (the predicted ones are not handed on: see
twist_of_image); without one (the default) nothing changes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Optional, Sequence

import numpy as np

from .._core import CameraModel, JointMapping, PartitionedServo
from . import types as t
from .cameras import camera_model
from .images import gray8
from .joints import float64_array, joint_positions, joint_trajectory
from .twist import twist_msg

# What ibvs.ros re-exports (and documents); the other names here are its own helpers.
__all__ = ["OUTPUTS", "NodeParams", "ServoNodeCore"]

#: What the node can publish.
OUTPUTS = ("twist", "joint_velocities", "joint_trajectory")


@dataclass
class NodeParams:
    """The servo node's parameters (the ROS node declares each as a ROS parameter of the same name).

    desired_pixels  (N, 2) the goal's pixels (teach by showing: where the tracker saw the points at the goal)
    depth           the goal depth(s), metres: one for all points, or N (the servo's depth, constant)
    scheme, gain    a scheme of ibvs.study.schemes ("polar", "cartesian"...) and its gain (1/s)
    damping         of the servo's least squares (0: none)
    max_linear_speed, max_angular_speed   m/s, rad/s: the twist is scaled down within them
    tracker         "dots" (ibvs.vision.DotTracker, started at initial_pixels, default the desired ones)
                    or "tag" (ibvs.vision.TagDetector of tag_ids)
    output          "twist" (TwistStamped), "joint_velocities" (Float64MultiArray) or "joint_trajectory"
    eMc             (4, 4) mount (end effector) <- camera: for joint velocities, and for twist_frame="mount"
    twist_frame     "camera": the twist in camera_frame; "mount": the same motion as the mount frame's
                    twist (mount_frame's axes, at its origin)
    joint_names     the arm's joints, in the order of the Jacobian (joint velocity outputs)
    max_joint_speed rad/s (or m/s) per joint, or one for all; None: no limit
    lost_timeout    seconds over which the last twist ramps down to zero once the features are lost
    turn            radians: which way a half-turn about the optical axis goes (Servo.continue_turn: the polar
                    angle errors taken near +pi or -pi at the first frame, instead of as the image noise has
                    them), applied at the start and at every reset; NaN (default): the noise decides; schemes
                    without polar angles ignore it, the partitioned one (no angle wrap) refuses it
    """

    desired_pixels: Sequence = ()
    depth: object = 0.5
    scheme: str = "polar"
    gain: float = 0.5
    damping: float = 0.0
    max_linear_speed: float = 0.1
    max_angular_speed: float = 0.5
    tracker: str = "dots"
    initial_pixels: Optional[Sequence] = None
    tag_ids: Sequence[int] = (0,)
    output: str = "twist"
    eMc: Optional[Sequence] = None
    twist_frame: str = "camera"
    camera_frame: str = "camera_optical_frame"
    mount_frame: str = "tool0"
    joint_names: Sequence[str] = ()
    max_joint_speed: Optional[object] = None
    lost_timeout: float = 0.2
    fps: float = 30.0
    turn: float = math.nan


def _check(p: NodeParams):
    desired = np.asarray(p.desired_pixels, dtype=np.float64)
    if desired.ndim == 1 and desired.size % 2 == 0:
        desired = desired.reshape(-1, 2)
    if desired.ndim != 2 or desired.shape[1] != 2 or len(desired) < 3 or not np.isfinite(desired).all():
        raise ValueError(f"desired_pixels must be N >= 3 finite pixels (N, 2) or 2N numbers, got shape "
                         f"{np.asarray(p.desired_pixels).shape}")
    n = len(desired)
    z = np.broadcast_to(np.asarray(p.depth, dtype=np.float64), (n,)) if np.size(p.depth) in (1, n) else None
    if z is None or not (np.isfinite(z).all() and (z > 0).all()):
        raise ValueError(f"depth must be one or {n} finite depths > 0 (metres), got {p.depth!r}")
    if p.tracker not in ("dots", "tag"):
        raise ValueError(f"tracker must be 'dots' or 'tag', got {p.tracker!r}")
    if p.output not in OUTPUTS:
        raise ValueError(f"output must be one of {OUTPUTS}, got {p.output!r}")
    if p.twist_frame not in ("camera", "mount"):
        raise ValueError(f"twist_frame must be 'camera' or 'mount', got {p.twist_frame!r}")
    for name in ("gain", "max_linear_speed", "max_angular_speed", "lost_timeout", "fps"):
        x = getattr(p, name)
        if not (isinstance(x, (int, float)) and not isinstance(x, bool) and x > 0):
            raise ValueError(f"{name} must be a number > 0, got {x!r}")
    if isinstance(p.turn, bool) or not isinstance(p.turn, (int, float)) or not (
            math.isnan(p.turn) or abs(p.turn) <= 1.25 * math.pi):
        raise ValueError(f"turn must be NaN or a number of radians within 5 pi / 4 of 0 (+-pi: which way a "
                         f"half-turn goes), got {p.turn!r}")
    eMc = None
    if p.eMc is not None:
        eMc = np.asarray(p.eMc, dtype=np.float64).reshape(4, 4) if np.size(p.eMc) == 16 else None
        if eMc is None or not np.isfinite(eMc).all() or not np.allclose(eMc[3], [0, 0, 0, 1]):
            raise ValueError("eMc must be a finite 4x4 transform (16 numbers, row by row)")
    if (p.output != "twist" or p.twist_frame == "mount") and eMc is None:
        raise ValueError(f"eMc: output {p.output!r} / twist_frame {p.twist_frame!r} needs the camera's mounting")
    if p.output != "twist" and not p.joint_names:
        raise ValueError(f"joint_names: output {p.output!r} needs the arm's joint names")
    return desired, z.copy(), eMc


class ServoNodeCore:
    """The servo node without ROS (see the module docstring). clock() returns the time in integer
    nanoseconds (the node's ROS clock; a fake one in tests). jacobian(q) -> (6, n), the mount frame's
    Jacobian in its own frame (ibvs.sim.UrdfRobot.kinematics(q)[1]), for the joint velocity outputs.
    types: the message classes to build (see ibvs.ros.types; None: rosbags')."""

    def __init__(self, params: NodeParams, clock: Callable[[], int], jacobian=None, types=None, predictor=None):
        from ..study import schemes

        self.params, self.clock, self.types = params, clock, types
        self.desired, self.depth, self.eMc = _check(params)
        n = len(self.desired)
        if params.scheme not in schemes.SCHEMES:
            raise ValueError(f"scheme must be one of {sorted(schemes.SCHEMES)}, got {params.scheme!r}")
        if params.scheme == "partitioned":
            self.servo = PartitionedServo(n, float(params.gain), damping=float(params.damping),
                                          max_linear_speed=float(params.max_linear_speed),
                                          max_angular_speed=float(params.max_angular_speed))
        else:
            self.servo = schemes.make(params.scheme, float(params.gain), n)
            self.servo.damping = float(params.damping)
            self.servo.max_linear_speed = float(params.max_linear_speed)
            self.servo.max_angular_speed = float(params.max_angular_speed)
        if not math.isnan(params.turn) and not hasattr(self.servo, "continue_turn"):
            raise ValueError(f"turn: the {params.scheme!r} scheme has no consistent angle wrap to choose a way with")
        self._turn()
        self.mapping = None
        if params.output != "twist":
            if jacobian is None:
                raise ValueError(f"jacobian: output {params.output!r} needs the arm's Jacobian, jacobian(q) -> (6, n)")
            self.mapping = JointMapping(len(params.joint_names), self.eMc, max_joint_speed=params.max_joint_speed)
        self.jacobian = jacobian
        self.camera: Optional[CameraModel] = None
        self.uv_desired = None
        self.tracker = None
        self.q = None
        self.last_twist = np.zeros(6)
        self.last_good_ns: Optional[int] = None
        self.state = "waiting"  # waiting (no camera_info or image yet), servoing, ramping, stopped
        self.last_error = ""
        self.bad_messages = 0
        self.predictor = predictor  # None: the servo sees the measured points (see the module docstring)
        self.pixels: Optional[np.ndarray] = None  # the last tracked pixels (N, 2), NaN where lost
        self.error_norm = math.nan  # the servo's last feature-error norm

    # ------------------------------------------------------------------ inputs

    def on_camera_info(self, msg) -> None:
        """The camera model (the first valid one is kept; a different one later is taken too)."""
        try:
            cam = camera_model(msg, float(self.params.fps))
            self.set_camera(cam)
        except (TypeError, ValueError) as e:
            self._bad(f"camera_info: {e}" if not str(e).startswith("camera_info") else str(e))

    def set_camera(self, cam: CameraModel) -> None:
        """The camera model (an ibvs.CameraModel with a pixel sensor); a new one restarts the tracker."""
        uv_desired = cam.normalize(self.desired)
        if self.camera is None or not (cam == self.camera):
            self.camera, self.uv_desired = cam, uv_desired
            self._new_tracker()

    def on_joint_state(self, msg) -> None:
        """The arm's joint positions (for the joint velocity outputs)."""
        try:
            self.q = joint_positions(msg, list(self.params.joint_names) or None)
        except (TypeError, ValueError) as e:
            self._bad(str(e))

    def on_image(self, msg):
        """One camera image: the command to publish (the servo's, or the lost-feature ramp), or None
        while there is no camera_info."""
        if self.camera is None:
            self.last_error = "image before camera_info: no camera model yet"
            return None
        try:
            image = gray8(msg)
        except (TypeError, ValueError) as e:
            self._bad(str(e))
            return self.tick()
        stamp = None
        if self.predictor is not None:
            try:
                stamp = t.stamp_ns(msg, "image") / t.NS
            except (TypeError, ValueError, AttributeError):
                stamp = None
        twist = self.twist_of_image(image, stamp)
        return None if twist is None else self._command(twist)

    def tick(self):
        """The watchdog (call it at a fixed rate): while no good image has come for a while, the last
        twist ramped down to zero over lost_timeout, then zero. None before the first good image."""
        twist = self.ramp_twist()
        return None if twist is None else self._command(twist)

    # ------------------------------------------------------------------ the same on arrays (ibvs.loop)

    def twist_of_image(self, image: np.ndarray, stamp: Optional[float] = None) -> Optional[np.ndarray]:
        """One gray image (uint8 (H, W), the camera's size): the camera twist (6,) to command, the
        servo's or the lost-feature ramp's; None before the first good image (or without a camera).
        stamp: the image's capture time (seconds on the clock), for the latency predictor."""
        if self.camera is None:
            self.last_error = "image before camera_info: no camera model yet"
            return None
        image = np.asarray(image)
        if image.shape != (int(self.camera.height), int(self.camera.width)):
            self._bad(f"image: {image.shape[1] if image.ndim > 1 else '?'} x {image.shape[0]} pixels, the "
                      f"camera_info says {int(self.camera.width)} x {int(self.camera.height)}")
            return self.ramp_twist()
        pixels = self.tracker.track(image).pixels
        self.pixels = np.array(pixels, dtype=np.float64)
        uv = self.camera.normalize(pixels, invalid="nan")
        if not np.isfinite(uv).all():
            self.last_error = "features lost"
            return self.ramp_twist()
        depth = self.depth
        if self.predictor is not None and stamp is not None:
            # The features are predicted; the depths the servo is given stay its own model (a constant or per
            # point). Handing on the predicted depths changes that model by a per-point millimetre or so, and a
            # law whose Jacobian is ill-conditioned (the polar law 40 mm / 17 deg off the goal: condition ~2000)
            # turns that into a different twist: the compensated polar loop then diverged at every delay
            # (docs/servo-loop.md, "Latency").
            try:
                uv, _ = self.predictor.predict(uv, depth, stamp)
            except ValueError as e:  # predicted out of the camera's field: as lost features
                self.last_error = str(e)
                return self.ramp_twist()
        result = self.servo.update(uv, depth, self.uv_desired, self.depth)
        if str(result.status).endswith("invalid_input"):
            self.last_error = "the servo refused the features (invalid_input)"
            return self.ramp_twist()
        self.error_norm = float(result.error_norm) if hasattr(result, "error_norm") else math.nan
        self.last_twist = np.array(result.velocity)
        self.last_good_ns = int(self.clock())
        self.state = "servoing"
        return self.last_twist

    def ramp_twist(self) -> Optional[np.ndarray]:
        """The lost-feature ramp now: the last good twist scaled by 1 - age / lost_timeout (age: since the
        last good image), then zero ("stopped"); None before the first good image."""
        if self.last_good_ns is None:
            return None
        age = (int(self.clock()) - self.last_good_ns) / t.NS
        if age <= 0:
            return self.last_twist
        scale = max(0.0, 1.0 - age / float(self.params.lost_timeout))
        self.state = "ramping" if scale > 0 else "stopped"
        return scale * self.last_twist

    def joint_velocities(self, twist: np.ndarray) -> np.ndarray:
        """The joint velocities (n,) of a camera twist at the last joint positions (self.q), through
        ibvs.JointMapping and the arm's Jacobian; zeros without joint positions or for a zero twist."""
        if self.mapping is None:
            raise ValueError("joint_velocities: the node's output is the twist (no joints)")
        if self.q is None or not np.asarray(twist).any():
            return np.zeros(len(self.params.joint_names))
        J = np.asarray(self.jacobian(self.q), dtype=np.float64)
        return np.array(self.mapping.update(np.asarray(twist, dtype=np.float64), J).qdot)

    def reset(self) -> None:
        """Start over: the tracker restarted at its initial pixels, no last twist (the next command is the
        servo's)."""
        self._new_tracker()
        self.last_twist, self.last_good_ns, self.state = np.zeros(6), None, "waiting"
        if hasattr(self.servo, "reset"):
            self.servo.reset()
        self._turn()

    # ------------------------------------------------------------------ internals

    def _turn(self) -> None:
        """The half-turn's direction chosen by params.turn (none when NaN)."""
        if not math.isnan(self.params.turn):
            self.servo.continue_turn(float(self.params.turn))

    def _bad(self, message: str) -> None:
        self.last_error = message
        self.bad_messages += 1

    def _new_tracker(self) -> None:
        from .. import vision

        if self.camera is None:
            return
        size = (int(self.camera.width), int(self.camera.height))
        n = len(self.desired)
        if self.params.tracker == "dots":
            self.tracker = vision.DotTracker(n, size)
            start = self.desired if self.params.initial_pixels is None else self.params.initial_pixels
            self.tracker.reset(np.asarray(start, dtype=np.float64).reshape(n, 2))
        else:
            self.tracker = vision.TagDetector(tuple(self.params.tag_ids), image_size=size)

    def _command(self, twist: np.ndarray):
        p, ns = self.params, int(self.clock())
        if self.predictor is not None:  # the node's own commands, for the prediction of the next images
            self.predictor.commanded(ns / t.NS, twist, None if self.mapping is None else self.joint_velocities(twist))
        if p.output == "twist":
            if p.twist_frame == "camera":
                return twist_msg(twist, self.types, p.camera_frame, ns)
            R, r = self.eMc[:3, :3], self.eMc[:3, 3]
            w = R @ twist[3:]
            return twist_msg(np.concatenate([R @ twist[:3] + np.cross(r, w), w]), self.types, p.mount_frame, ns)
        qdot = self.joint_velocities(twist)  # zeros without a joint state, or for a stop
        if p.output == "joint_velocities":
            return float64_array(qdot, self.types, "joints")
        return joint_trajectory(qdot, list(p.joint_names), self.types, ns)
