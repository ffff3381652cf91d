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
pentadiagonal (one D x D block per frame, diagonal couplings between frames), solved by banded
Cholesky in O(N D^3).
"""

from __future__ import annotations

import numpy as np

from deik.cleanup.banded import solve_spd_band


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


def spring_product(bands: tuple[np.ndarray, np.ndarray, np.ndarray], x: np.ndarray) -> np.ndarray:
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
    (N-2, D); rhs (N, D). With the unknowns frame by frame, M is banded, half width 2D
    (cleanup/banded.py): its Cholesky factor keeps that band, O(N D^3) time, O(N D^2) memory."""
    N, D = rhs.shape
    upper = np.zeros((N, D, 2 * D + 1))  # [n, a, i]: M's entry of unknown (n, a) and the i-th after it
    a, b = np.triu_indices(D)
    upper[:, a, b - a] = diagonal[:, a, b]
    upper[:-1, np.arange(D), D] = first
    upper[:-2, np.arange(D), 2 * D] = second
    return solve_spd_band(upper.reshape(N * D, 2 * D + 1), rhs.reshape(N * D)).reshape(N, D)


def spring_energy(x: np.ndarray, length: float, stiffness: np.ndarray | None = None) -> float:
    """E(x) summed over the DOFs: x (N, D) displacements in weighted units, fade `length` frames,
    each DOF's energy scaled by `stiffness` (D,) (default 1)."""
    c = 1.0 if stiffness is None else np.asarray(stiffness, float)
    return float((c * x * spring_product(spring_bands(len(x), length), x)).sum())


def spacetime_step(
    goal: tuple[np.ndarray, np.ndarray, np.ndarray],
    x: np.ndarray,
    movable: np.ndarray,
    length: float,
    damping: float = 0.0,
    stiffness: np.ndarray | None = None,
    steps: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """(N, D) step s minimising sum_n |sqrt(weights[n]) (rows[n] s[n] - errors[n])|^2 + E(x + s)
    + damping |s|^2 (module notes) over the `movable` (N, D) entries (the others stay 0): `goal`
    = (rows (N, R, D) per unit of the weighted DOFs, their errors (N, R), weights (N, R));
    x (N, D) the current displacement in weighted units; E's fade `length` in frames; `damping`
    (Levenberg-Marquardt) keeps a step short along directions the rows barely move, where goals
    that cannot all be met would otherwise pull a joint round for a micron; `stiffness` (D,)
    scales each DOF's E (default 1); `steps` = (weights (N-1, D), errors (N-1, D)) adds a row
    per DOF and pair of frames asking s[n+1] - s[n] to be errors[n] (a DOF's step between frames
    shrunk to its velocity limit), which couples frame n only to n+1 on the same DOF."""
    rows, errors, weights = goal
    N, D = x.shape
    movable = np.asarray(movable, bool)
    # a DOF no row of any frame moves, and that is not displaced yet, stays where it is: leave it out
    used = (rows != 0).any(axis=(0, 1)) | (x != 0).any(axis=0)
    used = movable.any(axis=0) & (used | (steps is not None and (np.asarray(steps[0]) != 0).any(axis=0)))
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
    # E's gradient at the whole displacement: a held entry's displacement (a DOF at a limit, a
    # frame outside a reach window) still pulls its movable neighbours towards it
    rhs = np.einsum("nrd,nr->nd", weighted, errors) - c * spring_product(bands, x)
    coupling = np.zeros((max(N - 1, 0), U))
    if steps is not None:  # w (s[n+1] - s[n] - e)^2: w on both diagonals, -w between them
        w, e = (np.asarray(a, float)[:, used] for a in steps)
        diagonal[:-1, np.arange(U), np.arange(U)] += w
        diagonal[1:, np.arange(U), np.arange(U)] += w
        coupling = -w
        rhs[:-1] -= w * e
        rhs[1:] += w * e
    # held entries: an identity row and column, no coupling, a zero right-hand side
    diagonal = np.where(movable[:, :, None] & movable[:, None, :], diagonal, 0.0)
    diagonal[:, np.arange(U), np.arange(U)] += ~movable
    first = np.where(movable[:-1] & movable[1:], bands[1][:, None] * c + coupling, 0.0)
    second = np.where(movable[:-2] & movable[2:], bands[2][:, None] * c, 0.0)
    step[:, used] = solve_block_bands(diagonal, first, second, np.where(movable, rhs, 0.0))
    return step
