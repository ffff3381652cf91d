"""Balance in the clip warm start: how far each frame's centre of mass must move to stand over
its support.

A frame's support is the convex hull of the ground projections of its sites in contact (the
kernels' ComInPolygon measure: inside some triangle of the points, else the distance to the
nearest segment between two of them). Where the COM's projection lies outside, it should move
to the nearest support point plus a margin towards the support's centroid, so the frame ends
inside and not on the edge. Those moves, eased in and out over the neighbouring frames like
any other correction (coherence.ease), make a track the warm start steers the COM along with
two rows (its horizontal Jacobian): the body shifts its weight ahead of a step instead of
jumping where the support shrinks. Frames the track leaves alone get no rows: balance never
holds the COM still.
"""

from __future__ import annotations

from itertools import combinations

import numpy as np

from deik.clips.coherence import ease
from deik.model.geometry import ground_frame
from deik.model.skeleton import Skeleton

# frames (about a third of the fade) over which a COM shift eases in before and out after the frames that need it
EASE = 3.0


def horizontal_axes(skeleton: Skeleton) -> np.ndarray:
    """(2, 3) the two ground axes of `skeleton` (perpendicular to its up direction)."""
    return ground_frame(np.asarray(skeleton.up, float))[:2]


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """z of the cross product of 2-D vectors u, v (..., 2)."""
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def inside_support(points: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(N,) bool: is q (N, 2) inside some non-degenerate triangle of points (N, S, 2)?"""
    inside = np.zeros(len(q), bool)
    for a, b, c in combinations(range(points.shape[1]), 3):
        pa, pb, pc = points[:, a], points[:, b], points[:, c]
        area = _cross(pb - pa, pc - pa)
        signs = np.stack([_cross(pb - pa, q - pa), _cross(pc - pb, q - pb), _cross(pa - pc, q - pc)])
        inside |= (area != 0) & ((signs >= 0).all(axis=0) | (signs <= 0).all(axis=0))
    return inside


def nearest_support_point(points: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(N, 2) the point of the segments between any two of points (N, S, 2) nearest to q (N, 2)."""
    best = points[:, 0].copy()
    best_distance = np.full(len(q), np.inf)
    for a, b in combinations(range(points.shape[1]), 2) if points.shape[1] > 1 else [(0, 0)]:
        pa, edge = points[:, a], points[:, b] - points[:, a]
        length2 = (edge * edge).sum(axis=1)
        t = np.clip(((q - pa) * edge).sum(axis=1) / np.where(length2 > 0, length2, 1.0), 0.0, 1.0)
        candidate = pa + t[:, None] * edge
        distance = np.linalg.norm(q - candidate, axis=1)
        closer = distance < best_distance
        best[closer], best_distance[closer] = candidate[closer], distance[closer]
    return best


def support_correction(points: np.ndarray, q: np.ndarray, margin: float) -> np.ndarray:
    """(N, 2) how far the COM projection q (N, 2) must move (zero where it is inside the
    support of points (N, S, 2)): to the nearest support point, then `margin` (length units)
    further towards the points' centroid (no further than the centroid)."""
    nearest = nearest_support_point(points, q)
    inwards = points.mean(axis=1) - nearest
    length = np.linalg.norm(inwards, axis=1, keepdims=True)
    target = nearest + inwards * np.minimum(1.0, margin / np.maximum(length, 1e-12))
    return np.where(inside_support(points, q)[:, None], 0.0, target - q)


def balance_track(com: np.ndarray, supports: list) -> tuple[np.ndarray, np.ndarray]:
    """(track (N, 2), steered (N,)): where the warm start should steer the COM projection com
    (N, 2), and in which frames. `supports`: (points (N, S, 2), active (N,) bool, margin) per
    support polygon. Frames outside their active support get support_correction; the shift
    eases in and out over EASE frames around them; steered frames are those it moves by more
    than 1 % of its largest shift."""
    shift = np.zeros_like(com)
    outside = np.zeros(len(com), bool)
    for points, active, margin in supports:
        correction = support_correction(points, com, margin)
        needs = active & (correction != 0).any(axis=1)
        shift[needs] = correction[needs]
        outside |= needs
    if not outside.any():
        return com, outside
    shift = ease(shift, outside[:, None], EASE)
    size = np.linalg.norm(shift, axis=1)
    steered = size > 0.01 * size.max()  # the fade's far tail moves nothing that matters
    return com + shift, steered
