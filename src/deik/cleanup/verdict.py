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
  The points are those the report's sliding counts: the resting joints and sites and the
  resting points along the bones (cleanup/bone_points.py: a shin lying on the floor as its
  knee pivots slides along its length, not at the knee).

SLIDING_TOLERANCE is twice the contact tolerance: two positions each within the contact
tolerance of one plant lie at most that far apart (0.85 mm on the shared humanoid, whose span
is 2.13 m). A plant may move (a heel rising as its foot rolls comes nearer its planted toe,
plants.linked_at_heights), and a calm that smooths a change blurs where a plant begins: a point
may then meet its plant in two frames and step further between them, and fix_clip counts both
frames unmet (ClipFix.met) as this measure does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from deik.cleanup.body import Body
from deik.cleanup.bone_points import BonePoints, bone_points
from deik.cleanup.clip_goals import CONTACT_TOLERANCE, FLOOR_TOLERANCE
from deik.cleanup.contacts import Contacts
from deik.cleanup.floor import penetration
from deik.cleanup.ground import body_paths, clearances, detect_resting
from deik.cleanup.summary import Grounding, resting_steps
from deik.io.trajectory import Motion

SLIDING_TOLERANCE = 2.0 * CONTACT_TOLERANCE


@dataclass(frozen=True, eq=False)
class Verdict:
    """Per frame (N,) bool: `met` (the goals met, nothing sunk, nothing sliding), `sunk` and
    `sliding` (module notes)."""

    met: np.ndarray
    sunk: np.ndarray
    sliding: np.ndarray


def resting_slides(fixed: Motion, resting: Contacts, along: BonePoints | None) -> np.ndarray:
    """(N,) the longest step along the ground (length units) to or from each frame of `fixed` of
    a point `resting` in both frames (Contacts; the points `along` the bones too); 0 where none."""
    out = np.zeros(fixed.n_frames)
    if fixed.n_frames < 2:
        return out
    steps = resting_steps(fixed.kinematics, fixed.skeleton, resting, along)
    longest = np.nan_to_num(steps, nan=0.0).max(axis=1, initial=0.0)
    out[1:] = longest
    out[:-1] = np.maximum(out[:-1], longest)
    return out


def sliding_frames(fixed: Motion, resting: Contacts, along: BonePoints | None, tolerance: float) -> np.ndarray:
    """(N,) bool: the frames at either end of a step along the ground longer than `tolerance`
    (length units) of a point `resting` in both (resting_slides)."""
    return resting_slides(fixed, resting, along) > tolerance


def sunk_frames(fixed: Motion, grounding: Grounding, tolerance: float) -> np.ndarray:
    """(N,) bool: the frames whose body surface (grounding.clearance below each point) goes more
    than `tolerance` (length units) under the floor at grounding.height."""
    return penetration(fixed.kinematics, fixed.skeleton, grounding.height, grounding.clearance) > tolerance


def capture_grounding(original: Motion, body: Body, height: float) -> Grounding:
    """The floor a clip fixed from `original` (on the `body`'s skeleton) is measured against: at
    `height`, each point's clearance (its radius), and every point of the body that rests in
    the capture (cleanup/ground.py), planted or not, the points along its bones included
    (cleanup/bone_points.py)."""
    paths = body_paths(original, body, split_at_cuts=True)
    resting = detect_resting(original, body, height, paths=paths)
    return Grounding(height, clearances(body), resting, bone_points(original, body, height, paths.seams))


def frame_verdict(goals_met: np.ndarray, fixed: Motion, grounding: Grounding, span: float) -> Verdict:
    """The Verdict of `fixed` (on the body's skeleton) whose goals are met in `goals_met` (N,),
    measured against `grounding`, tolerances as shares of the body's `span` (module notes)."""
    sunk = sunk_frames(fixed, grounding, FLOOR_TOLERANCE * span)
    sliding = sliding_frames(fixed, grounding.resting, grounding.along, SLIDING_TOLERANCE * span)
    return Verdict(np.asarray(goals_met, bool) & ~sunk & ~sliding, sunk, sliding)
