"""Deprecated: ibvs.scenario is now ibvs.study.scenario; this alias is removed in the next release."""

from __future__ import annotations

from .deprecation import warn_moved
from .study.scenario import (
    ANGLE_WRAPS,
    DEFAULT_RANGES,
    DEFAULTS,
    DEPTH_MODES,
    LIMITS,
    MAX_DURATION,
    MAX_GAIN,
    PARAMETERS,
    ROBOTS,
    SWEEP_KEYS,
    Scenario,
    builtin,
    load,
    offset,
)

warn_moved("ibvs.scenario", "ibvs.study.scenario")

__all__ = ["ANGLE_WRAPS", "DEFAULTS", "DEFAULT_RANGES", "DEPTH_MODES", "LIMITS", "MAX_DURATION", "MAX_GAIN",
           "PARAMETERS", "ROBOTS", "SWEEP_KEYS", "Scenario", "builtin", "load", "offset"]
