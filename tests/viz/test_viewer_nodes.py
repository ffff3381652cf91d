"""The 3-D view's floor grid: a cell people can read, and the grid turned to lie across the up
direction (checked by rotating +Z with the quaternion, independently of how it is built)."""

import numpy as np
import pytest

from deik.model.orientations import quaternion_matrix
from deik.viz.viewer_nodes import nice_step, turn_z_to


@pytest.mark.parametrize("length, step", [(0.225, 0.2), (0.049, 0.02), (3.0, 2.0), (7.5, 5.0), (10.0, 10.0)])
def test_grid_cells_are_one_two_or_five_times_a_power_of_ten(length, step):
    assert nice_step(length) == pytest.approx(step)


@pytest.mark.parametrize("up", [(0, 1, 0), (0, 0, 1), (0, 0, -1), (1, 0, 0), (0.3, 0.5, 0.8)])
def test_the_grid_turns_onto_the_up_direction(up):
    up = np.asarray(up, float) / np.linalg.norm(up)
    R = quaternion_matrix(turn_z_to(up), "wxyz")
    assert np.allclose(R @ [0, 0, 1], up) and np.allclose(R.T @ R, np.eye(3))
