"""Hand-eye calibration data from the simulator: an arm moved through stations where the camera sees a planar
target, the robot's poses and the target's poses measured there, and the truth to compare an estimate with.

    scene = ibvs.sim.hand_eye_scene("panda", mount="eye_in_hand")      # a Panda, a camera, a 30-point plate
    data = scene.collect(stations=12, noise_px=0.3, seed=0)           # or ibvs.sim.collect_hand_eye(...)
    result = data.calibrate(method="park")                           # ibvs.calibrate_hand_eye on the data
    translation_m, rotation_rad = data.error(result)                 # the estimate against the true eMc

Stations: views of the target from `distance` metres, the optical axis through the target's centre tilted from
the target's normal by up to max_tilt in azimuths spread by the golden angle (so that the motions between them
rotate about many axes), turned about the optical axis by up to max_roll; each turned into joints by
ibvs.sim.solve_ik from the home joints. A view is kept when the joints are within the limits and every point of
the target projects inside the image with a 10 px margin; collisions and occlusions are not simulated.
Measurements: the points projected through the camera model plus Gaussian pixel noise (noise_px), or rendered
and detected (vision="tag" / "dots", ibvs.vision); the target's pose from them by ibvs.PlanarPose
(ibvs.calibration.target_poses). The robot's poses are its exact forward kinematics at the joints reached.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..finite import finite_within

from .._core import CameraModel
from .._core import sim as _sim
from ..calibration.hand_eye import DEFAULT_METHOD, MOUNTS, calibrate_hand_eye
from ..calibration.rigid import as_pose_stack, invert, pose_error
from ..calibration.image_poses import target_poses as _target_poses
from .ik import solve_ik
from .poses import pose

__all__ = ["HandEyeData", "HandEyeScene", "collect_hand_eye", "hand_eye_scene"]

#: Margin (px) the target's points keep from the image border at every station.
MARGIN_PX = 10.0
#: Candidate views tried per station asked for before collect_hand_eye gives up.
TRIES_PER_STATION = 20
_GOLDEN_ANGLE = math.pi * (3.0 - math.sqrt(5.0))


def CAMERA() -> CameraModel:
    """The camera of hand_eye_scene: 640 x 480 pixels, focal length 1000 px, principal point at the centre,
    OpenCV's plumb-bob distortion k1 = -0.1, k2 = 0.05, 60 fps."""
    return CameraModel.from_opencv([[1000.0, 0.0, 320.0], [0.0, 1000.0, 240.0], [0.0, 0.0, 1.0]],
                                   [-0.1, 0.05, 0.0, 0.0, 0.0], width=640, height=480)


@dataclass(frozen=True)
class HandEyeData:
    """What collect_hand_eye measured at its stations, and the truth.

    mount: "eye_in_hand" or "eye_to_hand". robot_poses: (N, 4, 4) bMe, base <- end effector (forward
    kinematics). target_poses: (N, 4, 4) cMo, camera <- target, as measured (PlanarPose of the measured pixels).
    joints: (N, n) the joints of each station. pixels: (N, P, 2) the measured points (NaN: not detected).
    true_target_poses: (N, 4, 4) the exact cMo. hand_eye: the true eMc (eye_in_hand) or bMc (eye_to_hand); target:
    the true bMo (eye_in_hand) or eMo (eye_to_hand). dropped: stations measured but not kept (too few points
    detected), as their indices among the views reached.
    """

    mount: str
    robot_poses: np.ndarray
    target_poses: np.ndarray
    joints: np.ndarray
    pixels: np.ndarray
    true_target_poses: np.ndarray
    hand_eye: np.ndarray
    target: np.ndarray
    dropped: tuple = field(default=())

    def calibrate(self, method: str = DEFAULT_METHOD, **options):
        """ibvs.calibrate_hand_eye(robot_poses, target_poses, mount, method, **options): a HandEyeResult."""
        return calibrate_hand_eye(self.robot_poses, self.target_poses, self.mount, method, **options)

    def error(self, result) -> tuple[float, float]:
        """(translation (m), rotation (rad)) of result.hand_eye (a HandEyeResult) or of a 4x4 estimate against the
        true hand_eye."""
        return pose_error(getattr(result, "hand_eye", result), self.hand_eye)


@dataclass(frozen=True)
class HandEyeScene:
    """A calibration set-up for collect_hand_eye (hand_eye_scene builds them).

    mount: "eye_in_hand" (camera on robot, robot.mount its true eMc; target.pose = base <- target) or
    "eye_to_hand" (camera fixed at camera_pose, base <- camera; target.pose = end effector <- target).
    home: the joints stations are solved from; distance: the camera-target distance of the views (m).
    """

    mount: str
    robot: _sim.Robot
    camera: CameraModel
    target: _sim.Target
    home: np.ndarray
    distance: float
    camera_pose: Optional[np.ndarray] = None

    def collect(self, stations: int = 12, noise_px: float = 0.0, seed: int = 0, vision=None, **options) -> HandEyeData:
        """collect_hand_eye with this scene's robot, camera, target, mount, camera_pose, home and distance."""
        return collect_hand_eye(self.robot, self.camera, self.target, stations=stations, noise_px=noise_px,
                                seed=seed, mount=self.mount, camera_pose=self.camera_pose, vision=vision,
                                home=self.home, distance=self.distance, **options)


def _grid(columns: int, rows: int, pitch: float) -> np.ndarray:
    """columns x rows points `pitch` apart in the z = 0 plane, centred on the origin (a dot plate)."""
    x, y = np.meshgrid((np.arange(columns) - (columns - 1) / 2) * pitch, (np.arange(rows) - (rows - 1) / 2) * pitch)
    return np.c_[x.ravel(), y.ravel(), np.zeros(x.size)]


def hand_eye_scene(arm: str = "panda", mount: str = "eye_in_hand", target: str = "grid",
                   distance: float = 0.5) -> HandEyeScene:
    """A ready-made calibration set-up on an arm of example-robot-data (needs the robots extra).

    arm: "panda" or "ur5" (ibvs.sim.cases.ARMS: its goal joints are home, its camera mount the true eMc).
    mount: "eye_in_hand": the target lies `distance` in front of the camera at home, facing it.
        "eye_to_hand": the target is on the end effector, 10 cm out along its z axis and facing away from the
        flange; the camera is fixed `distance` from it at home, looking at it from 30 degrees off its normal.
    target: "grid" (6 x 5 points, 2.5 cm apart: a dot plate) or "tag" (a 10 cm square tag, its 4 corners).
    The camera: CAMERA() (640 x 480, 1000 px focal length, OpenCV's radial distortion k1 -0.1, k2 0.05): its
    project and normalize are inverses to round-off, so noise-free data are exact (ViSP's two-model distortion of
    CameraModel.afma6() is not: its round trip errs by up to 2.4e-5, 0.03 px, 0.04 mm in eMc).
    """
    from .cases import ARMS, arm_robot

    if arm not in ARMS:
        raise ValueError(f"arm must be one of {sorted(ARMS)}, got {arm!r}")
    if mount not in MOUNTS:
        raise ValueError(f"mount must be one of {MOUNTS}, got {mount!r}")
    if target not in ("grid", "tag"):
        raise ValueError(f"target must be 'grid' or 'tag', got {target!r}")
    robot, home, camera = arm_robot(arm), np.array(ARMS[arm][0], dtype=float), CAMERA()
    points = _grid(6, 5, 0.025) if target == "grid" else np.asarray(_sim.Target.square(0.1).points)
    if mount == "eye_in_hand":
        bMo = robot.camera(home) @ pose(t=(0.0, 0.0, distance))
        return HandEyeScene(mount, robot, camera, _sim.Target(points, bMo), home, distance)
    eMo = pose(t=(0.0, 0.0, 0.1), r=(math.pi, 0.0, 0.0))  # target z towards the flange: its front faces away
    bMo = np.asarray(robot.kinematics(home)[0]) @ eMo
    camera_pose = bMo @ _view(math.radians(30.0), math.radians(90.0), 0.0, distance, np.zeros(3))
    return HandEyeScene(mount, robot, camera, _sim.Target(points, eMo), home, distance, camera_pose)


def _view(tilt: float, azimuth: float, roll: float, distance: float, centre: np.ndarray) -> np.ndarray:
    """oMc, target <- camera: the camera `distance` from `centre` on the target's front (-z) side, its optical axis
    through centre tilted by `tilt` from the target's normal towards `azimuth`, turned by `roll` about that axis."""
    d = np.array([math.sin(tilt) * math.cos(azimuth), math.sin(tilt) * math.sin(azimuth), math.cos(tilt)])
    axis = np.cross([0.0, 0.0, 1.0], d)  # the tilt: the rotation taking the target's z to the optical axis d
    s = np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]]) / (s if s > 0 else 1.0)
    R_tilt = np.eye(3) + math.sin(tilt) * K + (1 - math.cos(tilt)) * K @ K
    R_roll = np.array([[math.cos(roll), -math.sin(roll), 0], [math.sin(roll), math.cos(roll), 0], [0, 0, 1]])
    T = np.eye(4)
    T[:3, :3] = R_tilt @ R_roll
    T[:3, 3] = centre - distance * d
    return T


def _project(camera: CameraModel, cMo: np.ndarray, points: np.ndarray) -> Optional[np.ndarray]:
    """The points' pixels seen from cMo, or None if one is behind the camera, beyond the lens model or within
    MARGIN_PX of the image border."""
    P = points @ cMo[:3, :3].T + cMo[:3, 3]
    if not (P[:, 2] > 1e-3).all():
        return None
    try:
        px = np.asarray(camera.project(P[:, :2] / P[:, 2:]))
    except ValueError:
        return None
    u0, u1, v0, v1 = camera.bounds
    if (px[:, 0] < u0 + MARGIN_PX).any() or (px[:, 0] > u1 - MARGIN_PX).any() or \
            (px[:, 1] < v0 + MARGIN_PX).any() or (px[:, 1] > v1 - MARGIN_PX).any():
        return None
    return px


def _real(x, name: str, lo: float, hi: float) -> float:
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a real number, got {type(x).__name__}")
    if not lo <= x <= hi:
        raise ValueError(f"{name} must be in [{lo:g}, {hi:g}], got {x!r}")
    return float(x)


def collect_hand_eye(robot, camera, target, stations=12, noise_px: float = 0.0, seed: int = 0,
                     mount: str = "eye_in_hand", camera_pose=None, vision=None, home=None,
                     distance: Optional[float] = None, max_tilt: float = math.radians(35.0),
                     max_roll: float = math.radians(60.0)) -> HandEyeData:
    """Move robot through calibration stations and measure there: a HandEyeData (the module docstring says how).

    robot: an ibvs.sim.Robot (a UrdfRobot...). camera: an ibvs.CameraModel with a pixel sensor. target: an
    ibvs.sim.Target with >= 4 points in its z = 0 plane, posed base <- target for mount="eye_in_hand" (the camera
    is robot's, at robot.mount: the eMc to recover), end effector <- target for "eye_to_hand" (then camera_pose,
    base <- camera, places the fixed camera: the bMc to recover).
    stations: how many stations to find (>= 3), or an (N, n) array of joints to measure at instead.
    noise_px: std of Gaussian noise (px) on the projected points (vision=None). vision: None, "tag" (the target's
    4 points are a tag's corners, rendered and found by ibvs.vision.TagDetector), "dots" (rendered dots,
    ibvs.vision.DotTracker started at the true pixels) or an ibvs.vision.ImageSensor whose renderer holds the
    target at the identity pose (the image brings its own noise: noise_px must be 0).
    seed: of the views (numpy default_rng([seed, 0])) and of the pixel noise (default_rng([seed, 1])): the same
    seed gives the same stations at any noise. home: (n,) joints the stations are solved from (default: the
    middle of the joint ranges). distance: camera-target distance (m; default: the target spans 40 % of the
    image width). max_tilt, max_roll (rad): how far the views turn from the target's normal and about their axis.
    Raises ValueError when fewer than `stations` views are reachable with the target in the image.
    """
    if not isinstance(robot, _sim.Robot):
        raise TypeError(f"robot must be an ibvs.sim.Robot, got {type(robot).__name__}")
    if not isinstance(camera, CameraModel):
        raise TypeError(f"camera must be an ibvs.CameraModel, got {type(camera).__name__}")
    if not isinstance(target, _sim.Target):
        raise TypeError(f"target must be an ibvs.sim.Target, got {type(target).__name__}")
    points = np.asarray(target.points, dtype=float)
    if len(points) < 4 or not finite_within(points[:, 2], 1e-9):
        raise ValueError("target must have at least 4 points, all in its z = 0 plane (a planar target)")
    if mount not in MOUNTS:
        raise ValueError(f"mount must be one of {MOUNTS}, got {mount!r}")
    noise_px = _real(noise_px, "noise_px", 0.0, 100.0)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise TypeError(f"seed must be a non-negative int, got {seed!r}")
    max_tilt = _real(max_tilt, "max_tilt", 0.0, math.radians(80.0))
    max_roll = _real(max_roll, "max_roll", 0.0, math.pi)
    Z = np.asarray(target.pose, dtype=float)  # bMo (eye in hand) or eMo (eye to hand)
    if mount == "eye_in_hand":
        if camera_pose is not None:
            raise ValueError("camera_pose is for mount='eye_to_hand' (the camera is the robot's, at robot.mount)")
        X = np.asarray(robot.mount, dtype=float)
    else:
        if camera_pose is None:
            raise ValueError("camera_pose (base <- camera) must be given for mount='eye_to_hand'")
        X = as_pose_stack([camera_pose], "camera_pose")[0]
    sensor = _sensor(vision, camera, points, noise_px)
    lo, hi = np.asarray(robot.q_min, dtype=float), np.asarray(robot.q_max, dtype=float)
    home = (lo + hi) / 2 if home is None else np.asarray(home, dtype=float)
    if home.shape != (robot.dof,) or not np.isfinite(home).all():
        raise ValueError(f"home must be {robot.dof} finite joint positions, got shape {home.shape}")
    if distance is None:
        extent = np.linalg.norm(points[:, None] - points[None], axis=-1).max()
        distance = extent * camera.px / (0.4 * camera.width)
    distance = _real(distance, "distance", 1e-3, 1e3)

    def camera_to_target(q) -> np.ndarray:  # cMo at joints q
        bMe = np.asarray(robot.kinematics(q)[0], dtype=float)
        return invert(bMe @ X) @ Z if mount == "eye_in_hand" else invert(X) @ bMe @ Z

    if isinstance(stations, (int, np.integer)) and not isinstance(stations, bool):
        if stations < 3:
            raise ValueError(f"stations must be >= 3 (two motions about different axes), got {stations}")
        joints = _find_stations(robot, camera, points, int(stations), X, Z, mount, home, distance, max_tilt,
                                max_roll, np.random.default_rng([seed, 0]), camera_to_target)
    else:
        try:
            joints = np.array(stations, dtype=float)
        except (TypeError, ValueError):
            raise TypeError(f"stations must be an int or an (N, {robot.dof}) array of joints") from None
        if joints.ndim != 2 or joints.shape[1] != robot.dof or len(joints) < 3 or not np.isfinite(joints).all():
            raise ValueError(f"stations must be an int or an (N >= 3, {robot.dof}) array of finite joints, got shape "
                             f"{joints.shape}")
        for i, q in enumerate(joints):
            if robot.outside_limits(q) >= 0:
                raise ValueError(f"stations[{i}]: joint {robot.outside_limits(q)} is outside its limits")
    true_cMo = np.array([camera_to_target(q) for q in joints])
    rng = np.random.default_rng([seed, 1])
    pixels = []
    for k, cMo in enumerate(true_cMo):
        px = _project(camera, cMo, points)
        if px is None:
            raise ValueError(f"stations[{k}]: the target is not wholly in the image (within {MARGIN_PX:g} px of the "
                             "border)")
        if sensor is None:
            pixels.append(px + noise_px * rng.standard_normal(px.shape))
        else:
            pixels.append(np.asarray(sensor.measure(0, invert(cMo), px, np.zeros(6)), dtype=float))
    poses, kept = _target_poses(camera, pixels, points)
    bMe = np.array([np.asarray(robot.kinematics(q)[0], dtype=float) for q in joints])
    return HandEyeData(mount, bMe[kept], poses, joints[kept], np.array(pixels)[kept], true_cMo[kept], X, Z,
                       tuple(int(i) for i in np.nonzero(~kept)[0]))


def _sensor(vision, camera, points, noise_px):
    """The image sensor measuring the target (held at the identity pose: poses given to it are target <- camera)."""
    if vision is None:
        return None
    if noise_px != 0:
        raise ValueError("noise_px must be 0 with vision: the rendered image brings its own noise (Renderer noise=)")
    from .. import vision as _vision

    if isinstance(vision, str):
        if vision not in ("tag", "dots"):
            raise ValueError(f"vision must be None, 'tag', 'dots' or an ibvs.vision.ImageSensor, got {vision!r}")
        return _vision.ImageSensor.for_target(camera, _sim.Target(points), vision)
    if not isinstance(vision, _vision.ImageSensor):
        raise TypeError(f"vision must be None, 'tag', 'dots' or an ibvs.vision.ImageSensor, got "
                        f"{type(vision).__name__}")
    return vision


def _find_stations(robot, camera, points, n, X, Z, mount, home, distance, max_tilt, max_roll, rng,
                   camera_to_target) -> np.ndarray:
    """Joints of n views of the target that the robot reaches with the target in the image (module docstring)."""
    centre = points.mean(0)
    found = []
    start = rng.uniform(0, 2 * math.pi)
    for k in range(TRIES_PER_STATION * n):
        tilt = max_tilt * math.sqrt(rng.uniform(0.1, 1.0))  # spread over the cone's area, not bunched at its axis
        azimuth = start + k * _GOLDEN_ANGLE + rng.uniform(-0.2, 0.2)
        roll = rng.uniform(-max_roll, max_roll)
        oMc = _view(tilt, azimuth, roll, distance * rng.uniform(0.9, 1.1), centre)
        if mount == "eye_in_hand":  # the camera goes to bMo oMc: the end effector to that times eMc^-1
            bMe = Z @ oMc @ invert(X)
        else:  # the target goes to bMc cMo: the end effector to that times eMo^-1
            bMe = X @ invert(oMc) @ invert(Z)
        r = solve_ik(robot, bMe @ np.asarray(robot.mount, dtype=float), home, restarts=5, seed=k)
        if r.converged and _project(camera, camera_to_target(r.q), points) is not None:
            found.append(r.q)
            if len(found) == n:
                return np.array(found)
    raise ValueError(f"stations: only {len(found)} of {n} views found reachable with the target in the image after "
                     f"{TRIES_PER_STATION * n} tries (distance {distance:.3g} m, max_tilt {math.degrees(max_tilt):.3g}"
                     f" deg): move the target or the camera, or ask for fewer stations")
