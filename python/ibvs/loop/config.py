"""`ibvs servo CONFIG.toml`: the servo loop's config file, read and checked before anything moves.

Sections (docs/servo-loop.md has every key; docs/servo.toml is a complete example):
  [camera]   ibvs.sim.Camera keywords (px, py, u0, v0, width, height, fps, ...) or from = "afma6";
             optional when the source knows its camera (a bag's camera_info)
  [source]   kind = "render" (the simulator's renderer at the robot's camera pose; its [target]),
             "video" (a file replayed at its rate), "capture" (OpenCV VideoCapture: device index, file or
             GStreamer pipeline), "bag" (a ROS 2 bag's images) or "mujoco" (the physics testbed's camera,
             ibvs.sim.physics.MujocoCamera of the mujoco robot's world) or "franky_scene" (a camera on the
             FR3's hand in franky-sim's own MuJoCo scene, the franky robot's joints: ibvs.robot.franky_scene);
             latency, drop (render)
  [target]   the rendered target (render): points, pose = { t = [...], r_deg = [...] }, as scenario files
  [tracker]  kind = "dots" or "tag", desired_pixels, initial_pixels, tag_ids
  [servo]    scheme, gain, depth, damping, max_linear_speed, max_angular_speed, max_joint_speed,
             lost_timeout, turn
  [robot]    kind = one of ibvs.robot.ROBOTS ("sim", "mujoco", "franky", "ur", "ros2_control") and its
             driver's options (ibvs.robot.open_robot(kind, **options))
  [loop]     rate, duration, watchdog, state_watchdog, late, latency, lag, converge_px, dry_run,
             log, record, rerun, record_images, clock

Every error is a ValueError naming the file, the section and the key (`ibvs servo` prints it as one
line and exits with status 2).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, Dict, Mapping, Optional

import numpy as np

from .servo_loop import LoopOptions

__all__ = ["LOOP_KEYS", "SECTIONS", "SOURCE_KINDS", "LoopConfig", "load", "loop_options", "read"]

#: The sections of a config file.
SECTIONS = ("camera", "source", "target", "tracker", "servo", "robot", "loop")
#: The frame sources a config can name.
SOURCE_KINDS = ("render", "video", "capture", "bag", "mujoco", "franky_scene")
#: The keys of [loop] (LoopOptions' fields, the clock, the signals handled always by the command).
LOOP_KEYS = tuple(f.name for f in fields(LoopOptions) if f.name != "signals") + ("clock",)
#: The clocks [loop] clock can name.
CLOCKS = ("real", "sim", "robot")

_SOURCE_KEYS = {"render": ("kind", "render", "latency", "drop", "seed", "dot_radius", "noise", "blur", "rate",
                           "stop_after"),
                "video": ("kind", "path", "rate"),
                "capture": ("kind", "device", "width", "height", "fps"),
                "bag": ("kind", "path", "image_topic", "camera_info_topic", "replay"),
                "mujoco": ("kind", "rate", "latency"),
                "franky_scene": ("kind", "rate", "dot_radius")}
_TRACKER_KEYS = ("kind", "desired_pixels", "initial_pixels", "tag_ids")
_SERVO_KEYS = ("scheme", "gain", "depth", "damping", "max_linear_speed", "max_angular_speed", "max_joint_speed",
               "lost_timeout", "turn")


def read(path) -> Dict[str, Any]:
    """The TOML document of a config file (ValueError naming the file when unreadable or not TOML)."""
    try:
        import tomllib
    except ImportError:  # Python < 3.11
        import tomli as tomllib
    path = Path(os.fspath(path))
    try:
        with open(path, "rb") as f:
            doc = tomllib.load(f)
    except OSError as e:
        raise ValueError(f"{path}: cannot read it ({e.strerror})") from None
    except tomllib.TOMLDecodeError as e:
        raise ValueError(f"{path}: not valid TOML: {e}") from None
    _keys(doc, SECTIONS, str(path))
    for name in SECTIONS:
        if name in doc and not isinstance(doc[name], Mapping):
            raise ValueError(f"{path}: [{name}] must be a table")
    return doc


def _keys(table: Mapping, allowed, where: str) -> None:
    extra = sorted(set(table) - set(allowed))
    if extra:
        raise ValueError(f"{where}: unknown key {extra[0]!r}; allowed: {', '.join(sorted(allowed))}")


def _number(table: Mapping, key: str, where: str, lo: float = 0.0, hi: float = 1e9, *, open_lo: bool = False,
            integer: bool = False, default=None):
    if key not in table:
        return default
    x = table[key]
    ok = not isinstance(x, bool) and isinstance(x, (int, float)) and (not integer or isinstance(x, int))
    if not ok or not math.isfinite(x) or x < lo or x > hi or (open_lo and x == lo):
        kind = "an integer" if integer else "a number"
        raise ValueError(f"{where} {key}: must be {kind} in {'(' if open_lo else '['}{lo:g}, {hi:g}], got {x!r}")
    return int(x) if integer else float(x)


def _bool(table: Mapping, key: str, where: str, default: bool) -> bool:
    x = table.get(key, default)
    if not isinstance(x, bool):
        raise ValueError(f"{where} {key}: must be true or false, got {x!r}")
    return x


def _path(table: Mapping, key: str, where: str) -> Optional[Path]:
    """An output path, relative to the working directory (as the command line's). Output paths (log,
    record, rerun) are checked for writing by the command (ibvs.cli.servo) before the run."""
    if key not in table:
        return None
    x = table[key]
    if not isinstance(x, str) or not x:
        raise ValueError(f"{where} {key}: must be a path (a non-empty string), got {x!r}")
    return Path(x)


def loop_options(table: Mapping, where: str = "[loop]") -> LoopOptions:
    """LoopOptions of a [loop] table (every value checked: a ValueError naming the key)."""
    if not isinstance(table, Mapping):
        raise ValueError(f"{where} must be a table")
    _keys(table, LOOP_KEYS, where)
    o = LoopOptions(
        rate=_number(table, "rate", where, 0, 1e4, open_lo=True),
        duration=_number(table, "duration", where, 0, 1e7, open_lo=True),
        watchdog=_number(table, "watchdog", where, 0, 3600, open_lo=True, default=0.5),
        state_watchdog=_number(table, "state_watchdog", where, 0, 3600, open_lo=True, default=0.5),
        late=_number(table, "late", where, 0, 3600, open_lo=True),
        latency=_number(table, "latency", where, 0, 10, default=0.0),
        lag=_number(table, "lag", where, 0, 10, default=0.0),
        converge_px=_number(table, "converge_px", where, 0, 1e5, open_lo=True),
        dry_run=_bool(table, "dry_run", where, False),
        log=_path(table, "log", where),
        record=_path(table, "record", where),
        rerun=_path(table, "rerun", where),
        record_images=_bool(table, "record_images", where, False),
    )
    if o.record is not None and o.record.suffix != ".mcap":
        raise ValueError(f"{where} record: must end in .mcap, got {str(o.record)!r}")
    if o.rerun is not None and o.rerun.suffix != ".rrd":
        raise ValueError(f"{where} rerun: must end in .rrd, got {str(o.rerun)!r}")
    clock = table.get("clock", None)
    if clock is not None and clock not in CLOCKS:
        raise ValueError(f"{where} clock: must be one of {', '.join(CLOCKS)}, got {clock!r}")
    return o


def _pixels(x, key: str, where: str, n: Optional[int] = None) -> np.ndarray:
    try:
        a = np.array(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{where} {key}: must be a list of [u, v] pixels, got {x!r}") from None
    if a.ndim == 1 and a.size % 2 == 0:
        a = a.reshape(-1, 2)
    if a.ndim != 2 or a.shape[1] != 2 or len(a) < 3 or not np.isfinite(a).all() or (n is not None and len(a) != n):
        raise ValueError(f"{where} {key}: must be {n or 'N >= 3'} finite [u, v] pixels, got shape {a.shape}")
    return a


def pose_of(table, where: str) -> np.ndarray:
    from .. import sim

    if not isinstance(table, Mapping):
        raise ValueError(f"{where} must be a table {{ t = [x, y, z], r_deg = [rx, ry, rz] }}")
    _keys(table, ("t", "r", "r_deg"), where)
    try:
        if "r_deg" in table:
            return sim.pose(table.get("t", (0, 0, 0)), table["r_deg"], degrees=True)
        return sim.pose(table.get("t", (0, 0, 0)), table.get("r", (0, 0, 0)))
    except (TypeError, ValueError) as e:
        raise ValueError(f"{where}: {e}") from None


@dataclass
class LoopConfig:
    """A checked config file (load()): its tables, the loop's options, the config's directory."""

    path: Path
    doc: Dict[str, Any]
    options: LoopOptions
    clock: str

    @property
    def robot_kind(self) -> str:
        return self.doc["robot"]["kind"]


def load(path) -> LoopConfig:
    """Read and check a config file (no device opened, no robot connected): a LoopConfig, or a ValueError
    naming the file, the section and the key."""
    path = Path(os.fspath(path))
    doc = read(path)
    where = str(path)
    for name in ("source", "tracker", "servo", "robot"):
        if name not in doc:
            raise ValueError(f"{where}: missing [{name}] table")
    src = doc["source"]
    kind = src.get("kind")
    if kind not in SOURCE_KINDS:
        raise ValueError(f"{where} [source] kind: must be one of {', '.join(SOURCE_KINDS)}, got {kind!r}")
    _keys(src, _SOURCE_KEYS[kind], f"{where} [source] ({kind})")
    if kind in ("video", "bag") and not isinstance(src.get("path"), str):
        raise ValueError(f"{where} [source] path: a {kind} source needs the path of its file")
    if kind == "capture":
        dev = src.get("device")
        if isinstance(dev, bool) or not isinstance(dev, (int, str)) or (isinstance(dev, int) and dev < 0):
            raise ValueError(f"{where} [source] device: a camera index >= 0, a file or a GStreamer pipeline, got "
                             f"{dev!r}")
    for key, lo, hi in (("latency", 0, 10), ("drop", 0, 0.99), ("rate", 0, 1e4), ("noise", 0, 255), ("blur", 0, 100)):
        _number(src, key, f"{where} [source]", lo, hi, open_lo=key == "rate")
    if kind in ("render", "franky_scene") and "target" not in doc:
        raise ValueError(f"{where}: a {kind} source needs a [target] table (points, pose)")
    if kind in ("video", "capture") and "camera" not in doc:
        raise ValueError(f"{where}: a {kind} source needs a [camera] table (the camera's intrinsics)")
    tr = doc["tracker"]
    _keys(tr, _TRACKER_KEYS, f"{where} [tracker]")
    if tr.get("kind", "dots") not in ("dots", "tag"):
        raise ValueError(f"{where} [tracker] kind: must be 'dots' or 'tag', got {tr.get('kind')!r}")
    if "desired_pixels" not in tr:
        raise ValueError(f"{where} [tracker] desired_pixels: the goal's pixels are needed")
    desired = _pixels(tr["desired_pixels"], "desired_pixels", f"{where} [tracker]")
    if "initial_pixels" in tr:
        _pixels(tr["initial_pixels"], "initial_pixels", f"{where} [tracker]", len(desired))
    sv = doc["servo"]
    _keys(sv, _SERVO_KEYS, f"{where} [servo]")
    from ..study.schemes import SCHEMES

    scheme = sv.get("scheme", "polar")
    if not isinstance(scheme, str) or scheme not in SCHEMES:
        raise ValueError(f"{where} [servo] scheme: must be one of {', '.join(sorted(SCHEMES))}, got "
                         f"{sv.get('scheme')!r}")
    for key, lo, hi in (("gain", 0, 1e4), ("damping", 0, 1e4), ("max_linear_speed", 0, 100),
                        ("max_angular_speed", 0, 100), ("max_joint_speed", 0, 100), ("lost_timeout", 0, 100)):
        _number(sv, key, f"{where} [servo]", lo, hi, open_lo=key != "damping")
    _number(sv, "turn", f"{where} [servo]", -1.25 * math.pi, 1.25 * math.pi)
    if "turn" in sv and scheme == "partitioned":
        raise ValueError(f"{where} [servo] turn: the partitioned scheme has no consistent angle wrap to choose a way "
                         f"with")
    depth = sv.get("depth", 0.5)
    try:
        z = np.array(depth, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        z = np.array([np.nan])
    if z.size not in (1, len(desired)) or not np.isfinite(z).all() or not (z > 0).all():
        raise ValueError(f"{where} [servo] depth: one or {len(desired)} finite depths > 0 (metres), got {depth!r}")
    rb = doc["robot"]
    if not isinstance(rb.get("kind"), str):
        raise ValueError(f"{where} [robot] kind: the driver's name is needed (ibvs.robot.ROBOTS), got "
                         f"{rb.get('kind')!r}")
    lp = doc.get("loop", {})
    options = loop_options(lp, f"{where} [loop]")
    clock = lp.get("clock") or ("sim" if rb["kind"] == "sim" and kind == "render" else "robot")
    return LoopConfig(path, doc, options, clock)
