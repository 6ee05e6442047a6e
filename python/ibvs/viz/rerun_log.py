"""Runs in Rerun (rerun-sdk, the `rerun` extra): ibvs.viz.rerun(result_or_results, recording=None, path=None).

What is logged, per run, under runs/<label>/ (entity paths; timelines "time" (s, the simulated time)
and "frame"):
  image/frame        rr.Image: the frame the tracker saw (image episodes whose sensor kept its frames)
  image/features     rr.Points2D: the measured pixels of each frame (History.measured)
  image/desired      rr.Points2D, static: the goal's measured pixels (Result.measured_desired)
  world/target       rr.Points3D, static: the target's points
  world/camera       rr.Transform3D (world <- camera) each frame and an rr.Pinhole (the frustum; pixel
                     cameras), static
  world/path         rr.LineStrips3D, static: the camera centre's path
  world/mount        rr.Transform3D each frame: a robot's mount frame (world <- camera eMc^-1)
  world/arm          rr.LineStrips3D each frame: a URDF arm's joint origins (Pinocchio), base to tip
  twist/Tx ... wz    rr.Scalars: the commanded twist (m/s, rad/s)
  error_norm         rr.Scalars: the servo's error norm
  sigma_min          rr.Scalars: the smallest singular value of the interaction matrix
Frames the episode did not compute (NaN) are not logged.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from .drawing import as_results, is_pixel_camera, run_labels

# What ibvs.viz re-exports (and documents); the other names here are its own helpers.
__all__ = ["rerun"]

#: The twist components' entity names (under twist/).
TWIST_NAMES = ("Tx", "Ty", "Tz", "wx", "wy", "wz")


def rerun_module():
    """The rerun module, or an ImportError saying how to install rerun-sdk."""
    try:
        import rerun as rr
    except ImportError as e:
        raise ImportError('ibvs.viz.rerun needs rerun-sdk: pip install ".[rerun]" from the ibvs repository root') \
            from e
    return rr


def _entity(label: str) -> str:
    """A label as one entity path part (letters, digits, - and _)."""
    return re.sub(r"[^A-Za-z0-9_-]+", "_", label).strip("_") or "run"


def _arm_points(robot, q) -> Optional[np.ndarray]:
    """The world positions of a URDF arm's joint origins at q (None for other robots)."""
    model = getattr(robot, "model", None)
    if model is None:
        return None
    import pinocchio as pin

    data = model.createData()
    pin.forwardKinematics(model, data, np.asarray(q, dtype=np.float64))
    return np.array([data.oMi[j].translation for j in range(model.njoints)])


def _log_run(rr, rec, root: str, r) -> None:
    h = r.history
    cam = r.camera
    frames = list(getattr(r.sensor, "frames", None) or [])
    rec.log(f"{root}/world/path", rr.LineStrips3D([h.pose[:, :3, 3]]), static=True)
    if r.target is not None:
        world = np.asarray(r.target.world_points() if callable(getattr(r.target, "world_points", None))
                           else r.target.points)
        world = world.T if world.shape[0] == 3 and world.shape[1] != 3 else world
        rec.log(f"{root}/world/target", rr.Points3D(world, radii=0.005), static=True)
    if cam is not None and is_pixel_camera(cam):
        rec.log(f"{root}/world/camera", rr.Pinhole(image_from_camera=cam.K, resolution=[cam.width, cam.height],
                                                    image_plane_distance=0.1), static=True)
    if r.measured_desired is not None:
        rec.log(f"{root}/image/desired", rr.Points2D(r.measured_desired, radii=4.0, colors=[255, 60, 60]),
                static=True)
    mount_inv = None if r.robot is None else np.linalg.inv(np.asarray(r.robot.mount))
    for k in range(len(h)):
        rec.set_time("frame", sequence=k)
        rec.set_time("time", duration=float(h.time[k]))
        T = h.pose[k]
        rec.log(f"{root}/world/camera", rr.Transform3D(translation=T[:3, 3], mat3x3=T[:3, :3]))
        if k < len(frames):
            rec.log(f"{root}/image/frame", rr.Image(frames[k]))
        if h.measured is not None and np.isfinite(h.measured[k]).all():
            rec.log(f"{root}/image/features", rr.Points2D(h.measured[k], radii=3.0, colors=[60, 255, 60]))
        if np.isfinite(h.error_norm[k]):
            for name, x in zip(TWIST_NAMES, h.twist[k]):
                rec.log(f"{root}/twist/{name}", rr.Scalars(float(x)))
            rec.log(f"{root}/error_norm", rr.Scalars(float(h.error_norm[k])))
        if np.isfinite(h.sigma_min[k]):
            rec.log(f"{root}/sigma_min", rr.Scalars(float(h.sigma_min[k])))
        if mount_inv is not None:
            M = T @ mount_inv
            rec.log(f"{root}/world/mount", rr.Transform3D(translation=M[:3, 3], mat3x3=M[:3, :3]))
            if h.q is not None:
                pts = _arm_points(r.robot, h.q[k])
                if pts is not None:
                    rec.log(f"{root}/world/arm", rr.LineStrips3D([pts]))


def rerun(results, recording=None, path=None, labels: Optional[Sequence[str]] = None):
    """Log one ibvs.sim.Result or several into Rerun (see the module docstring for the entity paths):
    into `recording` (an rr.RecordingStream; default a new one, application id "ibvs"), and, with
    `path`, saved as an .rrd file (written beside it and renamed when complete). labels: one per run
    (default their titles). Returns the RecordingStream (rr.notebook_show, .spawn() to look at it)."""
    rr = rerun_module()
    runs = as_results(results)
    names = [_entity(x) for x in run_labels(runs, labels)]
    names = [f"{n}_{i}" if names.count(n) > 1 else n for i, n in enumerate(names)]
    rec = rr.RecordingStream("ibvs") if recording is None else recording
    tmp = None
    if path is not None:
        path = Path(path)
        if path.suffix != ".rrd":
            raise ValueError(f"path must end in .rrd, got {str(path)!r}")
        tmp = path.with_name(f".{path.name}.partial-{os.getpid()}")
        rec.save(str(tmp))
    try:
        for name, r in zip(names, runs):
            _log_run(rr, rec, f"runs/{name}", r)
        if tmp is not None:
            rec.flush()
            rec.disconnect()
            os.replace(tmp, path)
    finally:
        if tmp is not None and tmp.exists():
            tmp.unlink()
    return rec
