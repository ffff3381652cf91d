"""deik.retarget(): move a clip onto other proportions or another skeleton (docs/retarget.md)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from numbers import Real

from numpy.typing import ArrayLike

from deik.cleanup.body import body_of, with_helpers
from deik.cleanup.clean import without_shake
from deik.cleanup.coherence import hinge_channels
from deik.cleanup.cuts import find_cuts
from deik.cleanup.up_axis import check_clip_rests
from deik.errors import InputError
from deik.io.bvh import read_bvh
from deik.io.bvh.preview import view_clip
from deik.io.files import FilePath
from deik.io.load import load_skeleton
from deik.io.motion import Clip
from deik.io.urdf import read_velocity_limits
from deik.model.skeleton import Skeleton
from deik.retargeting.continuity import continuous_within_limits
from deik.retargeting.maps import JointMap, read_map
from deik.retargeting.outcome import Progress, Retarget, frame_range
from deik.retargeting.proportions import check_same_rig, retarget_proportions
from deik.retargeting.rig import retarget_rig
from deik.retargeting.skeletons import scaled_bones
from deik.suggest import did_you_mean


def _target(to, up) -> tuple[Skeleton, Clip | None]:
    """(skeleton, its clip or None) of `to`: a Skeleton, a Clip, or what load_skeleton reads."""
    if isinstance(to, Skeleton):
        return to, None
    if isinstance(to, Clip):
        return to.skeleton, to
    loaded = load_skeleton(str(to), up=up if str(to).lower().endswith(".urdf") else None)
    return loaded.skeleton, loaded.clip


def _check_velocity(velocity: object, target: Skeleton) -> None:
    """InputError unless `velocity` maps DOF names of `target` to limits above 0."""
    if not isinstance(velocity, Mapping):
        raise InputError(f"velocity: give {{DOF name: limit}}, got {velocity!r:.60}")
    for name, limit in velocity.items():
        if name not in target.dof_names:
            raise InputError(
                f"velocity: {target.name!r} has no DOF {name!r}{did_you_mean(str(name), target.dof_names)}"
            )
        if isinstance(limit, bool) or not isinstance(limit, Real) or not 0 < limit < math.inf:
            raise InputError(f"velocity: the limit of {name!r} must be a finite number above 0, got {limit!r:.40}")


def _bvh_clip(result: Retarget, target_clip: Clip | None) -> Clip:
    """The BVH clip of a rig retarget: the target clip's layout for a BVH target, the skeleton's
    own where BVH can carry it (the built-in humanoid), else a view of the robot."""
    motion = result.motion
    frames = continuous_within_limits(motion.skeleton, motion.frames)
    if target_clip is not None and target_clip.skeleton.n_dofs == motion.skeleton.n_dofs:
        clip = Clip(target_clip.skeleton, frames, motion.frame_time, target_clip.layout, motion.source)
        return clip.with_continuous_channels()
    try:
        return Clip.from_poses(motion.skeleton, frames, motion.frame_time, motion.source).with_continuous_channels()
    except ValueError:  # rest rotations, mimics or oblique axes: BVH cannot carry the robot itself
        return view_clip(motion.skeleton, frames, motion.frame_time, motion.source)


def retarget(
    source: Clip | FilePath,
    to: str | Clip | Skeleton | FilePath | None = None,
    *,
    scale: dict[str, float] | None = None,
    joint_map: JointMap | FilePath | None = None,
    frames: tuple[int | None, int | None] | None = None,
    up: ArrayLike | None = None,
    velocity: dict[str, float] | None = None,
    progress: Progress | None = None,
) -> Retarget:
    """Retarget `source` (a deik.Clip or a BVH path) and return a Retarget (motion, BVH clip,
    report).

    - Other proportions, same rig: `to` a BVH path or Clip with the same joint names and other
      bone lengths, or `scale` {joint: factor} scaling the bones below those joints.
    - Another skeleton: `joint_map` (a JointMap or a TOML/JSON path) and `to` a BVH or URDF
      path, "humanoid", or a Skeleton; `up` (3,) a URDF's up when the map does not say it;
      `velocity` {DOF name: limit, rad/s or length units/s} bounds each DOF's step between
      frames (default: a URDF's own `<limit velocity>`s, none for another target).
    `frames` = (start, stop) cuts the source first (a Python slice: stop exclusive, negative
    from the end, None the clip's start or end); `progress(frames, stage)`
    is called after each stage. The source's up is its skeleton's (deik.read_bvh(path, up=...)
    for a file made with another than +Y; a map's rotation is written for a +Y-up source, and
    another is turned upright first); a source whose body does not rest on a floor along it
    but does along another axis is refused (docs/clips.md, "Up"). A source whose pose jumps
    (cleanup/cuts.py) is retargeted as the motion without the jump: a bind pose before or after
    the motion becomes a hold of the motion's nearest frame, a glitch is blended across;
    report["cuts"] says where. A source whose points shake at rest is low-passed first, as
    `deik clip` does (cleanup/noise.py; report["noise"]). ValueError for a mistake in the inputs."""
    clip = with_helpers(frame_range(read_bvh(source) if not isinstance(source, Clip) else source, frames))
    body = body_of(clip)
    check_clip_rests(clip, body)
    cuts = find_cuts(clip, body.span)
    stood = cuts.stand_in(clip)
    quiet, noise = without_shake(stood, body if stood is clip else body_of(stood))[:2]
    captured = None if quiet is stood else stood
    result = _retarget((quiet, captured), to, scale, joint_map, up, velocity, progress)
    return replace(result, report=result.report | {"cuts": cuts.record(), "noise": noise.record()})


def _retarget(
    source: tuple[Clip, Clip | None],
    to: str | Clip | Skeleton | FilePath | None,
    scale: dict[str, float] | None,
    joint_map: JointMap | FilePath | None,
    up: ArrayLike | None,
    velocity: dict[str, float] | None,
    progress: Progress | None,
) -> Retarget:
    """deik.retarget of `source` (the clip cut to its frames, its jumps stood in for, low-passed
    where it shakes; and as it was before that low-pass, None where it was not) with the same
    arguments."""
    clip, captured = source
    if joint_map is None:
        if (to is None) == (scale is None):
            raise InputError("give either a target rig (--to TARGET.bvh) or --scale JOINT=FACTOR, not both or neither")
        if scale is not None:
            if not isinstance(scale, Mapping):
                raise InputError(f"scale: give {{joint: factor}}, e.g. {{'LeftHip': 1.1}}, got {scale!r:.60}")
            return retarget_proportions(clip, scaled_bones(clip.skeleton, dict(scale)), progress, captured)
        target = replace(_target(to, None)[0], up=clip.skeleton.up)  # the same rig: the source's up
        check_same_rig(clip.skeleton, target, str(getattr(to, "source", to)))
        return retarget_proportions(clip, target, progress, captured)
    if to is None or scale is not None:
        raise InputError("a joint map retargets onto another skeleton: give --to TARGET with it, and no --scale")
    joint_map = joint_map if isinstance(joint_map, JointMap) else read_map(joint_map)
    target, target_clip = _target(to, joint_map.up or up)
    hinges = None if target_clip is None else hinge_channels(target_clip)
    if velocity is None and not isinstance(to, (Skeleton, Clip)) and str(to).lower().endswith(".urdf"):
        velocity = read_velocity_limits(to)
    elif velocity is not None:
        _check_velocity(velocity, target)
    result = retarget_rig(clip, target, joint_map, hinges, velocity, progress, captured)
    return Retarget(
        result.motion,
        _bvh_clip(result, target_clip),
        result.source,
        result.contacts,
        result.keypoints,
        result.targets,
        result.report,
    )
