"""Jacobians against central differences of the projection of a static point under a small camera twist."""

from __future__ import annotations

import numpy as np
import pytest

import ibvs


def moved_uv(P: np.ndarray, twist: np.ndarray) -> np.ndarray:
    """Image point of camera-frame point P after the camera moves with `twist` for unit time."""
    T = np.linalg.inv(ibvs.se3_exp(twist))
    Q = T[:3, :3] @ P + T[:3, 3]
    return Q[:2] / Q[2]


def numeric_jacobian(uv: np.ndarray, z: float, layout: ibvs.Layout, h: float) -> np.ndarray:
    P = np.array([uv[0] * z, uv[1] * z, z])
    cols = []
    for k in range(6):
        d = np.zeros(6)
        d[k] = h
        fa = ibvs.features(moved_uv(P, d)[None, :], layout)
        fb = ibvs.features(moved_uv(P, -d)[None, :], layout)
        cols.append(ibvs.feature_error(fa, fb, layout) / (2 * h))  # wraps theta differences
    return np.array(cols).T


def random_points(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    r = np.exp(rng.uniform(np.log(1e-3), np.log(1.0), n))
    theta = rng.uniform(-np.pi, np.pi, n)
    z = np.exp(rng.uniform(np.log(0.1), np.log(10.0), n))
    return np.column_stack([r * np.cos(theta), r * np.sin(theta)]), z


@pytest.mark.parametrize("kind", ["cartesian", "polar"])
def test_jacobian_matches_finite_differences(rng, kind):
    layout = getattr(ibvs.Layout, kind)(1)
    uv, z = random_points(rng, 300)
    # Edge samples: theta at and around +-pi, small radius, extreme depths.
    edges = np.array([[-0.2, 0.0], [-0.2, 1e-12], [-0.2, -1e-12], [2e-3, 0.0], [0.0, -2e-3], [0.3, 0.3]])
    uv = np.vstack([uv, edges, edges])
    z = np.concatenate([z, np.full(len(edges), 0.1), np.full(len(edges), 10.0)])
    for p, depth in zip(uv, z):
        r = np.hypot(*p)
        h = 1e-6 * min(1.0, depth, 10 * r)
        J = ibvs.jacobian(p[None, :], depth, layout)
        Jn = numeric_jacobian(p, depth, layout, h)
        np.testing.assert_allclose(J, Jn, rtol=1e-6, atol=1e-6 * np.abs(J).max(), err_msg=f"{kind} at {p}, z={depth}")


def test_polar_jacobian_is_negated_print_of_eq7():
    u, v, z = 0.15, -0.1, 2.0
    r, c, s = np.hypot(u, v), u / np.hypot(u, v), v / np.hypot(u, v)
    printed = np.array(
        [[c / z, s / z, -r / z, -(1 + r * r) * s, (1 + r * r) * c, 0], [-s / (r * z), c / (r * z), 0, -c / r, -s / r, 1]]
    )
    np.testing.assert_allclose(ibvs.jacobian([[u, v]], z, ibvs.Layout.polar(1)), -printed, rtol=1e-14)


def test_cartesian_jacobian_is_eq3():
    u, v, z = 0.1, -0.2, 1.5
    eq3 = np.array([[-1 / z, 0, u / z, u * v, -(1 + u * u), v], [0, -1 / z, v / z, 1 + v * v, -u * v, -u]])
    np.testing.assert_allclose(ibvs.jacobian([[u, v]], z, ibvs.Layout.cartesian(1)), eq3, rtol=1e-15)


def test_row_order_follows_layout(rng, per_point_hybrid):
    uv = rng.uniform(-0.3, 0.3, (4, 2))
    z = rng.uniform(0.5, 3.0, 4)
    custom = ibvs.Layout([(3, "polar"), (0, "cartesian"), (3, "cartesian"), (1, "polar")], n_points=4)
    for layout in [ibvs.Layout.cartesian(4), ibvs.Layout.polar(4), ibvs.Layout.stacked(4), per_point_hybrid, custom]:
        J = ibvs.jacobian(uv, z, layout)
        f = ibvs.features(uv, layout)
        assert J.shape == (layout.rows, 6) and f.shape == (layout.rows,)
        for k, (i, rep) in enumerate(layout.blocks):
            single = getattr(ibvs.Layout, rep)(1)
            np.testing.assert_array_equal(J[2 * k : 2 * k + 2], ibvs.jacobian(uv[i : i + 1], z[i], single))
            np.testing.assert_array_equal(f[2 * k : 2 * k + 2], ibvs.features(uv[i : i + 1], single))
    assert ibvs.Layout.stacked(4).rows == 16 and ibvs.Layout.cartesian(4).rows == 8
    assert ibvs.Layout.polar(64).rows == 128 and ibvs.Layout.stacked(64).rows == 256


def test_stacked_layout_interleaves_cartesian_then_polar():
    assert ibvs.Layout.stacked(2).blocks == [(0, "cartesian"), (0, "polar"), (1, "cartesian"), (1, "polar")]


def test_principal_point_falls_back_to_cartesian_rows():
    uv = np.array([[0.0, 0.0], [0.1, 0.1]])
    J = ibvs.jacobian(uv, 1.5, ibvs.Layout.polar(2))
    assert np.isfinite(J).all()
    np.testing.assert_array_equal(J[:2], ibvs.jacobian(uv[:1], 1.5, ibvs.Layout.cartesian(1)))
    f = ibvs.features(uv, ibvs.Layout.polar(2))
    assert np.isfinite(f).all() and f[0] == 0.0 and f[1] == 0.0


def test_features_are_polar_coordinates(rng):
    uv = rng.uniform(-0.3, 0.3, (5, 2))
    f = ibvs.features(uv, ibvs.Layout.polar(5)).reshape(5, 2)
    np.testing.assert_allclose(f[:, 0], np.hypot(uv[:, 0], uv[:, 1]))
    np.testing.assert_allclose(f[:, 1], np.arctan2(uv[:, 1], uv[:, 0]))


def test_any_memory_order_is_accepted(rng):
    uv = rng.uniform(-0.3, 0.3, (4, 2))
    layout = ibvs.Layout.stacked(4)
    ref = ibvs.jacobian(uv, 2.0, layout)
    np.testing.assert_array_equal(ibvs.jacobian(np.asfortranarray(uv), 2.0, layout), ref)
    np.testing.assert_array_equal(ibvs.jacobian(uv.T.copy().T, 2.0, layout), ref)
    wide = np.zeros((4, 4))
    wide[:, ::2] = uv
    np.testing.assert_array_equal(ibvs.jacobian(wide[:, ::2], 2.0, layout), ref)  # strided view
    np.testing.assert_array_equal(ibvs.jacobian(uv.astype(np.float32).astype(np.float64), 2.0, layout).shape, (16, 6))
    np.testing.assert_array_equal(ibvs.jacobian(uv.tolist(), [2.0] * 4, layout), ref)
