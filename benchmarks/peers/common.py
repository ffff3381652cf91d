"""What every peer adapter shares: stopping tolerances, the per-solve budget, the iterative loop.

An adapter module defines PACKAGE (its distribution name, for the version) and a class `Peer`:
`Peer(urdf, base, tip, dof_names)` loads the cut URDF (benchmarks.peers.chain_urdf);
`peer.settings` is a dict of what it uses; `peer.fk(q)` -> tip position (3,) m and rotation
(3, 3) for q (D,) in deik's DOF order; `peer.solve(position, rotation, start)` -> q (D,).
"""

from __future__ import annotations

import time

import numpy as np

POS_TOL, ROT_TOL = 1e-5, 1e-4  # m, rad: loops stop once both hold (the benchmark's strict level)
BUDGET_S = 0.005  # wall-clock budget of one solve, for loops that can check the clock
MAX_ITERATIONS = 500  # hard cap on the iterations of one solve


def rotation_angle(R_a: np.ndarray, R_b: np.ndarray) -> float:
    """Angle (rad) of R_a^T R_b; accurate near 0."""
    M = R_a.T @ R_b
    vee = np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]])
    return float(np.arctan2(np.linalg.norm(vee) / 2, (np.trace(M) - 1) / 2))


def reached(pose: tuple[np.ndarray, np.ndarray], position: np.ndarray, rotation: np.ndarray) -> bool:
    """Whether a tip pose (p (3,), R (3, 3)) is within POS_TOL and ROT_TOL of the target."""
    p, R = pose
    return bool(np.linalg.norm(p - position) < POS_TOL and rotation_angle(rotation, R) < ROT_TOL)


def iterate(step, done, budget: float = BUDGET_S, cap: int = MAX_ITERATIONS) -> int:
    """Call step() until done() is true, `budget` seconds have passed or `cap` steps were made;
    a step that raises StopIteration (the library gave up) ends the loop. Returns the steps made."""
    deadline = time.perf_counter() + budget
    for k in range(1, cap + 1):
        try:
            step()
        except StopIteration:
            return k
        if done() or time.perf_counter() > deadline:
            return k
    return cap


def index_map(names: list[str], dof_names: list[str]) -> np.ndarray:
    """Position in `names` (a library's joint order) of each of deik's `dof_names`."""
    missing = sorted(set(dof_names) - set(names))
    if missing:
        raise ValueError(f"the library's model lacks joints {missing}; it has {names}")
    return np.array([names.index(n) for n in dof_names])
