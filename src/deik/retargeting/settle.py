"""The last steps of every retarget: the source's contacts on the target, the space-time pass,
joint values a robot can play, and the report.

Both kinds of retarget end here (rig.py through a joint map, proportions.py onto the same rig
with other bone lengths) with per-frame poses of the target that follow their key points:
1. the contacts: every mapped source point at rest near the source's floor
   (resting.resting_contacts: feet, hands, knees, elbows, the back, the pelvis, the head) is a
   contact of the target frame it maps to, on the target's floor (height `floor`);
2. on a robot with velocity limits, the step each DOF may take between frames (step_limits):
   a rotation at most the larger of its velocity limit times the frame time and STEP_ALLOWANCE
   x the source's largest joint turn in one frame, so no joint swings round where the source
   does not; steps past a velocity limit itself are reported per frame and DOF;
3. the poses written as the same poses nearest the frame before (continuity.py), then the
   space-time pass (smooth.py), then written so again within the limits;
4. the report (measures.py) with the floor, the contacts and the steps past a velocity limit.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from deik.cleanup.contacts import Contacts
from deik.cleanup.metrics import joint_angles
from deik.cleanup.units import guess_unit, metres_per_unit
from deik.io.motion import Clip
from deik.io.trajectory import Trajectory
from deik.model.joints import ROTATE
from deik.model.skeleton import Skeleton
from deik.retargeting.capsule_overlaps import body_pairs
from deik.retargeting.continuity import continuous_within_limits
from deik.retargeting.ik import Targets
from deik.retargeting.keypoints import stature
from deik.retargeting.measures import retarget_report, velocity_violations
from deik.retargeting.resting import resting_contacts
from deik.retargeting.skeletons import without_sites
from deik.retargeting.smooth import MotionGoals, smooth_motion

STEP_ALLOWANCE = 1.5  # x the source's largest joint turn in a frame: a rotation without a velocity limit


@dataclass(frozen=True)
class Settling:
    """What the last steps take: the `source` clip and its `floor` (height along its up, where
    it rests: resting.rest_floor), and where that floor lies in the target's world,
    `target_floor`; the `target` as solved (with any steering sites) and its
    `poses` (N, D) from the key-point IK; the key points `names` (K,) with their `targets`
    (ik.Targets) and, for the report, `reported` (N, R, 3) where the first R of them belong;
    `points` {source frame: target frame} whose contacts carry over; the `searched` DOFs,
    their `weights` (dof_weights); the frames of the `body`; `velocity` {DOF name: limit,
    rad/s or length units/s} (a URDF's); `steering` the sites dropped from the output's
    skeleton; `began` the wall clock (time.perf_counter) the retarget started at; `scaled` the
    source's angles on the target (a same-rig retarget: the report's joint angle deviation);
    `captured` the source as given where it was low-passed (None: `source`), on which its rests'
    edges are read through its shake (resting.resting_contacts)."""

    source: Clip
    floor: float
    target_floor: float
    target: Skeleton
    poses: np.ndarray
    names: Sequence[str]
    targets: Targets
    reported: np.ndarray
    points: dict
    searched: np.ndarray
    weights: np.ndarray
    body: Sequence[str]
    velocity: dict
    steering: Sequence[str] = ()
    began: float = 0.0
    scaled: Clip | None = None
    captured: Clip | None = None


def largest_turn(clip: Clip) -> float:
    """The largest angle (radians) any joint of `clip` turns between two frames (0 for one frame)."""
    if clip.n_frames < 2:
        return 0.0
    before, after = replace(clip, frames=clip.frames[:-1]), replace(clip, frames=clip.frames[1:])
    angles = joint_angles(before, after)
    return float(np.radians(angles.max(initial=0.0)))


def step_limits(skeleton: Skeleton, velocity: dict, frame_time: float, turn: float) -> np.ndarray:
    """(D,) the largest step of each DOF between two frames `frame_time` s apart on a robot with
    velocity limits {DOF name: limit} (`velocity`; none: every step free, inf): a rotation's the
    larger of its limit x frame_time and STEP_ALLOWANCE x `turn` (radians, the source's largest
    joint turn in a frame: a robot playing the clip at its speed turns as fast as the source
    does, and a limit tighter than that is reported, not met by leaving the key points
    behind), a translation's its limit x frame_time (inf without one). A character without
    limits keeps every step free: its Euler channels may turn fast near gimbal lock for a small
    turn of the joint."""
    if not velocity:
        return np.full(skeleton.n_dofs, np.inf)
    rotation = skeleton.dof_kind == ROTATE
    limit = np.array([velocity.get(name, 0.0 if rotation[d] else np.inf) for d, name in enumerate(skeleton.dof_names)])
    return np.where(rotation, np.maximum(limit * frame_time, STEP_ALLOWANCE * turn), limit * frame_time)


def velocity_steps(skeleton: Skeleton, velocity: dict, frame_time: float) -> np.ndarray:
    """(D,) each DOF's velocity limit x `frame_time` (inf without one): the steps the report
    checks."""
    return np.array([velocity.get(name, np.inf) * frame_time for name in skeleton.dof_names])


def target_contacts(settling: Settling, size: float) -> Contacts | None:
    """The source's resting points (resting.resting_contacts) on the target frames they map
    to, on the target's floor; None when no mapped point rests."""
    sources = list(settling.points)
    found = resting_contacts(settling.source, sources, settling.floor, size, settling.captured)
    keep = [s for s, name in enumerate(sources) if found.mask[:, s].any()]
    seen, columns = set(), []
    for s in keep:  # two source points onto one target frame: the first one's contacts
        if settling.points[sources[s]] not in seen:
            seen.add(settling.points[sources[s]])
            columns.append(s)
    if not columns:
        return None
    names = tuple(settling.points[sources[s]] for s in columns)
    return Contacts(names, found.mask[:, columns], True, found.height, found.speed, settling.target_floor)


def settle(settling: Settling) -> tuple[Trajectory, Contacts | None, dict]:
    """(the target's motion, its contacts, the report) of the module notes' last steps."""
    source, solved = settling.source, settling.target
    contacts = target_contacts(settling, stature(source.skeleton))
    target = without_sites(solved, settling.steering)
    pairs = body_pairs(target, settling.body)
    velocity = dict(settling.velocity)
    largest = step_limits(solved, velocity, source.frame_time, largest_turn(source))
    goals = MotionGoals(
        solved,
        settling.names,
        settling.targets,
        contacts,
        settling.searched,
        settling.weights,
        settling.body,
        pairs,
        source.frame_time,
        stature(target),
        largest,
        settling.target_floor,
    )
    poses = smooth_motion(goals, continuous_within_limits(solved, settling.poses))
    motion = Trajectory(target, continuous_within_limits(target, poses), source.frame_time, source.source)
    wall = time.perf_counter() - settling.began
    metres = metres_per_unit(guess_unit(target))
    K = settling.reported.shape[1]
    reported = list(settling.names)[:K]
    report = retarget_report(
        motion, reported, settling.reported, contacts, metres, wall, scaled=settling.scaled, pairs=pairs
    )
    limited = velocity_steps(target, velocity, source.frame_time)
    report["velocity_violations"] = velocity_violations(motion, limited)
    report["summary"]["velocity_violations_count"] = len(report["velocity_violations"])
    report["summary"]["floor_height"] = settling.target_floor
    report["floor"] = {"height": settling.target_floor, "source_height": settling.floor, "found": FLOOR_FOUND}
    return motion, contacts, report


FLOOR_FOUND = (
    "where the source rests: the lower quartile of its lowest point's heights over the frames that point is slow in "
    "(deik.retargeting.resting.rest_floor), carried into the target's world"
)
