"""Banded matrices over a clip's frames, and the symmetric positive definite systems they make
solved by banded Cholesky.

A matrix A (N, N) of half width W (A[n, m] = 0 where |n - m| > W) is stored by rows as `band`
(N, 2W + 1), band[n, W + o] = A[n, n + o], entries past the ends 0. A symmetric one needs only
its upper half: `upper` (n, P + 1), upper[j, i] = A[j, j + i]. A clip fix couples each frame
to the few frames around it, so its systems are banded: a solve costs O(n P^2) time and O(n P)
memory where a dense one would take O(n^3) and O(n^2) (3.2 GB for a 10,000-frame balance
track). The factorisation runs in Numba: it is a loop over rows that NumPy would call per row.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np


def _rows(N: int, offset: int) -> tuple[int, int]:
    """[start, stop) of the rows n with 0 <= n + offset < N (empty when none)."""
    start = max(0, -offset)
    return start, max(start, min(N, N - offset))


def band_apply(band: np.ndarray, x: np.ndarray) -> np.ndarray:
    """A x for the banded A (N, N) stored by rows in `band` (N, 2W + 1), x (N, ...)."""
    N, W = len(band), band.shape[1] // 2
    out = np.zeros(np.shape(x))
    for o in range(-W, W + 1):
        start, stop = _rows(N, o)
        column = band[start:stop, W + o]
        out[start:stop] += column.reshape(column.shape + (1,) * (out.ndim - 1)) * x[start + o : stop + o]
    return out


def band_compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N, 2(Wa + Wb) + 1, ...): A B by rows, for A and B (N, N) stored by rows in a (N, 2Wa + 1)
    and b (N, 2Wb + 1, ...) (several B at once along b's further axes)."""
    N, Wa, Wb = len(a), a.shape[1] // 2, b.shape[1] // 2
    out = np.zeros((N, 2 * (Wa + Wb) + 1) + b.shape[2:])
    for i in range(-Wa, Wa + 1):  # A[n, n + i] times row n + i of B
        start, stop = _rows(N, i)
        column = a[start:stop, Wa + i]
        out[start:stop, Wa + i : Wa + i + 2 * Wb + 1] += (
            column.reshape(column.shape + (1,) * (b.ndim - 1)) * b[start + i : stop + i]
        )
    return out


def band_transpose(band: np.ndarray) -> np.ndarray:
    """(N, 2W + 1): A^T by rows, for A (N, N) stored by rows in `band` (N, 2W + 1)."""
    N, W = len(band), band.shape[1] // 2
    out = np.zeros_like(band, dtype=float)
    for o in range(-W, W + 1):  # A^T[n, n + o] = A[n + o, n]
        start, stop = _rows(N, o)
        out[start:stop, W + o] = band[start + o : stop + o, W - o]
    return out


def solve_spd_band(upper: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """x (n,) with A x = rhs (n,) for the symmetric positive definite A given by its upper half
    `upper` (n, P + 1) (module notes): A = L L^T, then two triangular solves. Raises
    numpy.linalg.LinAlgError naming the first row where A is not positive definite."""
    solve = _compiled_cholesky_solve()
    x, failed = solve(np.ascontiguousarray(upper, dtype=float), np.ascontiguousarray(rhs, dtype=float))
    if failed >= 0:
        raise np.linalg.LinAlgError(f"row {failed} of a banded system is not positive definite")
    return x


@lru_cache(maxsize=1)
def _compiled_cholesky_solve():
    """_cholesky_solve compiled by Numba (cached on disk) at the first solve: `import deik` stays light."""
    from numba import njit

    return njit(cache=True)(_cholesky_solve)


def _cholesky_solve(upper, rhs):
    """(x, -1), or (rhs, the row) where the matrix is not positive definite. L is kept by columns
    in the layout of `upper`: L[j + i, j] at [j, i]."""
    n, width = upper.shape
    L = upper.copy()
    for j in range(n):
        pivot = L[j, 0]
        if not pivot > 0.0:  # NaN too
            return rhs.copy(), j
        pivot = math.sqrt(pivot)
        L[j, 0] = pivot
        below = min(width - 1, n - 1 - j)
        for i in range(1, below + 1):
            L[j, i] /= pivot
        for c in range(1, below + 1):  # the trailing block loses column j's outer product
            lc = L[j, c]
            if lc != 0.0:
                for r in range(c, below + 1):
                    L[j + c, r - c] -= L[j, r] * lc
    x = rhs.copy()
    for j in range(n):  # L y = rhs
        x[j] /= L[j, 0]
        for i in range(1, min(width - 1, n - 1 - j) + 1):
            x[j + i] -= L[j, i] * x[j]
    for j in range(n - 1, -1, -1):  # L^T x = y
        total = x[j]
        for i in range(1, min(width - 1, n - 1 - j) + 1):
            total -= L[j, i] * x[j + i]
        x[j] = total / L[j, 0]
    return x, -1
