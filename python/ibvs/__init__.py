"""ibvs: real-time image-based visual servoing with Cartesian, polar and hybrid Jacobians.

Conventions (everywhere the same):
  camera frame x right, y down, z forward; camera twist v = (Tx, Ty, Tz, wx, wy, wz)
  in the camera frame (m/s, rad/s); image points in normalised coordinates
  (unit focal length) with shape (N, 2) or (N, 1, 2); depths in metres; angles in
  radians. Pixels (u right, v down) only through CameraModel (normalize / project,
  Servo(..., camera=).update_pixels); poses are 4x4 "a <- b" transforms.
  Robots: base frame b, end effector e, camera c; eMc = end-effector <- camera (4x4);
  joint_velocities / JointMapping turn the camera twist into joint velocities;
  mounting="eye_to_hand": the camera fixed (bMc), the target on the end effector;
  SecondaryTask adds null-space motions and joint-limit avoidance to JointMapping's qdot;
  calibrate_hand_eye estimates eMc (or a fixed camera's bMc) from robot and target poses (ibvs.calibration).
"""

from __future__ import annotations

import copyreg
from pathlib import Path

from ._core import (
    AdaptiveGain,
    CameraModel,
    DepthEstimator,
    Feature,
    JointMapping,
    JointMappingResult,
    Layout,
    LineFeature,
    MomentsFeature,
    PartitionedServo,
    PlanarPose,
    Representation,
    SecondaryTask,
    SecondaryTaskResult,
    Servo,
    ServoResult,
    SphericalPointFeature,
    SphericalPolarFeature,
    Status,
    Task,
    __version__,
    area_scale,
    area_scale_jacobian,
    damped_pinv,
    feature_error,
    features,
    jacobian,
    joint_velocities,
    se3_exp,
    segment_angle,
    segment_angle_jacobian,
    singular_values,
    spherical_measurements,
    wrap_angle,
)
# 3-D (PBVS), 2.5-D and user-defined feature blocks
from ._core import FunctionFeature, PbvsFeature, Point25DFeature, theta_u, theta_u_interaction
from .calibration import calibrate_hand_eye  # numpy only: OpenCV is imported when it runs
from ._core import EllipseFeature, SegmentFeature  # feature blocks of a Task: the segment and the ellipse
# photometric (direct) visual servoing and photometric moments (docs/photometric.md)
from ._core import LuminanceResult, LuminanceServo, photometric_moments

__all__ = [
    "AdaptiveGain",
    "CameraModel",
    "DepthEstimator",
    "Feature",
    "JointMapping",
    "JointMappingResult",
    "Layout",
    "LineFeature",
    "MomentsFeature",
    "PartitionedServo",
    "PlanarPose",
    "Representation",
    "SecondaryTask",
    "SecondaryTaskResult",
    "Servo",
    "ServoResult",
    "SphericalPointFeature",
    "SphericalPolarFeature",
    "Status",
    "Task",
    "__version__",
    "area_scale",
    "area_scale_jacobian",
    "calibrate_hand_eye",
    "cmake_dir",
    "damped_pinv",
    "feature_error",
    "features",
    "jacobian",
    "joint_velocities",
    "se3_exp",
    "segment_angle",
    "segment_angle_jacobian",
    "singular_values",
    "spherical_measurements",
    "wrap_angle",
]
__all__ += ["FunctionFeature", "PbvsFeature", "Point25DFeature", "theta_u", "theta_u_interaction"]
__all__ += ["EllipseFeature", "SegmentFeature"]
__all__ += ["LuminanceResult", "LuminanceServo", "photometric_moments"]


def _reduce_layout(layout: Layout):
    return Layout, (layout.blocks, layout.n_points)


copyreg.pickle(Layout, _reduce_layout)  # a Layout pickles as its blocks (sim.Result holds one)


def cmake_dir() -> str:
    """Directory holding ibvsConfig.cmake: pass it as ibvs_DIR to find_package(ibvs)."""
    from . import _core

    return str(Path(_core.__file__).resolve().parent / "share" / "cmake" / "ibvs")
