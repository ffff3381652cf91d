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
tolerance of one plant lie at most that far apart, so a frame whose planted points meet their
goals never fails it through them (0.85 mm on the shared humanoid, whose span is 2.13 m).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from deik.cleanup.clip_goals import CONTACT_TOLERANCE, FLOOR_TOLERANCE
from deik.cleanup.floor import penetration
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


def sliding_frames(fixed: Motion, grounding: Grounding, tolerance: float) -> np.ndarray:
    """(N,) bool: the frames at either end of a step along the ground longer than `tolerance`
    (length units) of a point resting in the capture in both (grounding.resting and .along)."""
    out = np.zeros(fixed.n_frames, bool)
    if fixed.n_frames < 2:
        return out
    steps = resting_steps(fixed.kinematics, fixed.skeleton, grounding.resting, grounding.along)
    long = (np.nan_to_num(steps, nan=0.0) > tolerance).any(axis=1)
    out[1:] |= long
    out[:-1] |= long
    return out


def sunk_frames(fixed: Motion, grounding: Grounding, tolerance: float) -> np.ndarray:
    """(N,) bool: the frames whose body surface (grounding.clearance below each point) goes more
    than `tolerance` (length units) under the floor at grounding.height."""
    return penetration(fixed.kinematics, fixed.skeleton, grounding.height, grounding.clearance) > tolerance


def frame_verdict(goals_met: np.ndarray, fixed: Motion, grounding: Grounding, span: float) -> Verdict:
    """The Verdict of `fixed` (on the body's skeleton) whose goals are met in `goals_met` (N,),
    measured against `grounding`, tolerances as shares of the body's `span` (module notes)."""
    sunk = sunk_frames(fixed, grounding, FLOOR_TOLERANCE * span)
    sliding = sliding_frames(fixed, grounding, SLIDING_TOLERANCE * span)
    return Verdict(np.asarray(goals_met, bool) & ~sunk & ~sliding, sunk, sliding)
