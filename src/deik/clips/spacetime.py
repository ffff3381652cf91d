"""Smooth displacements over a whole clip: the spring energy that fades a correction, and the
space-time least-squares step that meets every frame's goals with it.

Per DOF, displacements x (N,) from the capture in weighted DOF units (radians; a root
translation counted as the root turn that moves the body as far, warmstart.dof_weights) cost

    E(x) = sum_n  x[n]^2 / L^4  +  2 (x[n+1] - x[n])^2 / L^2  +  (x[n+2] - 2 x[n+1] + x[n])^2,

L a length in frames: a critically damped spring. Where no goal holds a DOF, the x minimising
E carries a correction on at the rate it had and fades it back to the capture with no kink in
value or rate. A step of the whole clip at once (spacetime_step) minimises E plus every frame's
goal rows, weighted: a contact that starts, or a foot that lifts, bends the displacement
smoothly over the neighbouring frames instead of in one frame, so fixes add no jolts. E's
matrix is pentadiagonal in time (spring_bands), so the step's normal equations are block
pentadiagonal (one D x D block per frame, diagonal couplings between frames), solved by block
Cholesky in O(N D^3).
"""

from __future__ import annotations

import numpy as np


def spring_bands(n: int, length: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(diagonal (n,), first (n-1,), second (n-2,)) bands of the symmetric matrix K of the
    spring energy E(x) = x^T K x over n frames with fade `length` > 0 frames (module notes)."""
    a0 = np.full(n, length**-4.0)
    a1 = np.zeros(max(n - 1, 0))
    a2 = np.zeros(max(n - 2, 0))
    rate = 2.0 / length**2  # with the two others: critical damping
    a0[:-1] += rate
    a0[1:] += rate
    a1 -= rate
    if n >= 3:  # second differences (x[k], x[k+1], x[k+2]), weights 1, -2, 1
        for k, c in enumerate((1.0, -2.0, 1.0)):
            a0[k : n - 2 + k] += c * c
        a1[:-1] -= 2.0
        a1[1:] -= 2.0
        a2 += 1.0
    return a0, a1, a2


def spring_product(bands, x: np.ndarray) -> np.ndarray:
    """K x for x (N, ...) and the bands (spring_bands) of K, along the first axis."""
    a0, a1, a2 = (np.reshape(b, b.shape + (1,) * (x.ndim - 1)) for b in bands)
    out = a0 * x
    out[:-1] += a1 * x[1:]
    out[1:] += a1 * x[:-1]
    out[:-2] += a2 * x[2:]
    out[2:] += a2 * x[:-2]
    return out


def solve_block_bands(diagonal: np.ndarray, first: np.ndarray, second: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Solve M z = rhs for symmetric positive definite block-pentadiagonal M: `diagonal` (N, D,
    D) blocks, frame n coupled to n+1 by diag(first[n]) (N-1, D) and to n+2 by diag(second[n])
    (N-2, D); rhs (N, D). Block Cholesky M = L L^T with L's blocks P (diagonal, kept as their
    inverses: the couplings are diagonal, so every other product is a scaling or a matmul), Q
    (one below) and R (two below)."""
    from scipy.linalg import lapack  # scipy loads with the first fix, not with `import deik`

    N, D = rhs.shape
    inverse, Q, R = np.zeros((N, D, D)), np.zeros((N, D, D)), np.zeros((N, D, D))
    y = np.zeros((N, D))
    for k in range(N):
        block = diagonal[k].copy()
        b = rhs[k].copy()
        if k >= 2:  # M[k, k-2] = R_k P_{k-2}^T
            R[k] = (inverse[k - 2] * second[k - 2]).T
            block -= R[k] @ R[k].T
            b -= R[k] @ y[k - 2]
        if k >= 1:  # M[k, k-1] = Q_k P_{k-1}^T + R_k Q_{k-1}^T
            coupling = np.diag(first[k - 1]) - (R[k] @ Q[k - 1].T if k >= 2 else 0.0)
            Q[k] = (inverse[k - 1] @ coupling.T).T
            block -= Q[k] @ Q[k].T
            b -= Q[k] @ y[k - 1]
        # LAPACK directly: scipy.linalg's wrappers cost milliseconds a call on these small blocks
        factor, info = lapack.dpotrf(block, lower=1, clean=1)
        if info == 0:
            inverse[k], info = lapack.dtrtri(factor, lower=1)
        if info != 0:
            raise np.linalg.LinAlgError(f"block {k} of the space-time system is not positive definite")
        y[k] = inverse[k] @ b
    z = np.zeros((N, D))
    for k in range(N - 1, -1, -1):
        b = y[k].copy()
        if k + 1 < N:
            b -= Q[k + 1].T @ z[k + 1]
        if k + 2 < N:
            b -= R[k + 2].T @ z[k + 2]
        z[k] = inverse[k].T @ b
    return z


def spacetime_step(
    rows: np.ndarray,
    errors: np.ndarray,
    weights: np.ndarray,
    x: np.ndarray,
    movable: np.ndarray,
    length: float,
    damping: float = 0.0,
    stiffness: np.ndarray | None = None,
) -> np.ndarray:
    """(N, D) step s minimising sum_n |sqrt(weights[n]) (rows[n] s[n] - errors[n])|^2 + E(x + s)
    + damping |s|^2 (module notes) over the `movable` (N, D) entries (the others stay 0): goal
    `rows` (N, R, D) per unit of the weighted DOFs, their `errors` (N, R) and `weights` (N, R);
    x (N, D) the current displacement in weighted units; E's fade `length` in frames; `damping`
    (Levenberg-Marquardt) keeps a step short along directions the rows barely move, where goals
    that cannot all be met would otherwise pull a joint round for a micron; `stiffness` (D,)
    scales each DOF's E (default 1)."""
    N, D = x.shape
    movable = np.asarray(movable, bool)
    # a DOF no row of any frame moves, and that is not displaced yet, stays where it is: leave it out
    used = movable.any(axis=0) & ((rows != 0).any(axis=(0, 1)) | (x != 0).any(axis=0))
    step = np.zeros((N, D))
    if not used.any():
        return step
    rows, x, movable = rows[..., used], x[:, used], movable[:, used]
    U = int(used.sum())
    c = np.ones(U) if stiffness is None else np.asarray(stiffness, float)[used]
    bands = spring_bands(N, length)
    weighted = rows * weights[..., None]
    diagonal = np.einsum("nrd,nre->nde", weighted, rows)
    diagonal[:, np.arange(U), np.arange(U)] += bands[0][:, None] * c + damping
    rhs = np.einsum("nrd,nr->nd", weighted, errors) - c * spring_product(bands, np.where(movable, x, 0.0))
    # held entries: an identity row and column, no coupling, a zero right-hand side
    diagonal = np.where(movable[:, :, None] & movable[:, None, :], diagonal, 0.0)
    diagonal[:, np.arange(U), np.arange(U)] += ~movable
    first = np.where(movable[:-1] & movable[1:], bands[1][:, None] * c, 0.0)
    second = np.where(movable[:-2] & movable[2:], bands[2][:, None] * c, 0.0)
    step[:, used] = solve_block_bands(diagonal, first, second, np.where(movable, rhs, 0.0))
    return step
