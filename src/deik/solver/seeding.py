"""Starting populations near a given pose (a clip frame, a previous solution)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from deik.errors import InputError
from deik.memory import check_memory
from deik.model.joints import ROTATE
from deik.model.skeleton import Skeleton
from deik.model.values import real_array


def poses_around(
    skeleton: Skeleton,
    pose: ArrayLike,
    count: int,
    spread: ArrayLike = 0.05,
    seed: int = 0,
    memory_limit: int | None = None,
) -> np.ndarray:
    """(*batch, count, D) poses: each `pose` (*batch, D) itself, then copies perturbed by
    Gaussian noise of `spread` radians on rotations and `spread` x reach on translations
    (`spread`: a scalar, or one value per perturbed copy (count - 1,) to mix fine and wide
    starts). A DOF whose limits span a full turn wraps around (in `pose` too: a continuous
    joint at 350 degrees is at -10); any other is folded back inside its limits. Every other
    DOF of `pose` must lie within its limits (InputError naming the first outside);
    more poses than `memory_limit` bytes hold (default: deik.memory's) are refused before they
    are made (SolveError)."""
    lower, upper, full_turn = skeleton.lower, skeleton.upper, skeleton.full_turns
    pose = skeleton.check_angles(pose, "seed pose")
    pose = skeleton.wrapped(pose)
    outside = np.argwhere((pose < lower) | (pose > upper))
    if outside.size:
        d = outside[0][-1]
        value = pose[tuple(outside[0])]
        raise InputError(f"seed pose DOF {skeleton.dof_names[d]!r} = {_shown(skeleton, d, value, lower[d], upper[d])}")
    if isinstance(count, (bool, np.bool_)) or not isinstance(count, (int, np.integer)) or count < 1:
        raise InputError(f"count must be a whole number >= 1, got {count!r}")
    rotation = skeleton.dof_kind == ROTATE
    # the noise, the poses and three same-sized temporaries of the folding, float64
    check_memory(5 * 8 * pose[..., 0].size * count * skeleton.n_dofs, memory_limit, f"{count} poses around a pose")
    spread = real_array(spread, "spread")
    if spread.ndim > 1 or spread.size not in (1, count - 1) or not (np.isfinite(spread) & (spread >= 0)).all():
        raise InputError(
            f"spread must be a finite number >= 0, or {count - 1} of them (one per perturbed copy), got {spread!r:.80}"
        )
    spread = np.broadcast_to(spread.reshape(-1, 1), (count - 1, 1))
    sigma = spread * np.where(rotation, 1.0, skeleton.reach)
    shape = pose.shape[:-1] + (count - 1, skeleton.n_dofs)
    noise = np.random.default_rng(seed).normal(size=shape) * sigma
    poses = np.concatenate([pose[..., None, :], pose[..., None, :] + noise], axis=-2)
    wrapped = lower + np.mod(poses - lower, 2 * math.pi)
    width = np.where(upper > lower, upper - lower, 1.0)
    folded = lower + width - np.abs(np.mod(poses - lower, 2 * width) - width)
    folded = np.where(upper > lower, folded, lower)
    out = np.where(full_turn, wrapped, folded)
    out[..., 0, :] = pose  # exactly, not through the folding arithmetic
    return out


def _shown(skeleton: Skeleton, d: int, value: float, lower: float, upper: float) -> str:
    """DOF d's `value` outside [lower, upper], in radians and degrees for a rotation (the
    command line takes degrees), length units for a translation."""
    if skeleton.dof_kind[d] != ROTATE:
        return f"{value:.6g} is outside its limits [{lower:.6g}, {upper:.6g}] (length units)"
    deg = np.degrees
    return (
        f"{value:.6g} rad ({deg(value):.4g} degrees) is outside its limits [{lower:.6g}, {upper:.6g}] rad "
        f"([{deg(lower):.4g}, {deg(upper):.4g}] degrees)"
    )
