"""Deprecated: ibvs.plots is now ibvs.viz (same functions); this alias is removed in the next release."""

from __future__ import annotations

from .deprecation import warn_moved
from .viz import (
    AXIS_COLOURS,
    COORDINATE_STYLES,
    TWIST_LABELS,
    animate,
    compare,
    episode,
    image_limits,
    image_limits_paths,
    square_perimeter_r,
    sweep_summary,
)

warn_moved("ibvs.plots", "ibvs.viz")

__all__ = ["AXIS_COLOURS", "COORDINATE_STYLES", "TWIST_LABELS", "animate", "compare", "episode", "image_limits",
           "image_limits_paths", "square_perimeter_r", "sweep_summary"]
