"""Shared fixtures: a seeded RNG and the paper's four-point target (Table I)."""

from __future__ import annotations

import numpy as np
import pytest

import ibvs

#: The paper's target points in the world (Table I), metres.
TARGET = np.array([[0.25, 0.25, 3.0], [-0.25, 0.25, 3.0], [-0.25, -0.25, 3.0], [0.25, -0.25, 3.0]])


def look(T_wc: np.ndarray, points: np.ndarray = TARGET) -> tuple[np.ndarray, np.ndarray]:
    """Normalised image points (N, 2) and depths (N,) of world points seen from pose T_wc."""
    T_cw = np.linalg.inv(T_wc)
    Q = points @ T_cw[:3, :3].T + T_cw[:3, 3]
    return Q[:, :2] / Q[:, 2:], Q[:, 2]


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture
def per_point_hybrid() -> ibvs.Layout:
    """The paper's Fig. 5 layout: Cartesian for two points, polar for the other two."""
    return ibvs.Layout([(0, "cartesian"), (1, "cartesian"), (2, "polar"), (3, "polar")])
