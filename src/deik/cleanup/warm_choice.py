"""Which warm start a clip fix keeps: fix._calmed_warm_start tries the floor lifted along smooth
envelopes, lifted with each bone whole, and the plain floor, and keeps the one with the most
frames on the floor (the highest priority), then the most frames meeting every goal, then the
fewest taken back (the first tried on a tie); never one that meets fewer frames than another and
turns a joint more than FAR_DEGREES from the capture in FAR_SHARE more of the clip's frames. A
lift that buys frames on the floor by turning the body away from the performance is no fix: with
one frame of the shared get-up left out (a capture hiccup), lifting each bone whole put 155
frames on the floor against the plain floor's 146, met 105 frames against 141 and turned a joint
past 30 degrees in 46 frames against none, and it was kept (a shoulder 95 degrees off, 92 frames
met in the end against 117 without the hiccup). A crawl needs its ankles turned far to lift its
toes out of the floor, in 12 % of its frames, and meets more frames so: that lift is kept.
"""

from __future__ import annotations

from collections.abc import Hashable
from dataclasses import dataclass

import numpy as np

from deik.cleanup.dynamics import FAR_DEGREES
from deik.cleanup.metrics import joint_angles
from deik.io.trajectory import Motion

FAR_SHARE = 0.1  # of the frames (module notes)


@dataclass(frozen=True)
class Tried:
    """How a warm start did, in frames of the clip: `on_floor` meeting their floor goals, `met`
    meeting every goal above fidelity, `calmed` taken back (cleanup/calm.py), `far` turning a
    joint more than FAR_DEGREES from the capture."""

    on_floor: int
    met: int
    calmed: int
    far: int

    def perfect(self, n_frames: int) -> bool:
        """Whether no other can do better on a clip of `n_frames`."""
        return self.on_floor == self.met == n_frames and not self.calmed and not self.far


def far_frames(clip: Motion, displacement: np.ndarray) -> int:
    """The frames of `clip` in which `displacement` (N, D) turns a joint more than FAR_DEGREES."""
    return int((joint_angles(clip, clip.with_frames(clip.frames + displacement)) > FAR_DEGREES).any(axis=1).sum())


def chosen(tries: dict[Hashable, Tried], n_frames: int) -> Hashable:
    """The key of the warm start kept of `tries` {key: Tried}, in the order tried (module notes)."""
    more = FAR_SHARE * n_frames
    kept = [key for key, t in tries.items() if not any(o.met > t.met and t.far - o.far > more for o in tries.values())]
    return max(kept, key=lambda key: (tries[key].on_floor, tries[key].met, -tries[key].calmed))
