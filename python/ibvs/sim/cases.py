"""The paper's simulated and experimental cases as ready-made start/goal set-ups.

Each function returns a Case; run it with

    ibvs.sim.run(servo, case.camera, case.target, case.start, case.goal,
                 robot=case.robot, duration=case.duration)

Free-flying cases (paper Section III-A, Table I): unit focal length, image plane
+-0.3, the four points (+-0.25, +-0.25, 3), goal camera pose at the world origin
looking along +z, exact depth. The paper does not give the start poses of its
figures numerically beyond "x-translation of 0.2" and "z-rotation of pi"; the
general-motion start below is ours.

Gantry case (Section III-B): the Afma6-like gantry with the distorted 640x480
camera, a 10 cm square target, desired pose (0, 0, 0.6, 0, 0, 0) (camera 0.6 m in
front of the target, target centred).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from .._core import CameraModel
from .._core import sim as _sim
from .ik import solve_ik, solve_joints  # noqa: F401  (solve_joints: the name scripts used before solve_ik)
from .poses import pose

__all__ = ["Case", "x_translation", "z_rotation", "general_motion", "corner_to_corner", "gantry_general_motion", "gantry_joint_limit", "arm_general_motion", "arm_motion", "arm_robot", "ARMS", "eye_to_hand", "EYE_TO_HAND_MOTIONS", "solve_ik", "solve_joints", "free_cases", "all_cases", "six_point_circle"]


@dataclass(frozen=True)
class Case:
    """A start/goal set-up. start/goal are 4x4 world <- camera poses, or joint vectors (n,) with a robot."""

    name: str
    description: str
    camera: CameraModel
    target: _sim.Target
    start: np.ndarray
    goal: np.ndarray
    robot: Optional[_sim.Robot] = None
    duration: float = 10.0
    extra: dict = field(default_factory=dict)


def x_translation(distance: float = 0.2) -> Case:
    """Paper Fig. 1: the camera starts displaced `distance` along its x axis from the goal (pure translation)."""
    return Case(
        "x_translation",
        f"pure x-axis translation of {distance} (paper Fig. 1)",
        CameraModel.normalized(0.3),
        _sim.Target.paper(),
        pose(t=(distance, 0.0, 0.0)),
        np.eye(4),
    )


def z_rotation(angle: float = np.pi) -> Case:
    """Paper Fig. 2 / Fig. 5: the camera starts rotated by `angle` about its optical axis.

    For angle = pi the rotation matrix is exact (diag(-1, -1, 1)), so every point's
    polar angle error is exactly pi; ibvs wraps it to +pi for all points (eq. 13).
    """
    return Case(
        "z_rotation",
        f"pure z-axis rotation of {angle:.6g} rad (paper Fig. 2)",
        CameraModel.normalized(0.3),
        _sim.Target.paper(),
        pose(r=(0.0, 0.0, angle)),
        np.eye(4),
    )


# Our general-motion start: translation and rotation about all axes, with every
# point inside the +-0.3 image plane along the way for all three schemes.
GENERAL_MOTION_T = (0.15, -0.1, -0.6)
GENERAL_MOTION_R = (0.12, -0.1, 0.6)


def general_motion() -> Case:
    """Paper Fig. 3: rotation and translation about all axes (start pose is ours, see GENERAL_MOTION_*)."""
    return Case(
        "general_motion",
        "rotation and translation about all axes (paper Fig. 3)",
        CameraModel.normalized(0.3),
        _sim.Target.paper(),
        pose(t=GENERAL_MOTION_T, r=GENERAL_MOTION_R),
        np.eye(4),
    )


def corner_to_corner(radius: float = 0.36, angle: float = 0.75, depth: float = 1.0) -> Case:
    """Paper Fig. 4, C -> D: every point must go from near one corner of the +-0.3 image to near
    the next one, and the straight polar path between them leaves the image.

    Target: a square in the plane z = depth whose corners the goal camera (at the world
    origin) sees at polar (radius, -angle + k pi/2), k = 0..3. Start: the camera rotated by
    -2 angle about its optical axis, where it sees them at (radius, angle + k pi/2). Point 1
    goes from C = (radius, angle) to D = (radius, -angle) (Fig. 4 draws r 0.40, theta +-0.75);
    IBVS-P drives r constant and theta straight, so every point crosses a side of the image
    (r = 0.3 / cos at mid-side) unless the camera retreats: see EpisodeOptions boundary_margin.
    Needs radius * max(|cos|, |sin|)(angle) < 0.3 so that start and goal are in view.
    """
    k = np.arange(4) * np.pi / 2
    th = -angle + k
    pts = np.c_[depth * radius * np.cos(th), depth * radius * np.sin(th), np.full(4, depth)]
    return Case(
        "corner_to_corner",
        f"corner to corner: polar ({radius:g}, {angle:g}) -> ({radius:g}, {-angle:g}) (paper Fig. 4, C -> D)",
        CameraModel.normalized(0.3),
        _sim.Target(pts),
        pose(r=(0.0, 0.0, -2.0 * angle)),
        np.eye(4),
        duration=20.0,
        extra={"C": (radius, angle), "D": (radius, -angle)},
    )


# Six points on a circle of 8 cm diameter, 0.5 m in front of the goal camera; the start is turned
# by 120 deg about the optical axis, tilted and moved (ours: the issue gives none numerically).
SIX_POINT_T = (-0.012, 0.031, -0.097)
SIX_POINT_R = (-0.134, 0.124, 2.0 * np.pi / 3.0)


def six_point_circle() -> Case:
    """Issue 11's plate: six points on a circle of 8 cm diameter at 0.5 m, 30 fps, start turned by
    120 deg about the optical axis (plus SIX_POINT_T / SIX_POINT_R). Run with gain 1, damping 0.01
    and exact depth: IBVS-P and the stacked law jump the camera round the plate's edge to 0.14 m
    behind its plane on the first frame (the simulator ends that as target_backside; without the
    check the run came back and reported converged); Cartesian IBVS converges."""
    a = 2.0 * np.pi * np.arange(6) / 6.0
    points = np.c_[0.04 * np.cos(a), 0.04 * np.sin(a), np.zeros(6)]
    return Case(
        "six_point_circle",
        "six points on an 8 cm circle at 0.5 m, start turned by 120 deg (issue 11)",
        CameraModel.normalized(0.3, fps=30.0),
        _sim.Target(points, pose(t=(0.0, 0.0, 0.5))),
        pose(t=SIX_POINT_T, r=SIX_POINT_R),
        np.eye(4),
        duration=30.0,
    )


# Gantry: the goal joint configuration (wrist tilted, well inside every limit and
# away from the wrist singularity q5 = pi/2), the desired camera <- target pose
# (0, 0, 0.6, 0, 0, 0), and the start as a camera-frame offset from the goal.
GANTRY_GOAL_Q = (0.0, 0.0, 0.0, 0.0, 0.4, 0.0)
DESIRED_DEPTH = 0.6
GANTRY_GENERAL_MOTION_T = (0.04, -0.03, -0.12)
GANTRY_GENERAL_MOTION_R = (0.1, -0.15, 0.8)
# A start from which polar and stacked IBVS drive joint 5 into its lower limit
# (paper Section V reports joint limits for one hybrid scheme on the real robot).
GANTRY_JOINT_LIMIT_T = (-0.03, 0.02, -0.1)
GANTRY_JOINT_LIMIT_R = (-0.1, 0.1, -0.6)


def _start_joints(robot: _sim.Robot, camera_pose: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """The start's joints: ibvs.sim.solve_ik from the goal joints (a ValueError if it finds none)."""
    r = solve_ik(robot, camera_pose, goal)
    if not r.converged:
        raise ValueError(f"start: {r.message}")
    return r.q


def _gantry_case(name: str, description: str, t, r, duration: float) -> Case:
    robot = _sim.Gantry.afma6()
    goal = np.array(GANTRY_GOAL_Q)
    goal_pose = robot.camera(goal)
    target = _sim.Target.square(0.1, goal_pose @ pose(t=(0.0, 0.0, DESIRED_DEPTH)))
    start = _start_joints(robot, goal_pose @ pose(t=t, r=r), goal)
    return Case(name, description, CameraModel.afma6(), target, start, goal, robot, duration,
                {"start_offset": (t, r)})


def gantry_general_motion() -> Case:
    """Paper Section III-B (Figs. 6-8): general motion on the Afma6-like gantry with the distorted camera.

    Goal: joints GANTRY_GOAL_Q, where the camera sees the 10 cm square target centred at
    0.6 m, i.e. the desired pose (0, 0, 0.6, 0, 0, 0). Start: the camera moved by
    pose(GANTRY_GENERAL_MOTION_T, GANTRY_GENERAL_MOTION_R) in its own frame from the goal,
    as joint positions. Cartesian, polar and stacked IBVS all reach the goal (gain 2, 15 s).
    """
    return _gantry_case("gantry_general_motion", "general motion on the gantry (paper Figs. 6-8)",
                        GANTRY_GENERAL_MOTION_T, GANTRY_GENERAL_MOTION_R, 15.0)


def gantry_joint_limit() -> Case:
    """A gantry start from which polar and stacked IBVS hit joint 5's lower limit (Cartesian converges)."""
    return _gantry_case("gantry_joint_limit", "gantry start leading IBVS-P into a joint limit",
                        GANTRY_JOINT_LIMIT_T, GANTRY_JOINT_LIMIT_R, 15.0)


#: Arms of example-robot-data (ibvs.sim.UrdfRobot, needs pip install ".[robots]"): name ->
#: (goal joints, eMc). Goals: the Panda's "default" posture of its SRDF (its hand pointing down,
#: joint 4 bent), the UR5 elbow up with the tool pointing down (q3 = pi/2 keeps it off the elbow
#: singularity, q5 = -pi/2 off the wrist one); both well inside every joint limit, smallest
#: singular value of the camera Jacobian 0.22. The camera sits 5 cm off the flange axis, 4 cm
#: out, tilted by (0.1, -0.2, 0.3) rad (rxyz).
ARMS = {
    "panda": ((0.0, -np.pi / 4, 0.0, -3 * np.pi / 4, 0.0, np.pi / 2, np.pi / 4), ((0.05, -0.03, 0.04), (0.1, -0.2, 0.3))),
    "ur5": ((0.0, -np.pi / 2, np.pi / 2, -np.pi / 2, -np.pi / 2, 0.0), ((0.05, -0.03, 0.04), (0.1, -0.2, 0.3))),
}
ARM_DESIRED_DEPTH = 0.5


def arm_robot(name: str, eMc=None):
    """The ibvs.sim.UrdfRobot of ARMS[name] ("panda" or "ur5"), its camera mounted as ARMS says unless
    eMc (4x4, flange <- camera) is given."""
    from .urdf import UrdfRobot

    if name not in ARMS:
        raise ValueError(f"name must be one of {sorted(ARMS)}, got {name!r}")
    return UrdfRobot.example(name, pose(*ARMS[name][1]) if eMc is None else eMc)


def arm_general_motion(name: str = "panda", robot: Optional[_sim.Robot] = None, goal=None) -> Case:
    """General motion with a camera on an arm: by default one of example-robot-data ("panda": Franka
    Panda, 7 joints, flange frame panda_hand; "ur5": Universal Robots UR5, 6 joints, flange frame tool0),
    from its URDF with Pinocchio (ibvs.sim.UrdfRobot; pip install ".[robots]" from the ibvs repository root).

    Goal: ARMS[name] joints, the 10 cm square target centred 0.5 m in front of the camera. Start: the
    camera moved by pose(GANTRY_GENERAL_MOTION_T, GANTRY_GENERAL_MOTION_R) in its own frame (as on the
    gantry), as joints from ibvs.sim.solve_ik started at the goal. Camera: Camera.afma6().

    robot: any other ibvs.sim.Robot (e.g. UrdfRobot(path, frame, eMc)), then `name` only names the case;
    goal: its goal joints (default: ARMS[name]'s for an example arm, else the middle of every joint's
    range). ValueError when the start cannot be reached within the joint limits. arm_motion(name,
    "general_motion") is the same case.
    """
    return arm_motion(name, "general_motion", robot, goal)


def arm_motion(name: str = "panda", motion: str = "general_motion", robot: Optional[_sim.Robot] = None,
               goal=None) -> Case:
    """A paper case with the camera on an arm (eye-in-hand; arm_general_motion's arm, goal and target):
    motion "x_translation", "z_rotation" or "general_motion", the start camera offset from the goal camera by
    EYE_TO_HAND_MOTIONS[motion] in its own frame. The z-rotation's start (pi about the optical axis) is
    searched from the goal with the last joint turned by -pi: on the Panda (joint 7 +-2.9 rad) the servo
    can only turn it back by +pi, which turn = +pi chooses (ibvs.sim.run's turn, NodeParams.turn; the image
    noise would pick either way); the UR5's last joint (+-2 pi) turns either way.
    ValueError when the start cannot be reached within the joint limits."""
    if motion not in EYE_TO_HAND_MOTIONS:
        raise ValueError(f"motion must be one of {sorted(EYE_TO_HAND_MOTIONS)}, got {motion!r}")
    if robot is None:
        robot = arm_robot(name)
    if goal is None:
        goal = ARMS[name][0] if name in ARMS and getattr(robot, "example_name", None) == name else \
            (np.asarray(robot.q_min, dtype=float) + np.asarray(robot.q_max, dtype=float)) / 2
    goal = np.array(goal, dtype=float)
    if goal.shape != (robot.dof,) or not np.isfinite(goal).all():
        raise ValueError(f"goal must be {robot.dof} finite joint positions, got shape {goal.shape}")
    if robot.outside_limits(goal) >= 0:
        raise ValueError(f"goal: joint {robot.outside_limits(goal) + 1} is outside its limits")
    goal_pose = robot.camera(goal)
    target = _sim.Target.square(0.1, goal_pose @ pose(t=(0.0, 0.0, ARM_DESIRED_DEPTH)))
    t, r = EYE_TO_HAND_MOTIONS[motion]
    seed = goal.copy()
    if motion == "z_rotation":
        seed[-1] -= np.pi
    start = _start_joints(robot, goal_pose @ pose(t=t, r=r), seed)
    what = "general motion" if motion == "general_motion" else motion.replace("_", "-")
    return Case(f"{name}_{motion}", f"{what} with a camera on the {name} arm (URDF, Pinocchio)",
                CameraModel.afma6(), target, start, goal, robot, 15.0)


# Eye-to-hand: the target (10 cm square) rides 10 cm beyond the flange, facing back along its axis
# (end effector <- target, (t, r) of pose()); the camera is fixed in the world, ARM_DESIRED_DEPTH in
# front of it at the goal joints, looking back at the tool.
EYE_TO_HAND_TARGET = ((0.0, 0.0, 0.1), (np.pi, 0.0, 0.0))
#: The starts of eye_to_hand() and arm_motion(): motion name -> (t, r) of pose(), the start camera in the goal
#: camera's frame relative to the target (the paper's offsets; the target moves the opposite way): its
#: x-translation (0.2 at 3 m depth, scaled to 0.5 m), its z-rotation of pi and the general motion of
#: arm_general_motion.
EYE_TO_HAND_MOTIONS = {
    "x_translation": ((0.2 * ARM_DESIRED_DEPTH / 3.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
    "z_rotation": ((0.0, 0.0, 0.0), (0.0, 0.0, np.pi)),
    "general_motion": (GANTRY_GENERAL_MOTION_T, GANTRY_GENERAL_MOTION_R),
}


def eye_to_hand(name: str = "panda", motion: str = "general_motion") -> Case:
    """A paper case transposed to eye-to-hand: the camera fixed in the world, the target carried by the
    end effector of an arm ("panda", "ur5": ibvs.sim.UrdfRobot, Pinocchio) or the gantry ("gantry").

    motion: "x_translation", "z_rotation" or "general_motion" (EYE_TO_HAND_MOTIONS: the relative start
    camera <- target offset). The robot's mount is the camera's world <- camera pose (mounting
    "eye_to_hand"); the case's target pose is end effector <- target (EYE_TO_HAND_TARGET) and its poses
    (robot.camera(q)) are end effector <- camera: the episode runs in the end effector's frame, where the
    target is still. Goal joints: ARMS[name] (GANTRY_GOAL_Q for the gantry). The z-rotation's start is
    searched from the goal with the last joint turned by -pi (the flange axis is the optical axis). The camera
    stands ARM_DESIRED_DEPTH (0.5 m) from the target at the goal, DESIRED_DEPTH (0.6 m) on the gantry as in
    gantry_general_motion.
    ValueError when the start cannot be reached within the joint limits.
    """
    if motion not in EYE_TO_HAND_MOTIONS:
        raise ValueError(f"motion must be one of {sorted(EYE_TO_HAND_MOTIONS)}, got {motion!r}")
    eMo = pose(*EYE_TO_HAND_TARGET)
    if name == "gantry":
        goal = np.array(GANTRY_GOAL_Q)
        bMe = _sim.Gantry.afma6().end_effector(goal)
        bMc = bMe @ eMo @ pose(t=(0.0, 0.0, -DESIRED_DEPTH))  # the gantry case's 0.6 m
        robot = _sim.Gantry.afma6().with_mount(bMc, "eye_to_hand")
        camera = CameraModel.afma6()
    elif name in ARMS:
        from .urdf import UrdfRobot

        goal = np.array(ARMS[name][0])
        bMe = np.asarray(UrdfRobot.example(name).kinematics(goal)[0])
        bMc = bMe @ eMo @ pose(t=(0.0, 0.0, -ARM_DESIRED_DEPTH))
        robot = UrdfRobot.example(name, bMc, mounting="eye_to_hand")
        camera = CameraModel.afma6()
    else:
        raise ValueError(f"name must be 'gantry' or one of {sorted(ARMS)}, got {name!r}")
    goal_pose = robot.camera(goal)  # end effector <- camera
    target = _sim.Target.square(0.1, eMo)
    t, r = EYE_TO_HAND_MOTIONS[motion]
    seed = goal.copy()
    if motion == "z_rotation":
        seed[-1] -= np.pi
    start = _start_joints(robot, goal_pose @ pose(t=t, r=r), seed)
    return Case(f"{name}_eye_to_hand_{motion}", f"{motion} with the target on the {name} and a fixed camera",
                camera, target, start, goal, robot, 15.0, {"start_offset": (t, r), "eMo": eMo})


def free_cases() -> list[Case]:
    """The three free-flying cases of Section III-A."""
    return [x_translation(), z_rotation(), general_motion()]


def all_cases() -> list[Case]:
    """The free-flying cases (free_cases) and the two gantry cases."""
    return free_cases() + [gantry_general_motion(), gantry_joint_limit()]
