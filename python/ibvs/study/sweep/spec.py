"""What determines a sweep's rows: the SweepSpec (scenario, seed, episodes, schemes, grid), the
parameters of each episode index and the rows' ids."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Mapping, Optional, Sequence, Union

import numpy as np

from ..schemes import SCHEMES, target_for
from ..scenario import DEFAULTS, LIMITS, PARAMETERS, Scenario, builtin

# What ibvs.study.sweep re-exports (and documents); the other names here are its own helpers.
__all__ = ["MAX_EPISODES", "MAX_JOBS", "SweepSpec", "samples", "episode_id"]

#: Most episodes and local worker processes a sweep may ask for.
MAX_EPISODES = 10**6
MAX_JOBS = 256


def check_int(x, name: str, lo: int, hi: int) -> int:
    """x as an int in [lo, hi], or a ValueError naming it (a bool is not an int here)."""
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
        check_int(self.episodes, "episodes", 0, MAX_EPISODES)
        if isinstance(self.schemes, str) or not self.schemes:
            raise ValueError(f"schemes must be a non-empty sequence of names, got {self.schemes!r}")
        for s in self.schemes:
            if s not in SCHEMES:
                raise ValueError(f"schemes: unknown scheme {s!r}; registered: {', '.join(SCHEMES)}")
        for s in self.schemes:  # a scheme beyond points: its target function accepts this target (or says why)
            target_for(s, self.setup.target)
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
    """The stable id of a row: config hash, episode index and scheme ("config:index:scheme")."""
    return f"{config}:{index}:{scheme}"
