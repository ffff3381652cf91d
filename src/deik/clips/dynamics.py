"""Does a fix keep the motion's dynamics? Its velocity and acceleration peaks against the capture's.

A fix keeps the dynamics when none of its peaks rises more than PEAK_RATIO above the capture's:
the largest rotation-channel velocity and acceleration (deg/s, deg/s^2 of the continuous Euler
channels, clips/metrics.spikes) and the largest velocity and acceleration of any joint or end
site (length units per s and s^2). A frame jolts when one of its values passes that bound (and
the capture's peak plus SLACK, so that a clip standing still may still be moved a little), or
when a joint there turns more than FAR_DEGREES from the capture. fix_clip skips balance where
it makes frames jolt, and refuses a DE repair that makes a frame jolt without meeting its goals.
"""

from __future__ import annotations

import numpy as np

from deik.clips.metrics import joint_angles, spikes
from deik.io.trajectory import Motion
from deik.model.kinematics import forward_kinematics

PEAK_RATIO = 1.1
FAR_DEGREES = 30.0  # a joint turned further than this from the capture changes the performance
MEASURES = ("dof_velocity", "dof_acceleration", "position_velocity", "position_acceleration")
# per measure: deg/s, deg/s^2, and reach per s and per s^2 (0.05 m/s and 0.5 m/s^2 on a person)
SLACK = {"dof_velocity": 10.0, "dof_acceleration": 200.0, "position_velocity": 0.05, "position_acceleration": 0.5}


def _peaks(clip) -> dict:
    """{measure: (values (M, K) >= 0, row 0's frame)} of MEASURES for `clip`."""
    moves = spikes(clip, forward_kinematics(clip.skeleton, clip.frames))
    return {
        "dof_velocity": (np.abs(moves["dof_velocity"]), 0),
        "dof_acceleration": (np.abs(moves["dof_acceleration"]), 1),
        "position_velocity": (moves["position_velocity"], 0),
        "position_acceleration": (moves["position_acceleration"], 1),
    }


def peak_ratios(original: Motion, fixed: Motion) -> dict:
    """{measure: largest value in `fixed` / largest in `original`} for MEASURES (NaN where the
    capture's is 0 or the clip is too short to have one)."""
    before, after = _peaks(original), _peaks(fixed)
    out = {}
    for key in MEASURES:
        top = before[key][0].max(initial=0.0)
        out[key] = after[key][0].max(initial=0.0) / top if top > 0 else float("nan")
    return out


def jolted_frames(
    original: Motion, fixed: Motion, ratio: float = PEAK_RATIO, degrees: float = FAR_DEGREES
) -> np.ndarray:
    """(N,) bool: frames of `fixed` with a velocity or acceleration above both `ratio` x the
    capture `original`'s largest of that measure and that largest + SLACK (a velocity between
    two frames marks both), or a joint more than `degrees` from the capture."""
    before, after = _peaks(original), _peaks(fixed)
    N = original.n_frames
    reach = original.skeleton.reach
    out = np.zeros(N, bool)
    for key in MEASURES:
        values, first = after[key]
        top = before[key][0].max(initial=0.0)
        slack = SLACK[key] * (reach if key.startswith("position") else 1.0)
        over = (values > max(ratio * top, top + slack)).any(axis=1) if values.size else np.zeros(0, bool)
        out[first : first + len(over)] |= over
        if key.endswith("velocity"):  # between frames n and n+1
            out[first + 1 : first + 1 + len(over)] |= over
    return out | (joint_angles(original, fixed) > degrees).any(axis=1)
