"""The 3-D view's scene, as arrays: a clip's figure is forward kinematics of every frame, a pose
JSON draws the same figure as its skeleton in its pose, a clip report marks each contact's plant
exactly over its frames and each reach target over its own, and mismatched inputs are refused."""

import json

import numpy as np
import pytest

import deik
from deik.cli.app import main
from deik.io.pose_json import read_pose_json
from deik.viz.marks import goal_targets
from deik.viz.report_marks import read_clip_report, with_clip_report
from deik.viz.scene import Scene, figure_from_pose_file, figure_from_poses, target_marks, with_compare
from helpers import random_poses, robot_arm


def _scene(figure, **fields):
    return Scene("test", figure, np.array([0.0, 1.0, 0.0]), "m", "given", **fields)


def test_a_pose_file_draws_what_its_skeleton_draws_in_that_pose(tmp_path):
    arm = robot_arm()
    targets = np.array([[0.3, 0.2, 0.5], [0.1, -0.3, 0.6], [0.2, 0.2, 0.4]])
    problem = deik.Problem(arm, [deik.Position("tool", targets), deik.Obstacle((0.2, 0, 0.3), 0.05)])
    result = deik.solve(problem, population=24, generations=20, seed=3)
    path = tmp_path / "pose.json"
    path.write_text(json.dumps({**result.to_dict(), "targets": goal_targets(problem)}))
    pose = read_pose_json(path)
    from_file, from_skeleton = figure_from_pose_file(pose), figure_from_poses(arm, result.angles)
    assert from_file.names == from_skeleton.names and np.array_equal(from_file.parents, from_skeleton.parents)
    assert np.allclose(from_file.positions, from_skeleton.positions, atol=1e-12)
    assert np.allclose(from_file.quaternions_wxyz, from_skeleton.quaternions_wxyz, atol=1e-12)
    assert np.allclose(from_file.com, from_skeleton.com, atol=1e-12)
    marks, obstacles = target_marks(pose.targets, 3)
    (target,) = marks
    assert target.kind == "target" and target.labels == ("position tool",) and np.allclose(target.points[:, 0], targets)
    assert len(obstacles) == 1 and np.allclose(obstacles[0][0], [[0.2, 0, 0.3]] * 3) and obstacles[0][1] == 0.05


def test_a_pose_file_without_its_tree_says_how_to_view_it(tmp_path):
    path = tmp_path / "old.json"
    path.write_text(json.dumps({"angles": [0.1, 0.2], "dof_names": ["a", "b"]}))
    with pytest.raises(ValueError, match=r"has no world frames to draw; .*`deik view SKELETON --pose"):
        figure_from_pose_file(read_pose_json(path))


def test_compare_holds_a_single_pose_still_and_refuses_other_lengths():
    arm = robot_arm()
    clip = figure_from_poses(arm, random_poses(arm, 5, seed=1))
    scene = with_compare(_scene(clip, step="frame"), figure_from_poses(arm, arm.reference), "--compare rest")
    assert scene.compare.positions.shape == clip.positions.shape
    assert np.allclose(scene.compare.positions, scene.compare.positions[0])
    with pytest.raises(ValueError, match=r"--compare other: has 3 frames, the viewed file 5"):
        with_compare(
            _scene(clip, step="frame"), figure_from_poses(arm, random_poses(arm, 3, seed=2)), "--compare other"
        )


@pytest.mark.shared_data
def test_a_clip_report_marks_contacts_and_reach_over_their_frames(tmp_path, shared_data):
    walk = shared_data / "humanoid" / "humanoid3d_walk.bvh"
    fixed, report = tmp_path / "fixed.bvh", tmp_path / "report.json"
    argv = ["clip", str(walk), "--reach", "RightElbow_end=1.04,0.96,0.28@20:28", "--out", str(fixed)]
    assert main([*argv, "--json", str(report), "--quiet"]) == 0
    clip = deik.read_bvh(fixed)
    figure = figure_from_poses(clip.skeleton, clip.poses())
    kin = deik.forward_kinematics(clip.skeleton, clip.poses())
    assert figure.positions.shape == (39, clip.skeleton.n_frames, 3)
    assert np.allclose(figure.positions, kin.p_world_frame) and np.allclose(figure.com, kin.p_world_com)
    document = read_clip_report(report)
    scene = with_clip_report(_scene(figure, step="frame", step_time=clip.frame_time), document, report)
    contacts, reach = scene.marks
    assert contacts.kind == "contact" and reach.kind == "target" and reach.labels == ("reach RightElbow_end",)
    for k, entry in enumerate(document["contacts"]["sites"]):
        touching = np.zeros(39, bool)
        for c in entry["contacts"]:
            touching[c["first_frame"] : c["last_frame"] + 1] = True
            assert np.allclose(contacts.points[c["first_frame"], k], c["plant"])
        assert np.array_equal(np.isfinite(contacts.points[:, k]).all(axis=1), touching)
    assert np.flatnonzero(np.isfinite(reach.points[:, 0, 0])).tolist() == list(range(20, 29))
    assert np.allclose(reach.points[20:29, 0], [1.04, 0.96, 0.28])
    assert scene.floor == pytest.approx(document["floor"]["height"]) and scene.unit == document["length_unit"]
    short = {**document, "frames": 12}
    with pytest.raises(ValueError, match=r"reports a clip of 12 frames, the viewed clip has 39"):
        with_clip_report(scene, short, report)
    bad = {**document, "contacts": {"sites": [{"site": "x", "contacts": [{"first_frame": 30, "last_frame": 50}]}]}}
    with pytest.raises(ValueError, match="must list each site with its contacts"):
        with_clip_report(scene, bad, report)


def test_a_clip_without_frames_shows_its_skeleton_at_rest(tmp_path):
    """`deik view` of a BVH with Frames: 0 (a valid file) stopped with an internal error."""
    from deik.viz.view import view_scene

    path = tmp_path / "still.bvh"
    path.write_text(
        "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n  JOINT Arm\n  {\n"
        "    OFFSET 0 1 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n    End Site\n    {\n      OFFSET 0 1 0\n"
        "    }\n  }\n}\nMOTION\nFrames: 0\nFrame Time: 0.033333\n"
    )
    scene = view_scene(str(path))
    assert scene.n_steps == 1 and any("no frames" in note for note in scene.notes)
    rest = figure_from_poses(deik.read_bvh(path).skeleton, np.zeros(6))
    assert np.allclose(scene.figure.positions, rest.positions)
