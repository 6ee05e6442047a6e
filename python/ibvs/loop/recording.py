"""What the servo loop writes: a JSON-lines log per run, and optionally an MCAP bag (ibvs.ros's BagWriter,
the topics of ibvs.ros.TOPICS) and a Rerun recording (.rrd, the entity names of ibvs.viz.rerun).

The log (one JSON object per line, each line flushed as written, so a killed run leaves what it did):
  {"kind": "start", "config": {...}, "clock": ...}
  {"kind": "frame", "index", "stamp", "t", "latency", "overhead", "late", "state", "error_norm",
   "pixels", "twist", "qdot", "sent", "clamped", "reason"}      one per frame
  {"kind": "event", "t", "what"}                                  watchdog, lost features, robot error...
  {"kind": "end", "outcome", "reason", "timing": {...}}          the last line
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any, Optional

import numpy as np

__all__ = ["BagRecording", "LoopLog", "RerunRecording"]


def _jsonable(x: Any) -> Any:
    if isinstance(x, np.ndarray):
        if x.dtype.kind == "f" and not np.isfinite(x).all():
            return [_jsonable(v) for v in x.tolist()]
        return x.tolist()  # finite numbers as they are (the fast path: a frame's arrays)
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else None  # JSON has no NaN
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.bool_,)):
        return bool(x)
    return x


class LoopLog:
    """A JSON-lines log at path (None: nothing written)."""

    def __init__(self, path: Optional[os.PathLike]):
        self.path = None if path is None else Path(path)
        self._f = None if self.path is None else open(self.path, "w", encoding="utf-8")

    def write(self, kind: str, **fields) -> None:
        if self._f is None:
            return
        self._f.write(json.dumps(_jsonable({"kind": kind, **fields}), allow_nan=False) + "\n")
        self._f.flush()

    def close(self) -> None:
        f, self._f = self._f, None
        if f is not None:
            try:
                f.close()
            except OSError:
                pass


class BagRecording:
    """The run as a ROS 2 bag (MCAP; ibvs.ros.BagWriter: written atomically, complete on close()): the
    camera_info once, per frame the tracked pixels (/ibvs/features), the commanded twist (/ibvs/cmd_twist),
    the joint state with the commanded joint velocities (/joint_states) and, with images=True, the image
    (/camera/image_raw), each stamped with the frame's capture time."""

    def __init__(self, path, camera=None, joint_names=None, images: bool = False):
        from .. import ros

        self.ros, self.images = ros, bool(images)
        self.ts = ros.types.typestore()
        self.bag = ros.BagWriter(path, self.ts).__enter__()
        self.joint_names = list(joint_names or [])
        self._info = None if camera is None else ros.camera_info(camera, self.ts, "camera_optical_frame")
        self._closed = False

    def frame(self, stamp: float, image, pixels, twist, q, qdot) -> None:
        ros, ts, topics = self.ros, self.ts, self.ros.TOPICS
        ns = max(0, ros.types.to_ns(stamp))
        if self._info is not None:
            self._info.header.stamp = ros.types.time_msg(ts, ns)
            self.bag.write(topics["camera_info"], self._info, ns)
        if self.images and image is not None:
            self.bag.write(topics["image"], ros.image_msg(np.ascontiguousarray(image), ts, "camera_optical_frame",
                                                          ns), ns)
        if pixels is not None:
            self.bag.write(topics["features"], ros.float64_array(np.asarray(pixels), ts, "points"), ns)
        if twist is not None:
            self.bag.write(topics["twist"], ros.twist_msg(np.asarray(twist), ts, "camera_optical_frame", ns), ns)
        if q is not None:
            names = self.joint_names or [f"joint{i + 1}" for i in range(len(q))]
            self.bag.write(topics["joint_states"], ros.types.make(
                ts, "sensor_msgs/msg/JointState", header=ros.types.header(ts, ns, "world"), name=names,
                position=np.array(q, dtype=np.float64), velocity=np.array(qdot if qdot is not None else
                                                                          np.zeros(len(q)), dtype=np.float64),
                effort=np.zeros(0)), ns)

    def close(self) -> None:
        """Finish the bag (what was recorded so far, whatever ended the run)."""
        if not self._closed:
            self._closed = True
            self.bag.__exit__(None, None, None)


class RerunRecording:
    """The run in Rerun, saved as an .rrd file (written beside it, renamed when closed): under runs/servo/,
    image/frame (with images=True), image/features, image/desired, twist/Tx ... wz, error_norm,
    latency_ms, on the timelines "time" (the capture time) and "frame"."""

    def __init__(self, path, desired_pixels=None, images: bool = False, label: str = "servo"):
        from ..viz.rerun_log import TWIST_NAMES, rerun_module

        self.rr, self.names = rerun_module(), TWIST_NAMES
        self.path = Path(path)
        if self.path.suffix != ".rrd":
            raise ValueError(f"rerun: the path must end in .rrd, got {str(self.path)!r}")
        self.tmp = self.path.with_name(f".{self.path.name}.partial-{os.getpid()}")
        self.rec = self.rr.RecordingStream("ibvs")
        self.rec.save(str(self.tmp))
        self.root, self.images = f"runs/{label}", bool(images)
        if desired_pixels is not None:
            self.rec.log(f"{self.root}/image/desired", self.rr.Points2D(np.asarray(desired_pixels), radii=4.0,
                                                                         colors=[255, 60, 60]), static=True)
        self._closed = False

    def frame(self, index: int, stamp: float, image, pixels, twist, error_norm: float, latency: float) -> None:
        rr, rec, root = self.rr, self.rec, self.root
        rec.set_time("frame", sequence=int(index))
        rec.set_time("time", duration=float(stamp))
        if self.images and image is not None:
            rec.log(f"{root}/image/frame", rr.Image(image))
        if pixels is not None and np.isfinite(pixels).all():
            rec.log(f"{root}/image/features", rr.Points2D(np.asarray(pixels), radii=3.0, colors=[60, 255, 60]))
        if twist is not None:
            for name, x in zip(self.names, twist):
                rec.log(f"{root}/twist/{name}", rr.Scalars(float(x)))
        if math.isfinite(error_norm):
            rec.log(f"{root}/error_norm", rr.Scalars(float(error_norm)))
        rec.log(f"{root}/latency_ms", rr.Scalars(float(latency) * 1e3))

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            self.rec.flush()
            self.rec.disconnect()
            os.replace(self.tmp, self.path)
        finally:
            if self.tmp.exists():
                self.tmp.unlink()
