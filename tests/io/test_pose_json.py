"""The pose JSON read back: its world frames are forward kinematics of its angles, its tree is the
skeleton's, its targets are the goals', one pose or a batch; every malformed file gets one error
that names it."""

import json

import numpy as np
import pytest

import deik
from deik.cli.app import main
from deik.io.pose_json import pose_angles, read_pose_json
from deik.viz.marks import frame_parents, goal_targets
from helpers import robot_arm

SMALL = dict(population=24, generations=30, seed=2)


def _written(tmp_path, problem, result, name="pose.json"):
    path = tmp_path / name
    path.write_text(json.dumps({**result.to_dict(), "targets": goal_targets(problem), "length_unit": "m"}))
    return path


@pytest.mark.parametrize("batch", [False, True])
def test_frames_tree_and_targets_round_trip(tmp_path, batch):
    arm = robot_arm()
    target = np.array([[0.3, 0.2, 0.5], [0.1, -0.3, 0.6]]) if batch else np.array([0.3, 0.2, 0.5])
    problem = deik.Problem(arm, [deik.Position("tool", target), deik.ComOverSupport((0.0, 0.0, 0.0))])
    result = deik.solve(problem, **SMALL)
    pose = read_pose_json(_written(tmp_path, problem, result))
    angles = np.atleast_2d(result.angles)
    assert pose.batched == batch and np.array_equal(pose.angles, angles)
    kin = deik.forward_kinematics(arm, angles)
    assert pose.frame_names == arm.frame_names and pose.n_joints == arm.n_joints
    assert np.allclose(pose.positions, kin.p_world_frame, atol=1e-12)
    assert np.allclose(pose.centre_of_mass, kin.p_world_com, atol=1e-12)
    assert np.array_equal(pose.parents, frame_parents(arm)) and np.array_equal(pose.up, [0, 0, 1])
    w = pose.quaternions_wxyz[..., 0]
    assert np.allclose(np.linalg.norm(pose.quaternions_wxyz, axis=-1), 1) and (w >= 0).all()
    tool, support = pose.targets
    assert tool["goal"] == "position tool" and np.allclose(tool["position"], np.broadcast_to(target, (len(angles), 3)))
    assert support["kind"] == "support" and pose.length_unit == "m"
    assert np.array_equal(pose_angles(pose, arm, "--pose"), angles)


def test_deik_solve_out_writes_the_target_and_the_unit(tmp_path, capsys):
    out = tmp_path / "pose.json"
    argv = ["solve", "humanoid", "--reach", "left_hand", "0.4", "1.2", "0.35", "--out", str(out)]
    assert main([*argv, "--population", "24", "--generations", "30", "--seed", "1"]) == 0
    pose = read_pose_json(out)
    assert pose.length_unit == "m" and pose.targets[0]["goal"] == "position left_hand"
    assert np.allclose(pose.targets[0]["position"], [[0.4, 1.2, 0.35]])
    human = deik.humanoid()
    assert np.allclose(pose.positions, deik.forward_kinematics(human, pose.angles).p_world_frame)


def test_a_pose_of_another_skeleton_is_refused(tmp_path):
    problem = deik.Problem(deik.chain(3, dims=3), [deik.Position("tip", (1, 1, 1))])
    pose = read_pose_json(_written(tmp_path, problem, deik.solve(problem, **SMALL)))
    with pytest.raises(ValueError, match=r"--pose .*: its angles hold 6 values, the skeleton has 5 DOFs"):
        pose_angles(pose, deik.chain(5), "--pose")
    with pytest.raises(ValueError, match=r"its dof_names .* are not this skeleton's .* same skeleton, base and tips"):
        pose_angles(pose, deik.chain(6), "--pose")


def _broken(data):
    data["parents"]["link1"] = None  # a second root
    return data


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda d: "not json{", "not valid JSON"),
        (lambda d: [1, 2], 'has no "angles"'),
        (lambda d: {**d, "angles": ["a"]}, '"angles" must be finite numbers'),
        (lambda d: {**d, "dof_names": ["one"]}, '"dof_names" must list one name per angle'),
        (_broken, '"parents" must have exactly one root'),
        (lambda d: {**d, "parents": {"link0": None}}, '"parents" must name the parent of every joint and site'),
        (lambda d: {**d, "joints": {**d["joints"], "link0": {"position": [0, 0]}}}, 'needs a "position" and a'),
        (lambda d: {**d, "centre_of_mass": [0, "x", 1]}, '"centre_of_mass" must hold numbers'),
        (lambda d: {**d, "targets": [{"goal": "g", "kind": "target", "position": [1, 2]}]}, "target of 'g' must be"),
    ],
)
def test_malformed_pose_files_name_the_file_and_the_fix(tmp_path, edit, message):
    problem = deik.Problem(deik.chain(3, dims=3), [deik.Position("tip", (1, 1, 1))])
    data = json.loads(_written(tmp_path, problem, deik.solve(problem, **SMALL)).read_text())
    bad = tmp_path / "bad.json"
    edited = edit(data)
    bad.write_text(edited if isinstance(edited, str) else json.dumps(edited))
    with pytest.raises(ValueError, match=message) as caught:
        read_pose_json(bad)
    assert str(bad) in str(caught.value)
