"""Small pose helpers for building start and goal poses (4x4, world <- camera)."""

from __future__ import annotations

import numpy as np


def rotation(rx: float = 0.0, ry: float = 0.0, rz: float = 0.0) -> np.ndarray:
    """3x3 rotation Rx(rx) @ Ry(ry) @ Rz(rz) (ViSP's rxyz convention), radians.

    Angles that are exact multiples of pi/2 give exact 0/+-1 entries, so a half turn
    about z mirrors the image points exactly (the paper's z-rotation of pi).
    """

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


def pose(t=(0.0, 0.0, 0.0), r=(0.0, 0.0, 0.0)) -> np.ndarray:
    """4x4 rigid transform with translation t (metres) and rotation rotation(*r) (radians)."""
    T = np.eye(4)
    T[:3, :3] = rotation(*r)
    T[:3, 3] = np.asarray(t, dtype=float)
    return T
