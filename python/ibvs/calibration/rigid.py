"""Rigid transforms for the calibration: stacks of 4x4 poses checked by the finite-or-refused rule, and the small
algebra the hand-eye solver and its residuals need (inverse, rotation angle, mean, difference).

Poses are 4x4 "a <- b" transforms in metres (ibvs's convention): x_a = R x_b + t.
"""

from __future__ import annotations

import math

import numpy as np

from ..finite import finite_within

__all__ = [
    "MAX_TRANSLATION",
    "ORTHONORMAL_TOLERANCE",
    "as_pose_stack",
    "invert",
    "mean_pose",
    "pose_error",
    "rotation_angle",
]

#: Largest translation (m) of a pose the calibration accepts (as ibvs.sim.solve_ik).
MAX_TRANSLATION = 1e6
#: How far from orthonormal (max |R R^T - I|) a rotation may be; within it, it is projected onto the nearest rotation.
ORTHONORMAL_TOLERANCE = 1e-6


def as_pose_stack(poses, name: str, min_count: int = 0) -> np.ndarray:
    """poses (a sequence of 4x4 arrays, or an (N, 4, 4) array) as a float (N, 4, 4) array of rigid transforms, each
    rotation projected onto the nearest orthonormal one; or a TypeError (not real numbers) / ValueError (shape, not
    finite, not rigid, translation beyond MAX_TRANSLATION, fewer than min_count) naming `name` and the pose."""
    if isinstance(poses, (str, bytes)) or poses is None:
        raise TypeError(f"{name} must be a sequence of 4x4 poses, got {type(poses).__name__}")
    try:
        a = np.asarray(poses)
    except (TypeError, ValueError):  # ragged nesting
        raise ValueError(f"{name} must be a sequence of 4x4 poses (an (N, 4, 4) array)") from None
    if a.dtype.kind not in "iuf":
        raise TypeError(f"{name} must hold real numbers, got {a.dtype} ({type(poses).__name__})")
    if a.ndim != 3 or a.shape[1:] != (4, 4):
        raise ValueError(f"{name} must have shape (N, 4, 4), got {a.shape}")
    if len(a) < min_count:
        raise ValueError(f"{name}: at least {min_count} poses are needed, got {len(a)}")
    a = a.astype(float)
    for i, T in enumerate(a):
        if not np.isfinite(T).all():
            raise ValueError(f"{name}[{i}] is not finite")
        R = T[:3, :3]
        if not finite_within(T[3] - (0.0, 0.0, 0.0, 1.0), 1e-9):
            raise ValueError(f"{name}[{i}] is not a rigid transform: its last row must be (0, 0, 0, 1)")
        if not finite_within(R @ R.T - np.eye(3), ORTHONORMAL_TOLERANCE) or not np.linalg.det(R) > 0:
            raise ValueError(f"{name}[{i}] is not a rigid transform: its rotation must be orthonormal with det +1 "
                             f"(within {ORTHONORMAL_TOLERANCE:g})")
        if not finite_within(T[:3, 3], MAX_TRANSLATION):
            raise ValueError(f"{name}[{i}]: translation beyond {MAX_TRANSLATION:g} m")
        U, _, Vt = np.linalg.svd(R)  # the nearest rotation (det +1 holds: R is within 1e-6 of one)
        a[i, :3, :3] = U @ Vt
        a[i, 3] = (0.0, 0.0, 0.0, 1.0)
    return a


def invert(T: np.ndarray) -> np.ndarray:
    """The inverse of a rigid transform (or of each of a stack (..., 4, 4)): b <- a from a <- b, as (R^T, -R^T t)."""
    T = np.asarray(T, dtype=float)
    out = np.zeros_like(T)
    Rt = np.swapaxes(T[..., :3, :3], -1, -2)
    out[..., :3, :3] = Rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", Rt, T[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def rotation_angle(R: np.ndarray) -> np.ndarray:
    """The angle (rad, in [0, pi]) of a rotation (3, 3) or of each of a stack (..., 3, 3), from both its trace and its
    antisymmetric part (accurate for small angles, where arccos of the trace alone loses half the digits)."""
    R = np.asarray(R, dtype=float)
    w = np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1)
    return np.arctan2(np.linalg.norm(w, axis=-1) / 2, (np.trace(R, axis1=-2, axis2=-1) - 1) / 2)


def pose_error(estimate, truth) -> tuple[float, float]:
    """(translation (m), rotation (rad)) between two poses a <- b: the distance between their translations and the
    angle of R_truth^T R_estimate. For an estimated eMc against the true one: how far the camera is placed."""
    E = as_pose_stack([estimate], "estimate")[0]
    T = as_pose_stack([truth], "truth")[0]
    return float(np.linalg.norm(E[:3, 3] - T[:3, 3])), float(rotation_angle(T[:3, :3].T @ E[:3, :3]))


def mean_pose(poses: np.ndarray) -> np.ndarray:
    """The mean of rigid transforms (N, 4, 4): the arithmetic mean of the translations and the chordal L2 mean of the
    rotations (the rotation nearest, in Frobenius norm, to the sum of the rotations; Hartley et al. 2013)."""
    poses = np.asarray(poses, dtype=float)
    U, _, Vt = np.linalg.svd(poses[:, :3, :3].sum(0))
    D = np.diag([1.0, 1.0, math.copysign(1.0, np.linalg.det(U @ Vt))])
    out = np.eye(4)
    out[:3, :3] = U @ D @ Vt
    out[:3, 3] = poses[:, :3, 3].mean(0)
    return out
