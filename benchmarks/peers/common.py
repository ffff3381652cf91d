"""What every peer adapter shares: tolerances, the per-target budget, the iterative loop, restarts.

An adapter module defines PACKAGE (its distribution name, for the version) and a class `Peer`:
`Peer(urdf, base, tip, dof_names)` loads the cut URDF (benchmarks.peers.chain_urdf);
`peer.settings` is a dict of what it uses; `peer.fk(q)` -> tip position (3,) m and rotation
(3, 3) for q (D,) in deik's DOF order; `peer.solve(position, rotation, start, budget)` -> q (D,),
one local attempt from `start` that should stop after `budget` seconds where the library allows.
RESTARTS = False in a module means the library restarts by itself (TRAC-IK); every other peer is
run through `solve_with_restarts`.
"""

from __future__ import annotations

import math
import time

import numpy as np

POS_TOL, ROT_TOL = 1e-5, 1e-4  # m, rad: loops stop once both hold (the benchmark's strict level)
LIMIT_SLACK = 1e-6  # rad (or m): a joint this close outside its limit still counts as inside
BUDGET_S = 0.005  # wall-clock budget of one target, restarts included (TRAC-IK's default)
MAX_ITERATIONS = 500  # hard cap on the iterations of one attempt
STALL_STEPS = 5  # an attempt whose error has not halved over this many steps is stuck: restart
RESTART_SEED = 2718  # restart poses of target k come from default_rng([RESTART_SEED, k])


def rotation_angle(R_a: np.ndarray, R_b: np.ndarray) -> float:
    """Angle (rad) of R_a^T R_b; accurate near 0. Scalar maths on the nine entries: this runs after
    every step of the fastest peers, where numpy's per-call cost would outweigh their step."""
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = (R_a.T @ R_b).tolist()
    return math.atan2(math.hypot(m21 - m12, m02 - m20, m10 - m01) / 2, (m00 + m11 + m22 - 1) / 2)


def pose_gap(pose: tuple[np.ndarray, np.ndarray], position: np.ndarray, rotation: np.ndarray) -> float:
    """Tip pose (p (3,) m, R (3, 3)) against the target in units of the tolerances: the larger of
    position error / POS_TOL and orientation error / ROT_TOL; below 1 means reached."""
    p, R = pose
    dx, dy, dz = (p - position).tolist()
    gap = max(math.hypot(dx, dy, dz) / POS_TOL, rotation_angle(rotation, R) / ROT_TOL)
    return gap if math.isfinite(gap) else math.inf


def in_limits(q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> bool:
    """Whether every joint of q (D,) is finite and within [lower, upper] up to LIMIT_SLACK."""
    return bool(np.isfinite(q).all() and (q >= lower - LIMIT_SLACK).all() and (q <= upper + LIMIT_SLACK).all())


def iterate(step, gap, budget: float = BUDGET_S, cap: int = MAX_ITERATIONS, stall: int = STALL_STEPS) -> int:
    """Call step() until gap() < 1, `budget` seconds have passed, `cap` steps were made or the gap
    has not halved over the last `stall` steps (a local minimum or a joint limit: time to restart);
    a step that raises StopIteration (the library gave up) ends the loop. Returns the steps made."""
    deadline = time.perf_counter() + budget
    gaps = []
    for k in range(1, cap + 1):
        try:
            step()
        except StopIteration:
            return k
        gaps.append(gap())
        if gaps[-1] < 1 or time.perf_counter() > deadline or (k > stall and gaps[-1] > 0.5 * gaps[-1 - stall]):
            return k
    return cap


def solve_with_restarts(attempt, fk, target, start, limits, seed, budget=BUDGET_S, clock=None):
    """One local attempt from `start`, then attempts from uniform in-limit poses drawn by
    numpy default_rng(seed), until an answer reaches `target` (position (3,) m, rotation (3, 3):
    pose_gap < 1) with its joints within `limits` (lower (D,), upper (D,)) or `budget` seconds
    (wall) have passed since the call; the attempt under way when the budget runs out is told
    the seconds left and finishes. attempt(q0 (D,), seconds_left) -> q (D,); fk(q) -> (p (3,) m,
    R (3, 3)). Returns (q (D,): the first success, else the answer in limits nearest the
    target, else the nearest; attempts made)."""
    clock = clock or time.perf_counter
    t0 = clock()
    rng = np.random.default_rng(seed)
    best, best_key, q0, attempts = None, None, np.asarray(start, dtype=float), 0
    while True:
        q = np.asarray(attempt(q0, max(budget - (clock() - t0), 0.0)), dtype=float)
        attempts += 1
        inside = in_limits(q, *limits)
        key = (not inside, pose_gap(fk(q), *target) if np.isfinite(q).all() else math.inf)
        if best_key is None or key < best_key:
            best, best_key = q, key
        if (inside and key[1] < 1) or clock() - t0 >= budget:
            return best, attempts
        q0 = rng.uniform(*limits)


def load_targets(path) -> dict:
    """Read robot_targets.save_targets' .npz file: arrays, and plain str/int for the scalar fields."""
    with np.load(path) as data:
        return {k: (data[k].item() if data[k].ndim == 0 else data[k]) for k in data.files}


def index_map(names: list[str], dof_names: list[str]) -> np.ndarray:
    """Position in `names` (a library's joint order) of each of deik's `dof_names`."""
    missing = sorted(set(dof_names) - set(names))
    if missing:
        raise ValueError(f"the library's model lacks joints {missing}; it has {names}")
    return np.array([names.index(n) for n in dof_names])
