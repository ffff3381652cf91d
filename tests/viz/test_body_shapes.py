"""The solid body of the 3-D view (deik.viz.body_shapes), placed by forward kinematics of random
poses and checked against where the geometry must be: a URDF robot's mesh files (STL, OBJ, DAE
written by trimesh) and primitives at their link frames and origins, a missing mesh drawn as a
capsule and named in the note, and a character's capsules around its bones, thick by segment
mass, coloured by side."""

import numpy as np
import pytest

import deik
from deik.io.segments import bone_side
from deik.model.orientations import quaternion_matrix
from deik.viz.body_shapes import MIN_RADIUS, body_height, character_body, robot_body
from deik.viz.marks import COLOURS, bones
from deik.viz.scene import figure_from_poses
from helpers import MESH_ROBOT, mesh_robot, random_poses

trimesh = pytest.importorskip("trimesh", reason='the 3-D view builds meshes with trimesh: pip install "deik[view]"')


def _world(figure, shape, step=0):
    """A shape's vertices (V, 3) in world coordinates at `step`."""
    R = quaternion_matrix(figure.quaternions_wxyz[step, shape.frame], "wxyz")
    return shape.vertices @ R.T + figure.positions[step, shape.frame]


def _segment_distance(points, a, b):
    t = np.clip((points - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1)
    return np.linalg.norm(points - (a + t[:, None] * (b - a)), axis=1)


def test_a_robot_shows_its_meshes_and_primitives_where_its_links_are(tmp_path):
    path = mesh_robot(tmp_path)
    arm = deik.read_urdf(path)
    figure = figure_from_poses(arm, random_poses(arm, 1, seed=5))
    body = robot_body(path, figure)
    kinds = {(figure.names[s.frame], s.kind) for s in body.shapes}
    assert kinds == {("base", "mesh"), ("upper", "mesh"), ("fore", "box"), ("hand", "mesh"), ("hand", "capsule")}
    assert "missing.stl" in body.note and "mesh x3" in body.note and "box x1" in body.note
    p = {name: figure.positions[0, figure.names.index(name)] for name in figure.names}
    R = {name: quaternion_matrix(figure.quaternions_wxyz[0, figure.names.index(name)], "wxyz") for name in figure.names}
    shapes = {(figure.names[s.frame], s.kind): s for s in body.shapes}
    base = _world(figure, shapes["base", "mesh"])  # the fixed base: an STL box at the world origin
    assert np.allclose(base.min(axis=0), [-0.1, -0.1, -0.05], atol=1e-6)
    assert np.allclose(base.max(axis=0), [0.1, 0.1, 0.05], atol=1e-6)
    upper = _world(figure, shapes["upper", "mesh"])  # an OBJ cylinder along the link's z, 0 to 0.4
    axis_end = p["upper"] + R["upper"] @ [0, 0, 0.4]
    assert _segment_distance(upper, p["upper"], axis_end).max() == pytest.approx(0.05, abs=1e-6)
    assert np.linalg.norm(upper - axis_end, axis=1).min() < 0.051
    fore = _world(figure, shapes["fore", "box"])  # corners of the box at its origin, turned by its rpy
    local = (fore - p["fore"]) @ R["fore"] - [0, 0, 0.15]
    turned = local @ quaternion_matrix([np.cos(0.15), np.sin(0.15), 0, 0], "wxyz")
    assert np.allclose(np.abs(turned), [0.04, 0.03, 0.15], atol=1e-6)
    hand = _world(figure, shapes["hand", "mesh"])  # a DAE sphere of radius 0.03, scaled 2x
    assert np.allclose(np.linalg.norm(hand - p["hand"], axis=1), 0.06, atol=1e-6)
    capsule = _world(figure, shapes["hand", "capsule"])  # the missing mesh: the bone from hand to tool
    assert _segment_distance(capsule, p["hand"], p["tool"]).max() > 0
    assert shapes["base", "mesh"].colour == (128, 128, 128) and shapes["fore", "box"].colour == (255, 0, 0)
    assert shapes["upper", "mesh"].colour == COLOURS["bone"]


def test_a_robot_without_visuals_gets_capsules_along_its_links(tmp_path):
    path = tmp_path / "bare.urdf"
    path.write_text(MESH_ROBOT.replace("<visual>", "<!--").replace("</visual>", "-->"))
    arm = deik.read_urdf(path)
    figure = figure_from_poses(arm, arm.reference)
    body = robot_body(path, figure)
    assert {s.kind for s in body.shapes} == {"capsule"} and len(body.shapes) == len(bones(figure.parents))
    assert "no visual geometry" in body.note


def test_a_character_is_capsules_around_its_bones_thick_by_mass_and_coloured_by_side():
    human = deik.humanoid()
    poses = random_poses(human, 2, seed=3) * 0.3 + human.reference * 0.7
    figure = figure_from_poses(human, poses)
    body = character_body(human, figure)
    pairs = bones(figure.parents)
    assert len(body.shapes) == len(pairs) and "segment masses" in body.note
    radii = {}
    for shape, (start, end) in zip(body.shapes, pairs):
        assert shape.frame == start
        for step in range(2):  # the capsule moves with its bone
            world = _world(figure, shape, step)
            a, b = figure.positions[step, start], figure.positions[step, end]
            distance = _segment_distance(world, a, b)
            assert np.ptp(distance) < 1e-6  # a capsule: every surface point at one distance from the bone
            radii[figure.names[end]] = float(distance.mean())
        side = bone_side(figure.names[end]) or bone_side(figure.names[start]) or "bone"
        assert shape.colour == COLOURS[side]
    assert radii["left_knee"] > 1.5 * radii["left_elbow"]  # a thigh (8 cm) is thicker than an upper arm (4 cm)
    assert radii["left_knee"] == pytest.approx(radii["right_knee"])
    assert min(radii.values()) >= MIN_RADIUS * body_height(figure) - 1e-9
