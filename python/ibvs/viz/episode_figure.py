"""The figure of one episode: ibvs.viz.episode (what sim.Result.plot draws)."""

from __future__ import annotations

import math
from typing import Optional

import numpy as np

from .drawing import (
    AXIS_COLOURS,
    COORDINATE_STYLES,
    TWIST_LABELS,
    end_time,
    equal_3d,
    frustum,
    frustum_corners,
    frustum_depth,
    has_joints,
    image_border,
    is_pixel_camera,
    measured_points,
    new_figure,
    point_colours,
    run_title,
    sensor_border,
    target_points,
    valid_frames,
)

# What ibvs.viz re-exports (and documents); the other names here are its own helpers.
__all__ = ["episode"]

_TEX = {"u": "u", "v": "v", "r": "r", "theta": r"\theta", "rtheta": r"r\theta"}
_BLOCK = {"cartesian": ("u", "v"), "polar": ("r", "theta"), "cylindrical": ("r", "rtheta")}


def _error_names(result) -> list:
    """(coordinate, point) of each column of result.history.error, from the servo's layout
    (coordinate in COORDINATE_STYLES, point 0-based); (None, k) when the layout is unknown."""
    m = result.history.error.shape[1]
    layout = getattr(result, "layout", None)
    if layout is not None:
        names = [(c, int(p)) for p, rep in layout.blocks for c in _BLOCK.get(str(rep), (None, None))]
        if len(names) == m and all(c is not None for c, _ in names):
            return names
    return [(None, k) for k in range(m)]


def _label(coord, point) -> str:
    return f"$e_{{{point + 1}}}$" if coord is None else f"${_TEX[coord]}_{{{point + 1}}}$"


def _outside_legend(ax, **kw) -> None:
    """A legend to the right of the axes, where it hides no data."""
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, fontsize=7, **kw)


def _image_panel(ax, result, colours, pixels: bool) -> None:
    """Feature paths in the image: pixels (distorted, as measured) or normalised coordinates."""
    h = result.history
    uv = h.uv[valid_frames(h)]
    des = np.asarray(result.uv_desired)
    camera = getattr(result, "camera", None)
    if pixels:
        uv, des = measured_points(result, uv), measured_points(result, des)
        border = sensor_border(camera)
        unit = "px"
    else:
        border = image_border(camera) if camera is not None else None
        unit = "normalised"
    n = uv.shape[1]
    for i in range(n):
        ax.plot(uv[:, i, 0], uv[:, i, 1], color=colours[i], lw=1.2, label=f"point {i + 1}" if n <= 10 else None)
        if len(uv):
            ax.plot(uv[0, i, 0], uv[0, i, 1], "o", color=colours[i], mfc="none")
            ax.plot(uv[-1, i, 0], uv[-1, i, 1], "*", color=colours[i], ms=9)
    ax.plot(des[:, 0], des[:, 1], "k+", ms=9, label="desired")
    if border is not None:
        ax.plot(border[:, 0], border[:, 1], "k-", lw=0.8)
        lo, hi = border.min(axis=0), border.max(axis=0)
        pad = 0.05 * (hi - lo)
        ax.set_xlim(lo[0] - pad[0], hi[0] + pad[0])
        ax.set_ylim(hi[1] + pad[1], lo[1] - pad[1])  # image v grows downwards
    else:
        ax.invert_yaxis()
    ax.set_aspect("equal")
    ax.set_xlabel(f"u ({unit})")
    ax.set_ylabel(f"v ({unit})")
    ax.set_title("camera image (pixels): o start, * end" if pixels else "image plane: o start, * end")
    _outside_legend(ax)


def _polar_panel(ax, result, colours) -> None:
    h = result.history
    rt = h.rtheta[valid_frames(h)]
    for i in range(rt.shape[1]):
        theta, r = rt[:, i, 1], rt[:, i, 0]
        # Break the line where theta wraps so that it is not drawn across the plot.
        jumps = np.flatnonzero(np.abs(np.diff(theta)) > np.pi) + 1
        for seg_t, seg_r in zip(np.split(theta, jumps), np.split(r, jumps)):
            ax.plot(seg_t, seg_r, lw=1.2, color=colours[i])
        if len(theta):
            ax.plot(theta[0], r[0], "o", color=colours[i], mfc="none")
            ax.plot(theta[-1], r[-1], "*", color=colours[i], ms=9)
    ud = np.asarray(result.uv_desired)
    ax.plot(np.arctan2(ud[:, 1], ud[:, 0]), np.hypot(ud[:, 0], ud[:, 1]), "k+", ms=9)
    camera = getattr(result, "camera", None)
    if camera is not None:
        b = image_border(camera)
        th, r = np.arctan2(b[:, 1], b[:, 0]), np.hypot(b[:, 0], b[:, 1])
        order = np.argsort(th)
        ax.plot(th[order], r[order], "k-", lw=0.8, label="image border")
    ax.set_xlim(-np.pi, np.pi)
    ax.set_ylim(bottom=0)
    ax.set_xlabel(r"$\theta$ (rad)")
    ax.set_ylabel("r (normalised)")
    ax.set_title(r"$r$-$\theta$ plane")


def _scene_panel(ax, result, colours) -> None:
    h = result.history
    poses = h.pose[valid_frames(h)]
    if not len(poses):
        poses = h.pose[:1]
    p = poses[:, :3, 3]
    corners, depth = frustum_corners(getattr(result, "camera", None)), frustum_depth(result)
    ax.plot(p[:, 0], p[:, 1], p[:, 2], "-", color="0.25", lw=1.2, label="camera path")
    f0, f1, fg = (frustum(T, corners, depth) for T in (poses[0], poses[-1], np.asarray(result.goal)))
    ax.plot(*f0.T, "-", color="0.6", lw=0.8, label="start")
    ax.plot(*f1.T, "-", color="k", lw=1.0, label="end")
    ax.plot(*fg.T, "--", color="tab:green", lw=0.8, label="goal")
    pts = [p, f0, f1, fg]
    P = target_points(result)
    if P is not None:
        if len(P) >= 3 and getattr(result.target, "planar", False):
            Q = np.vstack([P, P[:1]])
            ax.plot(Q[:, 0], Q[:, 1], Q[:, 2], "-", color="0.5", lw=0.8)
        ax.scatter(P[:, 0], P[:, 1], P[:, 2], c=colours[: len(P)], s=14, depthshade=False, label="target")
        pts.append(P)
    equal_3d(ax, np.vstack(pts))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.set_title("camera in the world")
    _outside_legend(ax)


def _error_panel(ax, result, colours) -> None:
    """The feature error, a line per row: the point's colour, the coordinate's style, named u1, v1, r1, theta1..."""
    h = result.history
    ok = valid_frames(h)
    t, e = h.time[ok], h.error[ok]
    names = _error_names(result)
    known = names[0][0] is not None
    if not known:  # rows of an unknown layout: e1, e2, ... in distinct colours
        colours = point_colours(len(names))
    # Legend entries coordinate by coordinate, so that each legend column is one coordinate.
    kinds = list(COORDINATE_STYLES)
    order = sorted(range(len(names)), key=lambda k: (kinds.index(names[k][0]) if known else 0, names[k][1]))
    for k in order:
        c, p = names[k]
        ax.plot(t, e[:, k], lw=1.0, color=colours[p], ls=COORDINATE_STYLES[c] if known else "-", label=_label(c, p))
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(r"$f \ominus f^*$")
    ax.set_title("feature error")
    if len(names) <= 40:
        ncol = len({c for c, _ in names}) if known else math.ceil(len(names) / 12)
        _outside_legend(ax, ncol=ncol, columnspacing=0.8, handlelength=2.2)


def _twist_panel(ax, result) -> None:
    h = result.history
    ok = valid_frames(h)
    for k in range(6):
        ax.plot(h.time[ok], h.twist[ok, k], lw=1.0, color=AXIS_COLOURS[k % 3], ls="-" if k < 3 else "--",
                label=TWIST_LABELS[k])
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("m/s (solid), rad/s (dashed)")
    ax.set_title("camera twist")
    _outside_legend(ax, ncol=1)


def _norm_panel(ax, result) -> None:
    h = result.history
    ok = valid_frames(h)
    ax.semilogy(h.time[ok], np.maximum(h.error_norm[ok], 1e-16), "k-", lw=1.0)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(r"$\|f \ominus f^*\|$")
    ax.set_title("error norm")


def _joints_panel(ax, result) -> None:
    h = result.history
    ok = valid_frames(h)
    robot = result.robot
    q_min, q_max = np.asarray(robot.q_min, dtype=float), np.asarray(robot.q_max, dtype=float)
    frac = (h.q[ok] - q_min) / (q_max - q_min)
    colours = point_colours(frac.shape[1])
    for k in range(frac.shape[1]):
        ax.plot(h.time[ok], frac[:, k], lw=1.0, color=colours[k], label=f"$q_{{{k + 1}}}$")
    ax.axhline(0, color="r", lw=0.8)
    ax.axhline(1, color="r", lw=0.8)
    ax.set_ylim(-0.05, 1.05)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(r"$(q - q_{min}) / (q_{max} - q_{min})$")
    ax.set_title("joints within their limits (red)")
    _outside_legend(ax)


def episode(result, *, title: Optional[str] = None, fig=None):
    """Figure of one episode (an ibvs.sim.Result): feature paths in the image (also in pixels
    for a pixel camera) and in the r-theta plane, the camera in the world (path, start, end and
    goal frustums, target), the feature error per coordinate and point, the camera twist, the
    error norm and, with a robot, its joints against their limits.

    title: the figure's title (default: the servo). fig: draw into this Figure or SubFigure
    (e.g. plt.figure()) instead of a new one. Returns the matplotlib Figure."""
    h = result.history
    camera = getattr(result, "camera", None)
    pixels = is_pixel_camera(camera)
    top = (["pixels"] if pixels else []) + ["image", "polar", "scene"]
    bottom = ["error", "twist", "norm"] + (["joints"] if has_joints(result) else [])
    cols = max(len(top), len(bottom))
    fig = new_figure(fig, (4.9 * cols, 8.6))
    n = h.uv.shape[1]
    colours = point_colours(n)
    for row, names in enumerate((top, bottom)):
        for k, name in enumerate(names):
            ax = fig.add_subplot(2, cols, row * cols + k + 1, projection="3d" if name == "scene" else None)
            if name == "pixels":
                _image_panel(ax, result, colours, pixels=True)
            elif name == "image":
                _image_panel(ax, result, colours, pixels=False)
            elif name == "polar":
                _polar_panel(ax, result, colours)
            elif name == "scene":
                _scene_panel(ax, result, colours)
            elif name == "error":
                _error_panel(ax, result, colours)
            elif name == "twist":
                _twist_panel(ax, result)
            elif name == "norm":
                _norm_panel(ax, result)
            else:
                _joints_panel(ax, result)
    s = result.status
    where = f" (point {s.point + 1})" if s.point >= 0 else f" (joint q{s.joint + 1})" if s.joint >= 0 else ""
    fig.suptitle(f"{run_title(result, title)} — {s.outcome}{where} at t = {end_time(result):.2f} s", fontsize=13)
    return fig
