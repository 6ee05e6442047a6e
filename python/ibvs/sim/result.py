"""What ibvs.sim.run returns: how the episode ended (RunStatus), its summary (Metrics), its
per-frame arrays (History) and the Result holding them with what the episode ran on."""

from __future__ import annotations

import math
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

    feature: index (0-based) of the Task's feature block for a lost_feature its source could
    not measure (e.g. a line whose plane passes through the camera centre), else -1.
    """

    outcome: str
    frame: int
    point: int = -1
    joint: int = -1
    feature: int = -1

    @property
    def converged(self) -> bool:
        return self.outcome == "converged"


@dataclass(frozen=True)
class Metrics:
    """Summary of an episode.

    frames_to_converge: frame index at which the episode converged (the error norm under
    tolerance, every measured point within tolerance_px of its goal: see run()), or -1.
    camera_retreat: largest increase (m) of the target centre's depth along the optical axis over its start.
    path_length: length (m) of the camera centre's path.
    final_translation_error / final_rotation_error: distance (m) and angle (rad) between the
    last camera pose and the goal (the pose error at the last frame: with noise, the camera can
    be farther from the goal than the image error at convergence suggests).
    peak_linear_speed / peak_angular_speed: the largest speed (m/s, rad/s) the camera actually
    moved at, from its poses (History.camera_speed: each frame's motion over its period); NaN
    for a one-frame episode. On a robot, the joint speed limits scale the commanded twist down.
    peak_commanded_linear_speed / peak_commanded_angular_speed: the largest |(Tx, Ty, Tz)|
    (m/s) and |(wx, wy, wz)| (rad/s) of the commanded twist (History.twist), what the
    controller asked for.
    """

    frames_to_converge: int
    camera_retreat: float
    path_length: float
    final_translation_error: float
    final_rotation_error: float
    peak_linear_speed: float = math.nan
    peak_angular_speed: float = math.nan
    peak_commanded_linear_speed: float = math.nan
    peak_commanded_angular_speed: float = math.nan


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
    measurements (K, S): the feature blocks' measurements given to the controller (a Task's
    lines...: each kind's values, concatenated in block order; S = Task.measurement_size, 0 for
    points only); error then holds the points' rows followed by each block's rows.
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
    measurements: Optional[np.ndarray] = None

    def __len__(self) -> int:
        return len(self.time)

    def camera_speed(self) -> tuple[np.ndarray, np.ndarray]:
        """The speed the camera actually moved at during each frame, from its poses: (linear
        (K - 1,) m/s: the distance between the camera centres of frames k and k + 1 over the
        frame period; angular (K - 1,) rad/s: the angle of the rotation between them over the
        period). On a robot this is the motion its joints made (within their speed limits), not
        the commanded twist; in free flight the two agree (the linear speed up to the chord of a
        screw motion)."""
        return camera_speed(self.pose, self.time)


def camera_speed(pose: np.ndarray, time: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(linear, angular) speeds between consecutive poses (K, 4, 4) at times (K,): see History.camera_speed."""
    pose, time = np.asarray(pose, dtype=float), np.asarray(time, dtype=float)
    if len(pose) < 2:
        return np.zeros(0), np.zeros(0)
    dt = np.diff(time)
    linear = np.linalg.norm(np.diff(pose[:, :3, 3], axis=0), axis=1) / dt
    R = np.einsum("kji,kjl->kil", pose[:-1, :3, :3], pose[1:, :3, :3])  # R_k^T R_k+1
    w = np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]], axis=1)
    angle = np.arctan2(0.5 * np.linalg.norm(w, axis=1), 0.5 * (np.trace(R, axis1=1, axis2=2) - 1.0))
    return linear, angle / dt


def _peak(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    return float(x.max()) if len(x) else math.nan


def peak_speeds(history: "History") -> tuple[float, float, float, float]:
    """(camera linear, camera angular, commanded linear, commanded angular) peak speeds of a history."""
    linear, angular = history.camera_speed()
    tw = history.twist
    return (_peak(linear), _peak(angular), _peak(np.linalg.norm(tw[:, :3], axis=1)),
            _peak(np.linalg.norm(tw[:, 3:], axis=1)))


def measurement_unit(camera) -> str:
    """"px", or "normalised units" for a camera whose pixels are normalised coordinates
    (CameraModel.normalized: unit focal length, principal point at 0)."""
    if camera is not None and camera.px == 1.0 and camera.py == 1.0 and camera.u0 == 0.0 and camera.v0 == 0.0:
        return "normalised units"
    return "px"


@dataclass(frozen=True)
class Result:
    """Outcome of run(): status, metrics, history, and the desired features/pose used.

    What the episode ran on comes with it, so that result.plot() and result.animate() need
    nothing else: camera, target, robot (None in free flight), layout (of the servo's error
    rows; a PartitionedServo's Cartesian layout), servo (a short description) and sensor (the
    vision= sensor, e.g. an ibvs.vision.ImageSensor with its frames and timings; None by default).

    How convergence was judged: tolerance (the error norm had to be below it; None: not tested)
    and tolerance_px (every measured point within this distance of its goal, measurement units;
    None: not tested); measured_desired (N, 2) is the goal as the sensor measured it, what
    pixel_error compares each frame's measurement with. measurements_desired (S,): the feature
    blocks' measurements at the goal (a Task's lines...; empty for points only)."""

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
    tolerance: Optional[float] = 1e-4
    tolerance_px: Optional[float] = None
    measured_desired: Optional[np.ndarray] = None
    measurements_desired: Optional[np.ndarray] = None

    @property
    def converged(self) -> bool:
        return self.status.converged

    @property
    def pixel_error(self) -> np.ndarray:
        """(K,) the largest distance of a measured point from its goal's measurement at each
        frame (measurement units: pixels; NaN where a point was not measured): what tolerance_px
        is compared with."""
        h = self.history
        if h.measured is None or self.measured_desired is None:
            return np.full(len(h), math.nan)
        with np.errstate(invalid="ignore"):
            d = np.linalg.norm(h.measured - self.measured_desired[None], axis=2)
        out = d.max(axis=1) if d.shape[1] else np.zeros(len(h))
        out[~np.isfinite(d).all(axis=1)] = math.nan
        return out

    def criterion(self) -> str:
        """What converged means for this episode, e.g. "error norm < 0.0001" or "every point within
        1 px of its goal"."""
        unit = measurement_unit(self.camera)
        parts = []
        if self.tolerance is not None:
            parts.append(f"error norm < {self.tolerance:g}")
        if self.tolerance_px is not None:
            parts.append(f"every point within {self.tolerance_px:g} {unit} of its goal")
        return " and ".join(parts)

    def judged(self) -> str:
        """The quantities convergence is judged on, beside their tolerances and in their units: at
        the frame of convergence ("error norm 8.3e-05 < tolerance 0.0001", "worst point 0.84 px from
        its goal <= tolerance_px 1"), else their last values ("error norm 0.01 at frame 899,
        tolerance 0.0001")."""
        unit = measurement_unit(self.camera)
        quantities = []
        if self.tolerance is not None or self.tolerance_px is None:
            quantities.append(("error norm {:.3g}", "error norm", self.history.error_norm, "<", "tolerance",
                               self.tolerance))
        if self.tolerance_px is not None:
            quantities.append((f"worst point {{:.3g}} {unit} from its goal", "worst point", self.pixel_error, "<=",
                               "tolerance_px", self.tolerance_px))
        parts = []
        for text, name, x, op, tol_name, tol in quantities:
            if self.converged:
                k: Optional[int] = self.status.frame
                parts.append(text.format(x[k]) + (f" {op} {tol_name} {tol:g}" if tol is not None else ""))
                continue
            k = _last_finite(x)
            value = f"{name} n/a (never computed)" if k is None else text.format(x[k]) + f" at frame {k}"
            parts.append(value + (f" ({tol_name} {tol:g})" if tol is not None else ""))
        return ", ".join(parts)

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
        extra = (f", point={s.point}" if s.point >= 0 else f", joint={s.joint}" if s.joint >= 0
                 else f", feature={s.feature}" if s.feature >= 0 else "")
        judged = f" ({self.judged()})" if s.converged else f" (not converged: {self.judged()})"
        return (
            f"Result({s.outcome} at frame {s.frame}{extra}{judged}, retreat={m.camera_retreat:.4g} m, "
            f"path={m.path_length:.4g} m, pose error at the last frame {1e3 * m.final_translation_error:.3g} mm / "
            f"{np.degrees(m.final_rotation_error):.3g} deg)"
        )


def _last_finite(x: np.ndarray) -> Optional[int]:
    k = np.flatnonzero(np.isfinite(x))
    return int(k[-1]) if len(k) else None
