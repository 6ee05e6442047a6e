"""Shared fixtures: a seeded RNG and the paper's four-point target (Table I)."""

from __future__ import annotations

import os

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

import ibvs

# MuJoCo picks its OpenGL backend when first imported (by any test module, e.g. franky-sim's): headless OSMesa
# unless the environment says otherwise, as ibvs.sim.physics does (Debian: apt-get install libosmesa6).
os.environ.setdefault("MUJOCO_GL", "osmesa")

# Property tests (hypothesis): the same examples on every run by default, so that CI is reproducible and a
# failure is seen again; IBVS_HYPOTHESIS=explore draws new random examples (10 times as many) to hunt for
# more (a test's own @settings(max_examples=...) keeps its count).
settings.register_profile("ibvs", derandomize=True, deadline=None, max_examples=150,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("explore", deadline=None, max_examples=1500, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("IBVS_HYPOTHESIS", "ibvs"))

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
