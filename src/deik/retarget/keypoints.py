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

from deik.io.trajectory import Motion
from deik.model.kinematics import forward_kinematics
from deik.model.rotations import euler_angles
from deik.model.skeleton import Skeleton


def rest_heights(skeleton: Skeleton, names: Sequence[str]) -> np.ndarray:
    """(K,) heights along skeleton.up of the frames `names` at rest (every DOF 0)."""
    kin = forward_kinematics(skeleton, np.zeros(skeleton.n_dofs))
    return np.array([kin.position(name) @ skeleton.up for name in names])


def height_ratio(source: Skeleton, target: Skeleton, source_names: Sequence[str], target_names: Sequence[str]) -> float:
    """Target length per source length: the ratio of the vertical spans at rest of the mapped
    frames (`target_names` on `target`, `source_names` on `source`, pairwise). ValueError when
    the source's mapped frames span no height (map a head and a foot)."""
    spans = [np.ptp(rest_heights(sk, names)) for sk, names in ((source, source_names), (target, target_names))]
    if not spans[0] > 1e-9 * source.reach:
        raise ValueError("the mapped source points span no height at rest; map a head and a foot, or give scale")
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


def mapped_rotations(
    source_clip: Motion, source_name: str, target: Skeleton, target_name: str, rotation: np.ndarray
) -> np.ndarray:
    """(N, 3, 3) the world orientation target frame `target_name` should have in each frame (see
    the module notes)."""
    sk = source_clip.skeleton
    R_s = forward_kinematics(sk, source_clip.poses()).rotation(source_name)
    R_s_rest = forward_kinematics(sk, np.zeros(sk.n_dofs)).rotation(source_name)
    R_t_rest = forward_kinematics(target, np.zeros(target.n_dofs)).rotation(target_name)
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
