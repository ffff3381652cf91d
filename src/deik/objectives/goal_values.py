"""Checked values of goals: target vectors with an optional batch axis, per-problem parameter
rows, reachability, masses and per-DOF comfort weights (objectives/goals.py)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from deik.errors import InputError
from deik.model.orientations import QUICK_MARGIN
from deik.model.skeleton import Skeleton
from deik.model.values import real_array
from deik.objectives.kinds import N_PARAMS

MAX_MAGNITUDE = 1e12  # of a target's numbers: their squares stay finite in the kernels' float32 maths
REACH_SLACK = 1e-9  # relative: a target this much beyond a chain's length is rounding, not out of reach


def vector(value: ArrayLike, shape: tuple[int, ...], what: str) -> np.ndarray:
    """`value` of `shape` or (B, *shape) as a finite float64 array (B, *shape), B = 1 without
    a batch axis; a ValueError naming `what` otherwise."""
    a = real_array(value, what)
    if a.shape[-len(shape) :] != shape or a.ndim > len(shape) + 1:
        raise InputError(f"{what} must have shape {shape} or (batch, *{shape}), got {a.shape}")
    if a.ndim > len(shape) and len(a) == 0:
        raise InputError(f"{what} is a batch of 0: give at least one target")
    if not np.isfinite(a).all():
        raise InputError(f"{what} contains NaN or infinite values: {value!r:.200}")
    if a.size and np.abs(a).max() > MAX_MAGNITUDE:
        raise InputError(f"{what} holds {np.abs(a).max():g}, beyond +-{MAX_MAGNITUDE:g}; give real coordinates")
    return a.reshape((-1,) + shape) if a.ndim > len(shape) else a[None]


def pack(*parts: np.ndarray) -> np.ndarray:
    """Concatenate parts (B_k, ...) along their flattened trailing axes -> (B, N_PARAMS);
    only the leading batch axis broadcasts."""
    B = max(p.shape[0] for p in parts)
    out = np.zeros((B, N_PARAMS))
    column = 0
    for p in parts:
        width = p[0].size
        out[:, column : column + width] = p.reshape(p.shape[0], width)  # a batch of 1 broadcasts
        column += width
    return out


def check_reachable(skeleton: Skeleton, target: np.ndarray, frame: int | None, label: str) -> None:
    """Raise when a target (B, 3) lies farther from every possible root position than the reach."""
    if not len(target):
        return
    length = skeleton.path_length(frame) if frame is not None else skeleton.reach
    bound = (length * (1 + REACH_SLACK)) ** 2
    if len(target) == 1:  # one target: plain Python passes it in 1 us (numpy's checks take 7)
        lo, hi = (corner.tolist() for corner in skeleton.root_box())
        if _outside_squared(*target[0].tolist(), lo, hi) <= bound * QUICK_MARGIN:
            return
    outside = target - np.clip(target, *skeleton.root_box())
    squared = (outside * outside).sum(axis=-1)
    if squared.max() > bound:
        gap = np.sqrt(squared)
        worst = int(np.argmax(gap))
        raise InputError(
            f"{label}: target {target[worst].round(6).tolist()} is unreachable: it lies "
            f"{gap[worst]:.6g} from the root's range but the chain to it is only {length:.6g} long"
        )


def reach_test(skeleton: Skeleton, frame: int) -> Callable[[float, float, float], bool]:
    """A plain-Python test of one point (x, y, z), finite, that check_reachable would pass for
    `frame`: the same sums, with QUICK_MARGIN of the bound to spare so that rounding cannot
    pass what it refuses. A False decides nothing (check_reachable then gives the verdict and
    its message)."""
    lo, hi = (corner.tolist() for corner in skeleton.root_box())
    bound = (skeleton.path_length(frame) * (1 + REACH_SLACK)) ** 2 * QUICK_MARGIN
    return lambda x, y, z: _outside_squared(x, y, z, lo, hi) <= bound


def _outside_squared(x: float, y: float, z: float, lo: list, hi: list) -> float:
    """Squared distance of point (x, y, z) from the box [lo, hi] (corners as lists), as
    check_reachable's numpy sums it (NaN for a NaN coordinate)."""
    dx, dy, dz = x - min(max(x, lo[0]), hi[0]), y - min(max(y, lo[1]), hi[1]), z - min(max(z, lo[2]), hi[2])
    return dx * dx + dy * dy + dz * dz


def need_mass(skeleton: Skeleton, what: str) -> None:
    """Raise when goal `what` needs masses and the skeleton has none."""
    if skeleton.total_mass <= 0:
        raise InputError(f"{what} needs masses, but skeleton {skeleton.name!r} has none")


def dof_weights(skeleton: Skeleton, spec: str | dict[str, float] | ArrayLike | None) -> np.ndarray:
    """Comfort's per-DOF weights (D,) from `spec` (see deik.Comfort's joint_weights)."""
    D = skeleton.n_dofs
    if spec is None:
        return np.ones(D)
    if isinstance(spec, str):
        if spec not in ("start", "end"):
            raise InputError(f"joint_weights string must be 'start' or 'end', got {spec!r}")
        depth = skeleton.dof_joint / max(skeleton.n_joints - 1, 1)
        return 1.0 - depth if spec == "start" else depth
    if isinstance(spec, dict):
        w = np.zeros(D)
        for name, value in spec.items():
            if not (np.isfinite(value) and value >= 0):
                raise InputError(f"joint_weights[{name!r}] = {value!r} must be finite and >= 0")
            w[skeleton.joint_dofs(name)] = value
        return w
    w = np.asarray(spec, dtype=np.float64)
    if w.shape != (D,) or not np.isfinite(w).all() or (w < 0).any():
        raise InputError(f"joint_weights array must be ({D},), finite and >= 0, got shape {w.shape}")
    return w
