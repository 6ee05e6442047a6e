"""Several episodes in one figure: ibvs.viz.compare."""

from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

from .drawing import as_results, end_time, equal_3d, image_border, new_figure, run_labels, target_points, valid_frames

# What ibvs.viz re-exports (and documents); the other names here are its own helpers.
__all__ = ["compare"]


def compare(results: Sequence, labels: Optional[Sequence[str]] = None, *, title: Optional[str] = None, fig=None):
    """Overlay several episodes (e.g. one start under several schemes), one colour per run:
    feature paths in the image, camera paths in the world, error norm, linear and angular
    speed, and the camera's distance to its goal against time. Returns the Figure."""
    results = as_results(results)
    labels = run_labels(results, labels)
    fig = new_figure(fig, (15, 8.8))
    from matplotlib import colormaps

    cmap = colormaps["tab10"]
    axes = [fig.add_subplot(2, 3, k + 1, projection="3d" if k == 1 else None) for k in range(6)]
    img, scene, norm, lin, ang, dist = axes
    pts = []
    for j, (r, lab) in enumerate(zip(results, labels)):
        c = cmap(j % 10)
        h = r.history
        ok = valid_frames(h)
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
                      label=f"{lab}: {s.outcome} at {end_time(r):.1f} s")
        lin.plot(t, np.linalg.norm(h.twist[ok, :3], axis=1), color=c, lw=1.0)
        ang.plot(t, np.linalg.norm(h.twist[ok, 3:], axis=1), color=c, lw=1.0)
        dist.plot(t, np.linalg.norm(p - np.asarray(r.goal)[:3, 3], axis=1), color=c, lw=1.0)
        pts += [p, np.asarray(r.goal)[None, :3, 3]]
    first = results[0]
    ud = np.asarray(first.uv_desired)
    img.plot(ud[:, 0], ud[:, 1], "k+", ms=9)
    if getattr(first, "camera", None) is not None:
        b = image_border(first.camera)
        img.plot(b[:, 0], b[:, 1], "k-", lw=0.8)
        lo, hi = b.min(axis=0), b.max(axis=0)
        pad = 0.05 * (hi - lo)
        img.set_xlim(lo[0] - pad[0], hi[0] + pad[0])
        img.set_ylim(hi[1] + pad[1], lo[1] - pad[1])
    else:
        img.invert_yaxis()
    img.set_aspect("equal")
    img.set(xlabel="u (normalised)", ylabel="v (normalised)", title="image paths (+ desired, * end)")
    P = target_points(first)
    if P is not None:
        scene.scatter(P[:, 0], P[:, 1], P[:, 2], c="k", s=10, depthshade=False)
        pts.append(P)
    equal_3d(scene, np.vstack(pts))
    scene.set(xlabel="x (m)", ylabel="y (m)", zlabel="z (m)", title="camera paths (* end)")
    norm.set(xlabel="time (s)", ylabel=r"$\|f \ominus f^*\|$", title="error norm")
    lin.set(xlabel="time (s)", ylabel="m/s", title=r"linear speed $\|T\|$")
    ang.set(xlabel="time (s)", ylabel="rad/s", title=r"angular speed $\|\omega\|$")
    dist.set(xlabel="time (s)", ylabel="m", title="camera distance to its goal")
    fig.legend(*norm.get_legend_handles_labels(), loc="outside lower center", ncol=min(len(results), 4), fontsize=9)
    if title is not None:
        fig.suptitle(title, fontsize=13)
    return fig
