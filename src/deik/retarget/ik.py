"""Key-point IK for every frame of a retarget at once: Levenberg-Marquardt on the points'
positions within the joint limits.

Each iteration takes, per frame, the damped least-squares step of the searched DOFs towards
the key points' targets (each point's error cut to LONGEST_STEP x reach, so a far target is
approached, not chased), with the DOFs at a limit that the step pushes outwards held, as the
kernels' LM polish holds them; the step is kept where it lowers the frame's error (its damping
then falls) and refused where it does not (its damping rises). Frames all start from the same
pose, so neighbouring frames settle in the same basin. Without the holding, steps cut back into
the limits stalled knees and ankles at a limit, toes pointing down, 10-30 cm from their targets.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np

from deik.clips.warmstart import position_jacobian
from deik.model.joints import ROTATE
from deik.model.rotations import wrap_rotations
from deik.model.skeleton import Skeleton

ITERATIONS = 20  # 40 gave the same errors on the shared clips (within 1 mm) in 1.5x the time
LONGEST_STEP = 0.1  # of reach: the longest error a point's row asks for in one step
DAMPING = (1e-4, 1e-3, 1e4)  # least, first and most damping (weighted DOF units squared)
FLOOR_WEIGHT = 10.0  # a point below the floor counts this many times a key point as far off


def _inside(skeleton, poses: np.ndarray) -> np.ndarray:
    """`poses` within the limits; rotations free over a whole turn wrap instead."""
    full_turn = (skeleton.dof_kind == ROTATE) & (skeleton.upper - skeleton.lower >= 2 * np.pi)
    wrapped = wrap_rotations(poses, full_turn)
    return np.where(full_turn, wrapped, np.clip(poses, skeleton.lower, skeleton.upper))


def _errors(x: np.ndarray, targets: np.ndarray, longest: float) -> np.ndarray:
    """(N, K, 3) targets - x, each point's error cut to `longest`."""
    error = targets - x
    length = np.linalg.norm(error, axis=-1, keepdims=True)
    return error * np.minimum(1.0, longest / np.maximum(length, longest))


def _step(A: np.ndarray, e: np.ndarray, damping: np.ndarray) -> np.ndarray:
    """(N, D) the damped least-squares steps of rows A (N, R, D) for errors e (N, R)."""
    D = A.shape[-1]
    normal = A.transpose(0, 2, 1) @ A + damping[:, None, None] * np.eye(D)
    return np.linalg.solve(normal, (A.transpose(0, 2, 1) @ e[..., None]))[..., 0]


def _floor_depth(x: np.ndarray, up: np.ndarray, floor: float) -> np.ndarray:
    """(N, F) how far each point of `x` (N, F, 3) lies below the floor (0 above it)."""
    return np.maximum(floor - x @ up, 0.0)


def solve_keypoints(
    skeleton: Skeleton,
    poses: np.ndarray,
    names: Iterable[str],
    targets: np.ndarray | Callable[[np.ndarray], np.ndarray],
    searched: np.ndarray,
    weights: np.ndarray,
    floor: float | None = None,
    point_weights: np.ndarray | None = None,
) -> np.ndarray:
    """(N, D) poses near `poses` (N, D) whose frames `names` (K,) meet `targets` as nearly as
    the limits allow: `targets` (N, K, 3), or a function of the poses giving them (points
    whose targets follow the pose, such as orientation points measured from a frame), moving
    only the `searched` (N, D) DOFs, each change counted by `weights` (D,) (dof_weights).
    With a `floor` (height along up, length units) every joint and site is also pushed out
    of the floor, each depth counted FLOOR_WEIGHT times; `point_weights` (N, K) count each
    point's error in each frame (default 1; 0 leaves a point free in a frame, where its target
    may be NaN)."""
    target_of = targets if callable(targets) else (lambda q: targets)
    names = list(names)
    K = len(names)
    every = names + (list(skeleton.frame_names) if floor is not None else [])
    up = np.asarray(skeleton.up, float)
    scale = searched * np.where(weights > 0, 1.0 / np.where(weights > 0, weights, 1.0), 0.0)
    longest = LONGEST_STEP * skeleton.reach
    lower, upper = skeleton.lower, skeleton.upper
    poses = _inside(skeleton, np.array(poses, float))
    N = len(poses)
    w = np.ones((N, K)) if point_weights is None else np.asarray(point_weights, float)

    def offsets(q, x):
        """(N, K, 3) weighted target - x, 0 where a point's weight is 0."""
        return np.where(w[..., None] > 0, target_of(q) - x[:, :K], 0.0) * w[..., None]

    def measured(q):
        """(points, Jacobian, cost per frame) at poses q."""
        x, J = position_jacobian(skeleton, q, every)
        cost = (np.linalg.norm(offsets(q, x), axis=-1) ** 2).sum(axis=1)
        if floor is not None:
            cost = cost + FLOOR_WEIGHT**2 * (_floor_depth(x[:, K:], up, floor) ** 2).sum(axis=1)
        return x, J, cost

    damping = np.full(N, DAMPING[1])
    x, J, cost = measured(poses)
    for _ in range(ITERATIONS):
        e = _errors(x[:, :K], np.where(w[..., None] > 0, target_of(poses), x[:, :K]), longest) * w[..., None]
        e = e.reshape(N, -1)
        A = (J[:, :K] * w[:, :, None, None]).reshape(N, -1, J.shape[-1])
        if floor is not None:
            depth = np.minimum(_floor_depth(x[:, K:], up, floor), longest)
            rows = np.einsum("k,nfkd->nfd", up, J[:, K:]) * (depth > 0)[..., None]
            e = np.concatenate([e, FLOOR_WEIGHT * depth], axis=1)
            A = np.concatenate([A, FLOOR_WEIGHT * rows], axis=1)
        A = A * scale[:, None, :]
        step = _step(A, e, damping) * scale
        held = ((poses <= lower) & (step < 0)) | ((poses >= upper) & (step > 0))
        if held.any():
            step = _step(A * ~held[:, None, :], e, damping) * scale * ~held
        trial = _inside(skeleton, poses + step)
        x_trial, J_trial, trial_cost = measured(trial)
        better = trial_cost < cost
        poses = np.where(better[:, None], trial, poses)
        x = np.where(better[:, None, None], x_trial, x)
        J = np.where(better[:, None, None, None], J_trial, J)
        cost = np.where(better, trial_cost, cost)
        damping = np.clip(np.where(better, damping / 3.0, damping * 10.0), DAMPING[0], DAMPING[2])
    return poses
