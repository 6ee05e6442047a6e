"""What a tracker or a tag detector reports for one frame: a Track."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Tuple

import numpy as np

# What ibvs.vision re-exports (and documents); the other names here are its own helpers.
__all__ = ["Track"]


@dataclass(frozen=True)
class Track:
    """One frame's detection: pixels (N, 2) (NaN rows: not measured), status per point ("tracked",
    "detected", "lost_gate": no dot wholly inside its tracking gate, "lost_border": touches or
    left the image, "not_found": tag not detected, "conflict": the blob was already another
    point's), and the detection time (s)."""

    pixels: np.ndarray
    status: Tuple[str, ...]
    seconds: float

    @property
    def lost(self) -> Tuple[int, ...]:
        """Indices of the points not measured this frame."""
        return tuple(i for i, s in enumerate(self.status) if s not in ("tracked", "detected"))
