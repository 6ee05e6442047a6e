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

from .._core import sim as _sim
from .poses import pose

__all__ = ["Case", "x_translation", "z_rotation", "general_motion", "gantry_general_motion", "free_cases", "all_cases"]


@dataclass(frozen=True)
class Case:
    """A start/goal set-up. start/goal are 4x4 world <- camera poses, or joint vectors (6,) with a robot."""

    name: str
    description: str
    camera: _sim.Camera
    target: _sim.Target
    start: np.ndarray
    goal: np.ndarray
    robot: Optional[_sim.Gantry] = None
    duration: float = 10.0
    extra: dict = field(default_factory=dict)


def x_translation(distance: float = 0.2) -> Case:
    """Paper Fig. 1: the camera starts displaced `distance` along its x axis from the goal (pure translation)."""
    return Case(
        "x_translation",
        f"pure x-axis translation of {distance} (paper Fig. 1)",
        _sim.Camera.normalized(0.3),
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
        _sim.Camera.normalized(0.3),
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
        _sim.Camera.normalized(0.3),
        _sim.Target.paper(),
        pose(t=GENERAL_MOTION_T, r=GENERAL_MOTION_R),
        np.eye(4),
    )


def free_cases() -> list[Case]:
    """The three free-flying cases of Section III-A."""
    return [x_translation(), z_rotation(), general_motion()]


def all_cases() -> list[Case]:
    return free_cases() + [gantry_general_motion()]
