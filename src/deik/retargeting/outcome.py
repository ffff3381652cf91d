"""What a retarget returns, and the frame range of a source clip it works on."""

from __future__ import annotations

import operator
from collections.abc import Callable
from dataclasses import dataclass, replace

from deik.cleanup.contacts import Contacts
from deik.errors import InputError
from deik.io.motion import Clip


@dataclass(frozen=True, eq=False)
class Retarget:
    """The outcome of deik.retarget: `motion` the target's motion (a Clip for a BVH target, a
    deik.io.trajectory.Trajectory for any other: `motion.frames` (N, D) radians / length units,
    `motion.skeleton.dof_names`), `clip` a BVH clip to look at (the motion itself, or a view of
    the robot: deik.io.bvh.preview), `source` the source frames used, `contacts` on the target's
    sites (or None), `keypoints` (K,) target frames and `targets` (N, K, 3) where they should be
    (target length units), `report` {"summary", "per_frame", "points", "floor", and for a robot
    "velocity_violations"} (retargeting/measures.py, settle.py)."""

    motion: object
    clip: Clip
    source: Clip
    contacts: Contacts | None
    keypoints: tuple[str, ...]
    targets: object
    report: dict


Progress = Callable[[int, str], None]  # progress(frames done, stage) after each stage of a retarget


def frame_range(clip: Clip, frames: tuple[int | None, int | None] | None) -> Clip:
    """`clip` cut to `frames` = (start, stop), stop exclusive, or None for every frame; as a
    Python slice, a negative index counts from the end and None is the clip's start or end;
    InputError naming the valid frames when the range is empty or leaves the clip."""
    if frames is None:
        return clip
    try:
        start, stop = (None if v is None else operator.index(v) for v in frames)
    except (TypeError, ValueError):
        raise InputError(f"frames: give (start, stop), two whole numbers or None, got {frames!r:.60}") from None
    n = clip.n_frames
    first = 0 if start is None else start + n if start < 0 else start
    end = n if stop is None else stop + n if stop < 0 else stop
    if not 0 <= first < end <= n:
        raise InputError(
            f"frames {'' if start is None else start}:{'' if stop is None else stop} are empty or outside the "
            f"clip of {n} frames; give START:STOP with 0 <= START < STOP <= {n} (STOP exclusive; a negative "
            "index counts from the end)"
        )
    return replace(clip, frames=clip.frames[first:end])
