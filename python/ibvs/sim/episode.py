"""One closed-loop episode: ibvs.sim.run checks its arguments, runs the loop in C++ and wraps what
comes back in a Result."""

from __future__ import annotations

import math
from typing import Optional, Union

import numpy as np

from .._core import CameraModel, PartitionedServo, Servo
from .._core import sim as _sim
from .result import History, Metrics, Result, RunStatus, peak_speeds

# What ibvs.sim re-exports (and documents); the other names here are its own helpers.
__all__ = ["run"]

# The simulator's parts under their ibvs.sim names (the native classes themselves).
Camera = CameraModel  # the simulator's camera is the core's CameraModel (the same class)
Target = _sim.Target
Robot = _sim.Robot
Gantry = _sim.Gantry
Sensor = _sim.Sensor
FeatureSource = _sim.FeatureSource
LineSource = _sim.LineSource
MomentsSource = _sim.MomentsSource
PbvsSource = _sim.PbvsSource
Point25DSource = _sim.Point25DSource
SphericalSource = _sim.SphericalSource
SegmentSource = _sim.SegmentSource
EllipseSource = _sim.EllipseSource
FunctionSource = _sim.FunctionSource
plane_in_camera = _sim.plane_in_camera


_REPRESENTATION_NAMES = {"cartesian": "Cartesian", "polar": "polar", "cylindrical": "cylindrical"}


def _describe_servo(servo) -> str:
    """A short name of a servo's control law, e.g. "polar 8x6", "stacked 16x6", "partitioned (4 points)"."""
    if isinstance(servo, PartitionedServo):
        return f"partitioned ({servo.n_points} points)"
    task = getattr(servo, "task", None)
    if task is not None and task.features:  # points and feature blocks, e.g. "task 12x6: cartesian(4) + line + line"
        return f"task {task.rows}x6: {repr(task)[5:-1]}"
    layout = servo.layout
    kinds = {str(rep) for _, rep in layout.blocks}
    points = [p for p, _ in layout.blocks]
    if len(points) > len(set(points)):
        name = "stacked"
    elif len(kinds) > 1:
        name = "hybrid"
    else:
        name = _REPRESENTATION_NAMES.get(next(iter(kinds), ""), "")
    out = f"{name} {layout.rows}x6".strip()
    pmr = getattr(servo, "polar_min_radius", 1e-3)
    if "polar" in kinds and pmr != 1e-3:  # e.g. Servo.automatic_hybrid: Cartesian near the centre
        out += f", Cartesian within r < {pmr:g}"
    return out


def _bool(x, name: str) -> bool:
    if not isinstance(x, (bool, np.bool_)):  # "no" or 0 are not read as a truth value
        raise TypeError(f"{name} must be a bool, got {type(x).__name__}")
    return bool(x)


def _real(x, name: str) -> float:
    """A real scalar: int, float, a numpy real scalar or 0-d array (not bool, complex or str)."""
    if isinstance(x, np.ndarray) and x.ndim == 0 and x.dtype.kind in "iuf":
        return float(x)
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a real number, got {type(x).__name__}")
    return float(x)


def run(
    servo: Union[Servo, PartitionedServo],
    camera: Camera,
    target: Target,
    start,
    goal,
    robot: Optional[Robot] = None,
    duration: float = 10.0,
    noise: float = 0.0,
    latency: int = 0,
    depth: str = "exact",
    seed: int = 0,
    tolerance: Optional[float] = None,
    tolerance_px: Optional[float] = None,
    max_depth_ratio: float = 10.0,
    max_error_ratio: float = 100.0,
    stop_on_singular: bool = True,
    depth_scale: float = 1.0,
    boundary_margin: float = 0.0,
    boundary_gain: float = 0.1,
    standoff_ratio: float = 0.05,
    vision=None,
    record=None,
    keep_lost: bool = False,
    goal_pose: str = "taught",
    turn: float = math.nan,
) -> Result:
    """Simulate one closed-loop episode (in C++) and return its Result.

    servo: an ibvs.Servo (any Layout or Task: points, feature blocks such as ibvs.LineFeature,
        weights, DOF; every option: gain or AdaptiveGain, damping, jacobian mode,
        polar_min_radius, max_linear_speed / max_angular_speed) or an ibvs.PartitionedServo.
        The episode runs a copy with the same task and options, with its diagnostics on (the
        history records sigma_min); the object itself is not modified.
    camera, target: an ibvs.CameraModel (also ibvs.sim.Camera) and a Target with as many points
        as the servo's layout (a Task of feature blocks only: any number), and one feature
        source per feature block of the servo's Task, in its order (Target(points, pose,
        features=[LineSource(0, 1), ...]); docs/simulator.md, "Feature sources"). A point the
        camera model cannot map (beyond its max_radius) ends the episode as left_image, like a
        point outside the sensor; the target's points decide it for the features made of them.
        A fisheye or omnidirectional camera (distortion "equidistant" or "omnidir") sees a point
        when from_bearing maps it inside its image circle and onto the sensor, whatever the sign of
        its depth (behind_camera: closer than 1 mm to the camera centre); sim.SphericalSource feeds
        spherical blocks with the bearings of the measured pixels (docs/wide.md).
        A block its source cannot measure (e.g. a line's plane through the camera centre) ends
        it as lost_feature (RunStatus.feature).
    start, goal: 4x4 world <- camera poses; with a robot (an ibvs.sim.Robot: a Gantry, a
        UrdfRobot or any subclass), start is its n joint positions and goal n joint positions
        or a 4x4 world <- camera pose. The desired features are what the camera measures at
        the goal. The robot's JointMapping turns each twist into joint velocities (scaled to
        its speed limits). The C++ gantry runs without the GIL; a Python robot (UrdfRobot)
        is called once per frame with the GIL held.
    duration: seconds; the episode has round(duration * camera.fps) frames.
    noise: std of Gaussian noise on the measured points, in measurement units (pixels;
        normalised units for Camera.normalized).
    latency: frames between capture and control.
    depth: "exact" (true depths), "pose" (from a planar pose estimate of the measured
        points; needs a planar target), "desired" (the constant desired depths) or
        "estimated" (online, per point, from successive frames and the camera's motion
        between them as the robot reports it: a Kalman filter on the point and its
        inverse depth (x, y, 1/z), initialised at depth_scale * z*). A feature block's depth
        inputs (a line's plane...) come from the matching pose: the true one, the goal's, the
        planar pose estimate, or the target's points fitted to the estimated points. The goal
        of PBVS, 2.5-D and moments blocks is the goal as the depth mode knows it there (teach by
        showing): the true one for "exact" and "desired", the planar pose estimate of the goal's
        image for "pose", the fit at the prior depths depth_scale * z* for "estimated" (goal_pose).
    goal_pose: the goal pose c*Mo of the PBVS, 2.5-D and moments blocks: "taught" (default: as the depth
        mode knew it at the goal, above) or "given" (the goal's true camera <- target pose whatever the
        depth mode, not times depth_scale: a goal pose measured and given, e.g. "0.5 m in front of the
        tag", while the current pose is still the depth mode's). The same for "exact" and "desired". With
        a wrong camera model (MiscalibratedCamera) and depth="pose" a taught goal carries the current
        estimate's bias, which cancels (PBVS ends at the goal); a given one does not: PBVS ends where the
        estimate equals it (focal length s times the true one: Z*·|1/s − 1| along the axis; principal point
        off by d px: Z*·d/f sideways; docs/compare.md). 2.5-D's x*, y*, Z* and the moments' desired image
        stay the goal image's.
    depth_scale: in [1e-3, 1e3], multiplies the depth given to the controller (a depth calibration
        error; 1 = none). With depth="estimated" it scales the initial guess only.
    seed: seed of the noise generator (std::mt19937_64).
    tolerance: converged when the servo's error norm (of its task's features, weighted:
        normalised coordinates, and radians for theta rows) is below this; default 1e-4 without
        tolerance_px, else none.
    tolerance_px: None, or converged when every point of the frame's measurement (the points as
        the sensor or a tracker reports them, before latency: History.measured) lies within this
        distance of the goal's measurement (Result.measured_desired), in measurement units
        (pixels; normalised units for Camera.normalized): e.g. 1 with 0.5 px of noise, where no
        error-norm tolerance can be met. With both given, converged needs both.
    max_depth_ratio, max_error_ratio: diverged when the target's depth or the error norm
        exceeds this multiple of its start value.
    stop_on_singular: end with "singular" when the servo reports a rank-deficient J.
    boundary_margin: >= 0, measurement units (pixels; normalised units for
        Camera.normalized). When > 0, an image-boundary potential (paper Section IV,
        Corke & Hutchinson 2001) adds a camera retreat to Tz while a point is within
        this distance of a side of the sensor (at most its goal's distance to that side),
        growing without bound towards the border; 0 (default) = off.
    boundary_gain: >= 0, 1/s, weight of that retreat.
    standoff_ratio: >= 0: the episode ends as "collision" when the camera centre comes
        closer to the target than this times the goal depth of the target's centroid
        (default 5 %), or goes through a planar target; "target_backside" when it goes
        behind a planar target's plane (see RunStatus).
    vision: None (the points are the camera model's projections plus `noise`), "dots", "tag", "klt" or
        "keypoints" (ibvs.vision.ImageSensor.for_target(camera, target, vision): each frame is rendered,
        the dots tracked, the tag detected or the textured plate's corners found by KLT or keypoints, and
        their pixels undistorted for the servo; a
        point the tracker loses ends the episode as lost_feature, unless keep_lost), or any ibvs.sim.Sensor
        (an ImageSensor with your renderer options). Needs a pixel camera. With a sensor,
        `noise` is not added (the image has its own) but still tells the depth estimator the
        measurement noise (px).
    keep_lost: False (default): the first point the sensor loses ends the episode as lost_feature. True:
        the servo (an ibvs.Servo; depth "exact" or "desired") leaves the lost points out (Servo.update's
        valid) and runs on the others while 2 x valid points >= its DOF (not converged while one is lost);
        with fewer it ramps the twist to zero over its stop_time, and the episode ends as lost_feature
        once the twist is zero, unless the points come back first. The servo's period (decay_rate,
        acceleration limits, stop_time) is replaced by 1 / camera.fps.
    record: None, or a path: the episode is also written there as a ROS 2 bag (a path ending in .mcap: one
        MCAP file; else a rosbag2 directory), after the run and atomically, stamped at the simulated frame
        times; an image sensor then keeps its frames (keep_frames). Needs the ros extra (rosbags).
        ibvs.ros.recorder lists the topics (docs/ros.md); ibvs.ros.replay runs a tracker and the servo
        over the bag again.
    turn: radians, which way a half-turn about the optical axis goes (Servo.continue_turn, applied after the
        run's reset of the servo): +pi or -pi instead of the first frame's image noise; NaN (default): the
        noise decides. An ibvs.Servo only; NaN or |turn| <= 5 pi / 4 (ValueError otherwise).
    """
    if robot is not None and not isinstance(robot, Robot):
        raise TypeError(f"robot must be an ibvs.sim.Robot (a Gantry, a UrdfRobot...) or None, got {type(robot).__name__}")
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be an ibvs.CameraModel (ibvs.sim.Camera), got {type(camera).__name__}")
    if not isinstance(target, Target):
        raise TypeError(f"target must be an ibvs.sim.Target, got {type(target).__name__}")
    if isinstance(latency, bool) or not isinstance(latency, (int, np.integer)):
        raise TypeError(f"latency must be an int (frames), got {type(latency).__name__}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise TypeError(f"seed must be a non-negative int, got {seed!r}")
    if record is not None and getattr(getattr(servo, "task", None), "features", None):
        raise ValueError("record: a Task with feature blocks other than points is not recorded (ibvs.ros records "
                         "point tasks)")
    if isinstance(vision, str):
        from .. import vision as _vision

        vision = _vision.ImageSensor.for_target(camera, target, vision)
    elif vision is not None and not isinstance(vision, Sensor):
        raise TypeError(f"vision must be None, 'dots', 'tag', 'klt', 'keypoints' or an ibvs.sim.Sensor, got "
                        f"{type(vision).__name__}")
    recording = None
    if record is not None:  # rosbags and the directory are checked before the run
        from ..ros.recorder import Recording

        recording = Recording(record, vision)
    if not isinstance(goal_pose, str):
        raise TypeError(f"goal_pose must be 'taught' or 'given', got {type(goal_pose).__name__}")
    if goal_pose not in ("taught", "given"):
        raise ValueError(f"goal_pose must be 'taught' or 'given', got {goal_pose!r}")
    if tolerance_px is not None:
        tolerance_px = _real(tolerance_px, "tolerance_px")
        if not (math.isfinite(tolerance_px) and tolerance_px > 0):
            raise ValueError(f"tolerance_px must be a finite number > 0 (measurement units: pixels; normalised units "
                             f"for Camera.normalized), or None for no pixel test, got {tolerance_px!r}")
    if tolerance is not None:
        tolerance = _real(tolerance, "tolerance")
        if not (math.isfinite(tolerance) and tolerance >= 0):
            raise ValueError(f"tolerance must be a finite number >= 0, or None, got {tolerance!r}")
    elif tolerance_px is None:
        tolerance = 1e-4
    d = _sim._run(
        servo,
        camera,
        target,
        start,
        goal,
        robot,
        duration=_real(duration, "duration"),
        noise=_real(noise, "noise"),
        latency=int(latency),
        depth=depth,
        seed=int(seed),
        tolerance=math.inf if tolerance is None else tolerance,
        tolerance_px=0.0 if tolerance_px is None else tolerance_px,
        max_depth_ratio=_real(max_depth_ratio, "max_depth_ratio"),
        max_error_ratio=_real(max_error_ratio, "max_error_ratio"),
        stop_on_singular=_bool(stop_on_singular, "stop_on_singular"),
        depth_scale=_real(depth_scale, "depth_scale"),
        boundary_margin=_real(boundary_margin, "boundary_margin"),
        boundary_gain=_real(boundary_gain, "boundary_gain"),
        standoff_ratio=_real(standoff_ratio, "standoff_ratio"),
        sensor=vision if recording is None else recording.sensor,
        keep_lost=_bool(keep_lost, "keep_lost"),
        goal_pose=goal_pose,
        turn=_real(turn, "turn"),
    )
    status = RunStatus(d["outcome"], d["frame"], d["point"], d["joint"], d["feature"])
    history = History(
        d["time"],
        d["pose"],
        d["twist"],
        d["uv"],
        d["rtheta"],
        d["depth"],
        d["error"],
        d["error_norm"],
        d["sigma_min"],
        d.get("q"),
        d.get("qdot"),
        d.get("manipulability"),
        d["measured"],
        d["projected"],
        d["measurements"],
    )
    metrics = Metrics(
        d["frames_to_converge"],
        d["camera_retreat"],
        d["path_length"],
        d["final_translation_error"],
        d["final_rotation_error"],
        *peak_speeds(history),
    )
    result = Result(status, metrics, history, d["uv_desired"], d["depth_desired"], d["goal"], camera=camera,
                    target=target, robot=robot, layout=servo.layout, servo=_describe_servo(servo), sensor=vision,
                    tolerance=tolerance, tolerance_px=tolerance_px, measured_desired=d["measured_desired"],
                    measurements_desired=d["measurements_desired"])
    if recording is not None:
        recording.write(result, servo, dict(duration=duration, noise=noise, latency=latency, depth=depth, seed=seed,
                                            depth_scale=depth_scale, boundary_margin=boundary_margin,
                                            boundary_gain=boundary_gain, tolerance=tolerance,
                                            tolerance_px=tolerance_px))
    return result
