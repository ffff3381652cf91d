"""Retarget a clip onto another skeleton through a joint map (item 2 of issue 18).

1. Key points: each mapped source frame's path in the target's world (keypoints.py): with
   `scale = "limbs"` the source's pose with the target's limb lengths (each point placed from
   its parent point, the pelvis's path scaled by the ratio of pelvis heights), else scaled by
   one body ratio; the pelvis (the target's root) and torso orientations turn as the source's.
2. Per-frame IK, all frames at once (ik.py: Levenberg-Marquardt within the joint limits): the
   root starts on the pelvis's orientation and mapped point; every DOF, the root's included
   (a leg its limits stop is met by turning the pelvis), moves to meet the key points; frames
   whose error stands out from their neighbours' are solved again from their poses. The torso
   orientation enters as two points a quarter of the reach along its turned axes, measured
   from its origin at each step.
3. The same IK again with every joint and site of the body kept above the floor, outliers
   repaired, then REBASIN times from the clip's poses smoothed over the frames, so that
   neighbouring frames share a basin (ik.rebasin); runs of frames whose key points still jolt
   are solved again from a neighbour's pose (ik.repair_jolts: an arm flicking between two
   equally good compromises).
4. The last steps (settle.py): every mapped source point at rest near the source's floor
   planted on the target frame it maps to, each DOF's step within its allowance (a robot's
   velocity limits), the joint values continuous, and the space-time pass (smooth.py): all
   frames at once, contacts held still, the body above the floor and out of itself (bone
   capsules), the key points as near as that allows, the motion as smooth as the IK's,
   within the limits. No DE repair: on targets whose limits cannot follow the source, DE's
   repairs within tight contact tolerances moved whole bodies tens of centimetres off their
   key points.
A target whose root does not move (a URDF robot) gets a floating root first, and a built-in
character's root limits are freed (skeletons.py).
"""

from __future__ import annotations

import time

import numpy as np

from deik.cleanup.body import rest_standing
from deik.cleanup.warmstart import dof_weights
from deik.errors import InputError
from deik.io.motion import Clip
from deik.io.trajectory import Trajectory
from deik.model.build import with_sites
from deik.model.joints import TRANSLATE
from deik.model.kinematics import forward_kinematics
from deik.model.rotations import upright
from deik.model.skeleton import Skeleton
from deik.retargeting import keypoints as kp
from deik.retargeting.ik import KeypointGoals, rebasin, repair_flips, repair_jolts, repair_outliers, solve_keypoints
from deik.retargeting.maps import JointMap, check_map
from deik.retargeting.outcome import Progress, Retarget
from deik.retargeting.resting import rest_floor
from deik.retargeting.settle import STEP_ALLOWANCE, Settling, largest_turn, settle
from deik.retargeting.skeletons import with_floating_root, with_free_root

TORSO_ARM = 0.25  # of the target's reach: how far the torso's orientation points lie from it
TORSO_SITES = ("retarget_torso_x", "retarget_torso_y")  # they steer the torso; they are no body part
REBASIN = 2  # rounds: the second lowers the humanoid's key-point acceleration peaks (dance 2.5->2.2, crawl 3.1->2.8)


def _prepared(target: Skeleton, joint_map: JointMap, targets: np.ndarray) -> Skeleton:
    """The target with a site per offset point, the torso's two orientation points and, for a
    root without DOFs, a floating root free over the key points' box plus reach."""
    sites = [(p.site, p.target, p.offset) for p in joint_map.points if any(p.offset)]
    if joint_map.torso:
        arm = TORSO_ARM * target.reach
        R_rest = rest_standing(target).rotation(joint_map.torso[1])
        sites += [(name, joint_map.torso[1], R_rest[k] * arm) for k, name in enumerate(TORSO_SITES)]
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


def _torso_targets(target: Skeleton, poses: np.ndarray, torso: str, turned: np.ndarray) -> np.ndarray:
    """(n, 2, 3) where the torso's two orientation points belong when the torso is `turned`
    (n, 3, 3) from its standing rest, measured from the torso's origin at `poses` (n, D)."""
    origin = forward_kinematics(target, poses).position(torso)
    return origin[:, None] + TORSO_ARM * target.reach * np.swapaxes(turned[:, :, :2], 1, 2)


def retarget_rig(
    source: Clip,
    target: Skeleton,
    joint_map: JointMap,
    hinges: np.ndarray | None = None,
    velocity: dict | None = None,
    progress: Progress | None = None,
    captured: Clip | None = None,
) -> Retarget:
    """Retarget the clip `source` onto `target` through `joint_map` (see the module notes).
    `hinges` (D,) bool of the target's DOFs to keep at 0 (a BVH rig's hinge channels, from
    clips.coherence.hinge_channels of its own clip), default none; `velocity` {DOF name: limit}
    (rad/s or length units/s, a URDF's) bounds each DOF's step between frames (settle.py);
    `progress(frames, stage)` is called after each IK pass and the space-time pass; `captured`
    the clip as given where `source` is it low-passed (settle.Settling)."""
    began = time.perf_counter()
    check_map(joint_map, source.skeleton, target)
    # a map's rotation is written for a source with +Y up, the BVH convention: one read with
    # another up is first turned upright
    rotation = (np.eye(3) if joint_map.rotation is None else joint_map.rotation) @ upright(source.skeleton.up)
    source_names = [p.source for p in joint_map.points]
    sited = with_sites(target, [(p.site, p.target, p.offset) for p in joint_map.points if any(p.offset)])
    names = [p.site for p in joint_map.points]
    scale = joint_map.scale or kp.height_ratio(source.skeleton, sited, source_names, names)
    floor = rest_floor(source, kp.stature(source.skeleton))
    origin = kp.floor_origin(source.skeleton, source.pose(0), floor)
    if joint_map.limbs:
        if joint_map.pelvis[0] not in source_names:
            raise InputError(
                f'{joint_map.source}: scale = "limbs" needs the pelvis {joint_map.pelvis[0]!r} among the points'
            )
        root = source_names.index(joint_map.pelvis[0])
        root_scale, scales = kp.limb_scales(source.skeleton, sited, source_names, names, root, scale)
        targets = kp.limb_points(source, source_names, origin, root, root_scale, scales, rotation)
    else:
        targets = kp.mapped_points(source, source_names, origin, scale, rotation)
    target = _prepared(target, joint_map, targets)
    size = kp.stature(sited)
    poses, placed = _start(target, joint_map, source, names, targets, rotation)
    searched = ~_held_translations(target)  # the root too: a leg its limits stop is met by turning the pelvis
    if hinges is not None:
        searched[-len(hinges) :] &= ~np.asarray(hinges, bool)
    weights = dof_weights(Trajectory(target, poses, source.frame_time))
    points, wanted = list(names), targets
    if joint_map.torso:
        R_torso = kp.mapped_rotations(source, joint_map.torso[0], target, joint_map.torso[1], rotation)
        turned = R_torso @ rest_standing(target).rotation(joint_map.torso[1]).T  # the turns from rest
        points += list(TORSO_SITES)

        def wanted(q, frames):  # the torso's points are measured from its origin at the pose
            torso = _torso_targets(target, q, joint_map.torso[1], turned[frames])
            return np.concatenate([targets[frames], torso], axis=1)

    body = [name for name in target.frame_names if name not in TORSO_SITES]
    # key points first: with the floor from the start, a point that must cross it on its way
    # (a hand swinging down to the floor) refuses every step and stalls
    goals = KeypointGoals(target, points, wanted, searched, weights, size=size)
    poses = repair_outliers(goals, solve_keypoints(goals, poses))
    progress = progress or (lambda frames, stage: None)
    progress(len(poses), "key points")
    goals = goals.above(0.0, body)  # the floor at 0
    poses = solve_keypoints(goals, poses)
    for k in range(REBASIN + 1):
        if k:
            poses = rebasin(goals, poses)
        poses = repair_outliers(goals, poses)
    poses = repair_jolts(goals, poses, source.frame_time)
    poses = repair_flips(goals, poses, STEP_ALLOWANCE * largest_turn(source))
    progress(len(poses), "the floor")
    # the orientation points steered the torso; the motion's skeleton is the target's own, and
    # its capsules too (a bone to an orientation point would thin the chest's: model.capsules).
    # They are the last frames, so every other frame keeps its index.
    settling = Settling(
        source=source,
        floor=floor,
        target_floor=0.0,
        target=target,
        poses=poses,
        names=points,
        targets=wanted,
        reported=targets,
        points=dict(zip(source_names, names)),
        searched=searched,
        weights=weights,
        body=body,
        velocity=velocity or {},
        steering=TORSO_SITES,
        began=began,
        captured=captured,
    )
    motion, contacts, report = settle(settling)
    progress(len(poses), "contacts, the floor, self-collision and velocity limits, all frames at once")
    report["summary"]["body_scale"] = scale
    return Retarget(motion, None, source, contacts, tuple(names), targets, report)


def _held_translations(skeleton: Skeleton) -> np.ndarray:
    """(D,) bool: the translations below the root, which keep their values (a rig's position
    channels carry bone lengths, not motion)."""
    return (skeleton.dof_kind == TRANSLATE) & (skeleton.dof_joint > 0)
