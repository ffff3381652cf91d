"""Retarget a clip onto another skeleton through a joint map (item 2 of issue 18).

1. Key points: each mapped source frame's path in the target's world (keypoints.py): with
   `scale = "limbs"` the source's pose with the target's limb lengths (each point placed from
   its parent point, the pelvis's path scaled by the ratio of pelvis heights), else scaled by
   one body ratio; the pelvis (the target's root) and torso orientations turn as the source's.
2. Per-frame IK, all frames at once (ik.py: Levenberg-Marquardt within the joint limits): the
   root starts on the pelvis's orientation and mapped point; every DOF, the root's included
   (a leg its limits stop is met by turning the pelvis), moves to meet the key points, every
   joint and site kept above the floor. The torso orientation enters as two points a quarter
   of the reach along its turned axes, measured from its origin at each step.
3. Contacts: the source's (detected there) on the mapped target sites, planted where step 2
   put them (clips.contacts.planted_targets: at the median height, on the floor when near it)
   and held there by a second IK pass in which a contact counts CONTACT_WEIGHT times a key
   point. No DE repair: on targets whose limits cannot follow the source, DE's repairs within
   tight contact tolerances moved whole bodies tens of centimetres off their key points.
A target whose root does not move (a URDF robot) gets a floating root first, and a built-in
character's root limits are freed (skeletons.py).
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from deik.clips.contacts import Contacts, detect_contacts
from deik.clips.floor import clearance
from deik.clips.plants import planted_targets
from deik.clips.units import guess_unit, metres_per_unit
from deik.clips.warmstart import dof_weights
from deik.io.clip import Clip
from deik.io.trajectory import Trajectory
from deik.model.kinematics import forward_kinematics
from deik.model.skeleton import Skeleton
from deik.retarget import keypoints as kp
from deik.retarget.ik import solve_keypoints
from deik.retarget.maps import JointMap, check_map
from deik.retarget.report import retarget_report, within_limits
from deik.retarget.result import Retarget
from deik.retarget.skeletons import with_floating_root, with_free_root, with_sites

CONTACT_WEIGHT = 30.0  # a planted contact's drift counts this many times a key point's error
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
    box = targets.reshape(-1, 3)
    if target.joint_dof_start[1] == 0:
        return with_floating_root(target, box.min(axis=0) - target.reach, box.max(axis=0) + target.reach)
    return with_free_root(target, box)


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
    clips.coherence.hinge_channels of its own clip), default none. `settings` are those of a
    clip fix (seed, device, population, ...), which this retarget does not run: only
    `progress(met, stage)` is called, after each IK pass."""
    began = time.perf_counter()
    check_map(joint_map, source.skeleton, target)
    rotation = np.eye(3) if joint_map.rotation is None else joint_map.rotation
    source_names = [p.source for p in joint_map.points]
    sited = with_sites(target, [(p.site, p.target, p.offset) for p in joint_map.points if any(p.offset)])
    names = [p.site for p in joint_map.points]
    scale = joint_map.scale or kp.height_ratio(source.skeleton, sited, source_names, names)
    source_contacts = detect_contacts(source)
    origin = kp.floor_origin(source.skeleton, source.pose(0), source_contacts.ground)
    if joint_map.limbs:
        if joint_map.pelvis[0] not in source_names:
            raise ValueError(
                f'{joint_map.source}: scale = "limbs" needs the pelvis {joint_map.pelvis[0]!r} among the points'
            )
        root = source_names.index(joint_map.pelvis[0])
        root_scale, scales = kp.limb_scales(source.skeleton, sited, source_names, names, root, scale)
        targets = kp.limb_points(source, source_names, origin, root, root_scale, scales, rotation)
    else:
        targets = kp.mapped_points(source, source_names, origin, scale, rotation)
    target = _prepared(target, joint_map, targets)
    poses, placed = _start(target, joint_map, source, names, targets, rotation)
    searched = np.ones(target.n_dofs, bool)  # the root too: a leg its limits stop is met by turning the pelvis
    if hinges is not None:
        searched[-len(hinges) :] &= ~np.asarray(hinges, bool)
    searched = np.broadcast_to(searched, poses.shape)
    weights = dof_weights(Trajectory(target, poses, source.frame_time))
    points, wanted = list(names), targets
    if joint_map.torso:
        R_torso = kp.mapped_rotations(source, joint_map.torso[0], target, joint_map.torso[1], rotation)
        points += [f"retarget_torso_{axis}" for axis in "xy"]

        def wanted(q):  # the torso's points are measured from its origin at the pose
            return np.concatenate([targets, _torso_targets(target, q, joint_map.torso[1], R_torso)], axis=1)

    # key points first: with the floor from the start, a point that must cross it on its way
    # (a hand swinging down to the floor) refuses every step and stalls
    poses = solve_keypoints(target, poses, points, wanted, searched, weights)
    progress = settings.get("progress") or (lambda met, stage: None)
    progress(len(poses), "key points")
    contacts = _target_contacts(source_contacts, joint_map)
    held, plants = np.ones((len(poses), len(points))), np.zeros((len(poses), 0, 3))
    if contacts is not None:  # planted where the key points put them above the floor, then held there
        poses = solve_keypoints(target, poses, points, wanted, searched, weights, floor=0.0)
        plants = planted_targets(Trajectory(target, poses, source.frame_time), contacts)
        held = np.concatenate([held, CONTACT_WEIGHT * contacts.mask], axis=1)

    def wanted_and_plants(q):
        return np.concatenate([wanted(q) if callable(wanted) else wanted, plants], axis=1)

    together = points + ([] if contacts is None else list(contacts.sites))
    poses = solve_keypoints(target, poses, together, wanted_and_plants, searched, weights, 0.0, held)  # floor at 0
    progress(len(poses), "contacts and the floor")
    motion = Trajectory(target, poses, source.frame_time, source.source)
    fix = None
    # the same rotations, written within the limits (continuous Euler channels may pick a twin outside)
    motion = replace(motion, frames=within_limits(target, motion.frames))
    wall = time.perf_counter() - began
    metres = metres_per_unit(guess_unit(target))
    clear = np.zeros(0) if contacts is None else clearance(forward_kinematics(target, motion.poses()), target, contacts)
    report = retarget_report(motion, names, targets, contacts, clear, metres, wall)
    report["summary"]["body_scale"] = scale
    return Retarget(motion, None, source, contacts, tuple(names), targets, report, fix)
