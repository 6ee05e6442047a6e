"""Animations of simulated episodes: ibvs.viz.animate writes them (GIF through Pillow, MP4
through imageio-ffmpeg).

Frames are rendered by blitting into one reused figure on a private Agg canvas (matplotlib's
global backend is never touched): the static parts (image border, desired points, target,
goal, axes) are drawn once and saved; each frame restores them and draws only the moving
artists (points, trails, frustum, camera path, joint bars, clock) on top.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from .drawing import (
    as_results,
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
    run_labels,
    sensor_border,
    target_points,
    valid_frames,
)

# What ibvs.viz re-exports (and documents); the other names here are its own helpers.
__all__ = ["animate"]

#: Default frames per second of each format (a GIF stores delays in 1/100 s).
FPS = {".gif": 20.0, ".mp4": 30.0}
_VIDEO_EXTRA = 'MP4 needs imageio-ffmpeg: pip install ".[video]" from the ibvs repository root (or write a .gif)'


def check_path(path) -> Path:
    """The output path as a Path; ValueError naming path for an unknown format, ImportError
    for MP4 without imageio-ffmpeg."""
    p = Path(path)
    if p.suffix.lower() not in FPS:
        raise ValueError(f"path must end in .gif or .mp4, got {str(path)!r}")
    if p.suffix.lower() == ".mp4":
        try:
            import imageio_ffmpeg  # noqa: F401
        except ImportError as e:
            raise ImportError(_VIDEO_EXTRA) from e
    return p


def frame_count(results, speed: float = 1.0, fps: float = FPS[".gif"]) -> int:
    """Frames an animation of these results has: ceil(duration * fps / speed) + 1."""
    duration = max(_Track(r).duration for r in as_results(results))
    return int(math.ceil(duration * fps / speed - 1e-9)) + 1


def _positive(x, name: str, hi: float) -> float:
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number, got {type(x).__name__}")
    if not (math.isfinite(x) and 0 < x <= hi):
        raise ValueError(f"{name} must be in (0, {hi:g}], got {x!r}")
    return float(x)


class _Track:
    """The valid frames of one result, and the frame shown at animation time t."""

    def __init__(self, result):
        h = result.history
        ok = valid_frames(h)
        if not ok.any():
            ok = np.zeros(len(h.time), dtype=bool)
            ok[:1] = True
        self.result = result
        self.time = h.time[ok] - h.time[0]
        self.uv = h.uv[ok]
        self.pose = h.pose[ok]
        self.q = h.q[ok] if has_joints(result) else None
        self.norm = h.error_norm[ok]
        self.duration = float(self.time[-1]) if len(self.time) else 0.0

    def index(self, t: float) -> int:
        return int(np.clip(np.searchsorted(self.time, t + 1e-9, side="right") - 1, 0, len(self.time) - 1))


class _View:
    """Camera view of one track: points, trails, desired points, border (pixels for a pixel camera)."""

    def __init__(self, ax, track: _Track, trail: Optional[float]):
        r = track.result
        camera = getattr(r, "camera", None)
        self.pixels = is_pixel_camera(camera)
        uv, des = track.uv, np.asarray(r.uv_desired)
        if self.pixels:
            uv, des = measured_points(r, uv), measured_points(r, des)
            border = sensor_border(camera)
        else:
            border = image_border(camera) if camera is not None else None
        self.uv, self.track, self.trail = uv, track, trail
        n = uv.shape[1]
        colours = point_colours(n)
        ax.scatter(des[:, 0], des[:, 1], s=60, marker="+", c=colours, linewidths=1.5)
        if border is not None:
            ax.plot(border[:, 0], border[:, 1], "k-", lw=1.0)
            lo, hi = border.min(axis=0), border.max(axis=0)
        else:
            lo, hi = uv.reshape(-1, 2).min(axis=0), uv.reshape(-1, 2).max(axis=0)
        pad = 0.08 * (hi - lo)
        ax.set_xlim(lo[0] - pad[0], hi[0] + pad[0])
        ax.set_ylim(hi[1] + pad[1], lo[1] - pad[1])  # v grows downwards
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_xlabel("camera view (pixels)" if self.pixels else "camera view (normalised)", fontsize=8)
        self.trails = [ax.plot([], [], "-", color=colours[i], lw=1.0, alpha=0.7, animated=True)[0] for i in range(n)]
        self.points = ax.scatter(uv[0, :, 0], uv[0, :, 1], s=28, c=colours, zorder=3, animated=True)
        self.text = ax.text(0.02, 0.02, "", transform=ax.transAxes, fontsize=8, animated=True)

    def update(self, k: int, now: float) -> list:
        t = self.track.time
        j0 = 0 if self.trail is None else int(np.searchsorted(t, t[k] - self.trail))
        for i, line in enumerate(self.trails):
            line.set_data(self.uv[j0:k + 1, i, 0], self.uv[j0:k + 1, i, 1])
        self.points.set_offsets(self.uv[k])
        if now >= self.track.duration and k == len(t) - 1:  # the episode is over: how it ended
            self.text.set_text(f"{self.track.result.status.outcome} at {self.track.duration:.2f} s")
        else:
            self.text.set_text(f"|e| = {self.track.norm[k]:.2e}")
        return [*self.trails, self.points, self.text]


class _Scene:
    """3D scene of one track: target, goal frustum, moving camera frustum and its path."""

    def __init__(self, ax, track: _Track):
        r = track.result
        self.track = track
        self.corners = frustum_corners(getattr(r, "camera", None))
        P = target_points(r)
        path = track.pose[:, :3, 3]
        extent = np.ptp(np.vstack([path, P] if P is not None else [path]), axis=0).max()
        self.depth = max(frustum_depth(r), 0.06 * extent)  # visible however far the camera goes
        goal = frustum(np.asarray(r.goal), self.corners, self.depth)
        ax.plot(*goal.T, "--", color="tab:green", lw=0.8)
        pts = [path, goal, frustum(track.pose[0], self.corners, self.depth)]
        if P is not None:
            if len(P) >= 3 and getattr(r.target, "planar", False):
                Q = np.vstack([P, P[:1]])
                ax.plot(Q[:, 0], Q[:, 1], Q[:, 2], "-", color="0.5", lw=0.8)
            ax.scatter(P[:, 0], P[:, 1], P[:, 2], c=point_colours(len(P)), s=12, depthshade=False)
            pts.append(P)
        equal_3d(ax, np.vstack(pts))
        for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
            axis.set_ticklabels([])
        ax.tick_params(length=0)
        ax.set_xlabel("x", labelpad=-12, fontsize=8)
        ax.set_ylabel("y", labelpad=-12, fontsize=8)
        ax.set_zlabel("z", labelpad=-12, fontsize=8)
        self.path = ax.plot([], [], [], "-", color="0.3", lw=1.0, animated=True)[0]
        self.frustum = ax.plot([], [], [], "-", color="k", lw=1.2, animated=True)[0]

    def update(self, k: int, now: float) -> list:
        p = self.track.pose[: k + 1, :3, 3]
        self.path.set_data_3d(p[:, 0], p[:, 1], p[:, 2])
        f = frustum(self.track.pose[k], self.corners, self.depth)
        self.frustum.set_data_3d(f[:, 0], f[:, 1], f[:, 2])
        return [self.path, self.frustum]


class _Joints:
    """The robot's joints as bars within their limits (red when within 2 % of one)."""

    def __init__(self, ax, track: _Track):
        robot = track.result.robot
        self.q_min, self.q_max = np.asarray(robot.q_min, float), np.asarray(robot.q_max, float)
        self.track = track
        n = len(self.q_min)
        self.bars = ax.barh(np.arange(n), np.zeros(n), color="tab:blue", height=0.6, animated=True).patches
        ax.set_yticks(np.arange(n), [f"$q_{{{i + 1}}}$" for i in range(n)])
        ax.set_xlim(0, 1)
        ax.set_ylim(n - 0.5, -0.5)
        ax.set_xticks([0, 0.5, 1], ["min", "", "max"])
        ax.axvline(0.5, color="0.8", lw=0.8)
        ax.set_xlabel("joints within their limits", fontsize=8)

    def update(self, k: int, now: float) -> list:
        frac = np.clip((self.track.q[k] - self.q_min) / (self.q_max - self.q_min), 0, 1)
        for bar, f in zip(self.bars, frac):
            bar.set_width(f)
            bar.set_color("tab:red" if min(f, 1 - f) < 0.02 else "tab:blue")
        return list(self.bars)


def _layout(n: int, joints: bool):
    """(rows, cols, slot(result j, panel kind) -> 1-based subplot index)."""
    kinds = ["view", "scene"] + (["joints"] if joints else [])
    if n == 1:
        return 1, len(kinds), lambda j, kind: kinds.index(kind) + 1
    return len(kinds), n, lambda j, kind: kinds.index(kind) * n + j + 1


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
    return write(as_results(results), path, labels=labels, speed=speed, fps=fps, dpi=dpi, trail=trail, hold=hold)


def write(results: list, path, *, labels: Optional[Sequence[str]], speed: float, fps: Optional[float], dpi: float,
          trail: Optional[float], hold: float) -> int:
    """animate() of a list of results (their checks done here)."""
    p = check_path(path)
    ext = p.suffix.lower()
    speed = _positive(speed, "speed", 1e6)
    fps = FPS[ext] if fps is None else _positive(fps, "fps", 120.0)
    dpi = _positive(dpi, "dpi", 600.0)
    if trail is not None:
        trail = _positive(trail, "trail", 1e9)
    if isinstance(hold, bool) or not isinstance(hold, (int, float)) or not (math.isfinite(hold) and 0 <= hold <= 60):
        raise ValueError(f"hold must be in [0, 60] seconds, got {hold!r}")
    labels = run_labels(results, labels)
    fig = new_figure(None, (1, 1))
    fig.set_layout_engine(None)
    tracks = [_Track(r) for r in results]
    joints = any(t.q is not None for t in tracks)
    rows, cols, slot = _layout(len(tracks), joints)
    fig.set_size_inches(3.6 * cols, 3.5 * rows + 0.35)
    fig.set_dpi(dpi)
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    parts = []
    for j, (track, label) in enumerate(zip(tracks, labels)):
        view_ax = fig.add_subplot(rows, cols, slot(j, "view"))
        view_ax.set_title(label, fontsize=10)
        parts.append(_View(view_ax, track, trail))
        parts.append(_Scene(fig.add_subplot(rows, cols, slot(j, "scene"), projection="3d"), track))
        if joints:
            ax = fig.add_subplot(rows, cols, slot(j, "joints"))
            if track.q is not None:
                parts.append(_Joints(ax, track))
            else:
                ax.set_visible(False)
    clock = fig.text(0.5, 0.985, "", ha="center", va="top", fontsize=10, animated=True)
    fig.subplots_adjust(left=0.04, right=0.98, bottom=0.06, top=(1 - 0.45 / fig.get_figheight()), wspace=0.12,
                        hspace=0.15)
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    n = frame_count(results, speed, fps)
    step = speed / fps
    end = max(t.duration for t in tracks)
    width, height = (int(x) for x in canvas.get_width_height())
    sink = _Gif(p, fps, hold) if ext == ".gif" else _Mp4(p, fps, hold, width, height)
    try:
        for k in range(n):
            t = min(k * step, end)
            canvas.restore_region(background)
            clock.set_text(f"t = {t:5.2f} s" + ("" if speed == 1 else f"   (×{speed:g})"))
            for part in parts:
                for artist in part.update(part.track.index(t), t):
                    artist.axes.draw_artist(artist)
            fig.draw_artist(clock)
            sink.add(canvas.buffer_rgba(), width, height)
        sink.close()
    except BaseException:
        sink.abort()
        raise
    return n


class _Gif:
    """GIF frames through Pillow, all on the first frame's palette (no flicker, small diffs)."""

    def __init__(self, path: Path, fps: float, hold: float):
        from PIL import Image

        self.Image, self.path, self.fps, self.hold = Image, path, fps, hold
        self.frames, self.palette = [], None

    def add(self, rgba, width: int, height: int) -> None:
        im = self.Image.frombuffer("RGBA", (width, height), rgba, "raw", "RGBA", 0, 1).convert("RGB")
        if self.palette is None:
            self.palette = im.quantize(colors=255, method=self.Image.Quantize.MEDIANCUT)
        self.frames.append(im.quantize(palette=self.palette, dither=self.Image.Dither.NONE))

    def close(self) -> None:
        ms = 1000.0 / self.fps
        durations = [ms] * len(self.frames)
        durations[-1] += 1000.0 * self.hold
        self.frames[0].save(self.path, save_all=True, append_images=self.frames[1:], duration=durations, loop=0,
                            optimize=False, disposal=1)

    def abort(self) -> None:
        self.frames = []


class _Mp4:
    """H.264 MP4 through imageio-ffmpeg (frames padded to even sizes for yuv420p)."""

    def __init__(self, path: Path, fps: float, hold: float, width: int, height: int):
        import imageio_ffmpeg

        self.w, self.h = width + width % 2, height + height % 2
        self.fps, self.hold, self.last = fps, hold, None
        self.gen = imageio_ffmpeg.write_frames(str(path), (self.w, self.h), fps=fps, codec="libx264",
                                               pix_fmt_in="rgb24", pix_fmt_out="yuv420p", macro_block_size=2,
                                               ffmpeg_log_level="error")
        self.gen.send(None)

    def add(self, rgba, width: int, height: int) -> None:
        frame = np.full((self.h, self.w, 3), 255, np.uint8)
        frame[:height, :width] = np.asarray(rgba)[..., :3]
        self.last = frame
        self.gen.send(frame.tobytes())

    def close(self) -> None:
        for _ in range(int(round(self.hold * self.fps))):
            self.gen.send(self.last.tobytes())
        self.gen.close()

    def abort(self) -> None:
        self.gen.close()
