"""Banded matrices of cleanup/banded.py against the same matrices dense: products, transposes and
symmetric positive definite solves."""

import numpy as np
import pytest

from deik.cleanup.banded import band_apply, band_compose, band_transpose, solve_spd_band


def random_band(rng, N, W):
    """(band (N, 2W + 1) by rows, the same matrix dense (N, N)), entries past the ends 0."""
    dense = rng.normal(size=(N, N))
    dense[np.abs(np.subtract.outer(np.arange(N), np.arange(N))) > W] = 0.0
    band = np.zeros((N, 2 * W + 1))
    for n in range(N):
        for o in range(-W, W + 1):
            if 0 <= n + o < N:
                band[n, W + o] = dense[n, n + o]
    return band, dense


@pytest.mark.parametrize("N, Wa, Wb", [(1, 0, 0), (2, 1, 3), (7, 2, 1), (30, 4, 6), (5, 8, 2)])
def test_band_products_and_transpose_match_dense(N, Wa, Wb):
    rng = np.random.default_rng(N + Wa + Wb)
    (a, A), (b, B) = random_band(rng, N, Wa), random_band(rng, N, Wb)
    x = rng.normal(size=(N, 3))
    np.testing.assert_allclose(band_apply(a, x), A @ x, atol=1e-12)
    np.testing.assert_allclose(band_apply(a, x[:, 0]), A @ x[:, 0], atol=1e-12)
    np.testing.assert_allclose(band_apply(band_compose(a, b), x), A @ B @ x, atol=1e-12)
    np.testing.assert_allclose(band_apply(band_transpose(a), x), A.T @ x, atol=1e-12)


@pytest.mark.parametrize("n, P", [(1, 0), (1, 3), (2, 1), (40, 1), (40, 6), (25, 40)])
def test_solve_spd_band_is_the_dense_solution(n, P):
    rng = np.random.default_rng(n * 100 + P)
    _, G = random_band(rng, n, P // 2)
    A = G @ G.T + 0.1 * np.eye(n)  # symmetric positive definite, half width <= P
    upper = np.zeros((n, P + 1))
    for j in range(n):
        for i in range(min(P, n - 1 - j) + 1):
            upper[j, i] = A[j, j + i]
    rhs = rng.normal(size=n)
    np.testing.assert_allclose(solve_spd_band(upper, rhs), np.linalg.solve(A, rhs), rtol=1e-9, atol=1e-12)


def test_solve_spd_band_refuses_a_matrix_that_is_not_positive_definite():
    upper = np.array([[1.0, 2.0], [1.0, 0.0]])  # [[1, 2], [2, 1]]: eigenvalues 3 and -1
    with pytest.raises(np.linalg.LinAlgError, match="row 1 of a banded system is not positive definite"):
        solve_spd_band(upper, np.ones(2))
    with pytest.raises(np.linalg.LinAlgError, match="row 0"):
        solve_spd_band(np.array([[np.nan]]), np.ones(1))
