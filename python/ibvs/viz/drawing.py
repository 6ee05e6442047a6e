"""The drawing helpers that the figures and the animation share: one Figure factory, the colours and
line styles every panel uses, and the geometry drawn in several places (sensor borders, camera
frustums, the 3D scene's box)."""

from __future__ import annotations

from typing import Optional

import numpy as np

# What ibvs.viz re-exports (and documents); the other names here are its own helpers.
__all__ = ["COORDINATE_STYLES", "AXIS_COLOURS", "TWIST_LABELS"]

_EXTRA = 'ibvs.viz needs matplotlib: pip install ".[plot]" from the ibvs repository root'


def new_figure(fig, size):
    """A new constrained-layout Figure of `size` inches, or `fig` (a Figure or SubFigure) cleared."""
    try:
        from matplotlib.figure import Figure, FigureBase
    except ImportError as e:
        raise ImportError(_EXTRA) from e
    if fig is None:
        return Figure(figsize=size, layout="constrained")
    if not isinstance(fig, FigureBase):
        raise TypeError(f"fig must be a matplotlib Figure or SubFigure, got {type(fig).__name__}")
    fig.clear()
    if isinstance(fig, Figure):
        fig.set_layout_engine("constrained")
    return fig


#: Line style of each feature coordinate.
COORDINATE_STYLES = {"u": "-", "v": "--", "r": "-.", "theta": ":", "rtheta": (0, (4, 1.5, 1, 1.5, 1, 1.5))}
#: Colour of the x, y, z components of the twist.
AXIS_COLOURS = ("tab:red", "tab:green", "tab:blue")
#: Legend labels of the six twist components.
TWIST_LABELS = ["$T_x$", "$T_y$", "$T_z$", r"$\omega_x$", r"$\omega_y$", r"$\omega_z$"]


def point_colours(n: int) -> list:
    """One colour per target point (tab10 up to 10 points, a continuous map beyond)."""
    from matplotlib import colormaps

    if n <= 10:
        return [colormaps["tab10"](i) for i in range(n)]
    return [colormaps["turbo"](x) for x in np.linspace(0.05, 0.95, n)]


def valid_frames(h) -> np.ndarray:
    """Frames whose values are finite (the stopping frame of an event may hold NaN)."""
    return np.isfinite(h.error_norm) & np.isfinite(h.twist).all(axis=1)


def is_pixel_camera(camera) -> bool:
    """True unless the camera is a normalised one (unit focal length, no offset, no distortion)."""
    if camera is None:
        return False
    return not (camera.px == 1 and camera.py == 1 and camera.u0 == 0 and camera.v0 == 0
                and camera.distortion == "none")


def sensor_border(camera, samples: int = 48) -> np.ndarray:
    """Closed polyline (M, 2) along the sensor's border, in measurement units."""
    u0, u1, v0, v1 = (float(x) for x in camera.bounds)
    s = np.linspace(0.0, 1.0, samples, endpoint=False)[:, None]
    corners = np.array([[u0, v0], [u1, v0], [u1, v1], [u0, v1], [u0, v0]])
    sides = [a + s * (b - a) for a, b in zip(corners[:-1], corners[1:])]
    return np.vstack(sides + [corners[:1]])


def image_border(camera, samples: int = 48) -> np.ndarray:
    """The sensor's border in normalised image coordinates (undistorted with the camera model)."""
    return np.asarray(camera.normalize(sensor_border(camera, samples)))


def measured_points(result, uv: np.ndarray) -> np.ndarray:
    """Normalised points (..., 2) in the camera's measurement units (pixels), distorted."""
    shape = uv.shape
    return np.asarray(result.camera.project(uv.reshape(-1, 2))).reshape(shape)


def frustum(pose: np.ndarray, corners: np.ndarray, depth: float) -> np.ndarray:
    """Line vertices (with NaN breaks) of a camera frustum: apex to the four image corners
    (normalised, (4, 2), top-left first, clockwise) at `depth` in front of the camera, the
    rectangle between them, and a small triangle on its top side that shows the camera's roll."""
    c = np.c_[corners * depth, np.full(4, depth)] @ pose[:3, :3].T + pose[:3, 3]
    o = pose[:3, 3]
    nan = np.full(3, np.nan)
    segs = []
    for k in range(4):
        segs += [o, c[k], nan]
    segs += [c[0], c[1], c[2], c[3], c[0], nan]
    top, up = c[1] - c[0], c[0] - c[3]  # along the top side; from the bottom side to the top one
    segs += [c[0] + 0.35 * top, c[0] + 0.5 * top + 0.25 * up, c[0] + 0.65 * top]
    return np.array(segs)


def frustum_corners(camera) -> np.ndarray:
    """The sensor's four corners in normalised coordinates (top-left first, clockwise), for frustum();
    a square of half-side 0.3 without a camera."""
    if camera is None:
        return np.array([[-0.3, -0.3], [0.3, -0.3], [0.3, 0.3], [-0.3, 0.3]])
    u0, u1, v0, v1 = (float(x) for x in camera.bounds)
    return np.asarray(camera.normalize([[u0, v0], [u1, v0], [u1, v1], [u0, v1]]))


def target_points(result) -> Optional[np.ndarray]:
    """The result's target points in the world (N, 3), or None without a target."""
    t = getattr(result, "target", None)
    return None if t is None else np.asarray(t.world_points())


def frustum_depth(result) -> float:
    """A frustum size that reads well: a quarter of the goal camera's distance to the target."""
    P = target_points(result)
    if P is None:
        return 0.1
    return 0.25 * float(np.linalg.norm(P.mean(axis=0) - result.goal[:3, 3])) or 0.1


def equal_3d(ax, points: np.ndarray) -> None:
    """Axis limits of a cube around the points, drawn as a cube."""
    points = points[np.isfinite(points).all(axis=1)]
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre, half = (lo + hi) / 2, max(float((hi - lo).max()) / 2 * 1.1, 1e-3)
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1, 1, 1))


def run_title(result, title: Optional[str] = None) -> str:
    """`title`, or else the result's servo description ("episode" without one)."""
    return title if title is not None else (getattr(result, "servo", "") or "episode")


def has_joints(result) -> bool:
    """True when the result has a robot and its joint history."""
    return getattr(result, "robot", None) is not None and result.history.q is not None


def end_time(result) -> float:
    """The time (s) of the frame at which the episode ended."""
    h = result.history
    s = result.status
    return float(h.time[min(max(s.frame, 0), len(h.time) - 1)]) if len(h.time) else 0.0


def run_labels(results, labels) -> list:
    """One label per result: `labels` as strings (ValueError unless one each), or their titles."""
    if labels is None:
        return [run_title(r) for r in results]
    labels = [str(x) for x in labels]
    if len(labels) != len(results):
        raise ValueError(f"labels: need one per result ({len(results)}), got {len(labels)}")
    return labels


def as_results(results) -> list:
    """A list of results from one ibvs.sim.Result or a non-empty sequence of them (else TypeError)."""
    if hasattr(results, "history"):
        return [results]
    out = list(results)
    if not out or not all(hasattr(r, "history") and hasattr(r, "status") for r in out):
        raise TypeError("results must be an ibvs.sim.Result or a non-empty sequence of them")
    return out
