"""Figures of the paper reproduction (matplotlib, headless Agg backend).

`run_figure` draws one episode the way the paper's Figs. 1-3 and 5-8 do (feature paths in
the u-v and r-theta planes, feature error and camera twist against time) plus the 3D camera
path and, on the gantry, the joints against their limits. `image_limits_figure` is Fig. 4.
"""

from __future__ import annotations

import numpy as np


def _pyplot():
    try:
        import matplotlib
    except ImportError as e:  # pragma: no cover - exercised only without the extra
        raise RuntimeError('plots need matplotlib: pip install "ibvs[plot]"') from e
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


TWIST_LABELS = ["$T_x$", "$T_y$", "$T_z$", r"$\omega_x$", r"$\omega_y$", r"$\omega_z$"]


def square_perimeter_r(theta: np.ndarray, half_width: float) -> np.ndarray:
    """Radius of the border of the square image [-b, b]^2 in direction theta: b / max(|cos|, |sin|)."""
    return half_width / np.maximum(np.abs(np.cos(theta)), np.abs(np.sin(theta)))


def _valid(h):
    """Frames whose values are finite (the stopping frame of an event may hold NaN)."""
    return np.isfinite(h.error_norm)


def _uv_plane(ax, result, bounds):
    h = result.history
    ok = _valid(h)
    uv = h.uv[ok]
    for i in range(uv.shape[1]):
        (line,) = ax.plot(uv[:, i, 0], uv[:, i, 1], lw=1.2, label=f"point {i + 1}")
        ax.plot(uv[0, i, 0], uv[0, i, 1], "o", color=line.get_color(), mfc="none")
        ax.plot(uv[-1, i, 0], uv[-1, i, 1], "*", color=line.get_color(), ms=9)
    ax.plot(result.uv_desired[:, 0], result.uv_desired[:, 1], "k+", ms=9, label="desired")
    (u0, u1), (v0, v1) = bounds
    ax.plot([u0, u1, u1, u0, u0], [v0, v0, v1, v1, v0], "k-", lw=0.8)
    ax.set_xlim(u0 - 0.05 * (u1 - u0), u1 + 0.05 * (u1 - u0))
    ax.set_ylim(v1 + 0.05 * (v1 - v0), v0 - 0.05 * (v1 - v0))  # image v grows downwards
    ax.set_aspect("equal")
    ax.set_xlabel("u (normalised)")
    ax.set_ylabel("v (normalised)")
    ax.set_title("image plane: o start, * end")
    ax.legend(fontsize=7, loc="best")


def _polar_plane(ax, result, bounds):
    h = result.history
    rt = h.rtheta[_valid(h)]
    for i in range(rt.shape[1]):
        theta, r = rt[:, i, 1], rt[:, i, 0]
        # Break the line where theta wraps so that it is not drawn across the plot.
        jumps = np.flatnonzero(np.abs(np.diff(theta)) > np.pi) + 1
        colour = None
        for seg_t, seg_r in zip(np.split(theta, jumps), np.split(r, jumps)):
            (line,) = ax.plot(seg_t, seg_r, lw=1.2, color=colour)
            colour = line.get_color()
        ax.plot(theta[0], r[0], "o", color=colour, mfc="none")
        ax.plot(theta[-1], r[-1], "*", color=colour, ms=9)
    ud = result.uv_desired
    ax.plot(np.arctan2(ud[:, 1], ud[:, 0]), np.hypot(ud[:, 0], ud[:, 1]), "k+", ms=9)
    (u0, u1), (v0, v1) = bounds
    if np.isclose(-u0, u1) and np.isclose(-v0, v1) and np.isclose(u1, v1):
        th = np.linspace(-np.pi, np.pi, 721)
        ax.plot(th, square_perimeter_r(th, u1), "k-", lw=0.8)
    ax.set_xlim(-np.pi, np.pi)
    ax.set_ylim(bottom=0)
    ax.set_xlabel(r"$\theta$ (rad)")
    ax.set_ylabel("r (normalised)")
    ax.set_title(r"$r$-$\theta$ plane")


def _against_time(ax, t, y, labels, title, ylabel):
    for k in range(y.shape[1]):
        ax.plot(t, y[:, k], lw=1.0, ls="-" if k < 3 or y.shape[1] != 6 else "--", label=labels[k])
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=7, ncol=2, loc="best")


def _trajectory_3d(ax, result, target_points):
    p = result.history.pose[_valid(result.history)][:, :3, 3]
    ax.plot(p[:, 0], p[:, 1], p[:, 2], "b-", lw=1.2, label="camera")
    ax.plot(*p[0], "bo", mfc="none")
    ax.plot(*p[-1], "b*", ms=9)
    ax.plot(*result.goal[:3, 3], "k+", ms=9, label="goal")
    P = np.vstack([target_points, target_points[:1]])
    ax.plot(P[:, 0], P[:, 1], P[:, 2], "r.-", label="target")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.set_title("camera path (world)")
    ax.legend(fontsize=7, loc="best")


def _joints(ax, result, q_min, q_max):
    h = result.history
    t, q = h.time[_valid(h)], h.q[_valid(h)]
    frac = (q - q_min) / (q_max - q_min)
    for k in range(6):
        ax.plot(t, frac[:, k], lw=1.0, label=f"$q_{k + 1}$")
    ax.axhline(0, color="r", lw=0.8)
    ax.axhline(1, color="r", lw=0.8)
    ax.set_ylim(-0.05, 1.05)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("(q - q_min) / (q_max - q_min)")
    ax.set_title("joints within their limits (red)")
    ax.legend(fontsize=7, ncol=2, loc="best")


def _error_norm(ax, result):
    h = result.history
    ok = _valid(h)
    ax.semilogy(h.time[ok], np.maximum(h.error_norm[ok], 1e-16), "k-", lw=1.0)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("|f (-) f*|")
    ax.set_title("error norm")


def run_figure(result, title: str, bounds, target_points, path: str, joint_limits=None, dpi: int = 90) -> None:
    """Save one episode's figure to `path` (PNG).

    bounds: ((u_min, u_max), (v_min, v_max)) of the image in normalised coordinates.
    target_points: (N, 3) target points in the world frame. joint_limits: (q_min, q_max) on the gantry.
    """
    plt = _pyplot()
    fig = plt.figure(figsize=(15, 8.5))
    h = result.history
    ok = _valid(h)
    _uv_plane(fig.add_subplot(2, 3, 1), result, bounds)
    _polar_plane(fig.add_subplot(2, 3, 2), result, bounds)
    _trajectory_3d(fig.add_subplot(2, 3, 3, projection="3d"), result, target_points)
    m = h.error.shape[1]
    _against_time(fig.add_subplot(2, 3, 4), h.time[ok], h.error[ok], [f"e{k + 1}" for k in range(m)],
                  "feature error", "f (-) f*")
    _against_time(fig.add_subplot(2, 3, 5), h.time[ok], h.twist[ok], TWIST_LABELS, "camera twist",
                  "m/s (solid), rad/s (dashed)")
    if joint_limits is not None and h.q is not None:
        _joints(fig.add_subplot(2, 3, 6), result, *joint_limits)
    else:
        _error_norm(fig.add_subplot(2, 3, 6), result)
    s = result.status
    fig.suptitle(f"{title} — {s.outcome} at t = {h.time[min(s.frame, len(h.time) - 1)]:.2f} s", fontsize=13)
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


def image_limits_figure(path: str, half_width: float = 0.3, dpi: int = 90) -> dict:
    """Fig. 4: the square image's border in r-theta, its largest inscribed circle shaded, a feasible
    straight-line polar path A->B and an infeasible C->D, also drawn back in the u-v plane.

    Returns whether each path stays inside the image (checked on the drawn samples)."""
    plt = _pyplot()
    th = np.linspace(-np.pi, np.pi, 1441)
    border = square_perimeter_r(th, half_width)
    paths = {
        "A→B": ((0.12, -2.6), (0.27, 1.2)),  # inside the inscribed circle: always feasible
        "C→D": ((0.40, 0.75), (0.40, -0.75)),  # two corners: the straight polar line leaves the image
    }
    inside = {}
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(13, 5.2), gridspec_kw={"width_ratios": [1.6, 1]})
    ax.fill_between(th, 0, half_width, color="0.85", label="largest inscribed circle")
    ax.plot(th, border, "k-", lw=1.2, label="image border")
    ax2.add_patch(plt.Circle((0, 0), half_width, color="0.85"))
    b = half_width
    ax2.plot([-b, b, b, -b, -b], [-b, -b, b, b, -b], "k-", lw=1.2)
    for (name, ((r0, t0), (r1, t1))), colour in zip(paths.items(), ["tab:blue", "tab:red"]):
        s = np.linspace(0, 1, 400)
        r, t = r0 + s * (r1 - r0), t0 + s * (t1 - t0)
        inside[name] = bool(np.all(r <= square_perimeter_r(t, half_width) + 1e-12))
        u, v = r * np.cos(t), r * np.sin(t)
        for a, (x, y) in [(ax, (t, r)), (ax2, (u, v))]:
            a.plot(x, y, "-", color=colour, lw=2, label=f"{name}: {'stays in' if inside[name] else 'leaves'} the image")
            a.plot(x[0], y[0], "o", color=colour)
            a.plot(x[-1], y[-1], "*", color=colour, ms=11)
            a.annotate(name[0], (x[0], y[0]), textcoords="offset points", xytext=(5, 5))
            a.annotate(name[-1], (x[-1], y[-1]), textcoords="offset points", xytext=(5, 5))
    ax.set_xlim(-np.pi, np.pi)
    ax.set_ylim(0, half_width * 1.5)
    ax.set_xlabel(r"$\theta$ (rad)")
    ax.set_ylabel("r (normalised)")
    ax.set_title(f"Fig. 4: square image plane ±{half_width} in r-θ space")
    ax.legend(fontsize=8, loc="upper right")
    ax2.set_aspect("equal")
    ax2.set_xlim(-1.5 * b, 1.5 * b)
    ax2.set_ylim(1.5 * b, -1.5 * b)
    ax2.set_xlabel("u (normalised)")
    ax2.set_ylabel("v (normalised)")
    ax2.set_title("the same straight polar paths in the image")
    ax2.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return inside
