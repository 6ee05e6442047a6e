"""Benchmark of the control step through the bindings, next to numpy.

``python -m ibvs.bench [--iterations N] [--n N] [--json]``

For the Cartesian (2N x 6), polar (2N x 6) and stacked hybrid (4N x 6)
layouts, and for the tasks of feature blocks of ibvs-bench's tasks section (image moments, PBVS in
both variants, 2.5-D, stacked(4) + moments: default and tuned, their twist checked against numpy's
damped normal equations on the servo's own J and e), ``ibvs.Servo.update`` (C++/Eigen through pybind11) is timed as built
by default (``ibvs.Servo(layout, gain)``: damping 0, diagnostics on) and tuned
(damping 0.01, diagnostics off), with the ratio default / tuned, and one damped
step v = -gain (J^T J + lambda^2 I)^-1 J^T e in pure vectorised numpy in the
same process. ibvs and numpy are first checked to give the same twist (a
RuntimeError says otherwise). Each case is warmed up, then timed call by call
with ``time.perf_counter_ns`` (the timer's own median cost subtracted): median,
p99 and max in microseconds, and calls/s from a batched loop. A few binding
baselines show where the time of a call goes.

``--vision`` times the image loop instead (ibvs.vision, needs the ``vision`` extra): on the gantry's
distorted 640x480 camera, per frame, rendering the dots, tracking them, rendering + detecting the
AprilTag, one servo step from pixels, and a whole image episode (--frames frames) per frame; each
with its share of the 16.7 ms frame budget at 60 Hz.

``--loop`` times the servo loop's own overhead per frame (ibvs.loop.ServoLoop; the source excluded:
the dot tracker, the servo, the joint mapping, the robot driver's call and the JSON-lines log) on
--frames pre-rendered 640x480 frames of dots: median, p99 and max in ms.
``--photometric`` times ``ibvs.LuminanceServo.update`` from Python on the 8-bit images of ibvs-bench's
photometric section (the same texture, 160x120 and 320x240, border 10, J at the desired image and at the
current one), to set beside ``ibvs-bench --sections photometric`` (the binding's share of a call).
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
import time
from typing import Any, Callable

import numpy as np

import ibvs

__all__ = ["main", "make_frames", "make_task_frames", "numpy_step", "run_photometric"]

LAYOUTS = ("cartesian", "polar", "stacked")
FRAMES = 64


def _wrap(a: np.ndarray) -> np.ndarray:
    """Angles into (-pi, pi] (as ibvs.wrap_angle)."""
    w = np.remainder(a + np.pi, 2.0 * np.pi) - np.pi
    return np.where(w <= -np.pi, w + 2.0 * np.pi, w)


def numpy_step(uv: np.ndarray, z: np.ndarray, uv_desired: np.ndarray, kind: str, damping: float,
               gain: float) -> np.ndarray:
    """One damped IBVS step in vectorised numpy (the reference the C++ is compared to).

    uv, uv_desired (N, 2); z (N,); kind "cartesian", "polar" or "stacked". Returns the twist (6,).
    J is filled column by column in one preallocated (N, blocks, 2, 6) array (about twice as fast
    as stacking per-row arrays), then A = J^T J + damping^2 I is solved by np.linalg.solve.
    """
    n = uv.shape[0]
    u, v = uv[:, 0], uv[:, 1]
    iz = 1.0 / z
    cart, pol = kind != "polar", kind != "cartesian"
    nb = int(cart) + int(pol)
    J = np.zeros((n, nb, 2, 6))
    e = np.empty((n, nb, 2))
    if cart:  # eq. (3)
        jc = J[:, 0]
        jc[:, 0, 0] = -iz
        jc[:, 0, 2] = u * iz
        jc[:, 0, 3] = u * v
        jc[:, 0, 4] = -1.0 - u * u
        jc[:, 0, 5] = v
        jc[:, 1, 1] = -iz
        jc[:, 1, 2] = v * iz
        jc[:, 1, 3] = 1.0 + v * v
        jc[:, 1, 4] = -u * v
        jc[:, 1, 5] = -u
        e[:, 0] = uv - uv_desired
    if pol:  # -(eq. 7)
        jp = J[:, nb - 1]
        r = np.hypot(u, v)
        ir = 1.0 / r
        c, s, k = u * ir, v * ir, 1.0 + r * r
        jp[:, 0, 0] = -c * iz
        jp[:, 0, 1] = -s * iz
        jp[:, 0, 2] = r * iz
        jp[:, 0, 3] = k * s
        jp[:, 0, 4] = -k * c
        jp[:, 1, 0] = s * ir * iz
        jp[:, 1, 1] = -c * ir * iz
        jp[:, 1, 3] = c * ir
        jp[:, 1, 4] = s * ir
        jp[:, 1, 5] = -1.0
        ud, vd = uv_desired[:, 0], uv_desired[:, 1]
        e[:, nb - 1, 0] = r - np.hypot(ud, vd)
        e[:, nb - 1, 1] = _wrap(np.arctan2(v, u) - np.arctan2(vd, ud))
    J = J.reshape(-1, 6)  # per point: its blocks in row order (Layout.cartesian/polar/stacked)
    e = e.reshape(-1)
    A = J.T @ J
    A.flat[::7] += damping * damping
    return -gain * np.linalg.solve(A, J.T @ e)


def make_frames(n: int, count: int = FRAMES, seed: int = 7,
                moved: bool = False) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(uv, depth, uv_desired) frames: desired points on a circle of radius 0.2, current ones
    rotated, scaled and shifted at random, depths in [0.7, 1.3] m (as ibvs-bench). moved: the
    desired points shifted by up to 1e-3 on every frame, so that no goal is reused (the servo
    caches what it computes from an unchanged goal)."""
    rng = np.random.default_rng(seed)
    a = 2.0 * np.pi * (np.arange(n) + 0.5) / n
    desired = np.ascontiguousarray(0.2 * np.stack([np.cos(a), np.sin(a)], axis=1))
    frames = []
    for _ in range(count):
        rot, scale = 0.6 * rng.uniform(-1, 1), 1.0 + 0.2 * rng.uniform(-1, 1)
        t = 0.03 * rng.uniform(-1, 1, 2)
        cur = scale * 0.2 * np.stack([np.cos(a + rot), np.sin(a + rot)], axis=1) + t
        cur = np.ascontiguousarray(cur + 0.005 * rng.uniform(-1, 1, (n, 2)))
        z = np.ascontiguousarray(1.0 + 0.3 * rng.uniform(-1, 1, n))
        goal = desired + 1e-3 * rng.uniform(-1, 1, (n, 2)) if moved else desired.copy()
        frames.append((cur, z, np.ascontiguousarray(goal)))
    return frames


TASKS = ("moments", "pbvs", "pbvs(object)", "2.5-D", "stacked+moments")


def make_task_frames(count: int = FRAMES, seed: int = 11) -> list[tuple[str, ibvs.Task, list[tuple]]]:
    """The tasks of ibvs-bench's tasks section, each with `count` update() argument tuples: an irregular
    planar quadrilateral (third-order alpha defined) seen from random poses around the goal (0.6 m in
    front), theta u up to ~0.5 rad, offsets of 5 cm, depths 0.45..0.75 m. Tasks: image moments
    (Tahri & Chaumette's six), PBVS (camera to desired camera; camera to object), 2.5-D (a corner),
    and stacked(4) on the corners + moments."""
    rng = np.random.default_rng(seed)
    obj = np.array([[-0.07, -0.05, 0.0], [0.08, -0.04, 0.0], [0.05, 0.06, 0.0], [-0.05, 0.04, 0.0]])
    goal = np.eye(4)
    goal[2, 3] = 0.6

    def camera_points(pose: np.ndarray) -> np.ndarray:
        return obj @ pose[:3, :3].T + pose[:3, 3]

    qd = camera_points(goal)
    m_goal = ibvs.MomentsFeature.project(qd, "region", 0.0, 0.6)
    area = ibvs.MomentsFeature.area(m_goal)
    uvd, zd = np.ascontiguousarray(qd[:, :2] / qd[:, 2:]), np.ascontiguousarray(qd[:, 2])
    tasks = {name: ibvs.Task() for name in TASKS[:4]}
    tasks["moments"].add(ibvs.MomentsFeature())
    tasks["pbvs"].add(ibvs.PbvsFeature("desired_camera"))
    tasks["pbvs(object)"].add(ibvs.PbvsFeature("object"))
    tasks["2.5-D"].add(ibvs.Point25DFeature())
    tasks["stacked+moments"] = ibvs.Task(ibvs.Layout.stacked(4)).add(ibvs.MomentsFeature())
    args: dict[str, list[tuple]] = {name: [] for name in TASKS}
    none = np.zeros((0, 2)), np.zeros(0), np.zeros((0, 2)), np.zeros(0)
    for _ in range(count):
        pose = ibvs.se3_exp(np.concatenate([np.zeros(3), rng.uniform(-1, 1, 3) * (0.25, 0.25, 0.5)]))
        pose[:3, 3] = 0.05 * rng.uniform(-1, 1), 0.05 * rng.uniform(-1, 1), 0.6 + 0.15 * rng.uniform(-1, 1)
        q = camera_points(pose)
        m = ibvs.MomentsFeature.project(q, "region", area, 0.6)
        args["moments"].append((*none, m, m_goal))
        for name, target in (("pbvs", "desired_camera"), ("pbvs(object)", "object")):
            args[name].append((*none, ibvs.PbvsFeature.measure(pose, goal, target),
                               ibvs.PbvsFeature.measure(goal, goal, target)))
        args["2.5-D"].append((*none, ibvs.Point25DFeature.measure(pose, goal, obj[1]),
                              ibvs.Point25DFeature.measure(goal, goal, obj[1])))
        uv, z = np.ascontiguousarray(q[:, :2] / q[:, 2:]), np.ascontiguousarray(q[:, 2])
        args["stacked+moments"].append((uv, z, uvd, zd, m, m_goal))
    return [(name, tasks[name], args[name]) for name in TASKS]


def check_task_agreement(task: ibvs.Task, args: list[tuple], damping: float, gain: float) -> float:
    """Largest relative difference between ibvs.Servo's twist for a task and numpy's damped normal
    equations on the same J and e (the servo's own ServoResult.jacobian / .error); raises if > 1e-9."""
    servo = ibvs.Servo(task, gain=gain, damping=damping, diagnostics=False)
    worst = 0.0
    for a in args:
        r = servo.update(*a)
        J, e = r.jacobian, r.error
        A = J.T @ J
        A.flat[::7] += damping * damping
        b = -gain * np.linalg.solve(A, J.T @ e)
        worst = max(worst, float(np.linalg.norm(r.velocity - b) / np.linalg.norm(b)))
    if not worst <= 1e-9:
        raise RuntimeError(f"ibvs.Servo and numpy disagree for a task ({task}): relative difference {worst:.3g}")
    return worst


def _layout(kind: str, n: int) -> ibvs.Layout:
    return {"cartesian": ibvs.Layout.cartesian, "polar": ibvs.Layout.polar, "stacked": ibvs.Layout.stacked}[kind](n)


def _timer_overhead_ns() -> float:
    clock = time.perf_counter_ns
    s = []
    for _ in range(20000):
        a = clock()
        s.append(clock() - a)
    return float(np.median(s))


def _time(fn: Callable[[int], Any], iterations: int, warmup: int, overhead_ns: float) -> dict[str, float]:
    """Warm-up, batched mean, then per-call median/p99/max (us)."""
    mask = FRAMES - 1
    for i in range(warmup):
        fn(i & mask)
    clock = time.perf_counter_ns
    t0 = clock()
    for i in range(iterations):
        fn(i & mask)
    mean_ns = (clock() - t0) / iterations
    samples = np.empty(iterations)
    for i in range(iterations):
        a = clock()
        fn(i & mask)
        samples[i] = clock() - a
    samples = np.maximum(samples - overhead_ns, 0.0) * 1e-3
    return {
        "median_us": float(np.median(samples)),
        "p99_us": float(np.percentile(samples, 99)),
        "max_us": float(samples.max()),
        "mean_us": mean_ns * 1e-3,
        "calls_per_s": 1e9 / mean_ns if mean_ns > 0 else math.inf,
    }


def check_agreement(kind: str, n: int, damping: float, gain: float, frames=None) -> float:
    """Largest relative twist difference between ibvs.Servo and numpy_step; raises if > 1e-9."""
    frames = frames or make_frames(n)
    servo = ibvs.Servo(_layout(kind, n), gain=gain, damping=damping, diagnostics=False)
    worst = 0.0
    for uv, z, uvd in frames:
        a = servo.update(uv, z, uvd).velocity
        b = numpy_step(uv, z, uvd, kind, damping, gain)
        worst = max(worst, float(np.linalg.norm(a - b) / np.linalg.norm(b)))
    if not worst <= 1e-9:
        raise RuntimeError(f"ibvs.Servo and the numpy step disagree for {kind}({n}): relative difference {worst:.3g}")
    return worst


def run(iterations: int = 20000, n: int = 4, damping: float = 0.01, gain: float = 0.5,
        warmup: int | None = None) -> dict[str, Any]:
    """Runs every case; returns the results as a dict (what --json prints)."""
    warmup = max(200, iterations // 10) if warmup is None else warmup
    overhead = _timer_overhead_ns()
    frames = make_frames(n)
    moved = make_frames(n, moved=True)
    cases: list[dict[str, Any]] = []

    def add(name: str, kind: str, rows: int, fn: Callable[[int], Any], **extra: Any) -> dict[str, Any]:
        r = {"name": name, "layout": kind, "n": n, "rows": rows, **extra, **_time(fn, iterations, warmup, overhead)}
        cases.append(r)
        return r

    for kind in LAYOUTS:
        layout = _layout(kind, n)
        difference = check_agreement(kind, n, damping, gain, frames)
        default = ibvs.Servo(layout, gain=gain)  # damping 0, diagnostics on: what a new user gets
        servo = ibvs.Servo(layout, gain=gain, damping=damping, diagnostics=False)
        servo_diag = ibvs.Servo(layout, gain=gain, damping=damping, diagnostics=True)
        upd_default, upd, upd_diag = default.update, servo.update, servo_diag.update
        slow = add("ibvs Servo.update default (damping 0, diagnostics)", kind, layout.rows,
                   lambda k, upd=upd_default: upd(*frames[k]), implementation="ibvs")
        fast = add("ibvs Servo.update damped", kind, layout.rows,
                   lambda k, upd=upd: upd(*frames[k]), implementation="ibvs", twist_difference=difference)
        slow["default_over_tuned"] = slow["median_us"] / fast["median_us"] if fast["median_us"] > 0 else math.inf
        add("ibvs Servo.update, goal moved every frame (default)", kind, layout.rows,
            lambda k, upd=upd_default: upd(*moved[k]), implementation="ibvs")
        add("ibvs Servo.update damped, .velocity", kind, layout.rows,
            lambda k, upd=upd: upd(*frames[k]).velocity, implementation="ibvs")
        add("ibvs Servo.update damped + diagnostics", kind, layout.rows,
            lambda k, upd=upd_diag: upd(*frames[k]), implementation="ibvs")
        ref = add("numpy vectorised, damped normal eqs", kind, layout.rows,
                  lambda k, kind=kind: numpy_step(*frames[k], kind, damping, gain), implementation="numpy")
        ratio = ref["median_us"] / fast["median_us"] if fast["median_us"] > 0 else math.inf
        fast["numpy_ratio"] = ref["numpy_ratio"] = ratio

    for name, task, args in make_task_frames():
        difference = check_task_agreement(task, args, damping, gain)
        default = ibvs.Servo(task, gain=gain).update  # damping 0, diagnostics on
        tuned = ibvs.Servo(task, gain=gain, damping=damping, diagnostics=False).update
        slow = add("ibvs Servo.update default (damping 0, diagnostics)", name, task.rows,
                   lambda k, upd=default, args=args: upd(*args[k]), implementation="ibvs", task=True)
        fast = add("ibvs Servo.update tuned (damped, no diagnostics)", name, task.rows,
                   lambda k, upd=tuned, args=args: upd(*args[k]),
                   implementation="ibvs", task=True, twist_difference=difference)
        slow["default_over_tuned"] = slow["median_us"] / fast["median_us"] if fast["median_us"] > 0 else math.inf

    # Binding baselines: what any call costs, and an array in / array out call.
    layout = _layout("stacked", n)
    add("baseline: Layout.rows (property)", "stacked", layout.rows, lambda k: layout.rows, implementation="binding")
    feats = ibvs.features
    add("baseline: ibvs.features(uv) (N,2) in, (M,) out", "stacked", layout.rows,
        lambda k: feats(frames[k][0], layout), implementation="binding")

    return {
        "benchmark": "ibvs.bench",
        "version": ibvs.__version__,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "machine": platform.machine(),
        "processor": _cpu_model(),
        "iterations": iterations,
        "damping": damping,
        "gain": gain,
        "timer_overhead_ns": overhead,
        "cases": cases,
    }


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def format_table(res: dict[str, Any]) -> str:
    lines = [
        (f"ibvs.bench {res['version']} | {res['processor']} | Python {res['python']} | numpy {res['numpy']} | "
         f"perf_counter_ns cost {res['timer_overhead_ns']:.0f} ns (subtracted)"),
        (f"N = {res['cases'][0]['n']} points, damping {res['damping']}, gain {res['gain']}, "
         f"{res['iterations']} iterations; times per call in microseconds"),
        "",
        f"  {'case':<52} {'layout':<20} {'median':>8} {'p99':>8} {'max':>8} {'calls/s':>10} {'ratio':>16}",
    ]
    for c in res["cases"]:
        what = f"{c['layout']} {c['rows']}x6" if c.get("task") else f"{c['layout']}({c['n']}) {c['rows']}x6"
        lines.append(f"  {c['name']:<52} {what:<20} {_cell(c['median_us'], 8, 2)} {_cell(c['p99_us'], 8, 2)} "
                     f"{_cell(c['max_us'], 8, 1)} {_cell(c['calls_per_s'], 10, 0)} {_ratio(c):>16}")
    lines.append(f"  {_NO_RATIO}")
    return "\n".join(lines)


# Why a row's ratio is n/a: the table compares two pairs of rows only.
_NO_RATIO = ("ratio n/a: only the damped ibvs step of a point layout (numpy/ibvs: numpy's time over it) and the default "
            "step (/tuned: over the damped one) have a counterpart to compare with")


def _ratio(c: dict[str, Any]) -> str:
    """The ratio column of one row: n/a where the row has no counterpart (_NO_RATIO) or the ratio is not finite."""
    if "default_over_tuned" in c:
        x, text = c["default_over_tuned"], "/tuned {:.2f}x"
    elif c.get("implementation") == "ibvs" and "numpy_ratio" in c:
        x, text = c["numpy_ratio"], "numpy/ibvs {:.0f}x"
    else:
        return "n/a"
    return text.format(x) if x is not None and math.isfinite(x) else "n/a"


FRAME_BUDGET_MS = 1000.0 / 60.0


def run_vision(frames: int = 300) -> dict[str, Any]:
    """Per-frame times (ms: median, p99, max, share of the 60 Hz budget) of the image loop's parts."""
    import cv2

    from . import sim, vision

    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)  # one thread: the CPU time is the work, whatever else the host runs
    try:
        return _run_vision(frames, cv2, sim, vision)
    finally:
        cv2.setNumThreads(threads)


def _run_vision(frames, cv2, sim, vision) -> dict[str, Any]:
    case = sim.cases.gantry_general_motion()
    cam, target, robot = case.camera, case.target, case.robot
    poses = [robot.camera(case.start + (case.goal - case.start) * k / frames) for k in range(frames)]
    dots = vision.Renderer(cam, target, "dots", noise=1.0)
    tag = vision.Renderer(cam, target, "tag", noise=1.0)
    images = [dots.render(p) for p in poses]
    tags = [tag.render(p) for p in poses]
    truth = [cam.project(_project(p, target)) for p in poses]
    tracker = vision.DotTracker(4, dots.size)
    detector = vision.TagDetector((0,), image_size=tag.size)
    servo = ibvs.Servo(ibvs.Layout.stacked(4), gain=1.0, camera=cam)
    desired = truth[-1]
    z = np.full(4, 0.6)

    cpu = {}

    def timed(fn, n, name):
        """Wall time per call (ms); the mean CPU time of this thread per call goes into cpu[name]."""
        out = np.empty(n)
        c0 = time.thread_time()
        for k in range(n):
            t0 = time.perf_counter()
            fn(k)
            out[k] = time.perf_counter() - t0
        cpu[name] = (time.thread_time() - c0) / n * 1e3
        return out * 1e3

    rows = {}
    name = "render dots (640x480, distorted, noise)"
    rows[name] = timed(lambda k: dots.render(poses[k]), frames, name)
    tracker.reset(truth[0])
    errors = []

    def track(k):
        t = tracker.track(images[k])
        errors.append(np.abs(t.pixels - truth[k]).max())

    rows["track 4 dots"] = timed(track, frames, "track 4 dots")
    rows["render tag"] = timed(lambda k: tag.render(poses[k]), frames, "render tag")
    tag_errors = []

    def detect(k):
        t = detector.detect(tags[k])
        tag_errors.append(np.abs(t.pixels - truth[k]).max())

    name = "detect tag (cv2.aruco, sub-pixel)"
    rows[name] = timed(detect, frames, name)
    rows["servo step from pixels (update_pixels)"] = timed(
        lambda k: servo.update_pixels(truth[k], z, desired), frames, "servo step from pixels (update_pixels)")
    servo_ep = ibvs.Servo(ibvs.Layout.stacked(4), gain=1.0)
    t0, c0 = time.perf_counter(), time.thread_time()
    r = sim.run(servo_ep, cam, target, case.start, case.goal, robot=robot, duration=frames / cam.fps,
                tolerance=0.0, vision="dots")
    episode_ms = (time.perf_counter() - t0) * 1e3
    episode_cpu_ms = (time.thread_time() - c0) * 1e3
    out = {"frames": frames, "budget_ms": FRAME_BUDGET_MS, "opencv_threads": cv2.getNumThreads(), "cases": []}
    for name, t in rows.items():
        med = float(np.median(t))
        out["cases"].append({"name": name, "median_ms": med, "p99_ms": float(np.percentile(t, 99)),
                             "max_ms": float(t.max()), "cpu_ms": cpu[name], "budget_share": med / FRAME_BUDGET_MS})
    per_frame = episode_ms / len(r.history)
    # The episode is timed once, as a whole: its per-frame time is a mean, with no spread (None: not
    # measured; JSON null, "n/a" in the table, with the reason in "why").
    out["cases"].append({"name": f"image episode, per frame ({len(r.history)} frames, gantry, dots)",
                         "median_ms": per_frame, "p99_ms": None, "max_ms": None,
                         "cpu_ms": episode_cpu_ms / len(r.history), "budget_share": per_frame / FRAME_BUDGET_MS,
                         "why": "the episode is timed once, as a whole: its median is the mean per frame, "
                                "p99 and max are not measured"})
    # over the frames where every point was measured (lost: frames with a point lost; None: every frame)
    for key, e in (("dot_error_px", errors), ("tag_error_px", tag_errors)):
        e = np.asarray(e)
        out[key] = {"median": float(np.nanmedian(e)) if np.isfinite(e).any() else None,
                    "max": float(np.nanmax(e)) if np.isfinite(e).any() else None,
                    "lost_frames": int(np.isnan(e).sum())}
    return out


def run_loop(frames: int = 300) -> dict[str, Any]:
    """The servo loop's own overhead per frame (ms: median, p99, max), the source excluded: the dot tracker,
    the servo, the joint mapping, the robot driver's call and the JSON-lines log, on 640x480 rendered dots
    (rendered beforehand) of the gantry's general motion, through ibvs.loop.ServoLoop on the real clock."""
    import cv2

    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        return _run_loop(frames)
    finally:
        cv2.setNumThreads(threads)


class _Frames:
    """Pre-rendered images as a frame source (stamped at read: capture-to-command = the loop's own time)."""

    def __init__(self, images, camera, clock):
        self.images, self.camera, self.clock, self.rate, self.k, self.ended = images, camera, clock, 1e4, 0, False

    def open(self):
        pass

    def read(self, timeout):
        from .vision.sources import Frame

        if self.k >= len(self.images):
            self.ended = True
            return None
        self.k += 1
        return Frame(self.images[self.k - 1], self.clock.now(), self.k - 1)

    def close(self):
        pass


class _BenchRobot:
    """A robot that takes every command at once (the driver call: the limit check of ibvs.robot when present)."""

    def __init__(self, model, q0, clock):
        self.kinematics, self.n_joints, self.rate, self.clock = model, model.dof, 1000.0, clock
        self.q, self.dq = np.array(q0, dtype=float), np.zeros(model.dof)
        try:
            from .robot import JointState, Limits, check_command
        except ImportError:
            self.check = None
        else:
            n = model.dof
            self.limits = Limits(np.full(n, -1e3), np.full(n, 1e3), np.full(n, 10.0), np.full(n, 1e3))
            self.check = lambda dq, s: check_command(dq, JointState(s.q, s.dq, s.stamp), self.limits, 1e-3, None)

    def connect(self):
        pass

    def state(self):
        from types import SimpleNamespace

        return SimpleNamespace(q=self.q, dq=self.dq, stamp=self.clock.now())

    def send_joint_velocity(self, dq, state=None):
        if self.check is not None:
            self.check(dq, state if state is not None else self.state())
        self.dq = np.asarray(dq)

    def stop(self):
        self.dq = np.zeros(self.n_joints)

    def disconnect(self):
        self.stop()


def _run_loop(frames: int) -> dict[str, Any]:
    import tempfile

    from . import sim, vision
    from .loop import RealClock
    from .loop.servo_loop import LoopOptions, ServoLoop
    from .ros.node import NodeParams, ServoNodeCore

    case = sim.cases.gantry_general_motion()
    cam, target, robot = case.camera, case.target, case.robot
    poses = [robot.camera(case.start + (case.goal - case.start) * k / frames) for k in range(frames)]
    renderer = vision.Renderer(cam, target, "dots", noise=1.0)
    images = [renderer.render(p) for p in poses]
    truth = [cam.project(_project(p, target)) for p in poses]
    clock = RealClock()
    params = NodeParams(desired_pixels=truth[-1], depth=0.6, scheme="polar", gain=1.0, initial_pixels=truth[0],
                        output="joint_velocities", eMc=np.eye(4), joint_names=[f"j{i}" for i in range(6)],
                        fps=cam.fps)
    core = ServoNodeCore(params, clock=lambda: int(clock.now() * 1e9), jacobian=robot.jacobian)
    core.set_camera(cam)
    with tempfile.TemporaryDirectory() as tmp:
        options = LoopOptions(rate=cam.fps, watchdog=10.0, log=f"{tmp}/loop.jsonl", signals=False)
        loop = ServoLoop(_Frames(images, cam, clock), _BenchRobot(robot, case.start, clock), core, clock, options)
        tracker_s, track = [], core.tracker.track

        def timed_track(image):  # the tracker's own share (its Track.seconds)
            out = track(image)
            tracker_s.append(out.seconds)
            return out

        core.tracker.track = timed_track
        c0 = time.thread_time()
        report = loop.run()
        cpu_ms = (time.thread_time() - c0) / max(1, report.frames) * 1e3
    t = np.asarray(report.timing.overhead) * 1e3
    return {"frames": len(t), "image": f"{int(cam.width)}x{int(cam.height)}", "outcome": report.outcome,
            "overhead_ms": {"median": float(np.median(t)), "p99": float(np.percentile(t, 99)),
                            "max": float(t.max())}, "cpu_ms": cpu_ms, "budget_ms": 1.0,
            "tracker_ms": {"median": float(np.median(tracker_s) * 1e3),
                           "p99": float(np.percentile(tracker_s, 99) * 1e3)},
            "without_tracker_ms": {"median": float(np.median(t - np.asarray(tracker_s[:len(t)]) * 1e3))}}


def format_loop(res: dict[str, Any]) -> str:
    o, tr = res["overhead_ms"], res["tracker_ms"]
    return "\n".join([
        f"servo loop overhead per frame ({res['frames']} frames, {res['image']} dots; tracker + servo + joint mapping "
        f"+ driver call + log, the source excluded; target: median <= {res['budget_ms']:g} ms)",
        f"  wall median {o['median']:.3f} ms, p99 {o['p99']:.3f} ms, max {o['max']:.3f} ms; CPU time of this thread "
        f"{res['cpu_ms']:.3f} ms per frame (mean)",
        f"  of which the dot tracker: median {tr['median']:.3f} ms, p99 {tr['p99']:.3f} ms; the rest (servo, joint "
        f"mapping, driver call, log): median {res['without_tracker_ms']['median']:.3f} ms"])


def _cell(x, width: int, digits: int = 3) -> str:
    """A number, or n/a for None (not measured) or a non-finite value."""
    return f"{x:{width}.{digits}f}" if x is not None and math.isfinite(x) else f"{'n/a':>{width}}"


def _project(pose_wc, target) -> np.ndarray:
    pw = np.column_stack([np.asarray(target.world_points()), np.ones(len(target))])
    pc = (np.linalg.inv(pose_wc) @ pw.T)[:3]
    return (pc[:2] / pc[2]).T


def format_vision(res: dict[str, Any]) -> str:
    lines = [f"vision, {res['frames']} frames, ms per frame: wall median / p99 / max, share of the "
             f"{res['budget_ms']:.1f} ms budget at 60 Hz, and the CPU time of this thread (mean)",
             f"  {'case':<58} {'median':>8} {'p99':>8} {'max':>8} {'budget':>7} {'cpu':>8}"]
    why = []
    for c in res["cases"]:
        lines.append(f"  {c['name']:<58} {_cell(c['median_ms'], 8)} {_cell(c['p99_ms'], 8)} {_cell(c['max_ms'], 8)} "
                     f"{100 * c['budget_share']:6.1f}% {_cell(c['cpu_ms'], 8)}")
        if "why" in c:
            why.append(f"  n/a: {c['name']}: {c['why']}")
    d, t = res["dot_error_px"], res["tag_error_px"]

    def error(e: dict, lost: str) -> str:
        if e["median"] is None:
            return f"n/a (every frame {lost})"
        return f"median {e['median']:.3f} max {e['max']:.3f} ({e['lost_frames']} frames {lost})"

    lines.append(f"  detection error vs the true projection (px): dots {error(d, 'with a dot lost')}; tag corners "
                 f"{error(t, 'without the tag')}")
    return "\n".join(lines + why)


def run_natural(frames: int = 100) -> dict[str, Any]:
    """Per-frame times (ms) of the natural-feature trackers at 640x480 beside OpenCV's own calls alone (the
    same frames; one OpenCV thread), and their error against the true projections (px)."""
    import cv2

    from . import sim, vision

    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        return _run_natural(frames, cv2, sim, vision)
    finally:
        cv2.setNumThreads(threads)


def _run_natural(frames, cv2, sim, vision) -> dict[str, Any]:
    cam = ibvs.CameraModel(600.0, 600.0, 319.5, 239.5, 0.0, 0.0, 640.0, 480.0)
    target = sim.Target.square(0.2, sim.pose(t=(0, 0, 0.5)))  # a 240 px textured plate at the goal
    start = np.array([0.05, -0.03, -0.2, 0.2, -0.15, 1.0])
    poses = [ibvs.se3_exp(start * math.exp(-0.05 * k)) for k in range(frames)]  # a servo's approach
    renderer = vision.Renderer(cam, target, "texture", noise=1.0)
    images = [renderer.render(p) for p in poses]
    truth = [cam.project(_project(p, target)) for p in poses]
    rows, errors = {}, {}

    def timed(name, fn, n):
        out = np.empty(n)
        for k in range(n):
            t0 = time.perf_counter()
            fn(k)
            out[k] = time.perf_counter() - t0
        rows[name] = out * 1e3

    rows_render = "render textured plate (640x480, noise)"
    timed(rows_render, lambda k: renderer.render(poses[k]), frames)
    klt = vision.KltTracker(renderer.size)
    klt.reset(images[0], truth[0])
    e_klt = []
    timed("KltTracker.track (300 features, refined)",
          lambda k: e_klt.append(np.abs(klt.track(images[k + 1]).pixels - truth[k + 1]).max()), frames - 1)
    # OpenCV's calls alone on the same frames: LK forward and backward and RANSAC, on 300 corners
    lk = dict(winSize=(21, 21), maxLevel=3, criteria=(cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01))
    p0 = cv2.goodFeaturesToTrack(images[0], 300, 0.01, 5, blockSize=5)

    def raw_klt(k):
        p1, _, _ = cv2.calcOpticalFlowPyrLK(images[k], images[k + 1], p0, None, **lk)
        cv2.calcOpticalFlowPyrLK(images[k + 1], images[k], p1, None, **lk)
        cv2.findHomography(p0, p1, cv2.RANSAC, 2.0)

    timed("  cv2 alone: LK forward + backward, findHomography", raw_klt, frames - 1)
    kp = vision.KeypointTracker(images[-1], truth[-1])  # the goal image as the reference
    e_kp = []
    timed("KeypointTracker.detect (ORB 500, refined)",
          lambda k: e_kp.append(np.abs(kp.detect(images[k]).pixels - truth[k]).max()), frames)
    orb, matcher = cv2.ORB_create(nfeatures=500, fastThreshold=10), cv2.BFMatcher(cv2.NORM_HAMMING)
    kr, dr = orb.detectAndCompute(images[-1], None)
    ref_pts = np.array([q.pt for q in kr], np.float32)

    def raw_kp(k):
        kq, dq = orb.detectAndCompute(images[k], None)
        good = [m[0] for m in matcher.knnMatch(dr, dq, k=2) if len(m) == 2 and m[0].distance < 0.8 * m[1].distance]
        if len(good) >= 4:
            cv2.findHomography(ref_pts[[m.queryIdx for m in good]],
                               np.array([kq[m.trainIdx].pt for m in good], np.float32), cv2.RANSAC, 3.0)

    timed("  cv2 alone: ORB, knnMatch, findHomography", raw_kp, frames)
    errors = {"klt_error_px": e_klt, "keypoints_error_px": e_kp}
    out = {"frames": frames, "budget_ms": FRAME_BUDGET_MS, "opencv_threads": cv2.getNumThreads(), "cases": []}
    for name, t in rows.items():
        med = float(np.median(t))
        out["cases"].append({"name": name, "median_ms": med, "p99_ms": float(np.percentile(t, 99)),
                             "max_ms": float(t.max()), "budget_share": med / FRAME_BUDGET_MS})
    for key, e in errors.items():
        e = np.asarray(e)
        ok = np.isfinite(e)
        out[key] = {"median": float(np.median(e[ok])) if ok.any() else None,
                    "max": float(e[ok].max()) if ok.any() else None, "lost_frames": int((~ok).sum())}
    return out


def format_natural(res: dict[str, Any]) -> str:
    lines = [f"natural features, {res['frames']} frames at 640x480, ms per frame: median / p99 / max, share of the "
             f"{res['budget_ms']:.1f} ms budget at 60 Hz (one OpenCV thread)",
             f"  {'case':<58} {'median':>8} {'p99':>8} {'max':>8} {'budget':>7}"]
    for c in res["cases"]:
        lines.append(f"  {c['name']:<58} {_cell(c['median_ms'], 8)} {_cell(c['p99_ms'], 8)} {_cell(c['max_ms'], 8)} "
                     f"{100 * c['budget_share']:6.1f}%")
    for key, label in (("klt_error_px", "KLT"), ("keypoints_error_px", "keypoints")):
        e = res[key]
        lines.append(f"  {label} corners vs the true projection (px): median "
                     f"{_cell(e['median'], 0)} max {_cell(e['max'], 0)} ({e['lost_frames']} frames lost)")
    return "\n".join(lines)


def _texture(w: int, h: int, shift: float, turn: float) -> np.ndarray:
    """ibvs-bench's photometric frames (bench/ibvs_bench.cpp, bench_photometric), the same formula."""
    c, r = np.meshgrid(np.arange(w) - 0.5 * w, np.arange(h) - 0.5 * h)
    X = c * math.cos(turn) - r * math.sin(turn) + shift
    Y = c * math.sin(turn) + r * math.cos(turn) - 0.5 * shift
    s = 0.32 * 160.0 / w
    im = 128.0 + 50.0 * np.sin(s * X * 0.9 + 0.3) + 40.0 * np.sin(s * (0.6 * Y - 0.3 * X)) + 25.0 * np.cos(
        s * 0.5 * (X + Y))
    return np.floor(im + 0.5).astype(np.uint8)  # lround: the values are positive


def run_photometric(iterations: int = 2000) -> dict[str, Any]:
    """LuminanceServo.update through the bindings, as ibvs-bench --sections photometric times it in C++."""
    overhead = _timer_overhead_ns()
    cases = []
    for w, h in ((160, 120), (320, 240)):
        f = 0.9 * w
        cam = ibvs.CameraModel(px=f, py=f, u0=0.5 * (w - 1), v0=0.5 * (h - 1))
        frames = [_texture(w, h, 0.25 * (k + 1), 0.002 * (k - 4)) for k in range(8)]
        for jac in ("desired", "current"):
            servo = ibvs.LuminanceServo(cam, w, h, jacobian=jac, plane=(0.0, 0.0, 1 / 0.6))
            servo.set_desired(_texture(w, h, 0.0, 0.0))
            upd = servo.update
            r = _time(lambda k, upd=upd: upd(frames[k & 7]), iterations, max(50, iterations // 10), overhead)
            cases.append({"name": f"ibvs LuminanceServo.update J {jac} (LM)", "layout": f"{w}x{h}",
                          "n": servo.pixels, **r})
    return {"benchmark": "ibvs.bench photometric", "version": ibvs.__version__, "iterations": iterations,
            "timer_overhead_ns": overhead, "cases": cases}


def format_photometric(res: dict[str, Any]) -> str:
    lines = [f"photometric, {res['iterations']} calls per case, microseconds per call",
             f"  {'case':<44} {'image':>8} {'pixels':>7} {'median':>9} {'p99':>9} {'max':>9}"]
    for c in res["cases"]:
        lines.append(f"  {c['name']:<44} {c['layout']:>8} {c['n']:>7} {c['median_us']:9.1f} {c['p99_us']:9.1f} "
                     f"{c['max_us']:9.1f}")
    return "\n".join(lines)


def build_parser(prog: str = "python -m ibvs.bench") -> argparse.ArgumentParser:
    """The benchmark's parser; `prog` heads its help and its one-line errors (`ibvs bench` from the ibvs command)."""
    from .cli.args import Parser, number

    from .cli.args import exit_status

    p = Parser(prog=prog, description=__doc__.split("\n\n")[0],
               epilog=exit_status("timed; the table (or the JSON line) printed"))
    p.add_argument("--iterations", type=number(1, 10**8, integer=True), default=20000,
                   help="timed calls per case (1 to 1e8; default 20000)")
    p.add_argument("--n", type=number(1, 10000, integer=True), default=4,
                   help="number of image points (1 to 10000; default 4)")
    p.add_argument("--damping", type=number(0, 1e6, open_lo=True), default=0.01, help="lambda > 0 (default 0.01)")
    p.add_argument("--gain", type=number(0, 1e6, open_lo=True), default=0.5, help="gain > 0 (default 0.5)")
    p.add_argument("--json", action="store_true", help="print one JSON line instead of the table")
    p.add_argument("--vision", action="store_true",
                   help="time the image loop (render, track, detect, servo, image episode; "
                        "needs the vision extra)")
    p.add_argument("--loop", action="store_true",
                   help="time the servo loop's own overhead per frame (ibvs.loop; needs the vision extra)")
    p.add_argument("--photometric", action="store_true",
                   help="time LuminanceServo.update (160x120 and 320x240) instead; --iterations caps at 2000")
    p.add_argument("--natural", action="store_true",
                   help="time the natural-feature trackers (KLT, keypoints) at 640x480 beside OpenCV's calls alone")
    p.add_argument("--frames", type=number(2, 100000, integer=True), default=300,
                   help="frames per vision case (2 to 1e5; default 300)")
    return p


def main(argv: list[str] | None = None, prog: str = "python -m ibvs.bench") -> int:
    """`python -m ibvs.bench [OPTIONS]` (sys.argv[1:] by default): run the benchmark and print its table, or one
    JSON line with --json; --vision times the image loop instead. Returns the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["--"]:  # as forwarded by `ibvs bench -- ...`
        argv = argv[1:]
    args = build_parser(prog).parse_args(argv)
    if args.loop:
        res = run_loop(args.frames)
        print(json.dumps(res, allow_nan=False) if args.json else format_loop(res))
        return 0
    if args.vision:
        res = run_vision(args.frames)
        print(json.dumps(res, allow_nan=False) if args.json else format_vision(res))
        return 0
    if args.natural:
        res = run_natural(min(args.frames, 1000))
        print(json.dumps(res, allow_nan=False) if args.json else format_natural(res))
        return 0
    if args.photometric:
        res = run_photometric(min(args.iterations, 2000))
        print(json.dumps(res) if args.json else format_photometric(res))
        return 0
    res = run(args.iterations, args.n, args.damping, args.gain)
    print(json.dumps(res) if args.json else format_table(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
