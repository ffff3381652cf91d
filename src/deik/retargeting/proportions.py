"""Retarget a clip onto the same skeleton with other bone lengths (item 1 of issue 18).

1. The joint angles (the style) are copied; the root's path is scaled about the floor point
   below its first position by the leg ratio r (the root's height above the lowest contact
   site at rest, target over source): strides lengthen with the legs and the feet land on the
   floor (copying the angles onto 10 % longer legs alone puts the feet 8 cm under it).
2. The source's contacts (detected on the source) are planted where this scaled motion puts
   them, and the other end sites (hands, head) follow their scaled paths, through the clip
   fix (clips.solver.fix_clip: warm start, DE repairs, limits kept).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from deik.cleanup.clip_goals import ClipGoals, Reach
from deik.cleanup.contacts import detect_contacts
from deik.cleanup.fix import fix_clip
from deik.cleanup.floor import clearance
from deik.cleanup.units import guess_unit, metres_per_unit
from deik.errors import InputError
from deik.io.motion import Clip
from deik.model.joints import TRANSLATE
from deik.model.kinematics import forward_kinematics
from deik.model.skeleton import Skeleton
from deik.retargeting.keypoints import floor_origin, rest_heights
from deik.retargeting.measures import retarget_report
from deik.retargeting.outcome import Retarget


def check_same_rig(source: Skeleton, target: Skeleton, target_name: str) -> None:
    """ValueError unless `target` has the source's joints, sites and DOFs by name and order."""
    for what in ("joint_names", "site_names", "dof_names"):
        ours, theirs = getattr(source, what), getattr(target, what)
        if ours != theirs:
            missing = sorted(set(ours) ^ set(theirs))[:3] or ["(same names, other order)"]
            raise InputError(
                f"--to {target_name}: its {what.replace('_', ' ')} differ from the source's "
                f"({', '.join(missing)}); --to takes the same rig with other bone lengths, "
                "use --map MAP.toml for another skeleton"
            )


def leg_ratio(source: Skeleton, target: Skeleton, sites: Sequence[str]) -> float:
    """Target over source height of the root above the lowest of `sites` at rest."""
    heights = [rest_heights(sk, (sk.joint_names[0], *sites)) for sk in (source, target)]
    legs = [h[0] - h[1:].min() for h in heights]
    if not legs[0] > 0:
        raise InputError("the source's root is not above its contact sites at rest: no leg length to scale by")
    return float(legs[1] / legs[0])


def scaled_root(clip: Clip, target: Skeleton, ground: float, ratio: float) -> np.ndarray:
    """(N, D) the clip's frames with the root's X, Y, Z translations (which must come first)
    moved so that the target's root follows the source's path scaled by `ratio` about the floor
    point below its first position."""
    sk = clip.skeleton
    start = sk.joint_dof_start[0]
    kinds = sk.dof_kind[start : start + 3]
    if len(kinds) < 3 or (kinds != TRANSLATE).any() or not np.allclose(sk.dof_axis[start : start + 3], np.eye(3)):
        raise InputError(f"the root {sk.joint_names[0]!r} needs X, Y and Z position channels first to be scaled")
    root = forward_kinematics(sk, clip.poses()).p_world_frame[:, 0]
    origin = floor_origin(sk, clip.pose(0), ground)
    wanted = origin + ratio * (root - origin)
    frames = clip.frames.copy()
    frames[:, start : start + 3] = (wanted - target.offsets[0]) @ target.joint_rotation[0]
    return frames


def _room_to_travel(target: Skeleton, frames: np.ndarray) -> Skeleton:
    """`target` with each translation's limits widened to the `frames` (N, D) plus its reach (a
    BVH target's limits come from its own clip, which may travel less than the source)."""
    slide = target.dof_kind == TRANSLATE
    lower = np.where(slide, np.minimum(target.lower, frames.min(axis=0) - target.reach), target.lower)
    upper = np.where(slide, np.maximum(target.upper, frames.max(axis=0) + target.reach), target.upper)
    return replace(target, lower=lower, upper=upper)


def retarget_proportions(
    clip: Clip, target: Skeleton, follow: Sequence[str] | None = None, **settings: object
) -> Retarget:
    """Retarget `clip` onto `target`, the same rig with other bone lengths (see the module
    notes). `follow`: the sites that keep their scaled paths (default every site not in
    contact); `settings` go to fix_clip (population, generations, seed, device, ...)."""
    began = time.perf_counter()
    sk = clip.skeleton
    contacts = detect_contacts(clip)
    ratio = leg_ratio(sk, target, contacts.sites)
    frames = scaled_root(clip, target, contacts.ground, ratio)
    target = _room_to_travel(target, frames)
    scaled = Clip(target, frames, clip.frame_time, clip.layout, clip.source, clip.mass_source)
    follow = [s for s in sk.site_names if s not in contacts.sites] if follow is None else list(follow)
    kin = forward_kinematics(target, scaled.poses())
    everywhere = np.ones(clip.n_frames, bool)
    reach = tuple(Reach(site, everywhere, kin.position(site)) for site in follow)
    fix = fix_clip(scaled, ClipGoals(contacts, reach), **settings)
    wall = time.perf_counter() - began
    clear = clearance(forward_kinematics(sk, clip.poses()), sk, contacts) * ratio
    targets = np.stack([kin.position(site) for site in follow], axis=1) if follow else np.zeros((clip.n_frames, 0, 3))
    metres = metres_per_unit(guess_unit(target))
    report = retarget_report(fix.clip, follow, targets, contacts, clear, metres, wall, scaled=scaled)
    report["summary"]["leg_ratio"] = ratio
    return Retarget(fix.clip, fix.clip, clip, contacts, tuple(follow), targets, report, fix)
