"""Deprecated: ibvs.animation is now ibvs.viz.animation; this alias is removed in the next release."""

from __future__ import annotations

from .deprecation import warn_moved
from .viz.animation import FPS, check_path, frame_count, write

warn_moved("ibvs.animation", "ibvs.viz.animation")

__all__ = ["FPS", "check_path", "frame_count", "write"]
