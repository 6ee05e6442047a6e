"""The deprecated module names kept for one release after a module moved: warn_moved tells whoever
imports one where the module went."""

from __future__ import annotations

import warnings

# Nothing public: the deprecated modules' warning, used inside ibvs only.
__all__: list[str] = []


def warn_moved(old: str, new: str) -> None:
    """Issue one DeprecationWarning saying that module `old` is now `new`; called from the body of
    the module `old`. stacklevel 3 is the code that imported `old` (warnings skips the import
    machinery's frames), so that Python's default filters show it when that code is a script."""
    warnings.warn(f"{old} is deprecated: import {new} instead (the same names); {old} will be removed in the "
                  f"next release", DeprecationWarning, stacklevel=3)
