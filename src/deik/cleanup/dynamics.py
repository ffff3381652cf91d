"""Does a fix keep the motion's dynamics? Its velocity and acceleration peaks against the capture's.

A fix keeps the dynamics when none of its peaks rises more than PEAK_RATIO above the capture's:
the largest rotation-channel velocity and acceleration (deg/s, deg/s^2 of the continuous Euler
channels, cleanup/metrics.spikes), the largest velocity of any joint or end site (length units
per s), and the acceleration of each joint and end site (length units per s^2) against that
point's own peak in the capture around that frame: its largest within PEAK_SECONDS before or
after it, and at least SLACK / (PEAK_RATIO - 1) of the body's size per s^2 (a point below that
is still). So a local pop (a hand that jerks) counts however fast the rest of the body moves,
and however fast that hand moves in another movement of a long take. A frame jolts when one of
its values passes that bound (for the clip-wide measures, also the capture's peak plus SLACK,
so that a joint the capture holds still may still be turned a little), or when a joint there
turns more than FAR_DEGREES from the capture. fix_clip skips balance where it makes frames
jolt, refuses a DE repair that makes a frame jolt without meeting its goals, and takes back any
change that still makes a point jolt (cleanup/calm.py).
A motion on another skeleton (a retarget) is compared through points both have, the key points:
their velocity and acceleration peaks against the source's (point_peak_ratios, jolted_points).
"""

from __future__ import annotations

import numpy as np

from deik.cleanup.contacts import running_max
from deik.cleanup.metrics import joint_angles, point_motion, spikes
from deik.io.trajectory import Motion
from deik.model.capsules import body_reach

PEAK_RATIO = 1.1
FAR_DEGREES = 30.0  # a joint turned further than this from the capture changes the performance
MEASURES = ("dof_velocity", "dof_acceleration", "position_velocity", "position_acceleration")
POINT_MEASURES = MEASURES[2:]
# per measure: deg/s, deg/s^2, and reach per s and per s^2 (5 mm/s and 2 cm/s^2 on a person)
SLACK = {"dof_velocity": 10.0, "dof_acceleration": 200.0, "position_velocity": 0.005, "position_acceleration": 0.02}
# seconds each side of a frame in which a point's own acceleration peak is taken: the movement
# it belongs to (a step, a kick, a get-up), not the next one of a long take. Shorter windows
# (0.5 s, 1 s) made the calm take back plants and lifts on the shared clips (docs/decisions.md).
PEAK_SECONDS = 2.0


def widened(frames: np.ndarray, reach: int) -> np.ndarray:
    """(N,) bool: the frames within `reach` frames of a True one of `frames` (N,)."""
    frames = np.asarray(frames, bool)
    out = frames.copy()
    for k in range(1, min(reach, len(frames)) + 1):
        out[k:] |= frames[:-k]
        out[:-k] |= frames[k:]
    return out


def own_peaks(accelerations: np.ndarray, frame_time: float, reach: float) -> np.ndarray:
    """(M, K): each point's own acceleration peak at each row of `accelerations` (M, K) (rows
    `frame_time` s apart): its largest within PEAK_SECONDS of the row, at least the still
    point's SLACK / (PEAK_RATIO - 1) x `reach` per s^2 (module notes)."""
    still = SLACK["position_acceleration"] / (PEAK_RATIO - 1.0) * reach
    if not accelerations.size:
        return np.full(accelerations.shape, still)
    return np.maximum(running_max(accelerations, max(1, int(round(PEAK_SECONDS / frame_time)))), still)


def _peaks(clip, points: np.ndarray | None = None) -> dict:
    """{measure: (values (M, K) >= 0, row 0's frame)} of MEASURES for `clip`, the position
    measures of the joints and sites `points` (F,) bool (default all)."""
    moves = spikes(clip, clip.kinematics)
    chosen = slice(None) if points is None else np.asarray(points, bool)
    return {
        "dof_velocity": (np.abs(moves["dof_velocity"]), 0),
        "dof_acceleration": (np.abs(moves["dof_acceleration"]), 1),
        "position_velocity": (moves["position_velocity"][:, chosen], 0),
        "position_acceleration": (moves["position_acceleration"][:, chosen], 1),
    }


def _point_peaks(points: np.ndarray, frame_time: float) -> dict:
    """{measure: (values (M, K), row 0's frame)} of POINT_MEASURES for points (N, K, 3)."""
    speed, acceleration = point_motion(points, frame_time)
    return {"position_velocity": (speed, 0), "position_acceleration": (acceleration, 1)}


def _ratios(before: dict, after: dict) -> dict:
    """{measure: largest value in `after` / largest in `before`} (NaN where before's is 0)."""
    out = {}
    for key in before:
        top = before[key][0].max(initial=0.0)
        out[key] = after[key][0].max(initial=0.0) / top if top > 0 else float("nan")
    return out


def _jolts(before: dict, after: dict, n_frames: int, reach: float, ratio: float, own: float | None) -> np.ndarray:
    """(N,) bool: frames with a value of `after` above both `ratio` x `before`'s largest of that
    measure and that largest + SLACK (a velocity between two frames marks both); with `own` (the
    frame time, s), a point's acceleration above `ratio` x its own peak around that frame
    (own_peaks) instead."""
    out = np.zeros(n_frames, bool)
    for key in before:
        values, first = after[key]
        if own is not None and key == "position_acceleration":
            over = (values > ratio * own_peaks(before[key][0], own, reach)).any(axis=1)
        else:
            top = before[key][0].max(initial=0.0)
            slack = SLACK[key] * (reach if key.startswith("position") else 1.0)
            over = (values > max(ratio * top, top + slack)).any(axis=1) if values.size else np.zeros(0, bool)
        out[first : first + len(over)] |= over
        if key.endswith("velocity"):  # between frames n and n+1
            out[first + 1 : first + 1 + len(over)] |= over
    return out


def peak_ratios(original: Motion, fixed: Motion) -> dict:
    """{measure: largest value in `fixed` / largest in `original`} for MEASURES (NaN where the
    capture's is 0 or the clip is too short to have one)."""
    return _ratios(_peaks(original), _peaks(fixed))


def point_acceleration_ratios(original: Motion, fixed: Motion, points: np.ndarray | None = None) -> np.ndarray:
    """(K,) each joint and site's (of `points` (F,) bool, default all) largest ratio, over the
    frames, of its acceleration in `fixed` to its own peak in the capture `original` around
    that frame (own_peaks; NaN where the clip has under 3 frames)."""
    before, after = (_peaks(clip, points)["position_acceleration"][0] for clip in (original, fixed))
    if not len(before):
        return np.full(before.shape[1], np.nan)
    return (after / own_peaks(before, original.frame_time, body_reach(original.skeleton))).max(axis=0)


def jolted_frames(
    original: Motion,
    fixed: Motion,
    ratio: float = PEAK_RATIO,
    degrees: float = FAR_DEGREES,
    points: np.ndarray | None = None,
) -> np.ndarray:
    """(N,) bool: frames of `fixed` with a rotation channel's velocity or acceleration above both
    `ratio` x the capture `original`'s largest and that largest + SLACK, a joint or site (of
    `points` (F,) bool, default all) moving faster than that bound on the capture's fastest or
    accelerating beyond `ratio` x its own peak in the capture around that frame (own_peaks; a
    velocity between two frames marks both), or a joint more than `degrees` from the capture."""
    before, after = _peaks(original, points), _peaks(fixed, points)
    jolts = _jolts(before, after, original.n_frames, body_reach(original.skeleton), ratio, own=original.frame_time)
    return jolts | (joint_angles(original, fixed) > degrees).any(axis=1)


def newly_jolted(original: Motion, current: Motion, moved: Motion, points: np.ndarray | None = None) -> np.ndarray:
    """(N,) bool: frames that a change from `current` to `moved` (both fixes of the capture
    `original`) makes jolt: a frame that does not jolt in `current` (jolted_frames, `points`
    (F,) bool) and does in `moved`; a frame that already does, where `moved` turns a joint more
    than FAR_DEGREES from `current` (its jolts against the capture are there already, but a
    change that large is a new pose, not a repair)."""
    before = jolted_frames(original, current, points=points)
    after = jolted_frames(original, moved, points=points)
    turned = (joint_angles(current, moved) > FAR_DEGREES).any(axis=1)
    return np.where(before, turned, after)


def point_peak_ratios(source: np.ndarray, points: np.ndarray, frame_time: float) -> dict:
    """{measure: largest value of `points` / largest of `source`} for POINT_MEASURES: the
    speeds and accelerations of points (N, K, 3) against those of the points they follow,
    `source` (N, K, 3) in the same length unit, frames `frame_time` s apart."""
    return _ratios(_point_peaks(source, frame_time), _point_peaks(points, frame_time))


def jolted_points(
    source: np.ndarray, points: np.ndarray, frame_time: float, reach: float, ratio: float = PEAK_RATIO
) -> np.ndarray:
    """(N,) bool: frames where a point of `points` (N, K, 3) moves faster or accelerates more
    than both `ratio` x the largest of `source` (N, K, 3) and that largest + SLACK (x `reach`,
    the length unit's body size)."""
    before, after = _point_peaks(source, frame_time), _point_peaks(points, frame_time)
    return _jolts(before, after, len(points), reach, ratio, own=None)
