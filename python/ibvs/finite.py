"""The one finiteness check of the Python layer (as cpp/include/ibvs/finite.hpp is the C++ one): every entry
finite, NaN and +-inf refused wherever they sit, and every magnitude within a bound. `np.abs(x).max() > bound`
alone is not such a check: NaN > bound is False, so a NaN passes it (tests/python/test_finite_checks.py forbids
that pattern in python/)."""

from __future__ import annotations

import numpy as np

__all__ = ["finite_within"]


def finite_within(x, bound: float) -> bool:
    """Every entry of x finite and |x| <= bound (True for an empty x)."""
    a = np.asarray(x, dtype=float)
    return bool(np.isfinite(a).all() and (a.size == 0 or np.abs(a).max(initial=0.0) <= bound))
