"""ibvs.study.sweep: convergence-basin studies at scale, one row per simulated episode.

    import ibvs.study.sweep as sw
    rows = sw.sweep("sweep.csv", episodes=1000, seed=0)         # the paper's free-flying set-up
    rows = sw.sweep("mine.csv", scenario="mine.toml")           # or your own (ibvs.study.scenario)
    table = sw.aggregate(rows)                                   # per scheme and rotation bin
    print(sw.format_table(table))
    sw.figure(table, "sweep.png")                                # needs matplotlib (.[plot])

or on the command line `ibvs sweep --out sweep.csv --episodes 1000 --seed 0` (add
`--scenario mine.toml` for your own set-up; docs/sweeps.md).

A sweep runs a scenario (ibvs.study.scenario.Scenario: camera, target, goal, robot, start
distribution and control settings; the built-in "free" and "gantry" ones or yours). Each
episode index i draws its start offset from the goal, noise, latency and depth error from
its own generator numpy.random.default_rng([seed, i]) -- or takes them from a grid -- and
runs it with every scheme: the same start, noise seed and depth error for every scheme, so
the schemes are compared pair-wise. Every row has a stable id (config hash, index, scheme);
re-running with the same output file skips the ids already in it, so an interrupted sweep
resumes and a sweep can be extended (more episodes, more schemes).

Local runs use a pool of worker processes (many episodes per task: an episode takes about a
millisecond of C++); `scheduler=` (an address or a dask.distributed Client) sends the same
tasks to Dask's distributed scheduler (pip install ".[distributed]"). Rows are
deterministic, so the tables of both paths are identical. An interruption (KeyboardInterrupt)
stops the workers at once; every row finished before it is in the file.

Schemes: SCHEMES (ibvs.study.schemes) maps a name to a factory(gain, n_points) -> servo (an
ibvs.Servo or an ibvs.PartitionedServo: whatever ibvs.sim.run accepts). Add more with
register_scheme(); for process pools the factory must be picklable (a module-level function
or functools.partial of one). The scenario's angle_wrap ("consistent", the default, or
"per_point") is set on every ibvs.Servo a factory returns; each row records it.
"""

from __future__ import annotations

import csv
import math
import multiprocessing
import os
import signal
import sys
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Optional, Sequence, Union

import numpy as np

import ibvs

from ... import sim
from .. import schemes as _schemes
from ..scenario import DEFAULT_RANGES, DEFAULTS, DEPTH_MODES, LIMITS, PARAMETERS, Scenario, builtin
from ..scenario import load as load_scenario

__all__ = [
    "COLUMNS",
    "DEFAULT_RANGES",
    "DEPTH_MODES",
    "PARAMETERS",
    "SCHEMES",
    "Scenario",
    "SweepSpec",
    "aggregate",
    "episode_id",
    "figure",
    "format_table",
    "load",
    "outcomes",
    "register_scheme",
    "run_episode",
    "samples",
    "sweep",
]

#: Scheme name -> factory(gain, n_points) -> servo (the registry of ibvs.study.schemes).
SCHEMES = _schemes.SCHEMES


def register_scheme(name: str, factory: Callable[..., Any], *, replace: bool = False) -> None:
    """Add a scheme: factory(gain, n_points) returns a servo for n_points points (anything
    ibvs.sim.run accepts as servo; factory(gain) is accepted for four-point targets). Raises
    ValueError if the name exists (unless replace)."""
    if not isinstance(name, str) or not name or any(c in name for c in ",: \t\n"):
        raise ValueError(f"name must be a non-empty string without ',', ':' or spaces, got {name!r}")
    if not callable(factory):
        raise TypeError(f"factory must be callable (gain, n_points -> servo), got {type(factory).__name__}")
    if name in SCHEMES and not replace:
        raise ValueError(f"name: scheme {name!r} is already registered (pass replace=True)")
    SCHEMES[name] = factory


# --------------------------------------------------------------------------- the spec

#: Columns of the CSV, in order.
COLUMNS = (
    "id", "config", "index", "scenario", "scheme", *PARAMETERS, "depth", "angle_wrap", "outcome", "frame",
    "point", "joint",
    "frames_to_converge", "time_to_converge", "camera_retreat", "path_length", "peak_linear_speed",
    "peak_angular_speed", "final_translation_error", "final_rotation_error",
)
_INT = {"index", "latency", "frame", "point", "joint", "frames_to_converge"}
_STR = {"id", "config", "scenario", "scheme", "depth", "angle_wrap", "outcome"}
#: Most episodes and local worker processes a sweep may ask for.
MAX_EPISODES = 10**6
MAX_JOBS = 256


def _count(x, name: str, lo: int, hi: int) -> int:
    if isinstance(x, bool) or not isinstance(x, (int, np.integer)) or not lo <= x <= hi:
        raise ValueError(f"{name} must be an int in [{lo}, {hi}], got {x!r}")
    return int(x)


@dataclass(frozen=True, eq=False)
class SweepSpec:
    """Everything that determines the rows: the scenario (a Scenario or a built-in name), the
    seed, the episode count (the grid's size in grid mode), the schemes and an optional grid
    {parameter: values} replacing the scenario's random starts. The config hash covers all but
    episodes and schemes, so that a sweep can be extended."""

    scenario: Union[Scenario, str] = "free"
    seed: int = 0
    episodes: int = 100
    schemes: tuple = ("cartesian", "polar", "hybrid", "stacked")
    grid: Optional[Mapping[str, Sequence[float]]] = None

    @property
    def setup(self) -> Scenario:
        return builtin(self.scenario) if isinstance(self.scenario, str) else self.scenario

    def validate(self) -> "SweepSpec":
        if not isinstance(self.scenario, (Scenario, str)):
            raise TypeError(f"scenario must be an ibvs.study.scenario.Scenario, a built-in name or a file, got "
                            f"{type(self.scenario).__name__}")
        self.setup.validate()
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or not 0 <= self.seed < 2**63:
            raise ValueError(f"seed must be an int in [0, 2**63), got {self.seed!r}")
        _count(self.episodes, "episodes", 0, MAX_EPISODES)
        if isinstance(self.schemes, str) or not self.schemes:
            raise ValueError(f"schemes must be a non-empty sequence of names, got {self.schemes!r}")
        for s in self.schemes:
            if s not in SCHEMES:
                raise ValueError(f"schemes: unknown scheme {s!r}; registered: {', '.join(SCHEMES)}")
        if len(set(self.schemes)) != len(self.schemes):
            raise ValueError(f"schemes: duplicate names in {list(self.schemes)}")
        for name, values in (self.grid or {}).items():
            if name not in PARAMETERS:
                raise ValueError(f"grid: unknown parameter {name!r}; choose from {', '.join(PARAMETERS)}")
            if len(values) == 0:
                raise ValueError(f"grid: {name} needs at least one value")
            lo, hi = LIMITS[name]
            for v in values:
                if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) \
                        or not (math.isfinite(v) and lo <= v <= hi) or (name == "latency" and v != int(v)):
                    raise ValueError(f"grid: {name} values must be {'integers' if name == 'latency' else 'numbers'}"
                                     f" in [{lo:g}, {hi:g}], got {v!r}")
        frames = self.setup.duration * self.setup.camera.fps
        if self.grid and "latency" in self.grid and max(self.grid["latency"]) >= frames:
            raise ValueError(f"grid: latency {max(self.grid['latency']):g} frames is not shorter than the episode "
                             f"({frames:g} frames)")
        if self.size > MAX_EPISODES:
            raise ValueError(f"grid: {self.size} combinations, more than {MAX_EPISODES}")
        return self

    @property
    def size(self) -> int:
        """Number of start set-ups (grid size in grid mode)."""
        if self.grid is not None:
            return int(np.prod([len(v) for v in self.grid.values()]))
        return int(self.episodes)

    def config(self) -> str:
        """Hash of what determines each episode (not the episode count or the schemes)."""
        import hashlib
        import json

        grid = None if self.grid is None else {k: [float(x) for x in v] for k, v in sorted(self.grid.items())}
        key = {"scenario": self.setup.key(), "seed": int(self.seed), "grid": grid}
        return hashlib.sha1(json.dumps(key, sort_keys=True).encode()).hexdigest()[:10]


def samples(spec: SweepSpec, indices: Optional[Iterable[int]] = None) -> list[dict]:
    """The parameters of the given episode indices (default: all). Index i depends only on
    (seed, i) in random mode, on its position in the grid in grid mode."""
    idx = range(spec.size) if indices is None else indices
    if spec.grid is not None:
        names = list(spec.grid)
        values = [[float(v) for v in spec.grid[n]] for n in names]
        sizes = [len(v) for v in values]
        out = []
        for i in idx:
            # i -> grid position, last parameter fastest (itertools.product order)
            pos, rest = [], int(i)
            for size in reversed(sizes):
                rest, k = divmod(rest, size)
                pos.append(k)
            p = {**DEFAULTS, **{n: v[k] for n, v, k in zip(names, values, reversed(pos))}}
            p["latency"] = int(p["latency"])
            out.append(p)
        return out
    setup = spec.setup
    return [setup.sample(spec.seed, i) for i in idx]


def episode_id(config: str, index: int, scheme: str) -> str:
    return f"{config}:{index}:{scheme}"


# --------------------------------------------------------------------------- one episode


def run_episode(spec: SweepSpec, index: int, scheme: str, params: Optional[dict] = None,
                factory: Optional[Callable] = None) -> dict:
    """Simulate one (index, scheme) of a sweep and return its row (a dict over COLUMNS)."""
    setup = spec.setup
    p = params if params is not None else samples(spec, [index])[0]
    config = spec.config()
    row = {"id": episode_id(config, index, scheme), "config": config, "index": int(index), "scenario": setup.name,
           "scheme": scheme, **{k: (int(p[k]) if k in _INT else float(p[k])) for k in PARAMETERS},
           "depth": setup.depth, "angle_wrap": setup.angle_wrap}
    start = setup.start(p)
    if start is None:
        return {**row, "outcome": "invalid_start", "frame": -1, "point": -1, "joint": -1, "frames_to_converge": -1,
                **{k: math.nan for k in COLUMNS[COLUMNS.index("time_to_converge"):]}}
    servo = _schemes.make(factory or scheme, setup.gain, len(setup.target))
    if isinstance(servo, ibvs.Servo):
        servo.angle_wrap = setup.angle_wrap
    # The noise seed is the episode's, shared by every scheme.
    noise_seed = int(np.random.default_rng([int(spec.seed), int(index), 1]).integers(0, 2**63))
    r = sim.run(servo, setup.camera, setup.target, start, setup.goal_for_run(), robot=setup.robot,
                duration=setup.duration, noise=p["noise"], latency=int(p["latency"]), depth=setup.depth,
                seed=noise_seed, tolerance=setup.tolerance, depth_scale=p["depth_scale"],
                boundary_margin=setup.boundary_margin, boundary_gain=setup.boundary_gain)
    s, m, h = r.status, r.metrics, r.history
    twist = h.twist[np.isfinite(h.twist).all(axis=1)]
    peak = (float(np.linalg.norm(twist[:, :3], axis=1).max()), float(np.linalg.norm(twist[:, 3:], axis=1).max())) \
        if len(twist) else (math.nan, math.nan)
    dt = 1.0 / setup.camera.fps
    return {**row, "outcome": s.outcome, "frame": s.frame, "point": s.point, "joint": s.joint,
            "frames_to_converge": m.frames_to_converge,
            "time_to_converge": m.frames_to_converge * dt if m.frames_to_converge >= 0 else math.nan,
            "camera_retreat": m.camera_retreat, "path_length": m.path_length, "peak_linear_speed": peak[0],
            "peak_angular_speed": peak[1], "final_translation_error": m.final_translation_error,
            "final_rotation_error": m.final_rotation_error}


def _run_batch(spec: SweepSpec, jobs: list, factories: Optional[dict] = None) -> list[dict]:
    """Worker task: rows of [(index, scheme), ...]."""
    indices = sorted({i for i, _ in jobs})
    params = dict(zip(indices, samples(spec, indices)))
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
    try:
        with open(path, newline="", encoding="utf-8") as f:
            text = raw_text = f.read()
    except UnicodeDecodeError:
        raise ValueError(f"out: {path} is not an ibvs sweep file (not text)") from None
    if text and not text.endswith("\n"):
        text = text[: text.rfind("\n") + 1]
    reader = csv.DictReader(text.splitlines())
    header = ",".join(COLUMNS)
    first = raw_text.split("\n", 1)[0]
    if raw_text and first != header and not ("\n" not in raw_text and header.startswith(first)):
        raise ValueError(f"out: {path} is not an ibvs sweep file of this version (its first line is not the "
                         f"header {COLUMNS[0]},{COLUMNS[1]},...)")
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


def resolve(scenario=None, *, world: Optional[str] = None, ranges: Optional[Mapping[str, tuple]] = None,
            **settings) -> tuple[Scenario, dict]:
    """The Scenario of sweep()'s arguments and the [sweep] options of a scenario file.

    scenario: a Scenario, a built-in name ("free", "gantry"), a TOML file (str or Path ending
    in .toml), or None (world, default "free"). ranges and settings (gain, duration, depth,
    tolerance, boundary_margin, boundary_gain, angle_wrap; None = the scenario's) override the
    scenario's."""
    options: dict = {}
    if scenario is not None and world is not None:
        raise ValueError("world and scenario: give one or the other")
    if scenario is None:
        scenario = world or "free"
    if isinstance(scenario, os.PathLike) or (isinstance(scenario, str) and scenario.endswith(".toml")):
        scenario, options = load_scenario(scenario)
    elif isinstance(scenario, str):
        scenario = builtin(scenario)
    elif not isinstance(scenario, Scenario):
        raise TypeError(f"scenario must be an ibvs.study.scenario.Scenario, a built-in name or a .toml file, got "
                        f"{type(scenario).__name__}")
    if ranges is not None and not isinstance(ranges, Mapping):
        raise TypeError(f"ranges must be a mapping {{parameter: (lo, hi)}}, got {type(ranges).__name__}")
    return scenario.replace(ranges=ranges, **settings), options


def sweep(
    out: Union[str, os.PathLike, None] = None,
    *,
    scenario: Union[Scenario, str, os.PathLike, None] = None,
    episodes: Optional[int] = None,
    seed: Optional[int] = None,
    schemes: Optional[Sequence[str]] = None,
    world: Optional[str] = None,
    ranges: Optional[Mapping[str, tuple]] = None,
    grid: Optional[Mapping[str, Sequence[float]]] = None,
    gain: Optional[float] = None,
    duration: Optional[float] = None,
    depth: Optional[str] = None,
    tolerance: Optional[float] = None,
    boundary_margin: Optional[float] = None,
    boundary_gain: Optional[float] = None,
    angle_wrap: Optional[str] = None,
    jobs: Optional[int] = None,
    batch: Optional[int] = None,
    scheduler: Any = None,
    progress: bool = True,
    limit: Optional[int] = None,
) -> list[dict]:
    """Run a sweep; returns its rows (dicts over COLUMNS) sorted by (index, scheme).

    out: CSV file (rows appended as they finish; rows already in it are skipped) or None.
    scenario: a Scenario (ibvs.study.scenario), a built-in name ("free" or "gantry"), or a TOML
        scenario file, whose [sweep] table gives defaults for episodes, seed and schemes.
        world: the built-in name (the same as scenario=name).
    episodes: number of random start set-ups (default 100; ignored with grid); seed: their seed.
    schemes: names in SCHEMES (default: all registered).
    ranges: {parameter: (lo, hi)} overriding the scenario's start distribution (PARAMETERS).
    grid: {parameter: values}: every combination instead of random samples.
    gain, duration, depth, tolerance, boundary_margin, boundary_gain: override the scenario's
        control settings (see ibvs.sim.run).
    angle_wrap: "consistent" or "per_point", set on every ibvs.Servo the schemes build
        (default: the scenario's, "consistent" unless it says otherwise).
    jobs: local worker processes (default: os.cpu_count(); 1 = in this process).
    batch: episodes per task (default: about 4 tasks per worker, at most 256).
    scheduler: a Dask scheduler address or a dask.distributed Client: run there instead.
        ConnectionError when the address does not answer within a few seconds.
    progress: a progress bar on stderr (tqdm if installed).
    limit: run at most this many new episodes (then stop, as if interrupted).
    """
    setup, options = resolve(scenario, world=world, ranges=ranges, gain=gain, duration=duration, depth=depth,
                             tolerance=tolerance, boundary_margin=boundary_margin,
                             boundary_gain=boundary_gain, angle_wrap=angle_wrap)
    schemes = schemes if schemes is not None else options.get("schemes")
    spec = SweepSpec(scenario=setup, seed=seed if seed is not None else options.get("seed", 0),
                     episodes=episodes if episodes is not None else options.get("episodes", 100),
                     schemes=tuple(schemes) if schemes is not None else tuple(SCHEMES), grid=grid).validate()
    if jobs is not None:
        _count(jobs, "jobs", 1, MAX_JOBS)
    if batch is not None:
        _count(batch, "batch", 1, MAX_EPISODES)
    if limit is not None:
        _count(limit, "limit", 0, 2**62)
    path = Path(out) if out is not None else None
    if path is not None and path.is_dir():
        raise ValueError(f"out: {path} is a directory")
    config = spec.config()
    existing = {r["id"]: r for r in load(path, config)} if path is not None else {}
    wanted = [(i, s) for i in range(spec.size) for s in spec.schemes]
    todo = [(i, s) for i, s in wanted if episode_id(config, i, s) not in existing]
    if limit is not None:
        todo = todo[:limit]
    factories = {s: SCHEMES[s] for s in spec.schemes}
    client = _connect(scheduler) if scheduler is not None else None
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
        if client is not None:
            _run_dask(client, scheduler is not client, spec, todo, factories, batch, take)
        elif n_workers == 1 or len(todo) <= (batch or 16):
            for chunk in _chunks(todo, batch or 16):
                take(_run_batch(spec, chunk, factories))
        else:
            size = batch or max(1, min(256, math.ceil(len(todo) / (4 * n_workers))))
            _run_local(n_workers, spec, _chunks(todo, size), factories, take)
    finally:
        bar.close()
        writer.close()
    keep = {episode_id(config, i, s) for i, s in wanted}
    return sorted((r for k, r in rows.items() if k in keep), key=lambda r: (r["index"], r["scheme"]))


def _worker(conn, spec: SweepSpec, factories: Optional[dict], inherited: list, parent: int) -> None:
    """A local worker process: runs the batches the parent sends on its own pipe until it sends None
    (or closes the pipe). Ctrl-C and SIGTERM are the parent's, which kills the workers. A parent that
    dies without a word (SIGKILL) is noticed within a second: the worker exits after its batch."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    for c in inherited:  # the parent's ends of the pipes, copied by fork: held here, they would hide its death
        c.close()
    while True:
        try:
            while not conn.poll(1.0):
                if os.getppid() != parent:
                    return
            chunk = conn.recv()
        except EOFError:
            return
        if chunk is None:
            return
        try:
            reply = ("rows", _run_batch(spec, chunk, factories), None)
        except Exception as e:  # re-raised in the parent, as a pool would, with the worker's traceback
            reply = ("error", e, traceback.format_exc())
        try:
            conn.send(reply)
        except Exception as e:  # an unpicklable result or exception: its text
            what = RuntimeError(f"{type(reply[1]).__name__}: {reply[1]}") if reply[0] == "error" else e
            conn.send(("error", what, traceback.format_exc()))


def _run_local(n_workers: int, spec: SweepSpec, chunks: list, factories: Optional[dict], take) -> None:
    """The batches on worker processes, each with its own pipe: no lock is shared between processes, so
    an interruption can kill the workers at any moment (multiprocessing.Pool.terminate can deadlock on its
    task queue's lock when a signal arrives while an idle worker holds it)."""
    from multiprocessing.connection import wait

    ctx = multiprocessing.get_context()
    workers: list = []
    finished = False
    try:
        fork = ctx.get_start_method() == "fork"
        for _ in range(min(n_workers, len(chunks))):
            parent, child = ctx.Pipe()
            inherited = [c for _, c in workers] + [parent] if fork else []
            p = ctx.Process(target=_worker, args=(child, spec, factories, inherited, os.getpid()), daemon=True)
            p.start()
            child.close()
            workers.append((p, parent))
        todo = iter(chunks)
        busy = {}
        for p, conn in workers:
            chunk = next(todo, None)
            if chunk is not None:
                conn.send(chunk)
                busy[conn] = p
        while busy:
            for conn in wait(list(busy)):
                try:
                    kind, value, where = conn.recv()
                except EOFError:
                    busy[conn].join(1)  # reaped, so that its exit code is known
                    raise RuntimeError(f"a sweep worker died (exit code {busy[conn].exitcode})") from None
                if kind == "error":
                    raise value from RuntimeError(f"in the sweep worker:\n{where}")
                take(value)
                chunk = next(todo, None)
                if chunk is None:
                    del busy[conn]
                else:
                    conn.send(chunk)
        for _, conn in workers:
            conn.send(None)
        finished = True
    finally:  # normal end: the workers exit by themselves; an interruption or an error: killed now
        for p, conn in workers:
            if finished:
                p.join(timeout=5)
            if p.exitcode is None:
                p.kill()
                p.join()
            conn.close()


#: Seconds a Dask scheduler address has to answer.
CONNECT_TIMEOUT = 5.0


def _connect(scheduler):
    """A dask.distributed Client of an address (ConnectionError within CONNECT_TIMEOUT s when it
    does not answer), or the Client given."""
    try:
        from dask.distributed import Client
    except ImportError as e:
        raise ImportError('scheduler= needs Dask: pip install ".[distributed]" from the ibvs repository') from e
    if isinstance(scheduler, Client):
        return scheduler
    if not isinstance(scheduler, str):
        raise TypeError(f"scheduler must be an address string or a dask.distributed Client, got "
                        f"{type(scheduler).__name__}")
    from distributed.comm.addressing import parse_address, parse_host_port

    try:  # a malformed address is refused here: a Client that fails to parse one hangs on exit
        kind, where = parse_address(scheduler, strict=False)
        if kind != "inproc" and parse_host_port(where)[1] <= 0:
            raise ValueError
    except (ValueError, TypeError):
        raise ValueError(f"scheduler: {scheduler!r} is not a scheduler address such as tcp://127.0.0.1:8786") \
            from None
    import logging

    # distributed logs every failed attempt; the one-line error below says it all.
    quiet = [logging.getLogger(n) for n in ("distributed.client", "distributed.comm.core", "distributed.core")]
    levels = [q.level for q in quiet]
    for q in quiet:
        q.setLevel(logging.CRITICAL)
    try:
        return Client(scheduler, timeout=CONNECT_TIMEOUT, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as e:
        raise ConnectionError(f"scheduler: no Dask scheduler answers at {scheduler!r} within "
                              f"{CONNECT_TIMEOUT:g} s ({type(e).__name__})") from None
    finally:
        for q, level in zip(quiet, levels):
            q.setLevel(level)


def _run_dask(client, own: bool, spec: SweepSpec, todo: list, factories: dict, batch: Optional[int], take) -> None:
    from dask.distributed import as_completed

    try:
        workers = max(1, sum(client.nthreads().values()))
        size = batch or max(1, min(256, math.ceil(len(todo) / (4 * workers))))
        futures = [client.submit(_run_batch, spec, chunk, factories, pure=False) for chunk in _chunks(todo, size)]
        try:
            for fut in as_completed(futures, loop=client.loop):
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


def outcomes(rows: Iterable[dict] = ()) -> list[str]:
    """The outcome columns of a table: ibvs.sim.OUTCOMES, then any other outcome in rows (but
    invalid_start, which is counted apart)."""
    names = list(sim.OUTCOMES)
    for r in rows:
        o = r["outcome"]
        if o not in names and o != "invalid_start":
            names.append(o)
    return names


def bins_for(rows: Sequence[dict], by: str = "rz_deg", width: Optional[float] = None) -> list[float]:
    """Bin edges for the values of `by` in rows: ROTATION_BINS (or multiples of width from 0 to
    180) when by is rz_deg and every value is in [0, 180]; else multiples of width (default: six
    bins) spanning the values."""
    xs = [r[by] for r in rows if math.isfinite(r[by])] or [0.0]
    lo, hi = min(xs), max(xs)
    if by == "rz_deg" and lo >= 0 and hi <= 180:
        lo, hi = 0.0, 180.0
        if width is None:
            return [float(b) for b in ROTATION_BINS]
    if width is None:
        width = (hi - lo) / 6 or 1.0
    a, b = math.floor(lo / width), max(math.ceil(hi / width), math.floor(lo / width) + 1)
    if b - a > 10_000:
        raise ValueError(f"bins: width {width:g} makes {b - a} bins; use a larger width")
    return [k * width for k in range(a, b + 1)]


def _median(xs) -> float:
    xs = [x for x in xs if math.isfinite(x)]
    return float(np.median(xs)) if xs else math.nan


def aggregate(rows: Iterable[dict], by: str = "rz_deg", bins: Optional[Sequence[float]] = None) -> list[dict]:
    """Per scheme and bin of `by` (edges `bins`, last bin closed; default bins_for(rows, by)):
    n (episodes with a valid start), the fraction of each outcome (a key per outcome of
    outcomes(rows): converged, left_image, ..., timeout, and any added later), time (median
    time to converge, s, converged only), the medians of retreat (camera retreat, m), path
    (camera path length, m), peak_linear_speed (m/s) and peak_angular_speed (rad/s) over the
    valid episodes, and invalid (starts skipped: target not in view or unreachable). Every
    row of the table also holds "outcomes", the list of outcome keys. Deterministic: rows are
    taken in (index, scheme) order."""
    if by not in PARAMETERS:
        raise ValueError(f"by must be one of {PARAMETERS}, got {by!r}")
    rows = sorted(rows, key=lambda r: (r["index"], r["scheme"]))
    edges = bins_for(rows, by) if bins is None else [float(b) for b in bins]
    if len(edges) < 2 or any(b >= a for a, b in zip(edges[1:], edges)) or not all(map(math.isfinite, edges)):
        raise ValueError(f"bins must be at least two finite increasing edges, got {list(bins)}")
    names = outcomes(rows)
    order = list(SCHEMES)  # registry order, then any other scheme
    schemes = sorted(dict.fromkeys(r["scheme"] for r in rows), key=lambda s: (order.index(s) if s in order
                                                                                 else len(order), s))
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
            t = {"scheme": s, "bin": f"[{edges[k]:g}, {edges[k + 1]:g}{']' if k == len(edges) - 2 else ')'}",
                 "lo": edges[k], "hi": edges[k + 1], "n": n}
            for o in names:
                t[o] = sum(r["outcome"] == o for r in valid) / n if n else math.nan
            t["time"] = _median(r["time_to_converge"] for r in valid if r["outcome"] == "converged")
            for key, col in (("retreat", "camera_retreat"), ("path", "path_length"),
                             ("peak_linear_speed", "peak_linear_speed"), ("peak_angular_speed", "peak_angular_speed")):
                t[key] = _median(r[col] for r in valid)
            t["invalid"] = len(g) - n
            t["outcomes"] = names
            table.append(t)
    return table


_METRIC_COLUMNS = (("time", "time (s)"), ("retreat", "retreat (m)"), ("path", "path (m)"),
                   ("peak_linear_speed", "peak ‖T‖ (m/s)"), ("peak_angular_speed", "peak ‖ω‖ (rad/s)"),
                   ("invalid", "invalid starts"))


def format_table(table: list[dict], by: str = "rz_deg") -> str:
    """Markdown table of aggregate(): a column per outcome (% of the valid starts), then the
    medians."""
    names = list(table[0]["outcomes"]) if table else list(sim.OUTCOMES)
    columns = [("scheme", "scheme"), ("bin", by), ("n", "n")] + [(o, o) for o in names] + list(_METRIC_COLUMNS)
    lines = ["| " + " | ".join(h for _, h in columns) + " |", "|" + "---|" * len(columns)]
    for t in table:
        cells = []
        for k, _ in columns:
            x = t[k]
            if k in names:
                cells.append("-" if math.isnan(x) else f"{100 * x:.1f} %")
            elif isinstance(x, float):
                cells.append("-" if math.isnan(x) else f"{x:.4g}")
            else:
                cells.append(str(x))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def figure(table: list[dict], path: Union[str, os.PathLike], by: str = "rz_deg", dpi: int = 90) -> None:
    """Save ibvs.viz.sweep_summary(table, by): every outcome's rate and the median retreat,
    path and peak twist against the bins of `by`, one curve per scheme."""
    from ... import viz

    viz.sweep_summary(table, by).savefig(os.fspath(path), dpi=dpi)
