"""sweep(): the episodes asked for that the CSV does not hold yet, run in this process, on local
workers or on Dask, each batch appended to the CSV as it finishes; and resolve(), the scenario of
its arguments."""

from __future__ import annotations

import contextlib
import dataclasses
import math
import os
from pathlib import Path
from typing import Any, Mapping, Optional, Sequence, Union

from ...writer_lock import one_writer
from .. import schemes as schemes_mod
from ..schemes import SCHEMES
from ..scenario import Scenario, builtin
from ..scenario import load as load_scenario
from .cluster import connect, run_dask
from .episodes import chunks, run_batch
from .local import run_local
from .progress import Progress
from .rows import RowWriter, load
from .spec import MAX_EPISODES, MAX_JOBS, SweepSpec, check_int, episode_id

# What ibvs.study.sweep re-exports (and documents); the other names here are its own helpers.
__all__ = ["resolve", "sweep"]


def resolve(scenario=None, *, world: Optional[str] = None, ranges: Optional[Mapping[str, tuple]] = None,
            **settings) -> tuple[Scenario, dict]:
    """The Scenario of sweep()'s arguments and the [sweep] options of a scenario file.

    scenario: a Scenario, a built-in name ("free", "gantry", "arm"), a TOML file (str or Path ending
    in .toml), or None (world, default "free"). ranges and settings (gain, duration, depth,
    tolerance, tolerance_px, boundary_margin, boundary_gain, angle_wrap, goal_pose_mode; None = the scenario's)
    override the scenario's; tolerance_px without tolerance replaces the scenario's tests by the
    pixel test alone (give both for both)."""
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
    out = scenario.replace(ranges=ranges, **settings)
    if settings.get("tolerance_px") is not None and settings.get("tolerance") is None:
        out = dataclasses.replace(out, tolerance=None)  # the pixels alone decide (replace() skips None)
    return out, options


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
    tolerance_px: Optional[float] = None,
    boundary_margin: Optional[float] = None,
    boundary_gain: Optional[float] = None,
    angle_wrap: Optional[str] = None,
    goal_pose: Optional[str] = None,
    jobs: Optional[int] = None,
    batch: Optional[int] = None,
    scheduler: Any = None,
    progress: bool = True,
    limit: Optional[int] = None,
) -> list[dict]:
    """Run a sweep; returns its rows (dicts over COLUMNS) sorted by (index, scheme).

    out: CSV file (rows appended as they finish; rows already in it are skipped) or None. Locked for the whole
        run (ibvs.writer_lock): another process writing it raises ibvs.writer_lock.WriterBusy at once.
    scenario: a Scenario (ibvs.study.scenario), a built-in name ("free" or "gantry"), or a TOML
        scenario file, whose [sweep] table gives defaults for episodes, seed and schemes.
        world: the built-in name (the same as scenario=name).
    episodes: number of random start set-ups (default 100; ignored with grid); seed: their seed.
    schemes: names in SCHEMES (default: every registered scheme on points only, schemes.points_only()).
    ranges: {parameter: (lo, hi)} overriding the scenario's start distribution (PARAMETERS).
    grid: {parameter: values}: every combination instead of random samples.
    gain, duration, depth, tolerance, tolerance_px, boundary_margin, boundary_gain: override the
        scenario's control settings (see ibvs.sim.run).
    angle_wrap: "consistent" or "per_point", set on every ibvs.Servo the schemes build
        (default: the scenario's, "consistent" unless it says otherwise).
    goal_pose: "taught" or "given", the goal pose of the PBVS, 2.5-D and moments schemes (see ibvs.sim.run;
        default: the scenario's, "taught" unless it says otherwise).
    jobs: local worker processes (default: os.cpu_count(); 1 = in this process).
    batch: episodes per task (default: about 4 tasks per worker, at most 256).
    scheduler: a Dask scheduler address or a dask.distributed Client: run there instead.
        ConnectionError when the address does not answer within a few seconds.
    progress: a progress bar on stderr (tqdm if installed).
    limit: run at most this many new rows (then stop, as if interrupted).
    """
    setup, options = resolve(scenario, world=world, ranges=ranges, gain=gain, duration=duration, depth=depth,
                             tolerance=tolerance, tolerance_px=tolerance_px, boundary_margin=boundary_margin,
                             boundary_gain=boundary_gain, angle_wrap=angle_wrap, goal_pose_mode=goal_pose)
    schemes = schemes if schemes is not None else options.get("schemes")
    spec = SweepSpec(scenario=setup, seed=seed if seed is not None else options.get("seed", 0),
                     episodes=episodes if episodes is not None else options.get("episodes", 100),
                     schemes=tuple(schemes) if schemes is not None else schemes_mod.points_only(), grid=grid).validate()
    if jobs is not None:
        check_int(jobs, "jobs", 1, MAX_JOBS)
    if batch is not None:
        check_int(batch, "batch", 1, MAX_EPISODES)
    if limit is not None:
        check_int(limit, "limit", 0, 2**62)
    path = Path(out) if out is not None else None
    if path is not None and path.is_dir():
        raise ValueError(f"out: {path} is a directory")
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
    # One writer per file (ibvs.writer_lock): held from reading what the file has to the last row appended.
    with one_writer(path) if path is not None else contextlib.nullcontext():
        config = spec.config()
        existing = {r["id"]: r for r in load(path, config)} if path is not None else {}
        wanted = [(i, s) for i in range(spec.size) for s in spec.schemes]
        todo = [(i, s) for i, s in wanted if episode_id(config, i, s) not in existing]
        if limit is not None:
            todo = todo[:limit]
        factories = {s: schemes_mod.entry(s) for s in spec.schemes}
        client = connect(scheduler) if scheduler is not None else None
        rows = dict(existing)
        writer = RowWriter(path)
        bar = Progress(spec.size, len(spec.schemes), [i for i, s in wanted if episode_id(config, i, s) in existing],
                       progress)
        n_workers = jobs or os.cpu_count() or 1

        def take(batch_rows):
            writer.write(batch_rows)
            for r in batch_rows:
                rows[r["id"]] = r
            bar.update(r["index"] for r in batch_rows)

        try:
            if client is not None:
                run_dask(client, scheduler is not client, spec, todo, factories, batch, take)
            elif n_workers == 1 or len(todo) <= (batch or 16):
                for chunk in chunks(todo, batch or 16):
                    take(run_batch(spec, chunk, factories))
            else:
                size = batch or max(1, min(256, math.ceil(len(todo) / (4 * n_workers))))
                run_local(n_workers, spec, chunks(todo, size), factories, take)
        finally:
            bar.close()
            writer.close()
    keep = {episode_id(config, i, s) for i, s in wanted}
    return sorted((r for k, r in rows.items() if k in keep), key=lambda r: (r["index"], r["scheme"]))
