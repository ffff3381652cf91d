"""Which warm start a clip fix keeps: warm_tries.calmed_warm_start tries the floor lifted along smooth
envelopes, lifted with each bone whole, and the plain floor, and keeps the one with the fewest
frames deep in the floor (its points more than DEEP x the body's span under it in all), then the
most frames on the floor (the highest priority), then the most frames meeting every goal, then
the fewest taken back (the first tried on a tie); never one that meets fewer frames than another and
turns a joint more than FAR_DEGREES from the capture in FAR_SHARE more of the clip's frames. A
lift that buys frames on the floor by turning the body away from the performance is no fix: with
one frame of the shared get-up left out (a capture hiccup), lifting each bone whole put 155
frames on the floor against the plain floor's 146, met 105 frames against 141 and turned a joint
past 30 degrees in 46 frames against none, and it was kept (a shoulder 95 degrees off, 92 frames
met in the end against 117 without the hiccup). A crawl needs its ankles turned far to lift its
toes out of the floor, in 12 % of its frames, and meets more frames so: that lift is kept.
A frame just under the floor and one deep in it both miss the floor, but only the second is a
body sunk through it: counted alike, the shared get-up with bending toes kept a lift whose
calm took it back in 25 frames, 58 mm under the floor, for one frame more on it than the plain
floor, whose deepest was 6 mm (docs/decisions.md).

Each try is calmed by cutting its change back and, where that takes something back, by
smoothing it first (cleanup/calm.py): smoothing keeps a lift that cutting drops, but blurs where
a correction begins and ends. The smoothed calm is kept stretch by stretch, where it does
better (smoothed_stretches; outside the frames either calm changed both are the warm start, so
the stretches join without a seam): no frame loses a goal, one gains, and no resting point steps
further than SLIDE_GROWTH times the cut calm's furthest step there plus the sliding tolerance
(smoothing blurs where a plant begins; allowed only the tolerance more, the get-up at 120 fps
kept a heel 9 mm under the floor for 2.1 mm against 2.05), and a try so smoothed is kept only where it puts more
frames on the floor than every try cut back: chosen like any other, a smoothed try cost the
shared jump two of its seven steps (docs/decisions.md), the plain floor, which does not roll
the feet, meeting the most frames smoothed while a resting toe drifted 10 mm up.
"""

from __future__ import annotations

from collections.abc import Hashable
from dataclasses import dataclass

import numpy as np

from deik.cleanup.dynamics import FAR_DEGREES
from deik.cleanup.metrics import joint_angles
from deik.io.trajectory import Motion

FAR_SHARE = 0.1  # of the frames (module notes)
DEEP = 0.005  # of the body's span: summed depth under the floor that sinks a frame (1.1 cm on the shared humanoid)
SLIDE_GROWTH = 2.0  # times the cut calm's furthest step a smoothed stretch may step (module notes)


@dataclass(frozen=True)
class Tried:
    """How a warm start did in each frame (N,) bool: `on_floor` meeting its floor goals, `met`
    meeting every goal above fidelity with no resting point sliding, `calmed` taken back
    (cleanup/calm.py), `far` turning a joint more than FAR_DEGREES from the capture; `slides`
    (N,) the longest step of a resting point to or from each frame (length units); whether it
    was `smoothed` before cut back (module notes); `sunk` (N,) bool the frames deep in the floor
    (DEEP; None: none)."""

    on_floor: np.ndarray
    met: np.ndarray
    calmed: np.ndarray
    far: np.ndarray
    slides: np.ndarray
    smoothed: bool = False
    sunk: np.ndarray | None = None

    def counts(self) -> tuple[int, int, int, int]:
        """(frames on the floor, met, calmed, far)."""
        return tuple(int(np.sum(frames)) for frames in (self.on_floor, self.met, self.calmed, self.far))

    def sunk_count(self) -> int:
        """Frames deep in the floor."""
        return 0 if self.sunk is None else int(np.sum(self.sunk))

    def perfect(self) -> bool:
        """Whether no other can do better."""
        return bool(self.on_floor.all() and self.met.all() and not self.calmed.any() and not self.far.any())


def far_frames(clip: Motion, displacement: np.ndarray) -> np.ndarray:
    """(N,) bool: the frames of `clip` in which `displacement` (N, D) turns a joint more than FAR_DEGREES."""
    return (joint_angles(clip, clip.with_frames(clip.frames + displacement)) > FAR_DEGREES).any(axis=1)


def smoothed_stretches(cut: Tried, smoothed: Tried, sliding: float) -> np.ndarray:
    """(N,) bool: the stretches of frames (runs of frames either calms) in which the `smoothed`
    calm of a warm start does better than the `cut` one (module notes): in no frame fewer of
    its goals (the floor first, then the rest), in one frame more, and in none a resting point
    stepping further than SLIDE_GROWTH times the cut one's furthest step there (or `sliding`,
    length units: the verdict's sliding tolerance) and `sliding` more."""
    rank = [2 * t.on_floor.astype(int) + t.met for t in (cut, smoothed)]
    changed = np.concatenate([[False], cut.calmed | smoothed.calmed, [False]])
    edges = np.flatnonzero(np.diff(changed.astype(np.int8)))
    out = np.zeros(len(cut.met), bool)
    for a, b in zip(edges[::2], edges[1::2]):
        better = (rank[1][a:b] >= rank[0][a:b]).all() and (rank[1][a:b] > rank[0][a:b]).any()
        furthest = SLIDE_GROWTH * np.maximum(cut.slides[a:b], sliding) + sliding
        out[a:b] = better and (smoothed.slides[a:b] <= furthest).all()
    return out


def chosen(tries: dict[Hashable, Tried]) -> Hashable:
    """The key of the warm start kept of `tries` {key: Tried}, in the order tried (module notes)."""
    counts = {key: t.counts() for key, t in tries.items()}
    more = FAR_SHARE * len(next(iter(tries.values())).met)
    exact = max((counts[key][0] for key, t in tries.items() if not t.smoothed), default=-1)
    counts = {key: c for key, c in counts.items() if not tries[key].smoothed or c[0] > exact}
    kept = [
        k
        for k, (_, met, _, far) in counts.items()
        if not any(o[1] > met and far - o[3] > more for o in counts.values())
    ]
    return max(kept, key=lambda key: (-tries[key].sunk_count(), counts[key][0], counts[key][1], -counts[key][2]))
