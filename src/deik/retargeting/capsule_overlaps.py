"""Self-collision in a retarget: how deep the target's bone capsules overlap, frame by frame,
and the least-squares rows that push overlapping capsules apart in the space-time pass, each
pair to one side over the frames it is close in (parting_sides, approach_sides).

The capsules and the pairs tested are deik.SelfCollision's (objectives/self_collision.py: radii
from the segment masses, bones within two links and pairs overlapping at rest left out),
restricted to the bones of the body: those ending at a joint or site of `body`, so the points a
retarget adds to steer orientations are not bones. Lengths are the skeleton's unit.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from deik.cleanup.contacts import true_runs
from deik.model.capsules import bone_starts
from deik.model.geometry import segments_closest
from deik.model.kinematics import forward_kinematics
from deik.model.skeleton import Skeleton
from deik.objectives.self_collision import SelfCollision

SIDE_FRAMES = 2  # a lasting overlap's side is averaged over this many frames either side (parting_sides)


@dataclass(frozen=True)
class BonePairs:
    """The tested capsule pairs: bones `a`, `b` (P,) named by their end frames, `starts` (F,)
    each bone's start frame (model.capsules.bone_starts), `reach` (P,) the radii's sum."""

    a: np.ndarray
    b: np.ndarray
    starts: np.ndarray
    reach: np.ndarray

    def closest(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(s, t, gap vector (N, P, 3) from b's closest point to a's, distance (N, P)) at the
        frame positions p (N, F, 3): s, t (N, P) the closest points' parameters on a and b."""
        a0, a1, b0, b1 = p[:, self.starts[self.a]], p[:, self.a], p[:, self.starts[self.b]], p[:, self.b]
        s, t = segments_closest(a0, a1, b0, b1)
        gap = a0 + s[..., None] * (a1 - a0) - b0 - t[..., None] * (b1 - b0)
        return s, t, gap, np.linalg.norm(gap, axis=-1)


def body_pairs(skeleton: Skeleton, body: Sequence[str]) -> BonePairs:
    """SelfCollision's tested pairs among the bones ending at the frames `body` of `skeleton`
    (an empty set when none)."""
    inside = np.zeros(skeleton.n_frames, bool)
    inside[[skeleton.frame_index(name) for name in body]] = True
    pairs = np.array(SelfCollision().pairs(skeleton), float).reshape(-1, 3)
    a, b = pairs[:, 0].astype(int), pairs[:, 1].astype(int)
    keep = inside[a] & inside[b]
    return BonePairs(a[keep], b[keep], bone_starts(skeleton), pairs[keep, 2])


def penetration_depths(skeleton: Skeleton, poses: np.ndarray, pairs: BonePairs) -> np.ndarray:
    """(N, P) how deep each pair's capsules overlap at `poses` (N, D) (0 apart), length units."""
    p = forward_kinematics(skeleton, np.atleast_2d(poses)).p_world_frame
    return np.maximum(pairs.reach - pairs.closest(p)[3], 0.0)


def _separating(gap, distance, a0, a1, b0, b1) -> np.ndarray:
    """(..., 3) unit directions that part each pair: along the gap (..., 3) between the closest
    points, or, where the segments cross (no gap to follow), across both of them (a zero row
    when they are also parallel: one point of each on the other)."""
    across = np.cross(a1 - a0, b1 - b0)
    across = across / np.maximum(np.linalg.norm(across, axis=-1, keepdims=True), 1e-300)
    crossing = distance[..., None] < 1e-12
    return np.where(crossing, across, gap / np.where(crossing, 1.0, distance[..., None]))


def collision_rows(
    x: np.ndarray, jac: np.ndarray, pairs: BonePairs, margin: float, sides: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(errors (N, M), rows (N, M, D)): one row per pair closer than its radii + 2 `margin` in
    a frame (M the most in any frame; frames with fewer get zero rows), asking the distance
    between the closest points to grow to radii + `margin`, along the line between them, turned
    to the pair's side (the distance counted along it, negative where the pair lies the other
    way): `sides` (N, P, 3) where it gives one (parting_sides), else the side of the frames
    around the run of frames it is that close in (approach_sides). x (N, F, 3) every frame's
    position and jac (N, F, 3, D) its Jacobian (position_jacobian)."""
    N, D = jac.shape[0], jac.shape[-1]
    s, t, gap, distance = pairs.closest(x)
    near = distance < pairs.reach + 2 * margin
    normal = _normals(pairs, x, gap, distance, near.any(axis=0))
    sides = np.zeros(normal.shape) if sides is None else sides
    given = (sides != 0).any(axis=-1)
    reference = np.where(given[..., None], sides, approach_sides(normal, near & ~given))
    flip = (np.einsum("npc,npc->np", normal, reference) < 0.0) & near
    normal = np.where(flip[..., None], -normal, normal)
    distance = np.where(flip, -distance, distance)
    M = int(near.sum(axis=1).max(initial=0))
    errors, rows = np.zeros((N, M)), np.zeros((N, M, D))
    for n in np.flatnonzero(near.any(axis=1)):
        k = np.flatnonzero(near[n])
        a, b = pairs.a[k], pairs.b[k]
        on_a = (1 - s[n, k])[:, None, None] * jac[n, pairs.starts[a]] + s[n, k][:, None, None] * jac[n, a]
        on_b = (1 - t[n, k])[:, None, None] * jac[n, pairs.starts[b]] + t[n, k][:, None, None] * jac[n, b]
        rows[n, : len(k)] = np.einsum("kc,kcd->kd", normal[n, k], on_a - on_b)
        errors[n, : len(k)] = pairs.reach[k] + margin - distance[n, k]
    return errors, rows


def approach_sides(normal: np.ndarray, near: np.ndarray) -> np.ndarray:
    """(N, P, 3) for each run of frames a pair is `near` (N, P) in, the parting direction
    `normal` (N, P, 3) of the frame before the run over its first half and of the frame after
    it over its second (either where the run reaches the clip's end; zero where both do, and
    outside the runs): the sides the pair came from and goes to. A pair that goes to the other
    side from the one it came from (the two directions more than a right angle apart: a
    sprinter's swing shin passing the standing one) gets no side (zero): it is parted along its
    closest points' line as it lies in each frame, and so passes round. Held to the side it came
    from over half the run and to the other over the rest, it could not pass, and jumped there
    at the run's middle: a CMU sprint onto `human.urdf` put its swing foot 0.4 m from its
    target in one frame and moved its knee at 3.9 times the source's top speed."""
    N = len(normal)
    out = np.zeros(normal.shape)
    for k in np.flatnonzero(near.any(axis=0)):
        for first, stop in true_runs(near[:, k]):
            before, after = (first - 1 if first > 0 else None), (stop if stop < N else None)
            if before is None and after is None:
                continue
            came = normal[before if before is not None else after, k]
            goes = normal[after if after is not None else before, k]
            if _passes_through(came, goes):
                continue
            middle = (first + stop) // 2
            out[first:middle, k] = came
            out[middle:stop, k] = goes
    return out


def parting_sides(x: np.ndarray, pairs: BonePairs, margin: float, shortest: int) -> np.ndarray:
    """(N, P, 3) the side each pair is parted to in each frame of positions x (N, F, 3) (zero
    where it lies farther apart than its radii + 2 `margin`, or is that close for fewer than
    `shortest` frames): over each longer run of frames a pair is that close in, the direction
    that parts it in each frame, turned where it would point more than a right angle away from
    the frame's neighbour's, outwards from the run's frame farthest apart, then averaged over
    SIDE_FRAMES frames either side (_averaged). Deep in a lasting overlap the closest points'
    line flips from frame to frame: a hand 10 cm inside a shin for some 0.3 s in the per-frame
    IK (the get-up from lying face up onto human.urdf) was parted one way in some frames and
    the other way in the next, and flicked between them at 12 m/s. A run whose frames before and
    after it part the pair opposite ways passes through (a walk's swing shin crossing the
    standing one where the feet cross the midline) and gets no side, as approach_sides gives
    none: held to the side of its farthest-apart frame, the swing foot of the shared walk with
    both hips turned in 8 degrees jumped 0.6 m to the far side of the other in one frame."""
    _, _, gap, distance = pairs.closest(x)
    near = distance < pairs.reach + 2 * margin
    normal = _normals(pairs, x, gap, distance, near.any(axis=0))
    sides = np.zeros(normal.shape)
    for k in np.flatnonzero(near.any(axis=0)):
        for first, stop in true_runs(near[:, k]):
            if stop - first < shortest:
                continue
            if 0 < first and stop < len(x) and _passes_through(normal[first - 1, k], normal[stop, k]):
                continue
            sides[first:stop, k] = normal[first:stop, k]
            apart = first + int(np.argmax(distance[first:stop, k]))
            for n, step in [(n, -1) for n in range(apart + 1, stop)] + [
                (n, 1) for n in range(apart - 1, first - 1, -1)
            ]:
                if sides[n, k] @ sides[n + step, k] < 0.0:  # turned by its neighbour nearer the farthest-apart frame
                    sides[n, k] = -sides[n, k]
            sides[first:stop, k] = _averaged(sides[first:stop, k], SIDE_FRAMES)
    return sides


def _passes_through(came: np.ndarray, goes: np.ndarray) -> bool:
    """Whether a pair parted along `came` (3,) before a run of frames close and along `goes` (3,)
    after it went to the other side (the two more than a right angle apart): such a run gets no
    side (approach_sides, parting_sides)."""
    return bool(came @ goes < 0.0)


def _averaged(directions: np.ndarray, reach: int) -> np.ndarray:
    """(n, 3) unit `directions` (n, 3) each averaged with those up to `reach` frames either side
    (within the n), so that no frame's side stands apart from its neighbours'."""
    padded = np.pad(directions, ((reach, reach), (0, 0)))
    summed = sum(padded[j : j + len(directions)] for j in range(2 * reach + 1))
    return summed / np.maximum(np.linalg.norm(summed, axis=-1, keepdims=True), 1e-300)


def _normals(pairs: BonePairs, x: np.ndarray, gap: np.ndarray, distance: np.ndarray, used: np.ndarray) -> np.ndarray:
    """(N, P, 3) _separating's direction for the pairs `used` (P,) in every frame (zero for the others)."""
    normal = np.zeros(gap.shape)
    k = np.flatnonzero(used)
    a, b = pairs.a[k], pairs.b[k]
    ends = (x[:, pairs.starts[a]], x[:, a], x[:, pairs.starts[b]], x[:, b])
    normal[:, k] = _separating(gap[:, k], distance[:, k], *ends)
    return normal
