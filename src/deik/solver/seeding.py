"""Starting populations near a given pose (a clip frame, a previous solution)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from deik.errors import InputError
from deik.model.joints import ROTATE
from deik.model.skeleton import Skeleton


def poses_around(
    skeleton: Skeleton, pose: ArrayLike, count: int, spread: ArrayLike = 0.05, seed: int = 0
) -> np.ndarray:
    """(*batch, count, D) poses: each `pose` (*batch, D) itself, then copies perturbed by
    Gaussian noise of `spread` radians on rotations and `spread` x reach on translations
    (`spread`: a scalar, or one value per perturbed copy (count - 1,) to mix fine and wide
    starts). A DOF whose limits span a full turn wraps around; any other is folded back inside
    its limits. Every pose must lie within the limits (ValueError naming the first DOF outside)."""
    pose = skeleton.check_angles(pose, "seed pose")
    outside = np.argwhere((pose < skeleton.lower) | (pose > skeleton.upper))
    if outside.size:
        d = outside[0][-1]
        value = pose[tuple(outside[0])]
        raise InputError(
            f"seed pose DOF {skeleton.dof_names[d]!r} = {value:.6g} is outside its limits "
            f"[{skeleton.lower[d]:.6g}, {skeleton.upper[d]:.6g}]"
        )
    if count < 1:
        raise InputError(f"count must be at least 1, got {count}")
    rotation = skeleton.dof_kind == ROTATE
    spread = np.broadcast_to(np.asarray(spread, np.float64).reshape(-1, 1), (count - 1, 1))
    sigma = spread * np.where(rotation, 1.0, skeleton.reach)
    shape = pose.shape[:-1] + (count - 1, skeleton.n_dofs)
    noise = np.random.default_rng(seed).normal(size=shape) * sigma
    poses = np.concatenate([pose[..., None, :], pose[..., None, :] + noise], axis=-2)
    lower, upper = skeleton.lower, skeleton.upper
    full_turn = rotation & (upper - lower >= 2 * math.pi)
    wrapped = lower + np.mod(poses - lower, 2 * math.pi)
    width = np.where(upper > lower, upper - lower, 1.0)
    folded = lower + width - np.abs(np.mod(poses - lower, 2 * width) - width)
    folded = np.where(upper > lower, folded, lower)
    out = np.where(full_turn, wrapped, folded)
    out[..., 0, :] = pose  # exactly, not through the folding arithmetic
    return out
