"""Deprecated: ibvs.schemes is now ibvs.study.schemes; this alias is removed in the next release."""

from __future__ import annotations

from .deprecation import warn_moved
from .study.schemes import (
    PAPER,
    SCHEMES,
    TITLES,
    automatic,
    cartesian,
    cylindrical,
    hybrid,
    make,
    partitioned,
    polar,
    stacked,
)

warn_moved("ibvs.schemes", "ibvs.study.schemes")

__all__ = ["PAPER", "SCHEMES", "TITLES", "automatic", "cartesian", "cylindrical", "hybrid", "make", "partitioned",
           "polar", "stacked"]
