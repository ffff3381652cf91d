"""A BVH clip that shows the motion of any skeleton (a URDF robot's included), to look at.

BVH cannot carry a robot's joints (rest rotations, hinges about oblique axes, mimics), so the
view is a skeleton of its own with the same joint tree and names: each joint's OFFSET is its
rest-pose (all DOFs 0) position relative to its parent in world axes, each site an End Site;
the root has X/Y/Z position channels (its world position, OFFSET 0), so does a joint that
slides (a prismatic one: its place in its parent's view frame, less its OFFSET), and every joint
has Z/X/Y rotation channels, the rotation of the joint's frame relative to its rest pose, relative to
its parent's. Forward kinematics of the view puts every joint and site where the skeleton's
own puts it, frame by frame (tests/io/test_bvh_view.py).
"""

from __future__ import annotations

import numpy as np

from deik.io.motion import Clip
from deik.model.build import build_skeleton
from deik.model.joints import TRANSLATE, Joint, Site, euler, translation
from deik.model.kinematics import forward_kinematics
from deik.model.rotations import euler_angles
from deik.model.skeleton import Skeleton


def view_skeleton(skeleton: Skeleton) -> Skeleton:
    """The BVH-shaped twin of `skeleton` (see the module notes); no masses."""
    rest = forward_kinematics(skeleton, np.zeros(skeleton.n_dofs))
    J = skeleton.n_joints
    p = rest.p_world_frame
    joints = [Joint(skeleton.joint_names[0], None, (0.0, 0.0, 0.0), translation("XYZ") + euler("ZXY"))]
    slides = _slides(skeleton)
    for k in range(1, J):
        parent = int(skeleton.parents[k])
        dofs = (translation("XYZ") if slides[k] else ()) + euler("ZXY")
        joints.append(Joint(skeleton.joint_names[k], skeleton.joint_names[parent], tuple(p[k] - p[parent]), dofs))
    sites = [
        Site(name, skeleton.joint_names[j], tuple(p[J + s] - p[j]))
        for s, (name, j) in enumerate(zip(skeleton.site_names, skeleton.site_joint))
    ]
    return build_skeleton(joints, sites, up=tuple(skeleton.up), name=f"{skeleton.name}_view")


def _slides(skeleton: Skeleton) -> np.ndarray:
    """(J,) bool: joints moved by a translation of their own (prismatic, mimics included)."""
    m = skeleton.motions
    own = np.repeat(np.arange(skeleton.n_joints), np.diff(m.joint_start))
    out = np.zeros(skeleton.n_joints, bool)
    out[own[m.kind == TRANSLATE]] = True
    return out


def view_clip(skeleton: Skeleton, poses: np.ndarray, frame_time: float, source: str = "") -> Clip:
    """A BVH clip of the view skeleton that moves as `skeleton` does through `poses` (N, D)
    (radians / length units), `frame_time` seconds; its Euler channels continuous."""
    view = view_skeleton(skeleton)
    rest = forward_kinematics(skeleton, np.zeros(skeleton.n_dofs)).R_world_frame[: skeleton.n_joints]
    kin = forward_kinematics(skeleton, np.atleast_2d(poses))
    J = skeleton.n_joints
    moved = kin.R_world_frame[:, :J] @ np.swapaxes(rest, -1, -2)  # (N, J, 3, 3) world turn from rest
    parents = np.maximum(skeleton.parents, 0)
    local_turns = np.where(
        (skeleton.parents >= 0)[None, :, None, None], np.swapaxes(moved[:, parents], -1, -2) @ moved, moved
    )
    rest_p = forward_kinematics(skeleton, np.zeros(skeleton.n_dofs)).p_world_frame
    slides = _slides(skeleton)
    columns = []
    for name in view.joint_names:  # the view is built depth-first: its joints by name
        k = skeleton.joint_names.index(name)
        if k == 0:
            columns.append(kin.p_world_frame[:, 0])
        elif slides[k]:
            parent = int(skeleton.parents[k])
            relative = kin.p_world_frame[:, k] - kin.p_world_frame[:, parent]
            local = np.einsum("nji,nj->ni", moved[:, parent], relative)  # in the parent's view frame
            columns.append(local - (rest_p[k] - rest_p[parent]))
        columns.append(euler_angles("ZXY", local_turns[:, k]))
    frames = np.concatenate(columns, axis=1)
    return Clip.from_poses(view, frames, frame_time, source or f"<view of {skeleton.name}>").with_continuous_channels()
