"""Where the target's key points and frames should be, frame by frame, from the source motion.

A source point p (length units) maps to R (p - o) s in the target's world: o is the floor point
below the source root in the first frame (so the target starts at the world origin, on the
floor at height 0), s the body scale (target length per source length), R the map's rotation
of source axes to target axes. A mapped frame's orientation turns from its rest orientation as
the source frame's turns from its own: R_t(n) = R R_s(n) R_s(rest)^T R^T R_t(rest), so both
rest poses are taken to be the same stance (both shared rigs stand upright, arms down).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from deik.cleanup.body import rest_standing
from deik.errors import InputError
from deik.io.trajectory import Motion
from deik.model.kinematics import forward_kinematics
from deik.model.rotations import euler_angles
from deik.model.skeleton import Skeleton


def rest_heights(skeleton: Skeleton, names: Sequence[str]) -> np.ndarray:
    """(K,) heights along skeleton.up of the frames `names` at rest (every DOF 0, stood up:
    cleanup.body.rest_standing)."""
    kin = rest_standing(skeleton)
    return np.array([kin.position(name) @ skeleton.up for name in names])


def stature(skeleton: Skeleton) -> float:
    """The vertical span of `skeleton` at rest (every DOF 0) along up, length units: the size
    every threshold of a retarget is a fraction of (a rig with position channels on every joint
    has DOF limits, and so a reach, far wider than its body). The span in any direction for a
    rig with no height at rest."""
    p = rest_standing(skeleton).p_world_frame
    height = float(np.ptp(p @ skeleton.up))
    return height if height > 0 else float(np.linalg.norm(np.ptp(p, axis=0)))


def height_ratio(source: Skeleton, target: Skeleton, source_names: Sequence[str], target_names: Sequence[str]) -> float:
    """Target length per source length: the ratio of the vertical spans at rest of the mapped
    frames (`target_names` on `target`, `source_names` on `source`, pairwise). ValueError when
    the source's mapped frames span no height (map a head and a foot)."""
    spans = [np.ptp(rest_heights(sk, names)) for sk, names in ((source, source_names), (target, target_names))]
    if not spans[0] > 1e-9 * stature(source):
        raise InputError(
            'the joint map\'s scale = "height": its source points span no height at rest; map a head and a foot, '
            "or give scale a number"
        )
    return float(spans[1] / spans[0])


def floor_origin(skeleton: Skeleton, first_pose: np.ndarray, ground: float) -> np.ndarray:
    """(3,) the point on the floor (height `ground` along up) below the root at `first_pose`."""
    root = forward_kinematics(skeleton, first_pose).p_world_frame[0]
    return root + (ground - root @ skeleton.up) * skeleton.up


def mapped_points(
    source_clip: Motion, names: Sequence[str], origin: np.ndarray, scale: float, rotation: np.ndarray
) -> np.ndarray:
    """(N, K) source frames `names` over the clip mapped into the target world: (N, K, 3)."""
    kin = forward_kinematics(source_clip.skeleton, source_clip.poses())
    p = np.stack([kin.position(name) for name in names], axis=1)
    return ((p - origin) * scale) @ rotation.T


def limb_tree(source: Skeleton, source_names: Sequence[str], root: int) -> list[int]:
    """(K,) each key point's parent key point: the nearest of its source frame's ancestors that
    is mapped, else `root` (the root point's own entry is -1)."""
    index = {source.frame_index(name): k for k, name in enumerate(source_names)}
    parents = []
    for k, name in enumerate(source_names):
        f = source.frame_index(name)
        f = f if f < source.n_joints else int(source.site_joint[f - source.n_joints])
        parent = root
        if f in index and index[f] != k:  # a site of a mapped joint hangs from that joint's point
            parent = index[f]
        else:
            f = int(source.parents[f]) if f < source.n_joints else f
            while f >= 0 and f not in index:
                f = int(source.parents[f])
            parent = index.get(f, root)
        parents.append(-1 if k == root else parent)
    return parents


def limb_scales(
    source: Skeleton,
    target: Skeleton,
    source_names: Sequence[str],
    target_names: Sequence[str],
    root: int,
    fallback: float,
) -> tuple[float, np.ndarray]:
    """(root scale, (K,) limb scales) at rest: the root key point's height above the skeleton's
    lowest joint or site, and each point's distance from its parent point (limb_tree), target over
    source (a point within 1 % of the source's stature of its parent takes `fallback`)."""
    rest = [rest_standing(sk).p_world_frame for sk in (source, target)]
    P, Q = (
        X[[sk.frame_index(n) for n in names]]
        for X, sk, names in zip(rest, (source, target), (source_names, target_names))
    )
    # the root's height above the sole (the lowest joint or site), which stands on the floor
    legs = [X[root] @ sk.up - (frames @ sk.up).min() for X, frames, sk in zip((P, Q), rest, (source, target))]
    size = stature(source)
    if not legs[0] > 1e-2 * size:
        raise InputError('scale = "limbs": the pelvis point is not above the other mapped points at rest')
    parents = np.array(limb_tree(source, source_names, root))
    up = np.where(parents >= 0, parents, root)
    far = [np.linalg.norm(X - X[up], axis=1) for X in (P, Q)]
    scales = np.where(far[0] > 1e-2 * size, far[1] / np.maximum(far[0], 1e-12), fallback)
    return float(legs[1] / legs[0]), scales


def limb_points(
    source_clip: Motion,
    names: Sequence[str],
    origin: np.ndarray,
    root: int,
    root_scale: float,
    scales: np.ndarray,
    rotation: np.ndarray,
) -> np.ndarray:
    """(N, K, 3) source frames `names` mapped limb by limb: the root point's path about
    `origin` by `root_scale`, then each point at its parent point (limb_tree) plus its offset
    from the parent in the source, scaled by its limb scale (K,) (limb_scales): the source's
    pose with the target's limb lengths."""
    kin = forward_kinematics(source_clip.skeleton, source_clip.poses())
    p = np.stack([kin.position(name) for name in names], axis=1)
    parents = limb_tree(source_clip.skeleton, names, root)
    out = np.empty_like(p)
    done = [False] * len(names)

    def place(k: int) -> None:
        if done[k]:
            return
        if parents[k] < 0:
            out[:, k] = (p[:, k] - origin) * root_scale
        else:
            place(parents[k])
            out[:, k] = out[:, parents[k]] + (p[:, k] - p[:, parents[k]]) * scales[k]
        done[k] = True

    for k in range(len(names)):
        place(k)
    return out @ rotation.T


def mapped_rotations(
    source_clip: Motion, source_name: str, target: Skeleton, target_name: str, rotation: np.ndarray
) -> np.ndarray:
    """(N, 3, 3) the world orientation target frame `target_name` should have in each frame (see
    the module notes)."""
    sk = source_clip.skeleton
    R_s = forward_kinematics(sk, source_clip.poses()).rotation(source_name)
    R_s_rest = rest_standing(sk).rotation(source_name)
    R_t_rest = rest_standing(target).rotation(target_name)
    return rotation @ R_s @ R_s_rest.T @ rotation.T @ R_t_rest


def root_dofs(
    skeleton: Skeleton, site_position: np.ndarray, site_offset: np.ndarray, R_root: np.ndarray
) -> np.ndarray | None:
    """(N, 6) values of a root's X, Y, Z translations and three rotations about coordinate
    axes (in that DOF order, as BVH roots and with_floating_root have them) that put the root
    frame at orientation `R_root` (N, 3, 3) and a point `site_offset` (3,) of it at
    `site_position` (N, 3); None for a root of another shape."""
    start, stop = skeleton.joint_dof_start[0], skeleton.joint_dof_start[1]
    axes, kinds = skeleton.dof_axis[start:stop], skeleton.dof_kind[start:stop]
    if stop - start != 6 or list(kinds) != [1, 1, 1, 0, 0, 0] or not np.allclose(axes[:3], np.eye(3)):
        return None
    letters = ["XYZ"[int(np.argmax(np.abs(a)))] for a in axes[3:]]
    signs = np.array([np.sign(a[int(np.argmax(np.abs(a)))]) for a in axes[3:]])
    if len(set(letters)) != 3 or not np.allclose(np.abs(axes[3:]).max(axis=1), 1.0):
        return None
    fixed = skeleton.joint_rotation[0]
    angles = euler_angles("".join(letters), fixed.T @ R_root) * signs
    translation = (site_position - R_root @ site_offset - skeleton.offsets[0]) @ fixed
    return np.concatenate([translation, angles], axis=1)
