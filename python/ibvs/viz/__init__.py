"""ibvs.viz: figures of simulated episodes, comparisons of runs, sweeps and the paper's Fig. 4.

    from ibvs import sim
    import ibvs.viz

    result = sim.run(servo, case.camera, case.target, case.start, case.goal)
    fig = result.plot()                            # the same as ibvs.viz.episode(result)
    fig.savefig("run.png")
    ibvs.viz.compare([a, b], ["polar", "cartesian"]).savefig("compare.png")
    ibvs.viz.animate(result, "run.gif", speed=2)

Every function builds a matplotlib.figure.Figure directly, without pyplot, so none of them
selects or changes matplotlib's backend: save the figure with fig.savefig(...), return it from
a notebook cell, or pass fig=plt.figure() to draw into a figure that pyplot manages (then
plt.show() shows it). Needs matplotlib: pip install ".[plot]" from the repository root.

Colours and styles are the same in every panel: one colour per target point, one line style
per feature coordinate (u solid, v dashed, r dash-dot, theta dotted, r theta dash-dot-dot);
twist components x, y, z in red, green, blue, translations solid and rotations dashed.
"""

from __future__ import annotations

import math
from typing import Optional, Sequence

import numpy as np

__all__ = ["animate", "compare", "episode", "image_limits", "image_limits_paths", "square_perimeter_r", "sweep_summary"]

_EXTRA = 'ibvs.viz needs matplotlib: pip install ".[plot]" from the ibvs repository root'


def _figure(fig, size):
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


# --------------------------------------------------------------------------- names, colours, geometry

#: Line style of each feature coordinate.
COORDINATE_STYLES = {"u": "-", "v": "--", "r": "-.", "theta": ":", "rtheta": (0, (4, 1.5, 1, 1.5, 1, 1.5))}
_TEX = {"u": "u", "v": "v", "r": "r", "theta": r"\theta", "rtheta": r"r\theta"}
_BLOCK = {"cartesian": ("u", "v"), "polar": ("r", "theta"), "cylindrical": ("r", "rtheta")}
#: Colour of the x, y, z components of the twist.
AXIS_COLOURS = ("tab:red", "tab:green", "tab:blue")
TWIST_LABELS = ["$T_x$", "$T_y$", "$T_z$", r"$\omega_x$", r"$\omega_y$", r"$\omega_z$"]


def _point_colours(n: int) -> list:
    """One colour per target point (tab10 up to 10 points, a continuous map beyond)."""
    from matplotlib import colormaps

    if n <= 10:
        return [colormaps["tab10"](i) for i in range(n)]
    return [colormaps["turbo"](x) for x in np.linspace(0.05, 0.95, n)]


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


def _valid(h) -> np.ndarray:
    """Frames whose values are finite (the stopping frame of an event may hold NaN)."""
    return np.isfinite(h.error_norm) & np.isfinite(h.twist).all(axis=1)


def _is_pixel_camera(camera) -> bool:
    """True unless the camera is a normalised one (unit focal length, no offset, no distortion)."""
    if camera is None:
        return False
    return not (camera.px == 1 and camera.py == 1 and camera.u0 == 0 and camera.v0 == 0
                and camera.distortion == "none")


def _sensor_border(camera, samples: int = 48) -> np.ndarray:
    """Closed polyline (M, 2) along the sensor's border, in measurement units."""
    u0, u1, v0, v1 = (float(x) for x in camera.bounds)
    s = np.linspace(0.0, 1.0, samples, endpoint=False)[:, None]
    corners = np.array([[u0, v0], [u1, v0], [u1, v1], [u0, v1], [u0, v0]])
    sides = [a + s * (b - a) for a, b in zip(corners[:-1], corners[1:])]
    return np.vstack(sides + [corners[:1]])


def _image_border(camera, samples: int = 48) -> np.ndarray:
    """The sensor's border in normalised image coordinates (undistorted with the camera model)."""
    return np.asarray(camera.normalize(_sensor_border(camera, samples)))


def square_perimeter_r(theta: np.ndarray, half_width: float) -> np.ndarray:
    """Radius of the border of the square image [-b, b]^2 in direction theta: b / max(|cos|, |sin|)."""
    return half_width / np.maximum(np.abs(np.cos(theta)), np.abs(np.sin(theta)))


def _measured(result, uv: np.ndarray) -> np.ndarray:
    """Normalised points (..., 2) in the camera's measurement units (pixels), distorted."""
    shape = uv.shape
    return np.asarray(result.camera.project(uv.reshape(-1, 2))).reshape(shape)


def _frustum(pose: np.ndarray, corners: np.ndarray, depth: float) -> np.ndarray:
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


def _corners(camera) -> np.ndarray:
    if camera is None:
        return np.array([[-0.3, -0.3], [0.3, -0.3], [0.3, 0.3], [-0.3, 0.3]])
    u0, u1, v0, v1 = (float(x) for x in camera.bounds)
    return np.asarray(camera.normalize([[u0, v0], [u1, v0], [u1, v1], [u0, v1]]))


def _target_points(result) -> Optional[np.ndarray]:
    t = getattr(result, "target", None)
    return None if t is None else np.asarray(t.world_points())


def _frustum_depth(result) -> float:
    """A frustum size that reads well: a quarter of the goal camera's distance to the target."""
    P = _target_points(result)
    if P is None:
        return 0.1
    return 0.25 * float(np.linalg.norm(P.mean(axis=0) - result.goal[:3, 3])) or 0.1


def _equal_3d(ax, points: np.ndarray) -> None:
    """Axis limits of a cube around the points, drawn as a cube."""
    points = points[np.isfinite(points).all(axis=1)]
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre, half = (lo + hi) / 2, max(float((hi - lo).max()) / 2 * 1.1, 1e-3)
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1, 1, 1))


def _outside_legend(ax, **kw) -> None:
    """A legend to the right of the axes, where it hides no data."""
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, fontsize=7, **kw)


def _title(result, title: Optional[str]) -> str:
    return title if title is not None else (getattr(result, "servo", "") or "episode")


# --------------------------------------------------------------------------- episode panels


def _image_panel(ax, result, colours, pixels: bool) -> None:
    """Feature paths in the image: pixels (distorted, as measured) or normalised coordinates."""
    h = result.history
    uv = h.uv[_valid(h)]
    des = np.asarray(result.uv_desired)
    camera = getattr(result, "camera", None)
    if pixels:
        uv, des = _measured(result, uv), _measured(result, des)
        border = _sensor_border(camera)
        unit = "px"
    else:
        border = _image_border(camera) if camera is not None else None
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
    rt = h.rtheta[_valid(h)]
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
        b = _image_border(camera)
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
    poses = h.pose[_valid(h)]
    if not len(poses):
        poses = h.pose[:1]
    p = poses[:, :3, 3]
    corners, depth = _corners(getattr(result, "camera", None)), _frustum_depth(result)
    ax.plot(p[:, 0], p[:, 1], p[:, 2], "-", color="0.25", lw=1.2, label="camera path")
    f0, f1, fg = (_frustum(T, corners, depth) for T in (poses[0], poses[-1], np.asarray(result.goal)))
    ax.plot(*f0.T, "-", color="0.6", lw=0.8, label="start")
    ax.plot(*f1.T, "-", color="k", lw=1.0, label="end")
    ax.plot(*fg.T, "--", color="tab:green", lw=0.8, label="goal")
    pts = [p, f0, f1, fg]
    P = _target_points(result)
    if P is not None:
        if len(P) >= 3 and getattr(result.target, "planar", False):
            Q = np.vstack([P, P[:1]])
            ax.plot(Q[:, 0], Q[:, 1], Q[:, 2], "-", color="0.5", lw=0.8)
        ax.scatter(P[:, 0], P[:, 1], P[:, 2], c=colours[: len(P)], s=14, depthshade=False, label="target")
        pts.append(P)
    _equal_3d(ax, np.vstack(pts))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.set_title("camera in the world")
    _outside_legend(ax)


def _error_panel(ax, result, colours) -> None:
    """The feature error, a line per row: the point's colour, the coordinate's style, named u1, v1, r1, theta1..."""
    h = result.history
    ok = _valid(h)
    t, e = h.time[ok], h.error[ok]
    names = _error_names(result)
    known = names[0][0] is not None
    if not known:  # rows of an unknown layout: e1, e2, ... in distinct colours
        colours = _point_colours(len(names))
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
    ok = _valid(h)
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
    ok = _valid(h)
    ax.semilogy(h.time[ok], np.maximum(h.error_norm[ok], 1e-16), "k-", lw=1.0)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(r"$\|f \ominus f^*\|$")
    ax.set_title("error norm")


def _joints_panel(ax, result) -> None:
    h = result.history
    ok = _valid(h)
    robot = result.robot
    q_min, q_max = np.asarray(robot.q_min, dtype=float), np.asarray(robot.q_max, dtype=float)
    frac = (h.q[ok] - q_min) / (q_max - q_min)
    colours = _point_colours(frac.shape[1])
    for k in range(frac.shape[1]):
        ax.plot(h.time[ok], frac[:, k], lw=1.0, color=colours[k], label=f"$q_{{{k + 1}}}$")
    ax.axhline(0, color="r", lw=0.8)
    ax.axhline(1, color="r", lw=0.8)
    ax.set_ylim(-0.05, 1.05)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(r"$(q - q_{min}) / (q_{max} - q_{min})$")
    ax.set_title("joints within their limits (red)")
    _outside_legend(ax)


def _has_joints(result) -> bool:
    return getattr(result, "robot", None) is not None and result.history.q is not None


def _end_time(result) -> float:
    h = result.history
    s = result.status
    return float(h.time[min(max(s.frame, 0), len(h.time) - 1)]) if len(h.time) else 0.0


def episode(result, *, title: Optional[str] = None, fig=None):
    """Figure of one episode (an ibvs.sim.Result): feature paths in the image (also in pixels
    for a pixel camera) and in the r-theta plane, the camera in the world (path, start, end and
    goal frustums, target), the feature error per coordinate and point, the camera twist, the
    error norm and, with a robot, its joints against their limits.

    title: the figure's title (default: the servo). fig: draw into this Figure or SubFigure
    (e.g. plt.figure()) instead of a new one. Returns the matplotlib Figure."""
    h = result.history
    camera = getattr(result, "camera", None)
    pixels = _is_pixel_camera(camera)
    top = (["pixels"] if pixels else []) + ["image", "polar", "scene"]
    bottom = ["error", "twist", "norm"] + (["joints"] if _has_joints(result) else [])
    cols = max(len(top), len(bottom))
    fig = _figure(fig, (4.9 * cols, 8.6))
    n = h.uv.shape[1]
    colours = _point_colours(n)
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
    fig.suptitle(f"{_title(result, title)} — {s.outcome}{where} at t = {_end_time(result):.2f} s", fontsize=13)
    return fig


# --------------------------------------------------------------------------- several runs


def _labels(results, labels) -> list:
    if labels is None:
        return [_title(r, None) for r in results]
    labels = [str(x) for x in labels]
    if len(labels) != len(results):
        raise ValueError(f"labels: need one per result ({len(results)}), got {len(labels)}")
    return labels


def _as_results(results) -> list:
    if hasattr(results, "history"):
        return [results]
    out = list(results)
    if not out or not all(hasattr(r, "history") and hasattr(r, "status") for r in out):
        raise TypeError("results must be an ibvs.sim.Result or a non-empty sequence of them")
    return out


def compare(results: Sequence, labels: Optional[Sequence[str]] = None, *, title: Optional[str] = None, fig=None):
    """Overlay several episodes (e.g. one start under several schemes), one colour per run:
    feature paths in the image, camera paths in the world, error norm, linear and angular
    speed, and the camera's distance to its goal against time. Returns the Figure."""
    results = _as_results(results)
    labels = _labels(results, labels)
    fig = _figure(fig, (15, 8.8))
    from matplotlib import colormaps

    cmap = colormaps["tab10"]
    axes = [fig.add_subplot(2, 3, k + 1, projection="3d" if k == 1 else None) for k in range(6)]
    img, scene, norm, lin, ang, dist = axes
    pts = []
    for j, (r, lab) in enumerate(zip(results, labels)):
        c = cmap(j % 10)
        h = r.history
        ok = _valid(h)
        t, uv, p = h.time[ok], h.uv[ok], h.pose[ok][:, :3, 3]
        for i in range(uv.shape[1]):
            img.plot(uv[:, i, 0], uv[:, i, 1], color=c, lw=1.0)
            if len(uv):
                img.plot(uv[-1, i, 0], uv[-1, i, 1], "*", color=c, ms=7)
        scene.plot(p[:, 0], p[:, 1], p[:, 2], color=c, lw=1.2)
        if len(p):
            scene.plot(*p[-1], "*", color=c, ms=7)
        s = r.status
        norm.semilogy(t, np.maximum(h.error_norm[ok], 1e-16), color=c, lw=1.0,
                      label=f"{lab}: {s.outcome} at {_end_time(r):.1f} s")
        lin.plot(t, np.linalg.norm(h.twist[ok, :3], axis=1), color=c, lw=1.0)
        ang.plot(t, np.linalg.norm(h.twist[ok, 3:], axis=1), color=c, lw=1.0)
        dist.plot(t, np.linalg.norm(p - np.asarray(r.goal)[:3, 3], axis=1), color=c, lw=1.0)
        pts += [p, np.asarray(r.goal)[None, :3, 3]]
    first = results[0]
    ud = np.asarray(first.uv_desired)
    img.plot(ud[:, 0], ud[:, 1], "k+", ms=9)
    if getattr(first, "camera", None) is not None:
        b = _image_border(first.camera)
        img.plot(b[:, 0], b[:, 1], "k-", lw=0.8)
        lo, hi = b.min(axis=0), b.max(axis=0)
        pad = 0.05 * (hi - lo)
        img.set_xlim(lo[0] - pad[0], hi[0] + pad[0])
        img.set_ylim(hi[1] + pad[1], lo[1] - pad[1])
    else:
        img.invert_yaxis()
    img.set_aspect("equal")
    img.set(xlabel="u (normalised)", ylabel="v (normalised)", title="image paths (+ desired, * end)")
    P = _target_points(first)
    if P is not None:
        scene.scatter(P[:, 0], P[:, 1], P[:, 2], c="k", s=10, depthshade=False)
        pts.append(P)
    _equal_3d(scene, np.vstack(pts))
    scene.set(xlabel="x (m)", ylabel="y (m)", zlabel="z (m)", title="camera paths (* end)")
    norm.set(xlabel="time (s)", ylabel=r"$\|f \ominus f^*\|$", title="error norm")
    lin.set(xlabel="time (s)", ylabel="m/s", title=r"linear speed $\|T\|$")
    ang.set(xlabel="time (s)", ylabel="rad/s", title=r"angular speed $\|\omega\|$")
    dist.set(xlabel="time (s)", ylabel="m", title="camera distance to its goal")
    fig.legend(*norm.get_legend_handles_labels(), loc="outside lower center", ncol=min(len(results), 4), fontsize=9)
    if title is not None:
        fig.suptitle(title, fontsize=13)
    return fig


# --------------------------------------------------------------------------- Fig. 4


def image_limits_paths(half_width: float = 0.3) -> dict:
    """Fig. 4's two straight-line polar paths, {name: (samples, inside)}: samples (2, 400) of
    (r, theta), inside whether every sample is within the square image [-b, b]^2. A->B lies in
    the image's largest inscribed circle; C->D joins two corners and leaves the image."""
    ends = {
        "A→B": ((0.4 * half_width, -2.6), (0.9 * half_width, 1.2)),
        "C→D": ((4 / 3 * half_width, 0.75), (4 / 3 * half_width, -0.75)),
    }
    s = np.linspace(0, 1, 400)
    out = {}
    for name, ((r0, t0), (r1, t1)) in ends.items():
        r, t = r0 + s * (r1 - r0), t0 + s * (t1 - t0)
        out[name] = (np.array([r, t]), bool(np.all(r <= square_perimeter_r(t, half_width) + 1e-12)))
    return out


def image_limits(half_width: float = 0.3, *, fig=None):
    """Fig. 4: the square image's border in r-theta, its largest inscribed circle shaded, a
    feasible straight-line polar path A->B and an infeasible C->D, also drawn in the u-v plane."""
    from matplotlib.patches import Circle

    fig = _figure(fig, (13, 5.2))
    ax, ax2 = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.6, 1]})
    th = np.linspace(-np.pi, np.pi, 1441)
    b = half_width
    ax.fill_between(th, 0, b, color="0.85", label="largest inscribed circle")
    ax.plot(th, square_perimeter_r(th, b), "k-", lw=1.2, label="image border")
    ax2.add_patch(Circle((0, 0), b, color="0.85"))
    ax2.plot([-b, b, b, -b, -b], [-b, -b, b, b, -b], "k-", lw=1.2)
    for (name, (rt, inside)), colour in zip(image_limits_paths(b).items(), ["tab:blue", "tab:red"]):
        r, t = rt
        for a, (x, y) in [(ax, (t, r)), (ax2, (r * np.cos(t), r * np.sin(t)))]:
            a.plot(x, y, "-", color=colour, lw=2, label=f"{name}: {'stays in' if inside else 'leaves'} the image")
            a.plot(x[0], y[0], "o", color=colour)
            a.plot(x[-1], y[-1], "*", color=colour, ms=11)
            a.annotate(name[0], (x[0], y[0]), textcoords="offset points", xytext=(5, 5))
            a.annotate(name[-1], (x[-1], y[-1]), textcoords="offset points", xytext=(5, 5))
    ax.set_xlim(-np.pi, np.pi)
    ax.set_ylim(0, b * 1.5)
    ax.set(xlabel=r"$\theta$ (rad)", ylabel="r (normalised)", title=f"Fig. 4: square image plane ±{b:g} in r-θ space")
    ax.legend(fontsize=8, loc="upper right")
    ax2.set_aspect("equal")
    ax2.set_xlim(-1.5 * b, 1.5 * b)
    ax2.set_ylim(1.5 * b, -1.5 * b)
    ax2.set(xlabel="u (normalised)", ylabel="v (normalised)", title="the same straight polar paths in the image")
    ax2.legend(fontsize=8, loc="lower right")
    return fig


# --------------------------------------------------------------------------- sweeps


def sweep_summary(table: Sequence[dict], by: str = "rz_deg", *, fig=None):
    """Figure of ibvs.sweep.aggregate(): per scheme (one colour each) against the bins of
    `by`, the fraction of every outcome (one panel each, converged first) and the medians of
    the camera retreat, the camera path length and the peak linear and angular speed."""
    if not table:
        raise ValueError("table: empty (no rows to plot)")
    outcomes = list(table[0]["outcomes"])
    metrics = [("retreat", "median camera retreat (m)"), ("path", "median camera path (m)"),
               ("peak_linear_speed", "median peak ‖T‖ (m/s)"), ("peak_angular_speed", "median peak ‖ω‖ (rad/s)")]
    panels = [(o, f"{o} (%)") for o in outcomes] + metrics
    cols = 4
    rows = math.ceil(len(panels) / cols)
    fig = _figure(fig, (4.2 * cols, 3.2 * rows + 0.6))
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    label = {"rz_deg": "rotation about the optical axis (deg)"}.get(by, by)
    schemes = list(dict.fromkeys(t["scheme"] for t in table))
    for ax, (key, name) in zip(axes, panels):
        for s in schemes:
            ts = [t for t in table if t["scheme"] == s]
            x = [(t["lo"] + t["hi"]) / 2 for t in ts]
            y = [t[key] * (100 if key in outcomes else 1) for t in ts]
            ax.plot(x, y, "o-", ms=3, lw=1.2, label=s)
        if key in outcomes:
            ax.set_ylim(-3, 103)
        ax.set_title(name, fontsize=10)
        ax.set_xlabel(label, fontsize=8)
        ax.grid(alpha=0.3)
    for ax in axes[len(panels):]:
        ax.set_visible(False)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncol=min(len(schemes), 7))
    return fig


# --------------------------------------------------------------------------- animation


def animate(results, path, *, labels: Optional[Sequence[str]] = None, speed: float = 1.0,
            fps: Optional[float] = None, dpi: float = 72, trail: Optional[float] = None, hold: float = 1.0):
    """Write an animation of one or several episodes to `path` (.gif, or .mp4 with
    imageio-ffmpeg: pip install ".[video]"); returns the number of frames written.

    For each result: the camera's view (current points, their desired positions, the image
    border and trails) and the 3D scene (camera frustum moving along its path, target, goal)
    and, with a robot, its joints as bars within their limits. One result: the panels side by
    side; several (e.g. schemes from the same start): one column per result.

    speed: simulated seconds per second of video (1 = real time). fps: frames per second of
    the file (default 20 for GIF, 30 for MP4). trail: seconds of feature trail (default: the
    whole path). hold: seconds the last frame stays. The file has
    ceil(duration * fps / speed) + 1 frames (duration: the longest episode's)."""
    from .animation import write

    return write(_as_results(results), path, labels=labels, speed=speed, fps=fps, dpi=dpi, trail=trail, hold=hold)
