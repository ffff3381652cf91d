"""2-D convex hulls (model/geometry.convex_hull) checked by what a hull is: its corners are input
points turning left, every point lies inside, and every point furthest along some direction is
a corner; degenerate sets give one corner or a segment's two ends."""

import numpy as np
import pytest

from deik.model.geometry import convex_hull


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
