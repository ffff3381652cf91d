"""Skeleton edits a retarget needs: bones scaled below joints, a floating root for a robot fixed
in the world, and sites at offsets from frames (key points a target has no frame for).

Each returns a new Skeleton (the arrays of the old one, changed); lengths are the skeleton's
length unit, angles radians.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike

from deik.errors import InputError
from deik.model.joints import ROTATE, TRANSLATE
from deik.model.skeleton import Skeleton
from deik.suggest import did_you_mean

ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
ROOT_AXES = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 1], [1, 0, 0], [0, 1, 0]], float)


MAX_SCALE = 100.0  # a bone 100 times longer or shorter is another creature; 1e9 overflowed the offsets' range


def bone_scales(skeleton: Skeleton, factors: dict[str, float]) -> np.ndarray:
    """(J,) the scale of the bones hanging from each joint: the product of the `factors`
    {joint name: factor from 1 / MAX_SCALE to MAX_SCALE} of the joint and its ancestors.
    InputError naming a bad factor or an unknown joint (with close names)."""
    scale = np.ones(skeleton.n_joints)
    for name, factor in factors.items():
        if name not in skeleton.joint_names:
            raise InputError(
                f"--scale: no joint {name!r} in {skeleton.name!r}{did_you_mean(name, skeleton.joint_names)}; "
                f"the joints are {', '.join(skeleton.joint_names)}"
            )
        if not (isinstance(factor, (int, float)) and 1 / MAX_SCALE <= factor <= MAX_SCALE):
            raise InputError(
                f"--scale {name}={factor!r}: a factor must be a number from {1 / MAX_SCALE:g} to {MAX_SCALE:g}, "
                f"e.g. {name}=1.1"
            )
        scale[skeleton.joint_names.index(name)] *= float(factor)
    for k in range(1, skeleton.n_joints):
        scale[k] *= scale[skeleton.parents[k]]
    return scale


def scaled_bones(skeleton: Skeleton, factors: dict[str, float]) -> Skeleton:
    """`skeleton` with every bone below each joint of `factors` {joint: factor} scaled by it
    (nested factors multiply): the offsets of its descendants, its subtree's sites and mass
    centres. The joint's own offset from its parent keeps its length (LeftHip=1.1 lengthens
    the left leg, not the pelvis)."""
    scale = bone_scales(skeleton, factors)
    parents = np.maximum(skeleton.parents, 0)
    offsets = skeleton.offsets * np.where(skeleton.parents >= 0, scale[parents], 1.0)[:, None]
    return replace(
        skeleton,
        offsets=offsets,
        site_offset=skeleton.site_offset * scale[skeleton.site_joint][:, None],
        mass_offset=skeleton.mass_offset * scale[skeleton.mass_joint][:, None],
    )


def with_floating_root(skeleton: Skeleton, lower: ArrayLike, upper: ArrayLike) -> Skeleton:
    """`skeleton`, whose root joint has no DOFs (a robot fixed in the world), with six on it:
    translations along X, Y, Z within `lower`/`upper` (3,) length units, then rotations Z, X, Y
    (intrinsic, over a whole turn), in the root joint's frame, named "ROOT.Xposition" and so on
    as BVH names a root's channels. ValueError when the root already moves."""
    if skeleton.joint_dof_start[1] != 0:
        raise InputError(f"the root joint {skeleton.joint_names[0]!r} of {skeleton.name!r} already has DOFs")
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    root = skeleton.joint_labels[0]
    return replace(
        skeleton,
        joint_dof_start=np.concatenate([[0], skeleton.joint_dof_start[1:] + 6]),
        dof_names=tuple(f"{root}.{c}" for c in ROOT_CHANNELS) + skeleton.dof_names,
        dof_joint=np.concatenate([np.zeros(6, np.int32), skeleton.dof_joint]),
        dof_kind=np.concatenate([[TRANSLATE] * 3 + [ROTATE] * 3, skeleton.dof_kind]).astype(np.int32),
        dof_axis=np.concatenate([ROOT_AXES, skeleton.dof_axis]),
        lower=np.concatenate([lower, [-math.pi] * 3, skeleton.lower]),
        upper=np.concatenate([upper, [math.pi] * 3, skeleton.upper]),
        reference=np.concatenate([np.zeros(6), skeleton.reference]),
        mimic_source=skeleton.mimic_source + 6,
    )


def with_free_root(skeleton: Skeleton, points: np.ndarray) -> Skeleton:
    """`skeleton` with its root free to go where a clip takes it: the limits of the root's
    translations widened, where needed, to carry it anywhere over `points` (M, 3) (world,
    length units) plus its reach, and its rotations free over a whole turn. A built-in
    character's root limits suit posing in place (the humanoid's pelvis turns at most 0.8 rad
    about its forward axis), not a clip that walks away, crawls or spins."""
    start, stop = skeleton.joint_dof_start[0], skeleton.joint_dof_start[1]
    lower, upper = skeleton.lower.copy(), skeleton.upper.copy()
    for d in range(start, stop):
        if skeleton.dof_kind[d] == ROTATE:
            lower[d], upper[d] = min(lower[d], -math.pi), max(upper[d], math.pi)
            continue
        axis = skeleton.joint_rotation[0] @ skeleton.dof_axis[d]  # the DOF's world direction at the root
        along = points @ axis - skeleton.offsets[0] @ axis
        lower[d] = min(lower[d], along.min() - skeleton.reach)
        upper[d] = max(upper[d], along.max() + skeleton.reach)
    return replace(skeleton, lower=lower, upper=upper)


def without_sites(skeleton: Skeleton, names: Sequence[str]) -> Skeleton:
    """`skeleton` without the sites `names` (every other frame keeps its place in the joint
    order; the poses are the same)."""
    keep = np.array([name not in names for name in skeleton.site_names], bool)
    return replace(
        skeleton,
        site_names=tuple(name for name, kept in zip(skeleton.site_names, keep) if kept),
        site_joint=skeleton.site_joint[keep],
        site_offset=skeleton.site_offset[keep],
        site_rotation=skeleton.site_rotation[keep],
    )
