"""Retarget a clip onto the same skeleton with other bone lengths (item 1 of issue 18).

1. The joint angles (the style) are copied; the root's path is scaled about the floor point
   below its first position by the leg ratio r (the root's height above the lowest joint or
   site at rest, target over source): strides lengthen with the legs and the feet land on
   the floor (copying the angles onto 10 % longer legs alone puts the feet 8 cm under it).
2. Every joint and site of that scaled motion is a key point, and the motion goes through the
   last steps every retarget takes (settle.py): the source's resting points (feet, hands,
   knees, the pelvis ...) planted, the whole body kept above the source's floor and out of
   itself, the steps between frames within 1.5 x the source's largest joint turn, corrections
   faded in and out (the space-time pass), so the same contacts and floor as onto another
   skeleton. The rig's hinge channels (knees, elbows) and its position channels below the
   root keep their values.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from deik.cleanup.coherence import hinge_channels
from deik.cleanup.warmstart import dof_weights
from deik.errors import InputError
from deik.io.motion import Clip, message_prefix
from deik.model.capsules import body_root, on_joints
from deik.model.joints import TRANSLATE
from deik.model.kinematics import forward_kinematics
from deik.model.skeleton import Skeleton
from deik.retargeting.keypoints import floor_origin, rest_heights, stature
from deik.retargeting.outcome import Progress, Retarget
from deik.retargeting.resting import rest_floor
from deik.retargeting.settle import Settling, settle


def check_same_rig(source: Skeleton, target: Skeleton, target_name: str) -> None:
    """InputError unless `target` has the source's joints, sites and DOFs by name and order."""
    for what in ("joint_names", "site_names", "dof_names"):
        ours, theirs = getattr(source, what), getattr(target, what)
        if ours != theirs:
            missing = sorted(set(ours) ^ set(theirs))[:3] or ["(same names, other order)"]
            raise InputError(
                f"--to {target_name}: its {what.replace('_', ' ')} differ from the source's "
                f"({', '.join(missing)}); --to takes the same rig with other bone lengths, "
                "use --map MAP.toml for another skeleton"
            )


def leg_ratio(source: Skeleton, target: Skeleton, sites: Sequence[str], prefix: str = "") -> float:
    """Target over source height of the body root (the hips, under any Reference joint)
    above the lowest of `sites` (joints or sites) at rest; `prefix` begins an error (the source
    file and a colon)."""
    heights = [rest_heights(sk, (sk.joint_names[body_root(sk)], *sites)) for sk in (source, target)]
    legs = [h[0] - h[1:].min() for h in heights]
    if not legs[0] > 0:
        raise InputError(f"{prefix}the root is above no joint or site at rest: no leg length to scale by")
    return float(legs[1] / legs[0])


def scaled_root(clip: Clip, target: Skeleton, ground: float, ratio: float) -> np.ndarray:
    """(N, D) the clip's frames with the root's three translations (which must come first, along
    three different axes in any order) moved so that the target's body root (model.capsules.
    body_root: the hips, under any Reference joint on the floor) follows the source's path
    scaled by `ratio` about the floor point below its first position. A body root with three
    translations of its own follows it by those, the root then moving its ground track only:
    the hips rise with longer legs while a Reference stays on the floor."""
    sk = clip.skeleton
    if not _translates(sk, 0):
        raise InputError(
            f"{message_prefix(clip)}the root {sk.joint_names[0]!r} needs three position channels first to be scaled"
        )
    body = body_root(sk)
    movers = [0, body] if body and _translates(sk, body) else [0]
    origin = floor_origin(sk, clip.pose(0), ground)
    source = forward_kinematics(sk, clip.poses()).p_world_frame
    frames = clip.frames.copy()
    for joint in movers:
        followed = joint if len(movers) == 2 else body
        wanted = origin + ratio * (source[:, followed] - origin)
        if len(movers) == 2 and joint == 0:  # a carrier under the body: along the ground only
            wanted -= ((wanted - source[:, joint]) @ sk.up)[:, None] * sk.up
        now = forward_kinematics(target, frames)
        parent = sk.parents[joint]
        R_parent = now.R_world_frame[:, parent] if parent >= 0 else np.broadcast_to(np.eye(3), (len(frames), 3, 3))
        move = np.einsum("nji,nj->ni", R_parent, wanted - now.p_world_frame[:, followed])
        start = sk.joint_dof_start[joint]
        frames[:, start : start + 3] += move @ target.joint_rotation[joint] @ sk.dof_axis[start : start + 3].T
    return frames


def _translates(skeleton: Skeleton, joint: int) -> bool:
    """Whether `joint`'s first three DOFs translate along three perpendicular axes."""
    start, stop = skeleton.joint_dof_start[joint], skeleton.joint_dof_start[joint + 1]
    kinds, axes = skeleton.dof_kind[start : min(start + 3, stop)], skeleton.dof_axis[start : min(start + 3, stop)]
    return len(kinds) == 3 and (kinds == TRANSLATE).all() and np.allclose(axes @ axes.T, np.eye(3))


def _room_to_travel(target: Skeleton, frames: np.ndarray) -> Skeleton:
    """`target` with each translation's limits widened to the `frames` (N, D) plus its reach (a
    BVH target's limits come from its own clip, which may travel less than the source)."""
    slide = target.dof_kind == TRANSLATE
    lower = np.where(slide, np.minimum(target.lower, frames.min(axis=0) - target.reach), target.lower)
    upper = np.where(slide, np.maximum(target.upper, frames.max(axis=0) + target.reach), target.upper)
    return replace(target, lower=lower, upper=upper)


def retarget_proportions(
    clip: Clip, target: Skeleton, progress: Progress | None = None, captured: Clip | None = None
) -> Retarget:
    """Retarget `clip` onto `target`, the same rig with other bone lengths (see the module
    notes); `progress(frames, stage)` is called after the space-time pass; `captured` the clip
    as given where `clip` is it low-passed (settle.Settling)."""
    began = time.perf_counter()
    sk = clip.skeleton
    target = replace(target, helpers=sk.helpers)  # the same rig: the same joints
    floor = rest_floor(clip, stature(sk))
    ratio = leg_ratio(sk, target, sk.frame_names, message_prefix(clip))
    frames = scaled_root(clip, target, floor, ratio)
    target = _room_to_travel(target, frames)
    scaled = Clip(target, frames, clip.frame_time, clip.layout, clip.source, clip.mass_source)
    helpers = on_joints(sk, sk.helpers)  # the source's helper bones: no key points
    names = [name for name, helper in zip(target.frame_names, helpers) if not helper]
    kin = forward_kinematics(target, scaled.poses())
    targets = np.stack([kin.position(name) for name in names], axis=1)
    searched = ~hinge_channels(clip) & ~((target.dof_kind == TRANSLATE) & (target.dof_joint > 0))
    settling = Settling(
        source=clip,
        floor=floor,
        target_floor=floor,
        target=target,
        poses=scaled.poses(),
        names=names,
        targets=targets,
        reported=targets,
        points={name: name for name in names},
        searched=searched,
        weights=dof_weights(scaled),
        body=names,
        velocity={},
        began=began,
        scaled=scaled,
        captured=captured,
    )
    motion, contacts, report = settle(settling)
    if progress is not None:
        progress(clip.n_frames, "contacts, the floor and self-collision")
    report["summary"]["leg_ratio"] = ratio
    out = Clip(target, motion.frames, clip.frame_time, clip.layout, clip.source, clip.mass_source)
    return Retarget(out, out, clip, contacts, tuple(names), targets, report)
