"""Which frames of a fixed clip are clean, by deik's own measure of what its report promises.

A fix's goals (cleanup/fix.py) are the contacts it planted, the floor it kept, balance and reach.
The report promises more: that nothing of the body lies under the floor it states (kept or not)
and that no point that rests in the capture slides, planted or not (cleanup/summary.Grounding).
A frame is met when its goals are and, measured on the body (cleanup/body.py, its surface a
radius from each joint and site), neither promise fails in it:

- sunk: the body's surface goes deeper than FLOOR_TOLERANCE x span under the floor stated;
- sliding: a point resting in the capture in this frame and a neighbouring one moves along the
  ground between them by more than SLIDING_TOLERANCE x span. Both frames of such a step are
  unmet: a plant met in one frame and missed in the next has slid into the frame that meets it.
  The points are the resting joints and sites and the middle of every bone of the body (a shin
  lying on the floor as the knee pivots slides under its middle, not at the knee), each
  resting by the rule of cleanup/ground.py with the thinner radius of its bone's two ends.

SLIDING_TOLERANCE is twice the contact tolerance: two positions each within the contact
tolerance of one plant lie at most that far apart, so a frame whose planted points meet their
goals never fails it through them (0.85 mm on the shared humanoid, whose span is 2.13 m).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from deik.cleanup import ground
from deik.cleanup.body import Body
from deik.cleanup.clip_goals import CONTACT_TOLERANCE, FLOOR_TOLERANCE
from deik.cleanup.floor import penetration
from deik.cleanup.metrics import sliding_steps
from deik.cleanup.summary import Grounding
from deik.io.trajectory import Motion
from deik.model.capsules import bone_starts
from deik.model.geometry import ground_frame

SLIDING_TOLERANCE = 2.0 * CONTACT_TOLERANCE
ALONG = (0.25, 0.5, 0.75)  # the points measured along each bone, as shares of it from its start


@dataclass(frozen=True, eq=False)
class Verdict:
    """Per frame (N,) bool: `met` (the goals met, nothing sunk, nothing sliding), `sunk` and
    `sliding` (module notes)."""

    met: np.ndarray
    sunk: np.ndarray
    sliding: np.ndarray


def sliding_frames(fixed: Motion, grounding: Grounding, tolerance: float) -> np.ndarray:
    """(N,) bool: the frames at either end of a step along the ground longer than `tolerance`
    (length units) of a point resting in the capture in both (grounding.resting)."""
    resting, sk = grounding.resting, fixed.skeleton
    out = np.zeros(fixed.n_frames, bool)
    if not resting.sites or fixed.n_frames < 2:
        return out
    index = [sk.frame_index(name) for name in resting.sites]
    steps = sliding_steps(fixed.kinematics, index, resting.mask, sk.up)
    long = (np.nan_to_num(steps, nan=0.0) > tolerance).any(axis=1)
    out[1:] |= long
    out[:-1] |= long
    return out


def _bones(body: Body) -> tuple[np.ndarray, np.ndarray]:
    """(start (B,), end (B,)) frames of the body's bones: both ends part of it, not both in a
    foot (its soles are its surface) nor ending at a sole site."""
    start = bone_starts(body.skeleton)
    names = body.skeleton.frame_names
    feet = {name for foot in body.feet for name in foot.chain + foot.soles}
    soles = set(body.sole_names)
    ends = [f for f in range(len(start)) if start[f] >= 0 and body.part[f] and body.part[start[f]]]
    ends = [f for f in ends if names[f] not in soles and not (names[f] in feet and names[start[f]] in feet)]
    ends = np.array(ends, np.int64)
    return start[ends], ends


def bone_sliding_frames(original: Motion, fixed: Motion, body: Body, floor: float, tolerance: float) -> np.ndarray:
    """(N,) bool: the frames at either end of a step along the ground longer than `tolerance`
    (length units) of a bone's middle in `fixed` where it rests in `original` in both (module
    notes; both clips on body.skeleton, the floor at height `floor`)."""
    start, end = _bones(body)
    out = np.zeros(fixed.n_frames, bool)
    if not len(end) or fixed.n_frames < 2:
        return out
    up = body.skeleton.up
    middle = [
        np.concatenate([(1 - t) * p[:, start] + t * p[:, end] for t in ALONG], axis=1)
        for p in (clip.kinematics.p_world_frame for clip in (original, fixed))
    ]
    radius = np.tile(np.minimum(body.radius[start], body.radius[end]), len(ALONG))
    low = middle[0] @ up - floor - radius <= ground.BAND * body.span
    slow = ground.point_speeds(middle[0], original.frame_time) <= ground.SPEED * body.span
    rest = ground.rest_runs(low & slow, original.frame_time)
    steps = np.linalg.norm(np.diff(middle[1] @ ground_frame(up)[:2].T, axis=0), axis=-1)
    long = (rest[1:] & rest[:-1] & (steps > tolerance)).any(axis=1)
    out[1:] |= long
    out[:-1] |= long
    return out


def sunk_frames(fixed: Motion, grounding: Grounding, tolerance: float) -> np.ndarray:
    """(N,) bool: the frames whose body surface (grounding.clearance below each point) goes more
    than `tolerance` (length units) under the floor at grounding.height."""
    return penetration(fixed.kinematics, fixed.skeleton, grounding.height, grounding.clearance) > tolerance


def frame_verdict(goals_met: np.ndarray, original: Motion, fixed: Motion, body: Body, grounding: Grounding) -> Verdict:
    """The Verdict of `fixed` made from `original` (both on body.skeleton) whose goals are met in
    `goals_met` (N,), measured against `grounding`, tolerances as shares of body.span (module
    notes)."""
    sunk = sunk_frames(fixed, grounding, FLOOR_TOLERANCE * body.span)
    tolerance = SLIDING_TOLERANCE * body.span
    sliding = sliding_frames(fixed, grounding, tolerance)
    sliding |= bone_sliding_frames(original, fixed, body, grounding.height, tolerance)
    return Verdict(np.asarray(goals_met, bool) & ~sunk & ~sliding, sunk, sliding)
