"""Deprecated: ibvs.sweep is now ibvs.study.sweep; this alias is removed in the next release."""

from __future__ import annotations

from .deprecation import warn_moved
from .study.scenario import builtin
from .study.scenario import load as load_scenario
from .study.sweep import (
    COLUMNS,
    CONNECT_TIMEOUT,
    DEFAULT_RANGES,
    DEPTH_MODES,
    MAX_EPISODES,
    MAX_JOBS,
    PARAMETERS,
    ROTATION_BINS,
    SCHEMES,
    Scenario,
    SweepSpec,
    aggregate,
    bins_for,
    episode_id,
    figure,
    format_table,
    load,
    outcomes,
    register_scheme,
    resolve,
    run_episode,
    samples,
    sweep,
)

warn_moved("ibvs.sweep", "ibvs.study.sweep")

__all__ = ["COLUMNS", "CONNECT_TIMEOUT", "DEFAULT_RANGES", "DEPTH_MODES", "MAX_EPISODES", "MAX_JOBS", "PARAMETERS",
           "ROTATION_BINS", "SCHEMES", "Scenario", "SweepSpec", "aggregate", "bins_for", "builtin", "episode_id",
           "figure", "format_table", "load", "load_scenario", "outcomes", "register_scheme", "resolve",
           "run_episode", "samples", "sweep"]
