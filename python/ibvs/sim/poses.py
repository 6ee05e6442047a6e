"""Small pose helpers for building start and goal poses (4x4, world <- camera). Angles are in
radians, as everywhere in ibvs; pose_deg (or degrees=True) takes degrees."""

from __future__ import annotations

import math
import warnings

import numpy as np

# What ibvs.sim re-exports (and documents); the other names here are its own helpers.
__all__ = ["rotation", "pose", "pose_deg"]


def _check_radians(r, stacklevel: int) -> None:
    """Warn when a rotation entry above 2 pi in magnitude looks like degrees."""
    big = [float(a) for a in r if abs(float(a)) > 2 * math.pi]
    if big:
        warnings.warn(f"rotation entry {big[0]:g} is larger than 2 pi: ibvs takes radians; for degrees use "
                      f"ibvs.sim.pose_deg or degrees=True", UserWarning, stacklevel=stacklevel + 1)


def rotation_matrix(rx: float, ry: float, rz: float) -> np.ndarray:
    """Rx(rx) @ Ry(ry) @ Rz(rz) of angles in radians, unchecked: what rotation() computes once it
    has checked its arguments (for callers whose angles are already checked: the sweeps' scenarios)."""

    def c_s(a: float) -> tuple[float, float]:
        q = a / (np.pi / 2)
        if abs(q - round(q)) < 1e-12:  # exact quarter turns
            return [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)][int(round(q)) % 4]
        return float(np.cos(a)), float(np.sin(a))

    cx, sx = c_s(rx)
    cy, sy = c_s(ry)
    cz, sz = c_s(rz)
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]], dtype=float)
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]], dtype=float)
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]], dtype=float)
    return Rx @ Ry @ Rz


def _angles(r, degrees: bool) -> tuple[float, float, float]:
    try:
        a = np.asarray(r, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"r must be 3 finite angles (rx, ry, rz), got {r!r}") from None
    if a.shape != (3,) or not np.isfinite(a).all():
        raise ValueError(f"r must be 3 finite angles (rx, ry, rz), got {r!r}")
    if degrees:
        a = np.radians(a)
    return float(a[0]), float(a[1]), float(a[2])


def rotation(rx: float = 0.0, ry: float = 0.0, rz: float = 0.0, *, degrees: bool = False) -> np.ndarray:
    """3x3 rotation Rx(rx) @ Ry(ry) @ Rz(rz) (ViSP's rxyz convention), in radians (degrees
    with degrees=True). An angle above 2 pi in magnitude warns that it looks like degrees.

    Angles that are exact multiples of pi/2 give exact 0/+-1 entries, so a half turn
    about z mirrors the image points exactly (the paper's z-rotation of pi).
    """
    a = _angles((rx, ry, rz), degrees)
    if not degrees:
        _check_radians(a, stacklevel=2)
    return rotation_matrix(*a)


def pose(t=(0.0, 0.0, 0.0), r=(0.0, 0.0, 0.0), *, degrees: bool = False) -> np.ndarray:
    """4x4 rigid transform with translation t (metres) and rotation rotation(*r): r in radians
    (rx, ry, rz), or in degrees with degrees=True. An entry of r above 2 pi in magnitude warns
    that it looks like degrees (pose(r=(0, 0, 170)) is 170 radians)."""
    a = _angles(r, degrees)
    if not degrees:
        _check_radians(a, stacklevel=2)
    T = np.eye(4)
    T[:3, :3] = rotation_matrix(*a)
    try:
        tt = np.asarray(t, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"t must be 3 finite numbers (metres), got {t!r}") from None
    if tt.shape != (3,) or not np.isfinite(tt).all():
        raise ValueError(f"t must be 3 finite numbers (metres), got {t!r}")
    T[:3, 3] = tt
    return T


def pose_deg(t=(0.0, 0.0, 0.0), r_deg=(0.0, 0.0, 0.0)) -> np.ndarray:
    """pose() with the rotation (rx, ry, rz) in degrees: pose_deg(r_deg=(0, 0, 170))."""
    return pose(t, r_deg, degrees=True)
