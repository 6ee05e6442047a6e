"""ibvs.sweep: convergence-basin studies at scale, one row per simulated episode.

    import ibvs.sweep as sw
    rows = sw.sweep("sweep.csv", episodes=1000, seed=0)         # all local cores
    table = sw.aggregate(rows)                                   # per scheme and rotation bin
    print(sw.format_table(table))
    sw.figure(table, "sweep.png")                                # needs ibvs[plot]

or on the command line `ibvs sweep --out sweep.csv --episodes 1000 --seed 0`.

Each episode index i draws a start pose (rotation about the optical axis, tilt, lateral
and depth offsets from the goal, in the goal camera's frame), a pixel-noise level and a
depth error (a factor on the depth given to the controller) from its own generator
numpy.random.default_rng([seed, i]) -- or takes them from a grid -- and runs it with
every scheme: the same start, noise seed and depth error for every scheme, so the
schemes are compared pair-wise. Every row has a stable id (config hash, index,
scheme); re-running with the same output file skips the ids already in it, so an
interrupted sweep resumes and a sweep can be extended (more episodes, more schemes).

Local runs use a ProcessPoolExecutor (many episodes per task: an episode takes about
a millisecond of C++); `scheduler=` (an address or a dask.distributed Client) sends
the same tasks to Dask's distributed scheduler (pip install "ibvs[distributed]").
Rows are deterministic, so the tables of both paths are identical.

Schemes: SCHEMES maps a name to a factory gain -> servo (an ibvs.Servo or an
ibvs.PartitionedServo: whatever ibvs.sim.run accepts). Add more with register_scheme();
for process pools the factory must be picklable (a module-level function or
functools.partial of one).
"""

from __future__ import annotations

import concurrent.futures as cf
import csv
import functools
import hashlib
import itertools
import json
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Optional, Sequence, Union

import numpy as np

import ibvs
from ibvs import sim

__all__ = [
    "COLUMNS",
    "DEFAULT_RANGES",
    "PARAMETERS",
    "SCHEMES",
    "SweepSpec",
    "aggregate",
    "episode_id",
    "figure",
    "format_table",
    "load",
    "register_scheme",
    "run_episode",
    "samples",
    "sweep",
]

# --------------------------------------------------------------------------- schemes


def _paper_servo(name: str, gain: float):
    from .reproduce import SCHEMES as LAYOUTS

    return ibvs.Servo(LAYOUTS[name](), gain=gain, damping=0.0)


#: Scheme name -> factory(gain) -> servo. The paper's four, the core's newer ones below;
#: register_scheme() adds more.
SCHEMES: dict[str, Callable[[float], Any]] = {
    name: functools.partial(_paper_servo, name) for name in ("cartesian", "polar", "hybrid", "stacked")
}


def _cylindrical_servo(gain: float):
    return ibvs.Servo(ibvs.Layout.cylindrical(4), gain=gain, damping=0.0)


def _automatic_servo(gain: float):
    return ibvs.Servo.automatic_hybrid(4, gain=gain)


def _partitioned_servo(gain: float):
    # Corke & Hutchinson 2001: wz from the angle of the segment from point 0 to point 1,
    # Tz from the square root of the polygon's area, the other four DOF Cartesian.
    return ibvs.PartitionedServo(4, gain=gain)


# Schemes beyond the paper, when the core has them: the (r, r theta) features of Iwatsuki &
# Okiyama, the automatic hybrid (polar away from the principal point, Cartesian near it)
# and the partitioned law of Corke & Hutchinson (run by the simulator as a PartitionedServo).
if hasattr(ibvs.Layout, "cylindrical"):
    SCHEMES["cylindrical"] = _cylindrical_servo
if hasattr(ibvs.Servo, "automatic_hybrid"):
    SCHEMES["automatic"] = _automatic_servo
SCHEMES["partitioned"] = _partitioned_servo


def register_scheme(name: str, factory: Callable[[float], Any], *, replace: bool = False) -> None:
    """Add a scheme: factory(gain) returns a servo for the four-point target (anything
    ibvs.sim.run accepts as servo). Raises ValueError if the name exists (unless replace)."""
    if not isinstance(name, str) or not name or any(c in name for c in ",: \t\n"):
        raise ValueError(f"name must be a non-empty string without ',', ':' or spaces, got {name!r}")
    if not callable(factory):
        raise TypeError(f"factory must be callable (gain -> servo), got {type(factory).__name__}")
    if name in SCHEMES and not replace:
        raise ValueError(f"name: scheme {name!r} is already registered (pass replace=True)")
    SCHEMES[name] = factory


# --------------------------------------------------------------------------- parameters

#: The sampled parameters of an episode: start offset from the goal in the goal camera's
#: frame (rotation rz about the optical axis, tilt about an axis in the image plane at
#: tilt_dir from x, translation tx, ty, tz in metres), measurement noise (measurement
#: units: normalised for the free camera, pixels on the gantry) and depth_scale (factor on
#: the depth given to the controller).
PARAMETERS = ("rz_deg", "tilt_deg", "tilt_dir_deg", "tx", "ty", "tz", "noise", "depth_scale")

#: Uniform ranges (lo, hi) per world; lo == hi fixes a parameter.
DEFAULT_RANGES = {
    "free": {
        "rz_deg": (0.0, 180.0), "tilt_deg": (0.0, 10.0), "tilt_dir_deg": (0.0, 360.0),
        "tx": (-0.2, 0.2), "ty": (-0.2, 0.2), "tz": (-0.5, 0.5),
        "noise": (0.0, 0.0), "depth_scale": (1.0, 1.0),
    },
    "gantry": {
        "rz_deg": (0.0, 180.0), "tilt_deg": (0.0, 8.0), "tilt_dir_deg": (0.0, 360.0),
        "tx": (-0.04, 0.04), "ty": (-0.04, 0.04), "tz": (-0.1, 0.1),
        "noise": (0.0, 0.0), "depth_scale": (1.0, 1.0),
    },
}
_DEFAULTS = {"rz_deg": 0.0, "tilt_deg": 0.0, "tilt_dir_deg": 0.0, "tx": 0.0, "ty": 0.0, "tz": 0.0,
             "noise": 0.0, "depth_scale": 1.0}

#: Control settings per world (those of `ibvs reproduce`).
GAIN = {"free": 1.0, "gantry": 2.0}
DURATION = {"free": 20.0, "gantry": 15.0}
DEPTH = {"free": "exact", "gantry": "pose"}
DEPTH_MODES = ("exact", "pose", "desired", "estimated")

#: Columns of the CSV, in order.
COLUMNS = (
    "id", "config", "index", "world", "scheme", *PARAMETERS, "depth", "outcome", "frame", "point", "joint",
    "frames_to_converge", "camera_retreat", "path_length", "final_translation_error", "final_rotation_error",
)
_INT = {"index", "frame", "point", "joint", "frames_to_converge"}
_STR = {"id", "config", "world", "scheme", "depth", "outcome"}


@dataclass(frozen=True)
class SweepSpec:
    """Everything that determines the rows (the config hash covers all but episodes/schemes)."""

    world: str = "free"
    seed: int = 0
    episodes: int = 100
    schemes: tuple = ("cartesian", "polar", "hybrid", "stacked")
    ranges: Optional[Mapping[str, tuple]] = None  # random mode
    grid: Optional[Mapping[str, Sequence[float]]] = None  # grid mode (episodes = grid size)
    gain: Optional[float] = None
    duration: Optional[float] = None
    depth: Optional[str] = None
    tolerance: float = 1e-5
    boundary_margin: float = 0.0
    boundary_gain: float = 0.1

    def validate(self) -> "SweepSpec":
        if self.world not in DEFAULT_RANGES:
            raise ValueError(f"world must be one of {sorted(DEFAULT_RANGES)}, got {self.world!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise ValueError(f"seed must be a non-negative int, got {self.seed!r}")
        if isinstance(self.episodes, bool) or not isinstance(self.episodes, (int, np.integer)) or self.episodes < 0:
            raise ValueError(f"episodes must be a non-negative int, got {self.episodes!r}")
        if isinstance(self.schemes, str) or not self.schemes:
            raise ValueError(f"schemes must be a non-empty sequence of names, got {self.schemes!r}")
        for s in self.schemes:
            if s not in SCHEMES:
                raise ValueError(f"schemes: unknown scheme {s!r}; registered: {sorted(SCHEMES)}")
        if len(set(self.schemes)) != len(self.schemes):
            raise ValueError(f"schemes: duplicate names in {list(self.schemes)}")
        if self.ranges is not None and self.grid is not None:
            raise ValueError("ranges and grid: give one or the other")
        for name, (lo, hi) in (self.ranges or {}).items():
            if name not in PARAMETERS:
                raise ValueError(f"ranges: unknown parameter {name!r}; choose from {PARAMETERS}")
            if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
                raise ValueError(f"ranges: {name} needs finite lo <= hi, got ({lo}, {hi})")
        for name, values in (self.grid or {}).items():
            if name not in PARAMETERS:
                raise ValueError(f"grid: unknown parameter {name!r}; choose from {PARAMETERS}")
            if len(values) == 0 or not all(math.isfinite(float(v)) for v in values):
                raise ValueError(f"grid: {name} needs at least one finite value")
        lims = {**DEFAULT_RANGES[self.world], **(self.ranges or {})}
        for name, values in (self.grid or {}).items():
            lims[name] = (min(values), max(values))
        if lims["noise"][0] < 0:
            raise ValueError("noise must be >= 0")
        if lims["depth_scale"][0] <= 0:
            raise ValueError("depth_scale must be > 0")
        if self.depth is not None and self.depth not in DEPTH_MODES:
            raise ValueError(f"depth must be one of {DEPTH_MODES}, got {self.depth!r}")
        for name in ("gain", "duration"):
            x = getattr(self, name)
            if x is not None and not (isinstance(x, (int, float)) and math.isfinite(x) and x > 0):
                raise ValueError(f"{name} must be finite and > 0, got {x!r}")
        if not (self.tolerance >= 0):
            raise ValueError(f"tolerance must be >= 0, got {self.tolerance!r}")
        if not (self.boundary_margin >= 0 and self.boundary_gain >= 0):
            raise ValueError("boundary_margin and boundary_gain must be >= 0")
        return self

    @property
    def size(self) -> int:
        """Number of start set-ups (grid size in grid mode)."""
        if self.grid is not None:
            return int(np.prod([len(v) for v in self.grid.values()]))
        return int(self.episodes)

    def settings(self) -> dict:
        """The resolved control settings."""
        return {
            "gain": float(self.gain if self.gain is not None else GAIN[self.world]),
            "duration": float(self.duration if self.duration is not None else DURATION[self.world]),
            "depth": self.depth if self.depth is not None else DEPTH[self.world],
            "tolerance": float(self.tolerance),
            "boundary_margin": float(self.boundary_margin),
            "boundary_gain": float(self.boundary_gain),
        }

    def config(self) -> str:
        """Hash of what determines each episode (not the episode count or the schemes)."""
        key = {
            "world": self.world, "seed": int(self.seed), **self.settings(),
            "ranges": None if self.grid is not None else {k: list(map(float, v)) for k, v in
                                                          sorted({**DEFAULT_RANGES[self.world],
                                                                  **(self.ranges or {})}.items())},
            "grid": None if self.grid is None else {k: list(map(float, v)) for k, v in sorted(self.grid.items())},
        }
        return hashlib.sha1(json.dumps(key, sort_keys=True).encode()).hexdigest()[:10]


def samples(spec: SweepSpec, indices: Optional[Iterable[int]] = None) -> list[dict]:
    """The parameters of the given episode indices (default: all). Index i depends only on
    (seed, i) in random mode, on its position in the grid in grid mode."""
    idx = range(spec.size) if indices is None else indices
    out = []
    if spec.grid is not None:
        names = list(spec.grid)
        combos = list(itertools.product(*[[float(v) for v in spec.grid[n]] for n in names]))
        for i in idx:
            out.append({**_DEFAULTS, **dict(zip(names, combos[i]))})
        return out
    ranges = {**DEFAULT_RANGES[spec.world], **(spec.ranges or {})}
    for i in idx:
        rng = np.random.default_rng([int(spec.seed), int(i)])
        u = rng.random(len(PARAMETERS))
        out.append({p: float(ranges[p][0] + u[k] * (ranges[p][1] - ranges[p][0])) for k, p in enumerate(PARAMETERS)})
    return out


def episode_id(config: str, index: int, scheme: str) -> str:
    return f"{config}:{index}:{scheme}"


# --------------------------------------------------------------------------- one episode


@functools.lru_cache(maxsize=4)
def _world(world: str):
    """(camera, target, goal, robot or None) of a world."""
    if world == "free":
        c = sim.cases.z_rotation()
        return c.camera, c.target, np.eye(4), None
    c = sim.cases.gantry_general_motion()
    return c.camera, c.target, np.asarray(c.goal), c.robot


def _start(world: str, p: dict):
    """Start (pose or joints) for parameters p, or None if it is unreachable or the target not fully in view."""
    camera, target, goal, robot = _world(world)
    tilt, d = math.radians(p["tilt_deg"]), math.radians(p["tilt_dir_deg"])
    offset = sim.pose(t=(p["tx"], p["ty"], p["tz"]), r=(tilt * math.cos(d), tilt * math.sin(d), math.radians(p["rz_deg"])))
    goal_pose = goal if robot is None else robot.camera(goal)
    start_pose = goal_pose @ offset
    T_cw = np.linalg.inv(start_pose)
    P = np.asarray(target.world_points()) @ T_cw[:3, :3].T + T_cw[:3, 3]
    if np.any(P[:, 2] <= 1e-3):
        return None
    m = np.asarray(camera.project(P[:, :2] / P[:, 2:]))
    u0, u1, v0, v1 = camera.bounds
    if np.any((m[:, 0] < u0) | (m[:, 0] > u1) | (m[:, 1] < v0) | (m[:, 1] > v1)):
        return None
    if robot is None:
        return start_pose
    try:
        return sim.cases.solve_joints(robot, start_pose, goal)
    except ValueError:
        return None


def run_episode(spec: SweepSpec, index: int, scheme: str, params: Optional[dict] = None,
                factory: Optional[Callable] = None) -> dict:
    """Simulate one (index, scheme) of a sweep and return its row (a dict over COLUMNS)."""
    p = params if params is not None else samples(spec, [index])[0]
    st = spec.settings()
    config = spec.config()
    row = {"id": episode_id(config, index, scheme), "config": config, "index": int(index), "world": spec.world,
           "scheme": scheme, **{k: float(p[k]) for k in PARAMETERS}, "depth": st["depth"]}
    start = _start(spec.world, p)
    if start is None:
        return {**row, "outcome": "invalid_start", "frame": -1, "point": -1, "joint": -1, "frames_to_converge": -1,
                "camera_retreat": math.nan, "path_length": math.nan, "final_translation_error": math.nan,
                "final_rotation_error": math.nan}
    camera, target, goal, robot = _world(spec.world)
    servo = (factory or SCHEMES[scheme])(st["gain"])
    # The noise seed is the episode's, shared by every scheme.
    noise_seed = int(np.random.default_rng([int(spec.seed), int(index), 1]).integers(0, 2**63))
    r = sim.run(servo, camera, target, start, goal, robot=robot, duration=st["duration"], noise=p["noise"],
                depth=st["depth"], seed=noise_seed, tolerance=st["tolerance"], depth_scale=p["depth_scale"],
                boundary_margin=st["boundary_margin"], boundary_gain=st["boundary_gain"])
    s, m = r.status, r.metrics
    return {**row, "outcome": s.outcome, "frame": s.frame, "point": s.point, "joint": s.joint,
            "frames_to_converge": m.frames_to_converge, "camera_retreat": m.camera_retreat,
            "path_length": m.path_length, "final_translation_error": m.final_translation_error,
            "final_rotation_error": m.final_rotation_error}


def _run_batch(spec: SweepSpec, jobs: list, factories: Optional[dict] = None) -> list[dict]:
    """Worker task: rows of [(index, scheme), ...]."""
    params = dict(zip(sorted({i for i, _ in jobs}), samples(spec, sorted({i for i, _ in jobs}))))
    return [run_episode(spec, i, s, params[i], (factories or {}).get(s)) for i, s in jobs]


# --------------------------------------------------------------------------- CSV


def _format(name: str, x) -> str:
    if name in _STR or name in _INT:
        return str(x)
    return repr(float(x))


def _parse(row: dict) -> dict:
    out = {}
    for k in COLUMNS:
        v = row[k]
        out[k] = v if k in _STR else int(v) if k in _INT else float(v)
    return out


def load(path: Union[str, os.PathLike], config: Optional[str] = None) -> list[dict]:
    """Rows of a sweep CSV (optionally of one config), sorted by (index, scheme); an
    incomplete last line (an interrupted write) is ignored."""
    path = Path(path)
    if not path.exists():
        return []
    rows = {}
    with open(path, newline="") as f:
        text = f.read()
    if text and not text.endswith("\n"):
        text = text[: text.rfind("\n") + 1]
    reader = csv.DictReader(text.splitlines())
    if reader.fieldnames is not None and tuple(reader.fieldnames) != COLUMNS:
        raise ValueError(f"out: {path} is not an ibvs sweep file (columns {reader.fieldnames})")
    for raw in reader:
        if None in raw.values() or None in raw:
            continue
        r = _parse(raw)
        if config is None or r["config"] == config:
            rows[r["id"]] = r
    return sorted(rows.values(), key=lambda r: (r["config"], r["index"], r["scheme"]))


class _Writer:
    """Appends rows to the CSV, one flushed line each (after cutting a torn last line)."""

    def __init__(self, path: Optional[Path]):
        self.f = None
        if path is None:
            return
        path.parent.mkdir(parents=True, exist_ok=True)
        if path.exists() and path.stat().st_size > 0:
            with open(path, "rb+") as f:
                data = f.read()
                if not data.endswith(b"\n"):
                    f.truncate(data.rfind(b"\n") + 1)
        new = not path.exists() or path.stat().st_size == 0
        self.f = open(path, "a", newline="")
        self.w = csv.writer(self.f, lineterminator="\n")
        if new:
            self.w.writerow(COLUMNS)
            self.f.flush()

    def write(self, rows: list[dict]) -> None:
        if self.f is not None:
            for r in rows:
                self.w.writerow([_format(c, r[c]) for c in COLUMNS])
            self.f.flush()

    def close(self) -> None:
        if self.f is not None:
            self.f.close()


# --------------------------------------------------------------------------- progress


class _Progress:
    def __init__(self, total: int, done: int, enabled: bool, stream=None):
        self.total, self.done, self.enabled = total, done, enabled and total > 0
        self.stream = stream or sys.stderr
        self.t0 = time.perf_counter()
        self.start = done
        self.last = 0.0
        self.bar = None
        if self.enabled:
            try:
                from tqdm import tqdm  # optional

                self.bar = tqdm(total=total, initial=done, unit="ep", file=self.stream, desc="sweep")
            except ImportError:
                pass

    def update(self, n: int) -> None:
        self.done += n
        if not self.enabled:
            return
        if self.bar is not None:
            self.bar.update(n)
            return
        now = time.perf_counter()
        if now - self.last < 0.2 and self.done < self.total:
            return
        self.last = now
        rate = (self.done - self.start) / max(now - self.t0, 1e-9)
        eta = (self.total - self.done) / rate if rate > 0 else float("inf")
        width = 30
        fill = int(width * self.done / self.total)
        print(f"\rsweep [{'#' * fill}{'.' * (width - fill)}] {self.done}/{self.total} episodes"
              f"  {rate:.0f} ep/s  eta {eta:.0f} s ", end="", file=self.stream, flush=True)

    def close(self) -> None:
        if not self.enabled:
            return
        if self.bar is not None:
            self.bar.close()
        else:
            print(file=self.stream, flush=True)


# --------------------------------------------------------------------------- the sweep


def _chunks(jobs: list, size: int) -> list[list]:
    return [jobs[i:i + size] for i in range(0, len(jobs), size)]


def sweep(
    out: Union[str, os.PathLike, None] = None,
    *,
    episodes: int = 100,
    seed: int = 0,
    schemes: Optional[Sequence[str]] = None,
    world: str = "free",
    ranges: Optional[Mapping[str, tuple]] = None,
    grid: Optional[Mapping[str, Sequence[float]]] = None,
    gain: Optional[float] = None,
    duration: Optional[float] = None,
    depth: Optional[str] = None,
    tolerance: float = 1e-5,
    boundary_margin: float = 0.0,
    boundary_gain: float = 0.1,
    jobs: Optional[int] = None,
    batch: Optional[int] = None,
    scheduler: Any = None,
    progress: bool = True,
    limit: Optional[int] = None,
) -> list[dict]:
    """Run a sweep; returns its rows (dicts over COLUMNS) sorted by (index, scheme).

    out: CSV file (rows appended as they finish; rows already in it are skipped) or None.
    episodes: number of random start set-ups (ignored with grid); seed: their seed.
    schemes: names in SCHEMES (default: all registered). world: "free" or "gantry".
    ranges: {parameter: (lo, hi)} overriding DEFAULT_RANGES[world] (uniform sampling).
    grid: {parameter: values}: every combination instead of random samples.
    gain, duration, depth, tolerance: control settings (defaults per world: GAIN,
        DURATION, DEPTH); boundary_margin / boundary_gain: see ibvs.sim.run.
    jobs: local worker processes (default: os.cpu_count(); 1 = in this process).
    batch: episodes per task (default: about 4 tasks per worker, at most 256).
    scheduler: a Dask scheduler address or a dask.distributed Client: run there instead.
    progress: a progress bar on stderr (tqdm if installed).
    limit: run at most this many new episodes (then stop, as if interrupted).
    """
    spec = SweepSpec(world=world, seed=seed, episodes=episodes,
                     schemes=tuple(schemes) if schemes is not None else tuple(SCHEMES), ranges=ranges, grid=grid,
                     gain=gain, duration=duration, depth=depth, tolerance=tolerance,
                     boundary_margin=boundary_margin, boundary_gain=boundary_gain).validate()
    if jobs is not None and (isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1):
        raise ValueError(f"jobs must be an int >= 1, got {jobs!r}")
    if batch is not None and (isinstance(batch, bool) or not isinstance(batch, int) or batch < 1):
        raise ValueError(f"batch must be an int >= 1, got {batch!r}")
    if limit is not None and (isinstance(limit, bool) or not isinstance(limit, int) or limit < 0):
        raise ValueError(f"limit must be an int >= 0, got {limit!r}")
    path = Path(out) if out is not None else None
    config = spec.config()
    existing = {r["id"]: r for r in load(path, config)} if path is not None else {}
    wanted = [(i, s) for i in range(spec.size) for s in spec.schemes]
    todo = [(i, s) for i, s in wanted if episode_id(config, i, s) not in existing]
    if limit is not None:
        todo = todo[:limit]
    factories = {s: SCHEMES[s] for s in spec.schemes}
    rows = dict(existing)
    writer = _Writer(path)
    bar = _Progress(len(wanted), len(wanted) - len(todo) if limit is None else len(existing), progress)
    n_workers = jobs or os.cpu_count() or 1

    def take(batch_rows):
        writer.write(batch_rows)
        for r in batch_rows:
            rows[r["id"]] = r
        bar.update(len(batch_rows))

    try:
        if scheduler is not None:
            _run_dask(scheduler, spec, todo, factories, batch, take)
        elif n_workers == 1 or len(todo) <= (batch or 16):
            for chunk in _chunks(todo, batch or 16):
                take(_run_batch(spec, chunk, factories))
        else:
            size = batch or max(1, min(256, math.ceil(len(todo) / (4 * n_workers))))
            with cf.ProcessPoolExecutor(max_workers=n_workers) as pool:
                futures = [pool.submit(_run_batch, spec, chunk, factories) for chunk in _chunks(todo, size)]
                try:
                    for fut in cf.as_completed(futures):
                        take(fut.result())
                except BaseException:
                    for fut in futures:
                        fut.cancel()
                    raise
    finally:
        bar.close()
        writer.close()
    keep = {episode_id(config, i, s) for i, s in wanted}
    return sorted((r for k, r in rows.items() if k in keep), key=lambda r: (r["index"], r["scheme"]))


def _run_dask(scheduler, spec: SweepSpec, todo: list, factories: dict, batch: Optional[int], take) -> None:
    try:
        from dask.distributed import Client, as_completed
    except ImportError as e:
        raise RuntimeError('scheduler= needs Dask: pip install "ibvs[distributed]"') from e
    own = not isinstance(scheduler, Client)
    if own and not isinstance(scheduler, str):
        raise TypeError(f"scheduler must be an address string or a dask.distributed Client, got "
                        f"{type(scheduler).__name__}")
    client = Client(scheduler) if own else scheduler
    try:
        workers = max(1, sum(client.nthreads().values()))
        size = batch or max(1, min(256, math.ceil(len(todo) / (4 * workers))))
        futures = [client.submit(_run_batch, spec, chunk, factories, pure=False) for chunk in _chunks(todo, size)]
        try:
            for fut in as_completed(futures):
                take(fut.result())
        except BaseException:
            client.cancel(futures)
            raise
    finally:
        if own:
            client.close()


# --------------------------------------------------------------------------- tables and figure

#: Default bins of the optical-axis rotation (degrees).
ROTATION_BINS = tuple(range(0, 181, 30))


def aggregate(rows: Iterable[dict], by: str = "rz_deg", bins: Sequence[float] = ROTATION_BINS) -> list[dict]:
    """Per scheme and bin of `by` (edges `bins`, last bin closed): n (episodes with a valid
    start), success (converged fraction), frames (mean frames to converge, converged only),
    retreat / path (mean camera retreat and path length, m), image_exit (left_image
    fraction), joint_limit (fraction), invalid (starts skipped: target not in view or
    unreachable). Deterministic: rows are taken in (index, scheme) order."""
    if by not in PARAMETERS:
        raise ValueError(f"by must be one of {PARAMETERS}, got {by!r}")
    edges = [float(b) for b in bins]
    if len(edges) < 2 or any(b >= a for a, b in zip(edges[1:], edges)):
        raise ValueError(f"bins must be at least two increasing edges, got {list(bins)}")
    rows = sorted(rows, key=lambda r: (r["index"], r["scheme"]))
    schemes = list(dict.fromkeys(r["scheme"] for r in rows))
    groups: dict = {}
    for r in rows:
        x = r[by]
        k = int(np.searchsorted(edges, x, side="right")) - 1
        if k == len(edges) - 1 and x == edges[-1]:
            k -= 1
        if 0 <= k < len(edges) - 1:
            groups.setdefault((r["scheme"], k), []).append(r)
    table = []
    for s in schemes:
        for k in range(len(edges) - 1):
            g = groups.get((s, k), [])
            valid = [r for r in g if r["outcome"] != "invalid_start"]
            n = len(valid)
            conv = [r for r in valid if r["outcome"] == "converged"]

            def mean(xs):
                xs = [x for x in xs if math.isfinite(x)]
                return float(sum(xs) / len(xs)) if xs else math.nan

            table.append({
                "scheme": s, "bin": f"[{edges[k]:g}, {edges[k + 1]:g}{']' if k == len(edges) - 2 else ')'}",
                "lo": edges[k], "hi": edges[k + 1], "n": n,
                "success": len(conv) / n if n else math.nan,
                "frames": mean([r["frames_to_converge"] for r in conv]),
                "retreat": mean([r["camera_retreat"] for r in valid]),
                "path": mean([r["path_length"] for r in valid]),
                "image_exit": sum(r["outcome"] == "left_image" for r in valid) / n if n else math.nan,
                "joint_limit": sum(r["outcome"] == "joint_limit" for r in valid) / n if n else math.nan,
                "invalid": len(g) - n,
            })
    return table


_TABLE_COLUMNS = (("scheme", "scheme"), ("bin", "bin"), ("n", "n"), ("success", "success"),
                  ("frames", "frames"), ("retreat", "retreat (m)"), ("path", "path (m)"),
                  ("image_exit", "image exit"), ("joint_limit", "joint limit"), ("invalid", "invalid starts"))


def format_table(table: list[dict], by: str = "rz_deg") -> str:
    """Markdown table of aggregate()."""
    head = [h if k != "bin" else by for k, h in _TABLE_COLUMNS]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for t in table:
        cells = []
        for k, _ in _TABLE_COLUMNS:
            x = t[k]
            if k in ("success", "image_exit", "joint_limit"):
                cells.append("-" if math.isnan(x) else f"{100 * x:.1f} %")
            elif isinstance(x, float):
                cells.append("-" if math.isnan(x) else f"{x:.4g}")
            else:
                cells.append(str(x))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def figure(table: list[dict], path: Union[str, os.PathLike], by: str = "rz_deg", dpi: int = 90) -> None:
    """Success rate and mean camera retreat against the bins of `by` (default the
    optical-axis rotation), one curve per scheme (matplotlib, Agg)."""
    from .plots import _pyplot

    plt = _pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    for s in dict.fromkeys(t["scheme"] for t in table):
        ts = [t for t in table if t["scheme"] == s]
        x = [(t["lo"] + t["hi"]) / 2 for t in ts]
        a.plot(x, [100 * t["success"] for t in ts], "o-", label=s)
        b.plot(x, [t["retreat"] for t in ts], "o-", label=s)
    label = {"rz_deg": "rotation about the optical axis (deg)"}.get(by, by)
    a.set_xlabel(label)
    a.set_ylabel("success rate (%)")
    a.set_ylim(-3, 103)
    a.set_title("converged")
    b.set_xlabel(label)
    b.set_ylabel("mean camera retreat (m)")
    b.set_title("camera retreat")
    for ax in (a, b):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(str(path), dpi=dpi)
    plt.close(fig)
