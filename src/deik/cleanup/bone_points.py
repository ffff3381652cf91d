"""Points along the body's bones: where a limb lying on the floor touches it between its joints.

A shin lying on the floor while its knee pivots slides along its length, not at the knee; the
joints and sites of the body (cleanup/body.py) do not see it. Along every bone of the body but
the feet's (their soles are their surface), points lie at most the resting band (ground.BAND x
span, 4.3 cm on the shared humanoid) apart. Each has the radius of the body's surface there: a
limb segment (a bone whose start joint starts no other) is the frustum cleanup/body.py sizes
its top joint by, TOP x its capsule radius (Body.bone_radius) at the top tapering to TAPER of
that, never thinner than the capsule (the next joint is sized by its own segment); any other
bone is its capsule. A point rests in a frame by the rule of cleanup/ground.py (slow, its surface
within the band of the floor, in runs of seconds) when it also touches: its axis at most TIE x
span above its bone's lower end's, as both ends of a bone lying level touch together (a thigh
that rises steeply from a kneeling knee does not lie on the floor, only its knee does), or its
surface within TIE x span of the floor where that end's surface (the point's radius below it)
lies under the floor. A capture sinks a kneeling knee into the floor (by 1.2 cm on the shared
crawl): the shin next to it rises 1.5 cm from the knee yet lies on the floor, and measured from
the sunk knee it would not. TIE, 1 % of the span (2.1 cm on the shared humanoid), errs towards
counting: these points decide which frames the report calls met, and a frame called met in
which a limb's surface slides along the floor is a silent miss, where one listed that a
thinner body would not have touched is only cautious. At half of it (1.07 cm) the studio
crawl's shin, tilted up from its knee, and the rescaled punch's shin beside its sunk heel slid
up to 1.4 and 3.3 mm a frame within 2 cm of the floor in frames the report called met (judged
with the DeepMimic capsules: benchmarks/clip_targets.py, docs/decisions.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from deik.cleanup import ground
from deik.cleanup.body import TAPER, TOP, Body
from deik.cleanup.speeds import NO_SEAMS, point_speeds, smoothed
from deik.io.trajectory import Motion
from deik.model.capsules import bone_starts

TIE = 0.01  # of the span: 2.1 cm on the shared humanoid (module notes)


@dataclass(frozen=True, eq=False)
class BonePoints:
    """Points along bones: each `share` (P,) of the way from frame `start` (P,) to frame `end`
    (P,) of the body's skeleton, and in which frames of the capture each rests, `rest` (N, P)."""

    start: np.ndarray
    end: np.ndarray
    share: np.ndarray
    rest: np.ndarray

    def positions(self, p: np.ndarray) -> np.ndarray:
        """(N, P, 3) the points given the frames' positions p (N, F, 3)."""
        t = self.share[:, None]
        return (1.0 - t) * p[:, self.start] + t * p[:, self.end]


def _bones(body: Body) -> tuple[np.ndarray, np.ndarray]:
    """(start (B,), end (B,)) frames of the body's bones: both ends part of it, not both in a
    foot nor ending at a sole site."""
    start = bone_starts(body.skeleton)
    names = body.skeleton.frame_names
    feet = {name for foot in body.feet for name in foot.chain + foot.soles}
    soles = set(body.sole_names)
    ends = [f for f in range(len(start)) if start[f] >= 0 and body.own[f] and body.part[start[f]]]
    ends = [f for f in ends if names[f] not in soles and not (names[f] in feet and names[start[f]] in feet)]
    ends = np.array(ends, np.int64)
    return start[ends], ends


def _radii(body: Body, start: np.ndarray, end: np.ndarray, bone: np.ndarray, share: np.ndarray) -> np.ndarray:
    """(P,) the surface's radius at each point, `share` (P,) along bone `bone` (P,) of the bones
    from frames `start` to `end` (B,): a limb segment's (its start joint starts no other bone)
    frustum, TOP x its capsule radius at its top tapering to TAPER of that (cleanup/body.py), but
    never under the capsule radius; any other bone's capsule radius (module notes)."""
    capsule = body.bone_radius[end][bone]
    starts = bone_starts(body.skeleton)
    limb = (np.bincount(starts[starts >= 0], minlength=len(starts))[start] == 1)[bone]
    frustum = TOP * capsule * (1.0 - (1.0 - TAPER) * share)
    return np.where(limb, np.maximum(frustum, capsule), capsule)


def bone_points(capture: Motion, body: Body, floor: float, seams: np.ndarray = NO_SEAMS) -> BonePoints:
    """The BonePoints of `capture` (on body.skeleton) over the floor at height `floor` (module
    notes), speeds read between the `seams` (ground.Paths.seams) only."""
    start, end = _bones(body)
    p = capture.kinematics.p_world_frame
    length = np.median(np.linalg.norm(p[:, end] - p[:, start], axis=-1), axis=0) if len(end) else np.zeros(0)
    band, up = ground.BAND * body.span, body.skeleton.up
    count = np.maximum(np.ceil(length / band).astype(np.int64), 2)
    bone = np.repeat(np.arange(len(end)), count - 1)
    share = np.concatenate([np.arange(1, n) / n for n in count]) if len(end) else np.zeros(0)
    points = BonePoints(start[bone], end[bone], share, np.zeros((capture.n_frames, len(bone)), bool))
    if not len(bone):
        return points
    radius = _radii(body, start, end, bone, share)
    x = points.positions(p)
    surface = x @ up - floor - radius
    lowest = np.minimum(p[:, points.start] @ up, p[:, points.end] @ up) - floor - radius
    low = (surface <= band) & (surface <= np.maximum(lowest, 0.0) + TIE * body.span)
    slow = point_speeds(x, capture.frame_time, seams) <= ground.SPEED * body.span
    step = ground.SPEED * body.span * capture.frame_time
    rest = ground.rest_runs(low & slow, capture.frame_time, smoothed(x, capture.frame_time, seams), step)
    return BonePoints(points.start, points.end, share, rest)
