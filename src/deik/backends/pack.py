"""Pack a Skeleton and a TermTable into the arrays the kernels read: layout.PackedSkeleton and
layout.PackedTerms (shapes and columns there), in the engine's dtype."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from deik.device.layout import PackedSkeleton, PackedTerms
from deik.model.geometry import ground_frame
from deik.model.joints import ROTATE
from deik.model.skeleton import Skeleton
from deik.objectives.kinds import MU, PRIORITY_TOLERANCE, SCALE, TOLERANCE
from deik.objectives.table import TermTable


def kernel_array(a, dtype) -> np.ndarray:
    """`a` as a fresh C-contiguous, writable array of `dtype`: the one array type the kernels
    are compiled for (Numba compiles a whole kernel again for a read-only or strided array)."""
    return np.array(a, dtype=dtype, order="C")


def pack_skeleton(skeleton: Skeleton, dtype=np.float32, limits: np.ndarray | None = None) -> PackedSkeleton:
    """The skeleton's arrays; `limits` (D, 2) overrides the skeleton's (e.g. the paper's +-pi);
    a rotation whose limits span a whole turn or more gets TURN = 2 pi (layout: LM wraps it).
    Without an override they are cached per (frozen) skeleton and dtype: callers must not
    write into them."""
    if limits is None:
        return _packed(skeleton, np.dtype(dtype))
    return _pack(skeleton, dtype, limits)


@lru_cache(maxsize=32)
def _packed(skeleton: Skeleton, dtype: np.dtype) -> PackedSkeleton:
    return _pack(skeleton, dtype, None)


def _pack(skeleton: Skeleton, dtype, limits: np.ndarray | None) -> PackedSkeleton:
    s = skeleton
    f = lambda a: kernel_array(a, dtype)  # noqa: E731
    m = s.motions
    plain = np.all(s.joint_rotation.reshape(-1, 9) == np.eye(3).ravel(), axis=1)
    joint_int = np.stack([s.parents, m.joint_start[:-1], m.joint_start[1:], plain], axis=1)
    joint_frame = np.concatenate([s.offsets, s.joint_rotation.reshape(-1, 9)], axis=1)
    motion_int = np.stack([m.kind, m.source, coordinate_axis(m.axis)], axis=1).reshape(-1, 3)
    motion_float = np.concatenate([m.axis, m.scale[:, None], m.bias[:, None]], axis=1).reshape(-1, 5)
    site_frame = np.concatenate([s.site_offset, s.site_rotation.reshape(-1, 9)], axis=1)
    total = s.mass_value.sum()
    fraction = s.mass_value / total if total > 0 else s.mass_value
    mass_data = np.concatenate([s.mass_offset, fraction[:, None]], axis=1)
    if limits is None:
        limits = np.stack([s.lower, s.upper], axis=1)
    limits = np.asarray(limits, np.float64)
    turns = np.where((s.dof_kind == ROTATE) & (limits[:, 1] - limits[:, 0] >= 2.0 * np.pi), 2.0 * np.pi, 0.0)
    limits = inward(limits, dtype)
    return PackedSkeleton(
        joint_int=kernel_array(joint_int, np.int32),
        joint_frame=f(joint_frame.reshape(-1, 12)),
        motion_int=kernel_array(motion_int, np.int32),
        motion_float=f(motion_float),
        site_joint=kernel_array(s.site_joint, np.int32),
        site_frame=f(site_frame.reshape(-1, 12)),
        mass_joint=kernel_array(s.mass_joint, np.int32),
        mass_data=f(mass_data.reshape(-1, 4)),
        limits=f(np.concatenate([limits, turns[:, None]], axis=1)),
        bounds=f(limits.reshape(-1)),
        ground=f(ground_frame(s.up)),
    )


def coordinate_axis(axis: np.ndarray) -> np.ndarray:
    """(N,) 0, 1 or 2 where a unit axis (N, 3) is exactly +-x, +-y or +-z, else -1: the FK
    turns such frames by mixing two columns (device_maths.turn_columns)."""
    unit = (np.count_nonzero(axis, axis=1) == 1) & np.any(np.abs(axis) == 1.0, axis=1)
    return np.where(unit, np.argmax(np.abs(axis), axis=1), -1)


def inward(limits: np.ndarray, dtype) -> np.ndarray:
    """Limits (D, 2) rounded to `dtype` towards the inside, so that every pose the kernels keep
    within them is also within the float64 limits."""
    rounded = limits.astype(dtype)
    wide = rounded.astype(np.float64)
    up, down = np.array(np.inf, dtype), np.array(-np.inf, dtype)
    rounded[:, 0] = np.where(wide[:, 0] < limits[:, 0], np.nextafter(rounded[:, 0], up), rounded[:, 0])
    rounded[:, 1] = np.where(wide[:, 1] > limits[:, 1], np.nextafter(rounded[:, 1], down), rounded[:, 1])
    return rounded


TOLERANCE_MARGIN = {np.dtype(np.float32): 1e-3, np.dtype(np.float64): 1e-12}
# the rounding of a kernel's FK and errors, in units of the term's scale (the reach for lengths):
# a Panda tip in float32 lands about 1e-7 m from its float64 position
ROUNDING_MARGIN = {np.dtype(np.float32): 16 * float(np.finfo(np.float32).eps), np.dtype(np.float64): 0.0}


def _kernel_term_float(table: TermTable, dtype) -> np.ndarray:
    """term_float with tolerances tightened for the dtype by the larger of a relative margin
    and the rounding of its maths (at most half the tolerance), so a pose the kernels accept as
    within tolerance is also within it when re-measured in float64."""
    term_float = table.term_float.copy()
    tightened = term_float[:, TOLERANCE] > 0
    tolerance, scale = term_float[tightened, TOLERANCE], term_float[tightened, SCALE]
    margin = np.maximum(TOLERANCE_MARGIN[np.dtype(dtype)] * tolerance, ROUNDING_MARGIN[np.dtype(dtype)] * scale)
    term_float[tightened, TOLERANCE] = tolerance - np.minimum(margin, 0.5 * tolerance)
    prioritised = term_float[:, PRIORITY_TOLERANCE] >= 0
    mu, scale = term_float[prioritised, MU], term_float[prioritised, SCALE]
    term_float[prioritised, PRIORITY_TOLERANCE] = -np.expm1(-mu * term_float[prioritised, TOLERANCE] / scale)
    return term_float


def pack_terms(table: TermTable, reference: np.ndarray, dtype=np.float32) -> PackedTerms:
    """The table's arrays, with reference (B, T, D) each comfort term's reference pose."""
    f = lambda a: kernel_array(a, dtype)  # noqa: E731
    return PackedTerms(
        term_int=kernel_array(table.term_int, np.int32),
        term_float=f(_kernel_term_float(table, dtype)),
        params=f(table.params),
        dof_weight=f(table.dof_weight),
        reference=f(reference),
        pair_int=kernel_array(table.pair_int, np.int32),
        pair_radius=f(table.pair_radius),
    )
