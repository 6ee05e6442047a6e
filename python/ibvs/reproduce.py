"""Deprecated: ibvs.reproduce is now ibvs.study.reproduce; this alias is removed in the next release."""

from __future__ import annotations

from .deprecation import warn_moved
from .study.reproduce import (
    CASES,
    DEFAULT_CASE,
    DEPTH,
    DURATION,
    FIGURES,
    GAIN,
    PAPER_CASES,
    SCHEME_TITLES,
    SCHEMES,
    TOLERANCE,
    Row,
    claims,
    make_case,
    reproduce,
    run_one,
    summarise,
    wrap_label,
    wrap_sentence,
    write_summary,
)

warn_moved("ibvs.reproduce", "ibvs.study.reproduce")

__all__ = ["CASES", "DEFAULT_CASE", "DEPTH", "DURATION", "FIGURES", "GAIN", "PAPER_CASES", "Row", "SCHEMES",
           "SCHEME_TITLES", "TOLERANCE", "claims", "make_case", "reproduce", "run_one", "summarise", "wrap_label",
           "wrap_sentence", "write_summary"]
