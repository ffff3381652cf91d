"""Self-collision in a retarget: how deep the target's bone capsules overlap, frame by frame,
and the least-squares rows that push overlapping capsules apart in the space-time pass.

The capsules and the pairs tested are deik.SelfCollision's (objectives/self_collision.py: radii
from the segment masses, bones within two links and pairs overlapping at rest left out),
restricted to the bones of the body: those ending at a joint or site of `body`, so the points a
retarget adds to steer orientations are not bones. Lengths are the skeleton's unit.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from deik.model.capsules import bone_starts
from deik.model.geometry import segments_closest
from deik.model.kinematics import forward_kinematics
from deik.model.skeleton import Skeleton
from deik.objectives.self_collision import SelfCollision


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
    """(k, 3) unit directions that part each pair: along the gap between the closest points, or,
    where the segments cross (no gap to follow), across both of them (a zero row when they are
    also parallel: one point of each on the other)."""
    across = np.cross(a1 - a0, b1 - b0)
    across = across / np.maximum(np.linalg.norm(across, axis=-1, keepdims=True), 1e-300)
    crossing = distance[:, None] < 1e-12
    return np.where(crossing, across, gap / np.where(crossing, 1.0, distance[:, None]))


def collision_rows(x: np.ndarray, jac: np.ndarray, pairs: BonePairs, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """(errors (N, M), rows (N, M, D)): one row per pair closer than its radii + 2 `margin` in
    a frame (M the most in any frame; frames with fewer get zero rows), asking the distance
    between the closest points to grow to radii + `margin`, along the line between them. x
    (N, F, 3) every frame's position and jac (N, F, 3, D) its Jacobian (position_jacobian)."""
    N, D = jac.shape[0], jac.shape[-1]
    s, t, gap, distance = pairs.closest(x)
    near = distance < pairs.reach + 2 * margin
    M = int(near.sum(axis=1).max(initial=0))
    errors, rows = np.zeros((N, M)), np.zeros((N, M, D))
    for n in np.flatnonzero(near.any(axis=1)):
        k = np.flatnonzero(near[n])
        a, b = pairs.a[k], pairs.b[k]
        normal = _separating(gap[n, k], distance[n, k], x[n, pairs.starts[a]], x[n, a], x[n, pairs.starts[b]], x[n, b])
        on_a = (1 - s[n, k])[:, None, None] * jac[n, pairs.starts[a]] + s[n, k][:, None, None] * jac[n, a]
        on_b = (1 - t[n, k])[:, None, None] * jac[n, pairs.starts[b]] + t[n, k][:, None, None] * jac[n, b]
        rows[n, : len(k)] = np.einsum("kc,kcd->kd", normal, on_a - on_b)
        errors[n, : len(k)] = pairs.reach[k] + margin - distance[n, k]
    return errors, rows
