"""Joint limits tables: applied to a skeleton, read and written, measured from a clip, and used
by `deik solve`, `deik clip` and problem files, with errors that name the file and the DOF."""

import json
import math

import numpy as np
import pytest

import deik
from deik.cli.app import main
from deik.io.bvh import read_bvh
from deik.io.limits import clip_within, range_of_motion, read_limits, with_limits, write_limits
from deik.solver.problem_file import load_problem
from helpers import shared_path


def walk():
    return read_bvh(shared_path("humanoid", "humanoid3d_walk.bvh"))


def test_with_limits_changes_only_the_named_dofs():
    sk = deik.chain(3)
    narrowed = with_limits(sk, {"link1.Zrotation": (-0.5, 0.25)})
    d = sk.dof_names.index("link1.Zrotation")
    assert (narrowed.lower[d], narrowed.upper[d]) == (-0.5, 0.25)
    keep = np.arange(sk.n_dofs) != d
    np.testing.assert_array_equal(narrowed.lower[keep], sk.lower[keep])
    assert sk.lower[d] == -math.pi  # the original skeleton is untouched
    with pytest.raises(KeyError, match="did you mean 'link1.Zrotation'"):
        with_limits(sk, {"link1.Zrotaton": (0, 1)})
    with pytest.raises(ValueError, match="'link1.Zrotation': limits must be finite with lower <= upper"):
        with_limits(sk, {"link1.Zrotation": (1, 0)})


@pytest.mark.shared_data
def test_limits_table_uses_degrees_for_rotations_and_lengths_for_translations(tmp_path):
    sk = walk().skeleton
    path = tmp_path / "limits.json"
    path.write_text(json.dumps({"LeftKnee.Zrotation": [-150, 0], "Hips.Xposition": [-2, 2]}))
    limits = read_limits(path, sk)
    assert limits["LeftKnee.Zrotation"] == pytest.approx((math.radians(-150), 0.0))
    assert limits["Hips.Xposition"] == (-2.0, 2.0)
    out = tmp_path / "again.json"
    write_limits(out, sk, limits)
    again = read_limits(out, sk)
    assert again.keys() == limits.keys()
    for name in limits:
        assert again[name] == pytest.approx(limits[name], abs=1e-7)  # degrees written to 6 decimals


@pytest.mark.shared_data
@pytest.mark.parametrize(
    "text, fragment",
    [
        ("[1, 2]", "must be a JSON object"),
        ('{"LeftKnee.Zrotation": [0]}', "LeftKnee.Zrotation: must be [lower, upper]"),
        ('{"LeftKnee.Zrotation": [0, 1e999]}', "LeftKnee.Zrotation[1]: must be a finite number"),
        ('{"LeftKnee.Zrotation": [0, 1%s]}' % ("0" * 400), "LeftKnee.Zrotation[1]: must be a finite number"),
        ('{"LeftKnee.Zrotation": [0, 1%s]}' % ("0" * 5000), "not a limits (JSON) file: Exceeds the limit"),
        ('{"LeftKnee.Zrotation": [10, -10]}', "lower <= upper"),
        ('{"LeftKnee.Zrotaton": [0, 10]}', "did you mean 'LeftKnee.Zrotation'"),
        ('{"LeftKnee.Zrotation": [0, 10],', "not valid JSON"),
    ],
)
def test_bad_limits_tables_name_the_file_and_the_dof(tmp_path, text, fragment):
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises((ValueError, KeyError)) as caught:
        read_limits(path, walk().skeleton)
    message = caught.value.args[0]
    assert message.startswith(str(path)) and fragment in message


@pytest.mark.shared_data
def test_range_of_motion_holds_every_frame_with_its_margin():
    clip = walk()
    limits = range_of_motion(clip, 10.0, 0.05)
    sk = with_limits(clip.skeleton, limits)
    poses = clip.poses()
    margin = np.where(sk.dof_kind == deik.model.joints.ROTATE, math.radians(10), 0.05)
    np.testing.assert_allclose(sk.lower, np.maximum(poses.min(axis=0) - margin, clip.skeleton.lower))
    np.testing.assert_allclose(sk.upper, np.minimum(poses.max(axis=0) + margin, clip.skeleton.upper))
    assert clip_within(clip, sk, "test").skeleton is sk
    with pytest.raises(ValueError, match="margins must be finite and >= 0"):
        range_of_motion(clip, -1.0)


@pytest.mark.shared_data
def test_clip_outside_the_limits_is_refused_with_frame_and_dof():
    clip = walk()
    d = clip.skeleton.dof_names.index("RightKnee.Zrotation")
    values = clip.poses()[:, d]
    narrowed = with_limits(clip.skeleton, {"RightKnee.Zrotation": (values.min(), values.min() + 0.01)})
    with pytest.raises(ValueError, match=r"frame \d+ has RightKnee.Zrotation = .* outside its limits"):
        clip_within(clip, narrowed, "limits.json")


@pytest.mark.shared_data
def test_cli_limits_then_solve_keeps_the_pose_inside(tmp_path, capsys):
    clip_path = shared_path("humanoid", "humanoid3d_walk.bvh")
    table = tmp_path / "limits.json"
    assert main(["limits", str(clip_path), "--margin", "5", "--out", str(table)]) == 0
    clip = read_bvh(clip_path)
    sk = with_limits(clip.skeleton, read_limits(table, clip.skeleton))
    pose = np.random.default_rng(3).uniform(sk.lower, sk.upper)  # a target the narrowed body can reach
    target = deik.forward_kinematics(sk, pose).position("LeftElbow_end")
    out = tmp_path / "pose.json"
    argv = [
        "solve",
        str(clip_path),
        "--frame",
        "3",
        "--limits",
        str(table),
        "--reach",
        "LeftElbow_end",
        *map(str, target),
        "--seed",
        "1",
        "--out",
        str(out),
    ]
    assert main(argv) == 0, capsys.readouterr().err
    angles = np.array(json.loads(out.read_text())["angles"])
    assert (angles >= sk.lower).all() and (angles <= sk.upper).all()
    assert np.linalg.norm(deik.forward_kinematics(sk, angles).position("LeftElbow_end") - target) <= 0.01 * sk.reach


@pytest.mark.shared_data
def test_cli_clip_refuses_a_table_the_capture_breaks(tmp_path, capsys):
    table = tmp_path / "tight.json"
    table.write_text(json.dumps({"RightKnee.Zrotation": [0, 1]}))
    argv = [
        "clip",
        str(shared_path("humanoid", "humanoid3d_walk.bvh")),
        "--limits",
        str(table),
        "--out",
        str(tmp_path / "w.bvh"),
    ]
    assert main(argv) == 2
    assert "RightKnee.Zrotation" in capsys.readouterr().err and not (tmp_path / "w.bvh").exists()


@pytest.mark.shared_data
def test_problem_file_joint_limits_relative_to_the_file(tmp_path):
    clip_path = shared_path("humanoid", "humanoid3d_walk.bvh")
    (tmp_path / "lim.json").write_text(json.dumps({"LeftElbow.Zrotation": [0, 90]}))
    problem = tmp_path / "p.toml"
    problem.write_text(f'skeleton = "{clip_path}"\njoint_limits = "lim.json"\n[[goal]]\ntype = "comfort"\n')
    sk = load_problem(problem).problem.skeleton
    d = sk.dof_names.index("LeftElbow.Zrotation")
    assert (sk.lower[d], sk.upper[d]) == pytest.approx((0.0, math.pi / 2))
    problem.write_text('skeleton = "chain:3"\njoint_limits = "missing.json"\n[[goal]]\ntype = "comfort"\n')
    with pytest.raises(
        ValueError, match="field 'joint_limits'.*missing.json: no such limits \\(JSON\\) file; check the path"
    ):
        load_problem(problem)
