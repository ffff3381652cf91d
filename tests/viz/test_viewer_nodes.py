"""The 3-D view's nodes: the floor grid's cell people can read and the grid turned to lie across
the up direction (checked by rotating +Z with the quaternion, independently of how it is built);
the camera opening on the first step's body, filling FILL of the view; marks and frame axes sized
to the body; solids moving with their frames (on a stand-in for viser's server)."""

from unittest import mock

import numpy as np
import pytest

import deik
from deik.model.orientations import quaternion_matrix
from deik.viz.body_shapes import character_body
from deik.viz.scene import Scene, figure_from_poses
from deik.viz.viewer_nodes import FILL, FOV, SceneNodes, nice_step, turn_z_to


@pytest.mark.parametrize("length, step", [(0.225, 0.2), (0.049, 0.02), (3.0, 2.0), (7.5, 5.0), (10.0, 10.0)])
def test_grid_cells_are_one_two_or_five_times_a_power_of_ten(length, step):
    assert nice_step(length) == pytest.approx(step)


@pytest.mark.parametrize("up", [(0, 1, 0), (0, 0, 1), (0, 0, -1), (1, 0, 0), (0.3, 0.5, 0.8)])
def test_the_grid_turns_onto_the_up_direction(up):
    up = np.asarray(up, float) / np.linalg.norm(up)
    R = quaternion_matrix(turn_z_to(up), "wxyz")
    assert np.allclose(R @ [0, 0, 1], up) and np.allclose(R.T @ R, np.eye(3))


def _nodes(scene):
    """SceneNodes on a stand-in server that records what viser would be asked to draw."""
    server = mock.MagicMock()
    server.scene.add_frame.side_effect = lambda *args, **kwargs: mock.MagicMock()  # a handle per node
    return SceneNodes(server, scene), server


def _walk_scene(steps=12, stride=0.15):
    """The humanoid walking `stride` along x per step, with its body (viz.body_shapes)."""
    human = deik.humanoid()
    poses = np.tile(human.reference, (steps, 1))
    poses[:, human.dof_names.index("pelvis.Xposition")] += stride * np.arange(steps)
    figure = figure_from_poses(human, poses)
    body = character_body(human, figure)
    return Scene("walk", figure, human.up, "m", "given", step="frame", shapes=body.shapes), figure


def test_the_camera_opens_on_the_first_step_s_body_whatever_the_path():
    """The camera looks at the middle of the first step's body, from where its bounding sphere
    fills FILL of the view's height at the field of view it sets, however far the clip walks."""
    for stride in (0.0, 0.3):
        scene, figure = _walk_scene(stride=stride)
        nodes, server = _nodes(scene)
        camera = server.initial_camera
        assert camera.fov == pytest.approx(FOV)
        first = np.concatenate(
            [figure.positions[0]]
            + [
                s.vertices @ quaternion_matrix(figure.quaternions_wxyz[0, s.frame], "wxyz").T
                + figure.positions[0, s.frame]
                for s in scene.shapes
            ]
        )
        low, high = first.min(axis=0), first.max(axis=0)
        assert np.allclose(camera.look_at, (low + high) / 2)
        radius = np.linalg.norm(high - low) / 2
        distance = np.linalg.norm(np.asarray(camera.position) - camera.look_at)
        # the sphere's share of the view's height at that distance
        assert radius / (distance * np.tan(FOV / 2)) == pytest.approx(FILL)


def test_marks_and_frame_axes_are_sized_to_the_body_not_to_its_path():
    for stride in (0.0, 0.5):
        scene, figure = _walk_scene(stride=stride)
        nodes, server = _nodes(scene)
        height = np.ptp(figure.positions[0], axis=0).max()
        (axes,) = [c for c in server.scene.add_batched_axes.call_args_list]
        assert axes.kwargs["axes_length"] == pytest.approx(height / 8)
        assert nodes.point == pytest.approx(height / 80)
        # every solid hangs from a frame node the step moves
        assert server.scene.add_mesh_simple.call_count == len(scene.shapes)
        nodes.show(5)
        for frame, node in nodes.solids.items():
            assert np.allclose(node.position, figure.positions[5, frame])
            assert np.allclose(node.wxyz, figure.quaternions_wxyz[5, frame])
