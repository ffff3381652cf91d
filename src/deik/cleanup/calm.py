"""Taking back a change that makes the motion jolt (no new pops, point by point).

A fix's displacement from the capture is checked the way cleanup/dynamics.py measures jolts: a
joint or site accelerating beyond PEAK_RATIO x its own peak in the capture, a point moving or
a rotation channel turning faster than the capture's fastest. Where frames jolt, the fix takes
part of its change back there: those frames and their neighbours keep a share CUT less of it
(small steps: a lift taken back puts a point back under the floor), the frames around them a
share that grows back smoothly (smoothstep) over EASE_SECONDS, so taking back adds no jolt of
its own; rounds repeat until nothing jolts, and after ROUNDS the whole change is taken back
(the capture is the better clip). The frames that keep less than all of the change are reported
(fix_clip: `calmed`; those that then miss a goal are listed unmet).

Smoothing first (`smooth`): a jolt is a change that turns too quickly, not one too large, so
the change is first averaged along the frames where they jolt, by a Gaussian that widens a
frame at a time up to EASE_SECONDS (eased in and out as a cut is; each joint's turn averaged as
a rotation, noise.smoothed_change, so a rotation written in other Euler values changes alike):
it keeps the change's size and loses its quick turn, and what still jolts is then cut back. On
the shared get-up, whose forearms lie 25 mm in the floor while the body lies on them, cutting
the plain floor's lift back where an elbow rises left a forearm 15 mm under it; smoothed, 6.6
mm (docs/decisions.md). A smoothed change blurs where a correction begins and ends, a planted
foot's too: the warm start keeps smoothed stretches only where they do better
(cleanup/warm_tries.py, warm_choice.py). Smoothed frames are reported as taken back.
"""

from __future__ import annotations

import numpy as np

from deik.cleanup.dynamics import PEAK_RATIO, jolted_frames, widened
from deik.cleanup.noise import smoothed_change
from deik.io.trajectory import Motion

EASE_SECONDS = 0.15
ROUNDS = 25
CUT = 0.2


def eased_share(taken: np.ndarray, length: float) -> np.ndarray:
    """(N,) 1 on `taken` (N,) frames, falling as a smoothstep to 0 over `length` frames from them
    (how much of a cut, or of any change, each frame takes)."""
    frames = np.arange(len(taken))
    nearest = np.abs(frames[:, None] - np.flatnonzero(taken)[None, :]).min(axis=1)
    x = np.clip(nearest / (length + 1.0), 0.0, 1.0)
    return 1.0 - x * x * (3.0 - 2.0 * x)


def calm(
    motion: Motion,
    displacement: np.ndarray,
    points: np.ndarray | None = None,
    ratio: float = PEAK_RATIO,
    base: np.ndarray | None = None,
    captured: Motion | None = None,
    smooth: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """(displacement (N, D), taken back (N,) bool): `displacement` (N, D) of `motion`'s frames,
    a change made on top of `base` (N, D) (default none), with the change taken back, as the
    module notes say, where it makes a joint or site of `points` (F,) bool (default all) jolt
    against the capture, `captured` (default `motion`: a capture low-passed before the fix is
    measured against the capture as it was, cleanup/noise.py), in a frame that `motion` with
    the base alone does not; with `smooth`, smoothed first (module notes)."""
    N = len(displacement)
    start = motion.frames if base is None else motion.frames + base
    captured = motion if captured is None else captured

    def jolting(share, change):
        moved = motion.with_frames(start + share[:, None] * change)
        return jolted_frames(captured, moved, ratio, degrees=np.inf, points=points) & ~already

    already = np.zeros(N, bool)
    if base is not None or captured is not motion:
        already = jolting(np.zeros(N), displacement)

    length = min(max(EASE_SECONDS / motion.frame_time, 2.0), max(N, 2))
    averaged = np.zeros(N, bool)
    for width in range(1, int(np.ceil(length)) + 1 if smooth else 1):
        jolts = jolting(np.ones(N), displacement)
        if not jolts.any():
            break
        near = eased_share(widened(jolts, 1), length)
        gentler = smoothed_change(motion.skeleton, start, displacement, width / 2.0, where=near > 0)
        displacement = displacement + near[:, None] * (gentler - displacement)
        averaged |= near > 0
    share = np.ones(N)
    for _ in range(ROUNDS):
        jolts = jolting(share, displacement)
        if not jolts.any():
            return share[:, None] * displacement, (share < 1.0) | averaged
        share = share * (1.0 - CUT * eased_share(widened(jolts, 1), length))
    if jolting(share, displacement).any():
        return np.zeros_like(displacement), np.ones(N, bool)
    return share[:, None] * displacement, (share < 1.0) | averaged
