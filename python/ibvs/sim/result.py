"""What ibvs.sim.run returns: how the episode ended (RunStatus), its summary (Metrics), its
per-frame arrays (History) and the Result holding them with what the episode ran on."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from .._core import CameraModel, Layout
from .._core import sim as _sim

#: How an episode can end (the C++ Outcome enum, in its order).
OUTCOMES = ("converged", "left_image", "behind_camera", "joint_limit", "singular", "diverged", "timeout",
            "target_backside", "collision", "lost_feature")


@dataclass(frozen=True)
class RunStatus:
    """How an episode ended.

    outcome: one of OUTCOMES. frame: frame of the event (the last frame for a
    timeout). point: index of the point for left_image / behind_camera / lost_feature (the
    sensor lost it: ibvs.vision's tracker or tag detector) and for a collision with a
    non-planar target, else -1. joint: index (0-based) of the joint for joint_limit, else -1.

    target_backside: the camera centre went behind a planar target's plane (the front is
    the side the goal camera sees), so its points are seen from behind. collision: the
    camera centre went through the plate (crossed its plane within the disc about the
    points' centroid through the farthest point) or came closer to it than the standoff;
    a non-planar target has no front (never target_backside) and collides within the
    standoff of any of its points. See run(standoff_ratio=...).
    """

    outcome: str
    frame: int
    point: int = -1
    joint: int = -1

    @property
    def converged(self) -> bool:
        return self.outcome == "converged"


@dataclass(frozen=True)
class Metrics:
    """Summary of an episode.

    frames_to_converge: frame index at which the error norm fell under tolerance, or -1.
    camera_retreat: largest increase (m) of the target centre's depth along the optical axis over its start.
    path_length: length (m) of the camera centre's path.
    final_translation_error / final_rotation_error: distance (m) and angle (rad) between the
    last camera pose and the goal.
    """

    frames_to_converge: int
    camera_retreat: float
    path_length: float
    final_translation_error: float
    final_rotation_error: float


@dataclass(frozen=True)
class History:
    """Per-frame arrays (K frames). NaN where the last frame could not compute a value.

    time (K,) s; pose (K, 4, 4) world <- camera; twist (K, 6) commanded camera twist;
    uv (K, N, 2) and rtheta (K, N, 2) the points the controller saw (normalised, undistorted;
    rtheta is the same points in polar form whatever the servo's features);
    depth (K, N) the depths it was given; error (K, M) the servo's f (-) f* (for a
    PartitionedServo the Cartesian error, M = 2N); error_norm (K,);
    sigma_min (K,) smallest singular value of the servo's interaction matrix (for a
    PartitionedServo: of the four (Tx, Ty, wx, wy) columns of its Cartesian Jacobian).
    measured (K, N, 2) the sensor's points at frame k (pixels; before latency; NaN = lost) and
    projected (K, N, 2) the true projections (the default sensor adds noise to these; an image
    sensor detects them in a rendered image).
    With a robot (else None): q (K, n), qdot (K, n) joint velocity applied after the frame,
    manipulability (K,) the product of the singular values of the robot's camera Jacobian
    (|det J| = |cos q5| on the gantry).
    """

    time: np.ndarray
    pose: np.ndarray
    twist: np.ndarray
    uv: np.ndarray
    rtheta: np.ndarray
    depth: np.ndarray
    error: np.ndarray
    error_norm: np.ndarray
    sigma_min: np.ndarray
    q: Optional[np.ndarray] = None
    qdot: Optional[np.ndarray] = None
    manipulability: Optional[np.ndarray] = None
    measured: Optional[np.ndarray] = None
    projected: Optional[np.ndarray] = None

    def __len__(self) -> int:
        return len(self.time)


@dataclass(frozen=True)
class Result:
    """Outcome of run(): status, metrics, history, and the desired features/pose used.

    What the episode ran on comes with it, so that result.plot() and result.animate() need
    nothing else: camera, target, robot (None in free flight), layout (of the servo's error
    rows; a PartitionedServo's Cartesian layout), servo (a short description) and sensor (the
    vision= sensor, e.g. an ibvs.vision.ImageSensor with its frames and timings; None by default)."""

    status: RunStatus
    metrics: Metrics
    history: History
    uv_desired: np.ndarray
    depth_desired: np.ndarray
    goal: np.ndarray
    camera: Optional[CameraModel] = None
    target: Optional[_sim.Target] = None
    robot: Optional[_sim.Robot] = None
    layout: Optional[Layout] = None
    servo: str = ""
    sensor: Optional[_sim.Sensor] = None

    @property
    def converged(self) -> bool:
        return self.status.converged

    def plot(self, **kwargs):
        """A matplotlib Figure of the episode: ibvs.viz.episode(self, **kwargs)."""
        from .. import viz

        return viz.episode(self, **kwargs)

    def animate(self, path, **kwargs) -> int:
        """Write a GIF or MP4 of the episode: ibvs.viz.animate(self, path, **kwargs)."""
        from .. import viz

        return viz.animate(self, path, **kwargs)

    def __repr__(self) -> str:
        s, m = self.status, self.metrics
        extra = f", point={s.point}" if s.point >= 0 else f", joint={s.joint}" if s.joint >= 0 else ""
        return (
            f"Result({s.outcome} at frame {s.frame}{extra}, retreat={m.camera_retreat:.4g} m, "
            f"path={m.path_length:.4g} m, final error {m.final_translation_error:.3g} m / "
            f"{np.degrees(m.final_rotation_error):.3g} deg)"
        )
