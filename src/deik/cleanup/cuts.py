"""Cuts in a capture: frames where the pose jumps instead of moving, and what a cleanup does
about them.

Exported captures often begin (or end) with the rig's bind pose, a T-pose held for a frame
before the motion starts, and a capture whose markers were lost for a frame or two holds
poses that leap away and back. Measured across such a jump, every speed is wrong: a foot
resting beside the jump looks as if it moves, so its rest is not found and it slides, and the
smoothing stages pull the motion towards the bind pose.

A step from frame n to n + 1 is a cut when the points of the body (every joint and site but its
helpers and carriers: model.capsules.off_body; 40 finger points shifted the average) move
in it at least CUT_SPAN x the body's span on average, and the motion changes abruptly at both of
its frames: their accelerations (each point's second difference, averaged over the points) are
at least CUT_RATIO times the typical acceleration around them, the median over the frames
within `window` of them (WINDOW seconds, at least STEPS frames). Motion that only moves fast,
or lurches at a coarse frame rate, accelerates as much in the frames around; a leap into another
pose does not. (On the shared clips and their hard cases, at 10 to 120 frames a second, motion
reaches at most 4.3 times its typical acceleration; a T-pose before, after or inside them 9 to
600 times; the seam where the shared walk's loop starts again 7.3 times.)

The cuts split the clip into runs of frames. A run of at most `window` frames (a run too short
to be motion of its own) is:
- kept as captured at the start or the end of the clip (a bind pose): the cleanup sees a copy
  of the nearest frame of the motion in its place and writes the captured frame back (a bind
  pose under the floor stays there: raising it would make a new leap, and it is reported);
- bridged between two longer runs (a glitch): the cleanup sees the frames in between blended
  from the frame before to the frame after (DOF by DOF, rotations by their nearest turns) and
  cleans those.
Cuts between two longer runs (two takes in one file) are reported and cleaned across.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from deik.cleanup.contacts import true_runs
from deik.io.euler import continuous_angles
from deik.io.trajectory import Motion
from deik.model.capsules import off_body

CUT_SPAN = 0.01  # of the span (2 cm on the shared humanoid): a cut moves the body's points this far on average
CUT_RATIO = 6.0  # times the typical acceleration around its frames, at least
WINDOW = 0.1  # seconds around a frame that set its typical acceleration (at least STEPS frames)
STEPS = 5


@dataclass(frozen=True, eq=False)
class Cuts:
    """The cuts of a clip of N frames: `steps` (C,) each cut's first frame n (the pose jumps from
    frame n to n + 1), and per frame (N,) bool whether it is `kept` as captured (a bind pose at
    an end) or `bridged` (a glitch between two cuts); module notes."""

    steps: np.ndarray
    kept: np.ndarray
    bridged: np.ndarray

    @property
    def between_takes(self) -> np.ndarray:
        """(K,) the cuts' first frames whose both sides are motion: neither kept nor bridged."""
        return np.array([n for n in self.steps if not (self.kept | self.bridged)[[n, n + 1]].any()], np.int64)

    def stand_in(self, clip: Motion) -> Motion:
        """`clip` as the cleanup sees it: kept frames replaced by the nearest frame of the motion,
        bridged frames blended across (module notes). The clip itself when nothing is kept or
        bridged."""
        if not (self.kept.any() or self.bridged.any()):
            return clip
        frames = np.array(clip.frames)
        motion = np.flatnonzero(~self.kept)
        for n in np.flatnonzero(self.kept):
            frames[n] = frames[motion[np.argmin(np.abs(motion - n))]]
        for a, b in true_runs(self.bridged):
            before, after = frames[a - 1], continuous_angles(clip.skeleton, frames[b : b + 1], frames[a - 1 : a])[0]
            share = (np.arange(a, b) - (a - 1))[:, None] / (b - (a - 1))
            frames[a:b] = (1.0 - share) * before + share * after
        return clip.with_frames(frames)

    def record(self) -> dict:
        """The JSON record: each cut's first frame, the frames kept as captured and bridged, the
        cuts between takes (cleaned across)."""
        return {
            "cut_after_frames": self.steps.tolist(),
            "kept_frames": np.flatnonzero(self.kept).tolist(),
            "bridged_frames": np.flatnonzero(self.bridged).tolist(),
            "between_takes": self.between_takes.tolist(),
        }


def window(frame_time: float) -> int:
    """Frames around a frame that set its typical acceleration, and the longest run of frames
    that is no motion of its own: WINDOW seconds, at least STEPS."""
    return max(STEPS, int(round(WINDOW / frame_time)))


def abruptness(p: np.ndarray, span: float, around: int) -> np.ndarray:
    """(N-1,) how abruptly the motion of the points p (N, F, 3) changes at each step: the smaller
    acceleration of its two frames over the typical acceleration around them (module notes); 0
    for a step that moves the points less than CUT_SPAN x `span` on average or has no frames
    around it."""
    moves = np.diff(p, axis=0)
    step = np.linalg.norm(moves, axis=-1).mean(axis=1)
    out = np.zeros(len(step))
    if len(step) < 2:
        return out
    acceleration = np.linalg.norm(np.diff(moves, axis=0), axis=-1).mean(axis=1)  # [m]: frame m + 1
    padded = np.pad(acceleration, (around + 1, around + 1), constant_values=np.nan)
    # step n: its frames' accelerations are [n - 1] and [n]; the window around them [n - 1 - around, n + around]
    window = np.lib.stride_tricks.sliding_window_view(padded, 2 * around + 2)[: len(step)].copy()
    own = window[:, around : around + 2].copy()
    window[:, around : around + 2] = np.nan
    has_own, has_others = np.isfinite(own).any(axis=1), np.isfinite(window).any(axis=1)
    ok = (step >= CUT_SPAN * span) & has_own & has_others
    if ok.any():
        typical = np.nanmedian(window[ok], axis=1)
        out[ok] = np.nanmin(own[ok], axis=1) / np.maximum(typical, np.finfo(float).tiny)
    return out


def cut_steps(p: np.ndarray, span: float, frame_time: float) -> np.ndarray:
    """(C,) the steps n (from frame n to n + 1) of the points p (N, F, 3) of a body that spans
    `span` length units, `frame_time` seconds apart, in which the pose jumps (module notes)."""
    return np.flatnonzero(abruptness(p, span, window(frame_time)) >= CUT_RATIO)


def find_cuts(clip: Motion, span: float) -> Cuts:
    """The Cuts of `clip`, whose body spans `span` length units (module notes)."""
    N = clip.n_frames
    steps = cut_steps(clip.kinematics.p_world_frame[:, ~off_body(clip.skeleton)], span, clip.frame_time)
    kept, bridged = np.zeros(N, bool), np.zeros(N, bool)
    starts = np.concatenate([[0], steps + 1, [N]])
    runs = list(zip(starts[:-1], starts[1:]))
    short = [b - a <= window(clip.frame_time) for a, b in runs]
    if all(short):  # no run is motion: nothing to stand in for
        return Cuts(steps, kept, bridged)
    for k, (a, b) in enumerate(runs):
        if not short[k]:
            continue
        if k == 0 or k == len(runs) - 1:
            kept[a:b] = True
        elif not short[k - 1] and not short[k + 1]:
            bridged[a:b] = True
    return Cuts(steps, kept, bridged)
