"""NumPy raw error of each term kind, one function per kind: the readable oracle of the kernels'
device functions (objectives/reference.py dispatches to them through the registry).

Every function takes the evaluated poses (`Posed`) and one term (`Term`) and returns its raw
error (N,) for N poses: metres (or the skeleton's length unit) or radians, as the kind's
registry row states.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from deik.model.geometry import polygon_distance, segment_distance
from deik.model.rotations import direction_angle, rotation_angle
from deik.model.skeleton import Skeleton


@dataclass(frozen=True)
class Posed:
    """N poses (N, D) of `skeleton` and their forward kinematics: frame rotations R (N, F, 3, 3),
    frame positions p (N, F, 3), centre of mass com (N, 3); ground (3, 3): two horizontal
    axes, then up."""

    skeleton: Skeleton
    poses: np.ndarray
    R: np.ndarray
    p: np.ndarray
    com: np.ndarray
    ground: np.ndarray


@dataclass(frozen=True)
class Term:
    """One term row as each pose sees it: frames (k,) frame indices, params (N, N_PARAMS) the
    targets of each pose's problem, dof_weight (D,), reference (N, D) comfort reference poses."""

    frames: np.ndarray
    params: np.ndarray
    dof_weight: np.ndarray
    reference: np.ndarray

    @property
    def frame(self) -> int:
        return int(self.frames[0])


def position(x: Posed, term: Term) -> np.ndarray:
    """Distance of the frame from its target params[:3]."""
    return np.linalg.norm(x.p[:, term.frame] - term.params[:, :3], axis=-1)


def orientation(x: Posed, term: Term) -> np.ndarray:
    """Angle between the frame's rotation and the target params[:9] (row-major 3x3)."""
    return rotation_angle(term.params[:, :9].reshape(-1, 3, 3), x.R[:, term.frame])


def aim(x: Posed, term: Term) -> np.ndarray:
    """Angle between the frame's local axis params[:3] (in the world) and the direction to the
    target params[3:6]."""
    g = term.params
    axis = np.einsum("nij,nj->ni", x.R[:, term.frame], g[:, :3])
    return direction_angle(axis, g[:, 3:6] - x.p[:, term.frame])


def centre_of_mass(x: Posed, term: Term) -> np.ndarray:
    """Distance of the centre of mass from its target params[:3]."""
    return np.linalg.norm(x.com - term.params[:, :3], axis=-1)


def com_over_support(x: Posed, term: Term) -> np.ndarray:
    """Horizontal distance of the centre of mass from the support point params[:3]."""
    d = x.com - term.params[:, :3]
    d = d - (d @ x.ground[2])[:, None] * x.ground[2]
    return np.linalg.norm(d, axis=-1)


def support_polygon(x: Posed, term: Term) -> np.ndarray:
    """Ground distance of the centre of mass outside the convex hull of the frames."""
    flat = x.ground[:2].T
    return polygon_distance(x.com @ flat, x.p[:, term.frames] @ flat)


def _comfort(x: Posed, term: Term) -> np.ndarray:
    return term.dof_weight * np.abs(x.poses - term.reference)


def comfort_sum(x: Posed, term: Term) -> np.ndarray:
    """Weighted sum of |q - reference| (Eq. 6)."""
    return _comfort(x, term).sum(axis=1)


def comfort_max(x: Posed, term: Term) -> np.ndarray:
    """Largest weighted |q - reference| (Eq. 7)."""
    return _comfort(x, term).max(axis=1)


def joint_limits(x: Posed, term: Term) -> np.ndarray:
    """Summed violation of the joint limits."""
    sk, q = x.skeleton, x.poses
    return (np.maximum(sk.lower - q, 0) + np.maximum(q - sk.upper, 0)).sum(axis=1)


def obstacle(x: Posed, term: Term) -> np.ndarray:
    """Summed penetration of every bone (a capsule of radius params[4]) into the sphere of
    centre params[:3] and radius params[3]."""
    sk, g = x.skeleton, term.params
    starts = np.concatenate([sk.parents[1:], sk.site_joint])
    ends = np.arange(1, sk.n_frames)
    dist = segment_distance(g[:, None, :3], x.p[:, starts], x.p[:, ends])
    return np.maximum(g[:, None, 3] + g[:, None, 4] - dist, 0).sum(axis=1)
