"""Ground frames, 2-D convex hulls, and point-to-segment, segment-to-segment and point-to-polygon
distances, in NumPy (batched).

The kernels compute the same quantities in device code (device/terms.py); these are the
readable versions that the oracle, the clip metrics and the balance track use.
"""

from __future__ import annotations

import math

import numpy as np

from deik.errors import InputError

STRAIGHT = 1e-12  # radians: points that turn less than this are collinear (as rounding leaves them)


def unit_up(up: object) -> np.ndarray:
    """(3,) the unit direction of `up` (three finite numbers of any length but 0); InputError
    naming `up` otherwise."""
    try:
        vector = np.asarray(up, np.float64)
    except (TypeError, ValueError):
        vector = np.full(1, np.nan)
    length = float(np.linalg.norm(vector)) if vector.shape == (3,) and np.isfinite(vector).all() else 0.0
    if not 1e-9 < length < math.inf:
        raise InputError(f"up: give a direction of three finite numbers, not all 0 (e.g. (0, 0, 1)), got {up!r:.60}")
    return vector / length


def ground_frame(up: np.ndarray) -> np.ndarray:
    """(3, 3): two horizontal unit axes, then `up`."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(up[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    e1 = np.cross(up, helper)
    e1 /= np.linalg.norm(e1)
    return np.stack([e1, np.cross(up, e1), up])


def convex_hull(points: np.ndarray) -> np.ndarray:
    """(K, 2) the corners of the convex hull of 2-D points (S, 2), S >= 1, counter-clockwise from
    the lowest x (then y): one for coincident points, the two ends for collinear ones (within
    STRAIGHT), and no point inside an edge (Andrew's monotone chain)."""
    points = np.unique(np.asarray(points, float), axis=0)  # sorted by x, then y
    if len(points) <= 2:
        return points

    def chain(ordered):  # the lower hull left to right (the upper one right to left), its last point left off
        kept = []
        for p in ordered:
            while len(kept) >= 2:
                (ux, uy), (vx, vy) = kept[-1] - kept[-2], p - kept[-2]
                if ux * vy - uy * vx > STRAIGHT * math.hypot(ux, uy) * math.hypot(vx, vy):  # a left turn: a corner
                    break
                kept.pop()
            kept.append(p)
        return kept[:-1]

    return np.array(chain(points) + chain(points[::-1]))


def segment_distance(point: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from point (..., k) to segments a-b (..., k)."""
    u = b - a
    length2 = np.sum(u * u, axis=-1)
    t = np.where(length2 > 0, np.sum((point - a) * u, axis=-1) / np.where(length2 > 0, length2, 1), 0)
    t = np.clip(t, 0.0, 1.0)
    return np.linalg.norm(point - a - t[..., None] * u, axis=-1)


def segments_closest(a0: np.ndarray, a1: np.ndarray, b0: np.ndarray, b1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(s, t) (...,): the parameters in [0, 1] of the closest points a0 + s (a1 - a0) and
    b0 + t (b1 - b0) of segments a0-a1 and b0-b1 (..., 3), minimising their distance (Ericson,
    Real-Time Collision Detection, 5.1.9); a segment of zero length is its point (parameter 0)."""
    u, v, w = a1 - a0, b1 - b0, a0 - b0
    a, e = np.sum(u * u, axis=-1), np.sum(v * v, axis=-1)
    b, c, f = np.sum(u * v, axis=-1), np.sum(u * w, axis=-1), np.sum(v * w, axis=-1)
    safe = lambda x: np.where(x > 0, x, 1.0)  # noqa: E731
    denom = a * e - b * b
    s = np.where((a > 0) & (e > 0) & (denom > 0), np.clip((b * f - c * e) / safe(denom), 0, 1), 0.0)
    s = np.where((a > 0) & (e <= 0), np.clip(-c / safe(a), 0, 1), s)
    t = np.where(e > 0, (b * s + f) / safe(e), 0.0)
    s = np.where((a > 0) & (t < 0), np.clip(-c / safe(a), 0, 1), s)
    s = np.where((a > 0) & (t > 1), np.clip((b - c) / safe(a), 0, 1), s)
    return s, np.clip(t, 0, 1)


def segments_distance(a0: np.ndarray, a1: np.ndarray, b0: np.ndarray, b1: np.ndarray) -> np.ndarray:
    """Distance between segments a0-a1 and b0-b1 (..., 3): between their closest points
    (segments_closest)."""
    s, t = segments_closest(a0, a1, b0, b1)
    return np.linalg.norm(a0 - b0 + s[..., None] * (a1 - a0) - t[..., None] * (b1 - b0), axis=-1)


def polygon_distance(q: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Distance of 2-D point q (N, 2) outside the convex hull of pts (N, n, 2): zero inside it or
    on its edge, else the distance to the nearest point-pair segment. q lies in the hull unless
    every point lies in one half-plane through q: unless, seen from q, the points' directions
    leave a gap wider than half a turn (n log n a row, where testing every triangle of the
    points took n^3: 40 s on a clip planting 34 finger and foot points)."""
    rel = pts - q[:, None]
    angle = np.sort(np.arctan2(rel[..., 1], rel[..., 0]), axis=1)
    gaps = np.diff(np.concatenate([angle, angle[:, :1] + 2.0 * np.pi], axis=1), axis=1)
    inside = gaps.max(axis=1, initial=0.0) <= np.pi
    n = pts.shape[1]
    best = np.full(len(q), np.inf)
    for a in range(n):
        for b in range(a, n):
            best = np.minimum(best, segment_distance(q, pts[:, a], pts[:, b]))
    return np.where(inside & (n > 0), 0.0, best)
