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
stops the workers at once; every row finished before it is in the file, and so it is when the
Dask scheduler dies (SchedulerLost, a ConnectionError).

Schemes: SCHEMES (ibvs.study.schemes) maps a name to a factory(gain, n_points) -> servo (an
ibvs.Servo or an ibvs.PartitionedServo: whatever ibvs.sim.run accepts). Add more with
register_scheme(); for process pools the factory must be picklable (a module-level function
or functools.partial of one). The scenario's angle_wrap ("consistent", the default, or
"per_point") is set on every ibvs.Servo a factory returns; each row records it.

Modules: spec (SweepSpec, samples, episode ids), episodes (one episode, a worker's batch), rows
(the CSV), progress, local (the worker pool), cluster (Dask), runner (sweep, resolve) and tables
(aggregate, format_table, figure, starts); this package re-exports their public names.

Starts that run no episode are rows too, never dropped: outcome "invalid_start" (the target not
entirely in view at the start) or "unreachable" (a robot's start that ibvs.sim.solve_ik cannot reach
within the joint limits); the tables count them apart (NOT_RUN, starts(), format_starts()).
"""

from __future__ import annotations

from ..schemes import SCHEMES, register_scheme
from ..scenario import DEFAULT_RANGES, DEPTH_MODES, PARAMETERS, Scenario
from .cluster import CONNECT_TIMEOUT, SchedulerLost
from .episodes import run_episode
from .rows import COLUMNS, load
from .runner import resolve, sweep
from .spec import MAX_EPISODES, MAX_JOBS, SweepSpec, episode_id, samples
from .tables import NOT_RUN, ROTATION_BINS, aggregate, bins_for, figure, format_starts, format_table, outcomes, starts

__all__ = [
    "COLUMNS",
    "CONNECT_TIMEOUT",
    "DEFAULT_RANGES",
    "DEPTH_MODES",
    "MAX_EPISODES",
    "MAX_JOBS",
    "NOT_RUN",
    "PARAMETERS",
    "ROTATION_BINS",
    "SCHEMES",
    "Scenario",
    "SchedulerLost",
    "SweepSpec",
    "aggregate",
    "bins_for",
    "episode_id",
    "figure",
    "format_starts",
    "format_table",
    "load",
    "outcomes",
    "register_scheme",
    "resolve",
    "run_episode",
    "samples",
    "starts",
    "sweep",
]
