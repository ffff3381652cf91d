"""2-D convex hulls (model/geometry.convex_hull) checked by what a hull is: its corners are input
points turning left, every point lies inside, and every point furthest along some direction is
a corner; degenerate sets give one corner or a segment's two ends."""

import numpy as np
import pytest

from deik.model.geometry import convex_hull, polygon_distance


def cross(o, a, b):
    """z of (a - o) x (b - o), for points (..., 2)."""
    return (a[..., 0] - o[..., 0]) * (b[..., 1] - o[..., 1]) - (a[..., 1] - o[..., 1]) * (b[..., 0] - o[..., 0])


@pytest.mark.parametrize("count", [3, 4, 8, 30])
def test_convex_hull_is_counter_clockwise_holds_every_point_and_every_extreme_one(count):
    rng = np.random.default_rng(count)
    for _ in range(50):
        points = rng.uniform(-1, 1, (count, 2))
        corners = convex_hull(points)
        assert all((corner == points).all(axis=1).any() for corner in corners)
        following = np.roll(corners, -1, axis=0)
        assert (cross(corners, following, np.roll(corners, -2, axis=0)) > 0).all()  # left turns only
        sides = cross(corners[:, None], following[:, None], points[None])  # (K, S)
        assert (sides >= -1e-12).all()  # every point on the left of every edge: inside
        directions = rng.normal(size=(64, 2))
        extreme = points[np.argmax(directions @ points.T, axis=1)]
        assert all((e == corners).all(axis=1).any() for e in extreme)


def test_degenerate_point_sets_give_a_point_or_a_segments_ends():
    np.testing.assert_array_equal(convex_hull(np.array([[0.3, 0.2]] * 3)), [[0.3, 0.2]])
    ends = np.array([[0.1, -0.2], [0.7, 0.4]])
    along = ends[0] + np.linspace(0, 1, 7)[:, None] * (ends[1] - ends[0])  # collinear up to rounding
    np.testing.assert_array_equal(convex_hull(along[[3, 6, 0, 2, 5]]), along[[0, 6]])
    np.testing.assert_array_equal(convex_hull(ends[::-1]), ends)
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0], [1, 0.5]], float)  # two on edges
    np.testing.assert_array_equal(convex_hull(square), square[:4])


@pytest.mark.parametrize("count", [1, 2, 3, 5, 34])
def test_polygon_distance_is_zero_in_the_hull_and_the_nearest_edge_s_distance_outside(count):
    """Against scipy's Delaunay triangulation for inside and the distance to every edge of scipy's
    hull (or to the points, when they span no area) for outside, on random point sets of 1 to 34
    points (a clip planting every finger) with collinear and repeated points among them."""
    from scipy.spatial import ConvexHull, Delaunay, QhullError

    rng = np.random.default_rng(count)
    for trial in range(6):
        points = rng.uniform(-0.3, 0.3, (count, 2))
        if trial == 1 and count >= 3:
            points[2:] = points[0] + np.linspace(0.2, 1.4, count - 2)[:, None] * (points[1] - points[0])
        if trial == 2 and count >= 2:
            points[1] = points[0]
        q = np.vstack([rng.uniform(-0.6, 0.6, (300, 2)), points])  # the points themselves too
        got = polygon_distance(q, np.broadcast_to(points, (len(q),) + points.shape))
        try:
            inside = Delaunay(points).find_simplex(q) >= 0
            corners = points[ConvexHull(points).vertices]
            edges = list(zip(corners, np.roll(corners, -1, axis=0)))
        except (QhullError, ValueError):  # no area: every pair's segment
            inside = np.zeros(len(q), bool)
            edges = [(a, b) for a in points for b in points]
        expected = np.min([_segment_distance(q, a, b) for a, b in edges], axis=0)
        expected[inside] = 0.0
        assert np.allclose(got, expected, atol=1e-12), (count, trial)


def _segment_distance(q: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N,) distance of points q (N, 2) to the segment a-b, by projection clipped to its ends."""
    u = b - a
    t = np.clip((q - a) @ u / max(u @ u, 1e-300), 0.0, 1.0)
    return np.linalg.norm(q - (a + t[:, None] * u), axis=1)
