"""Pseudoinverse: Moore-Penrose identities (damping 0), damped least squares (damping > 0)."""

from __future__ import annotations

import numpy as np
import pytest

import ibvs


def random_jacobians(rng):
    for m in [1, 2, 5, 6, 8, 16, 40]:
        J = rng.normal(size=(m, 6))
        yield J
        if m >= 2:
            K = J.copy()
            K[:, 4] = 2 * K[:, 1]  # rank-deficient
            yield K
        yield rng.normal(size=(m, 2)) @ rng.normal(size=(2, 6))  # rank <= 2


def test_moore_penrose_identities(rng):
    for J in random_jacobians(rng):
        P = ibvs.damped_pinv(J)
        assert P.shape == (6, J.shape[0])
        np.testing.assert_allclose(J @ P @ J, J, atol=1e-10)
        np.testing.assert_allclose(P @ J @ P, P, atol=1e-10)
        np.testing.assert_allclose((J @ P).T, J @ P, atol=1e-10)
        np.testing.assert_allclose((P @ J).T, P @ J, atol=1e-10)
        np.testing.assert_allclose(P, np.linalg.pinv(J), atol=1e-9)


@pytest.mark.parametrize("damping", [1e-3, 0.01, 1.0])
def test_damped_least_squares_formula(rng, damping):
    for J in random_jacobians(rng):
        P = ibvs.damped_pinv(J, damping=damping)
        # (J^T J + l^2 I)^-1 J^T, to the accuracy the normal equations allow (their condition grows as 1/l^2) ...
        normal = np.linalg.solve(J.T @ J + damping**2 * np.eye(6), J.T)
        np.testing.assert_allclose(P, normal, atol=1e-13 / damping**2)
        # ... and its SVD form V diag(s / (s^2 + l^2)) U^T, where a rank-deficient J's rounding-level
        # singular values (~1e-15) are amplified by 1/l^2.
        U, s, Vt = np.linalg.svd(J, full_matrices=False)
        np.testing.assert_allclose(P, Vt.T @ np.diag(s / (s**2 + damping**2)) @ U.T, atol=max(1e-12, 1e-15 / damping**2))


def test_zero_matrix_has_zero_pseudoinverse():
    np.testing.assert_array_equal(ibvs.damped_pinv(np.zeros((4, 6))), np.zeros((6, 4)))


def test_singular_values_match_numpy(rng):
    J = rng.normal(size=(16, 6))
    np.testing.assert_allclose(ibvs.singular_values(J), np.linalg.svd(J, compute_uv=False), rtol=1e-12)


@pytest.mark.parametrize(
    "J, damping, exc, word",
    [
        (np.zeros((0, 6)), 0.0, ValueError, "J"),
        (np.zeros((4, 5)), 0.0, ValueError, "J"),
        (np.zeros(6), 0.0, ValueError, "J"),
        (np.full((4, 6), np.nan), 0.0, ValueError, "J"),
        (np.ones((4, 6)), -1.0, ValueError, "damping"),
        (np.ones((4, 6)), float("nan"), ValueError, "damping"),
        ("abc", 0.0, TypeError, "J"),
        (None, 0.0, TypeError, "J"),
    ],
)
def test_bad_input_names_argument(J, damping, exc, word):
    with pytest.raises(exc, match=word):
        ibvs.damped_pinv(J, damping=damping)
