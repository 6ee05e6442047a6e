"""One episode of a sweep (run_episode) and the task a worker runs: a batch of them (run_batch)."""

from __future__ import annotations

import math
from typing import Callable, Optional

import numpy as np

import ibvs

from ... import sim
from .. import schemes
from ..scenario import PARAMETERS
from .rows import COLUMNS, INT_COLUMNS
from .spec import SweepSpec, episode_id, samples

# What ibvs.study.sweep re-exports (and documents); the other names here are its own helpers.
__all__ = ["run_episode"]


def run_episode(spec: SweepSpec, index: int, scheme: str, params: Optional[dict] = None,
                factory: Optional[Callable] = None) -> dict:
    """Simulate one (index, scheme) of a sweep and return its row (a dict over COLUMNS)."""
    setup = spec.setup
    p = params if params is not None else samples(spec, [index])[0]
    config = spec.config()
    row = {"id": episode_id(config, index, scheme), "config": config, "index": int(index), "scenario": setup.name,
           "scheme": scheme, **{k: (int(p[k]) if k in INT_COLUMNS else float(p[k])) for k in PARAMETERS},
           "depth": setup.depth, "angle_wrap": setup.angle_wrap}
    start, why = setup.start_outcome(p)
    if start is None:  # no episode: "invalid_start" (target not in view) or "unreachable" (by the robot)
        return {**row, "outcome": why, "frame": -1, "point": -1, "joint": -1, "frames_to_converge": -1,
                **{k: math.nan for k in COLUMNS[COLUMNS.index("time_to_converge"):]}}
    servo = schemes.make(factory or scheme, setup.gain, len(setup.target))
    target = schemes.target_for(factory or scheme, setup.target)  # with the scheme's feature sources, if any
    if isinstance(servo, ibvs.Servo):
        servo.angle_wrap = setup.angle_wrap
    # The noise seed is the episode's, shared by every scheme.
    noise_seed = int(np.random.default_rng([int(spec.seed), int(index), 1]).integers(0, 2**63))
    # klt, keypoints: their image sensor; photometric: its block measured in rendered images
    sensor = schemes.sensor_for(factory or scheme, setup.camera, setup.target)
    camera = setup.camera if sensor is None else sensor.renderer.camera
    camera, target = schemes.dense_target(factory or scheme, camera, target)
    r = sim.run(servo, camera, target, start, setup.goal_for_run(), robot=setup.robot,
                duration=setup.duration, noise=p["noise"], latency=int(p["latency"]), depth=setup.depth,
                seed=noise_seed, tolerance=setup.tolerances()[0], tolerance_px=setup.tolerances()[1],
                depth_scale=p["depth_scale"],
                boundary_margin=setup.boundary_margin, boundary_gain=setup.boundary_gain,
                goal_pose=setup.goal_pose_mode, vision=sensor)
    s, m, h = r.status, r.metrics, r.history
    twist = h.twist[np.isfinite(h.twist).all(axis=1)]
    # the commanded twist's peaks, as before (bit for bit: Metrics.peak_commanded_* skip only NaN norms)
    peak = (float(np.linalg.norm(twist[:, :3], axis=1).max()), float(np.linalg.norm(twist[:, 3:], axis=1).max())) \
        if len(twist) else (math.nan, math.nan)
    dt = 1.0 / setup.camera.fps
    return {**row, "outcome": s.outcome, "frame": s.frame, "point": s.point, "joint": s.joint,
            "frames_to_converge": m.frames_to_converge,
            "time_to_converge": m.frames_to_converge * dt if m.frames_to_converge >= 0 else math.nan,
            "camera_retreat": m.camera_retreat, "path_length": m.path_length, "peak_linear_speed": peak[0],
            "peak_angular_speed": peak[1], "final_translation_error": m.final_translation_error,
            "final_rotation_error": m.final_rotation_error, "peak_camera_linear_speed": m.peak_linear_speed,
            "peak_camera_angular_speed": m.peak_angular_speed}


def run_batch(spec: SweepSpec, jobs: list, factories: Optional[dict] = None) -> list[dict]:
    """Worker task: rows of [(index, scheme), ...]."""
    indices = sorted({i for i, _ in jobs})
    params = dict(zip(indices, samples(spec, indices)))
    return [run_episode(spec, i, s, params[i], (factories or {}).get(s)) for i, s in jobs]


def chunks(jobs: list, size: int) -> list[list]:
    """The jobs in consecutive lists of `size` (the last one shorter): the batches of a sweep."""
    return [jobs[i:i + size] for i in range(0, len(jobs), size)]
