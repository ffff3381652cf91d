"""Taking back a change that makes the motion jolt (no new pops, point by point).

A fix's displacement from the capture is checked the way cleanup/dynamics.py measures jolts: a
joint or site accelerating (or moving) beyond PEAK_RATIO x its own peak in the capture, or a
rotation channel beyond its peak. Where a frame jolts, the fix takes its change back there:
each such frame and its neighbours keep none of it, and the frames around them a share that
grows smoothly (smoothstep) to all of it over EASE_SECONDS, so taking back adds no jolt of its
own; rounds repeat, the taken-back stretch and its easing widening, until nothing jolts, and
after ROUNDS the whole change is taken back (the capture is the better clip). The frames taken
back keep the capture's motion (and miss the goals the change met); fix_clip reports them.
"""

from __future__ import annotations

import numpy as np

from deik.cleanup.dynamics import PEAK_RATIO, jolted_frames
from deik.io.trajectory import Motion

EASE_SECONDS = 0.15
ROUNDS = 6


def _kept_share(taken: np.ndarray, length: float) -> np.ndarray:
    """(N,) the share of a change each frame keeps: 0 on `taken` (N,) frames, rising as a
    smoothstep to 1 over `length` frames from them."""
    N = len(taken)
    if not taken.any():
        return np.ones(N)
    frames = np.arange(N)
    nearest = np.abs(frames[:, None] - np.flatnonzero(taken)[None, :]).min(axis=1)
    x = np.clip(nearest / (length + 1.0), 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def calm(
    motion: Motion, displacement: np.ndarray, points: np.ndarray | None = None, ratio: float = PEAK_RATIO
) -> tuple[np.ndarray, np.ndarray]:
    """(displacement (N, D), taken back (N,) bool): `displacement` (N, D) of `motion`'s frames
    with its change taken back, as the module notes say, where it makes a joint or site of
    `points` (F,) bool (default all) jolt."""
    N = len(displacement)

    def jolting(share):
        moved = motion.with_frames(motion.frames + share[:, None] * displacement)
        return jolted_frames(motion, moved, ratio, degrees=np.inf, points=points)

    taken = np.zeros(N, bool)
    share = np.ones(N)
    length = max(EASE_SECONDS / motion.frame_time, 2.0)
    for round_ in range(ROUNDS):
        jolts = jolting(share)
        if not jolts.any():
            return share[:, None] * displacement, share < 1.0
        taken |= np.convolve(jolts, np.ones(3), mode="same") > 0
        share = _kept_share(taken, length * 1.5**round_)
    if jolting(share).any():
        return np.zeros_like(displacement), np.ones(N, bool)
    return share[:, None] * displacement, share < 1.0
