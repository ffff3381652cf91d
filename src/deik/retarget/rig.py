"""Retarget a clip onto another skeleton through a joint map (item 2 of issue 18).

1. Key points: each mapped source frame's path, scaled by the body-height ratio into the
   target's world (keypoints.py); the pelvis (the target's root) and torso orientations turn
   as the source's do.
2. Per-frame IK, all frames at once: the root takes the pelvis orientation and the position
   that puts its mapped point on its target; the other DOFs meet the key points by damped
   least squares (clips.warmstart.warm_start, frames pulled towards their neighbours), cut
   back into the target's joint limits, in ROUNDS rounds. The torso orientation enters as two
   points a forearm's length along its turned axes, re-aimed from its origin each round.
3. Contacts: the source's (detected there) on the mapped target sites, planted through the
   clip fix (clips.solver.fix_clip: warm start, DE repairs within the limits, smooth easing).
A target whose root does not move (a URDF robot) gets a floating root first (skeletons.py).
"""

from __future__ import annotations

import time

import numpy as np

from deik.clips.contacts import Contacts, detect_contacts
from deik.clips.floor import clearance
from deik.clips.problem import ClipGoals
from deik.clips.solver import fix_clip
from deik.clips.units import guess_unit, metres_per_unit
from deik.clips.warmstart import dof_weights, warm_start
from deik.io.clip import Clip
from deik.io.trajectory import Trajectory
from deik.model.kinematics import forward_kinematics
from deik.model.skeleton import Skeleton
from deik.objectives.goals import Position
from deik.retarget import keypoints as kp
from deik.retarget.maps import JointMap, check_map
from deik.retarget.report import retarget_report
from deik.retarget.result import Retarget
from deik.retarget.skeletons import with_floating_root, with_sites

ROUNDS = 4
STEPS = 4  # Gauss-Newton steps per round (each moves a point at most 10 % of reach)
TORSO_ARM = 0.25  # of the target's reach: how far the torso's orientation points lie from it


def _prepared(target: Skeleton, joint_map: JointMap, targets: np.ndarray) -> Skeleton:
    """The target with a site per offset point, the torso's two orientation points and, for a
    root without DOFs, a floating root free over the key points' box plus reach."""
    sites = [(p.site, p.target, p.offset) for p in joint_map.points if any(p.offset)]
    if joint_map.torso:
        arm = TORSO_ARM * target.reach
        R_rest = forward_kinematics(target, np.zeros(target.n_dofs)).rotation(joint_map.torso[1])
        sites += [(f"retarget_torso_{axis}", joint_map.torso[1], R_rest[k] * arm) for k, axis in enumerate("xy")]
    target = with_sites(target, sites)
    if target.joint_dof_start[1] == 0:
        box = targets.reshape(-1, 3)
        target = with_floating_root(target, box.min(axis=0) - target.reach, box.max(axis=0) + target.reach)
    return target


def _start(target: Skeleton, joint_map: JointMap, source, names, targets, rotation) -> tuple[np.ndarray, bool]:
    """(poses (N, D), placed): every DOF at 0 cut into its limits, the root placed on the
    pelvis (placed True) when the map names a pelvis and a point on the root."""
    N = source.n_frames
    poses = np.tile(np.clip(0.0, target.lower, target.upper), (N, 1))
    if not joint_map.pelvis:
        return poses, False
    R_root = kp.mapped_rotations(source, joint_map.pelvis[0], target, joint_map.pelvis[1], rotation)
    on_root = [k for k, name in enumerate(names) if _carrier(target, name) == 0]
    if not on_root:
        return poses, False
    f = target.frame_index(names[on_root[0]])
    offset = np.zeros(3) if f < target.n_joints else target.site_offset[f - target.n_joints]
    root = kp.root_dofs(target, targets[:, on_root[0]], offset, R_root)
    if root is None:
        return poses, False
    poses[:, :6] = root
    return poses, True


def _carrier(skeleton: Skeleton, name: str) -> int:
    f = skeleton.frame_index(name)
    return f if f < skeleton.n_joints else int(skeleton.site_joint[f - skeleton.n_joints])


def _torso_targets(target: Skeleton, poses: np.ndarray, torso: str, R_torso: np.ndarray) -> np.ndarray:
    """(N, 2, 3) where the torso's two orientation points belong at orientations `R_torso`
    (N, 3, 3), measured from the torso's origin at `poses` (N, D)."""
    origin = forward_kinematics(target, poses).position(torso)
    R_rest = forward_kinematics(target, np.zeros(target.n_dofs)).rotation(torso)
    turned = R_torso @ R_rest.T  # the turn from rest: its first two columns carry the points
    return origin[:, None] + TORSO_ARM * target.reach * np.swapaxes(turned[:, :, :2], 1, 2)


def _target_contacts(source_contacts: Contacts, joint_map: JointMap) -> Contacts | None:
    """The source's contacts on the target sites their sites map to (ground 0), or None."""
    sites = {p.source: p.site for p in joint_map.points}
    columns = [s for s, name in enumerate(source_contacts.sites) if name in sites]
    if not columns:
        return None
    mask = source_contacts.mask[:, columns]
    names = tuple(sites[source_contacts.sites[s]] for s in columns)
    return Contacts(names, mask, source_contacts.detected, None, None, 0.0)


def retarget_rig(
    source: Clip, target: Skeleton, joint_map: JointMap, hinges: np.ndarray | None = None, **settings: object
) -> Retarget:
    """Retarget the clip `source` onto `target` through `joint_map` (see the module notes).
    `hinges` (D,) bool of the target's DOFs to keep at 0 (a BVH rig's hinge channels, from
    clips.coherence.hinge_channels of its own clip), default none; `settings` go to fix_clip."""
    began = time.perf_counter()
    check_map(joint_map, source.skeleton, target)
    rotation = np.eye(3) if joint_map.rotation is None else joint_map.rotation
    source_names = [p.source for p in joint_map.points]
    sited = with_sites(target, [(p.site, p.target, p.offset) for p in joint_map.points if any(p.offset)])
    names = [p.site for p in joint_map.points]
    scale = joint_map.scale or kp.height_ratio(source.skeleton, sited, source_names, names)
    source_contacts = detect_contacts(source)
    origin = kp.floor_origin(source.skeleton, source.pose(0), source_contacts.ground)
    targets = kp.mapped_points(source, source_names, origin, scale, rotation)
    target = _prepared(target, joint_map, targets)
    poses, placed = _start(target, joint_map, source, names, targets, rotation)
    searched = np.ones(target.n_dofs, bool)
    if placed:
        searched[:6] = False
    if hinges is not None:
        searched[-len(hinges) :] &= ~np.asarray(hinges, bool)
    searched = np.broadcast_to(searched, poses.shape)
    weights = dof_weights(Trajectory(target, poses, source.frame_time))
    goals = [Position(name, targets[:, k]) for k, name in enumerate(names)]
    R_torso = None
    if joint_map.torso:
        R_torso = kp.mapped_rotations(source, joint_map.torso[0], target, joint_map.torso[1], rotation)
    for _ in range(ROUNDS):
        extra = []
        if R_torso is not None:
            points = _torso_targets(target, poses, joint_map.torso[1], R_torso)
            extra = [Position(f"retarget_torso_{axis}", points[:, k]) for k, axis in enumerate("xy")]
        step = warm_start(target, poses, goals + extra, searched, weights, steps=STEPS)
        poses = np.clip(poses + step, target.lower, target.upper)
    motion = Trajectory(target, poses, source.frame_time, source.source)
    contacts = _target_contacts(source_contacts, joint_map)
    fix = None
    if contacts is not None:
        fix = fix_clip(motion, ClipGoals(contacts), **settings)
        motion = fix.clip
    wall = time.perf_counter() - began
    metres = metres_per_unit(guess_unit(target))
    clear = np.zeros(0) if contacts is None else clearance(forward_kinematics(target, motion.poses()), target, contacts)
    report = retarget_report(motion, names, targets, contacts, clear, metres, wall)
    report["summary"]["body_scale"] = scale
    return Retarget(motion, None, source, contacts, tuple(names), targets, report, fix)
