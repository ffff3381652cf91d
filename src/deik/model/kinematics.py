"""Forward kinematics and centre of mass in NumPy for any batch shape (the Python edge).

The compiled kernels carry their own scalar copy of this maths (deik.device.maths); tests
hold the two to each other and to scipy's Rotation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from deik.model.joints import ROTATE
from deik.model.rotations import axis_angle_matrix
from deik.model.skeleton import Skeleton


@dataclass(frozen=True)
class Kinematics:
    """World frames of every joint then site, and the whole-body centre of mass.

    R_world_frame (*batch, F, 3, 3); p_world_frame (*batch, F, 3) in length units;
    p_world_com (*batch, 3) (NaN when the skeleton has no mass).
    """

    skeleton: Skeleton
    R_world_frame: np.ndarray
    p_world_frame: np.ndarray
    p_world_com: np.ndarray

    def position(self, name: str) -> np.ndarray:
        """World position (*batch, 3) of joint or site `name`."""
        return self.p_world_frame[..., self.skeleton.frame_index(name), :]

    def rotation(self, name: str) -> np.ndarray:
        """World rotation (*batch, 3, 3) of joint or site `name`."""
        return self.R_world_frame[..., self.skeleton.frame_index(name), :, :]


def forward_kinematics(skeleton: Skeleton, angles: ArrayLike) -> Kinematics:
    """Angles (*batch, D) in radians / length units -> Kinematics of every joint and site."""
    q = skeleton.check_angles(angles)
    batch = q.shape[:-1]
    q = q.reshape(math.prod(batch), skeleton.n_dofs)  # not -1: a skeleton without DOFs has size 0
    N, J = q.shape[0], skeleton.n_joints
    R = np.empty((N, J, 3, 3))
    p = np.empty((N, J, 3))
    m = skeleton.motions
    value = q[:, m.source] * m.scale + m.bias
    turns = axis_angle_matrix(m.axis, value)  # (N, M, 3, 3): every motion's, used by the rotations
    for k in range(J):
        R_local = np.broadcast_to(skeleton.joint_rotation[k], (N, 3, 3))
        p_local = np.broadcast_to(skeleton.offsets[k], (N, 3))
        for n in range(m.joint_start[k], m.joint_start[k + 1]):
            if m.kind[n] == ROTATE:
                R_local = R_local @ turns[:, n]
            else:
                p_local = p_local + (R_local @ m.axis[n]) * value[:, n, None]
        parent = skeleton.parents[k]
        if parent < 0:
            R[:, k], p[:, k] = R_local, p_local
        else:
            R[:, k] = R[:, parent] @ R_local
            p[:, k] = p[:, parent] + np.einsum("nij,nj->ni", R[:, parent], p_local)
    R_site = R[:, skeleton.site_joint] @ skeleton.site_rotation
    p_site = p[:, skeleton.site_joint] + np.einsum("nsij,sj->nsi", R[:, skeleton.site_joint], skeleton.site_offset)
    R_all = np.concatenate([R, R_site], axis=1)
    p_all = np.concatenate([p, p_site], axis=1)
    com = centre_of_mass(skeleton, R, p)
    F = skeleton.n_frames
    return Kinematics(
        skeleton,
        R_all.reshape(batch + (F, 3, 3)),
        p_all.reshape(batch + (F, 3)),
        com.reshape(batch + (3,)),
    )


def centre_of_mass(skeleton: Skeleton, R_world_joint: np.ndarray, p_world_joint: np.ndarray) -> np.ndarray:
    """Mass-weighted centre (N, 3) from joint frames (N, J, 3, 3) and (N, J, 3); Eq. 3."""
    m = skeleton.mass_value
    if m.sum() <= 0:
        return np.full(p_world_joint.shape[:-2] + (3,), np.nan)
    j = skeleton.mass_joint
    points = p_world_joint[:, j] + np.einsum("nmij,mj->nmi", R_world_joint[:, j], skeleton.mass_offset)
    return np.einsum("m,nmi->ni", m, points) / m.sum()
