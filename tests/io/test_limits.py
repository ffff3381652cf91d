"""Joint limits tables: applied to a skeleton, read and written, measured from a clip, and used
by `deik solve`, `deik clip` and problem files, with errors that name the file and the DOF."""

import dataclasses
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


@pytest.mark.shared_data
@pytest.mark.parametrize("name", ["dance_a", "walk"])
def test_a_table_measured_from_a_clip_holds_that_clip_in_clip_and_solve(tmp_path, capsys, name):
    """`deik limits` measures the values as written; `deik clip` checked them after writing the
    first frame's Euler triples nearest 0, so the shared dance (a shoulder at 46 degrees read as
    its twin at 134) was refused by its own table; with --margin 0 the table, rounded to 6
    decimals, cut a frame's own value off and `deik solve --frame` refused it."""
    clip_path = shared_path("humanoid", f"humanoid3d_{name}.bvh")
    for margin in ("10", "0"):
        table = tmp_path / f"limits_{margin}.json"
        assert main(["limits", str(clip_path), "--margin", margin, "--out", str(table)]) == 0
        out = tmp_path / f"fixed_{margin}.bvh"
        assert main(["clip", str(clip_path), "--limits", str(table), "--out", str(out), "--quiet"]) == 0, (
            capsys.readouterr().err
        )
        clip = read_bvh(clip_path)
        narrowed = with_limits(clip.skeleton, read_limits(table, clip.skeleton))
        poses = clip.poses()
        assert ((poses >= narrowed.lower) & (poses <= narrowed.upper)).all()  # outward rounding keeps every value
        for frame in (0, clip.n_frames // 2, clip.n_frames - 1):
            argv = ["solve", str(clip_path), "--frame", str(frame), "--limits", str(table), "--generations", "20"]
            assert main([*argv, "--reach", "LeftElbow_end", "0.3", "1.0", "0.3", "--quiet"]) == 0, (
                capsys.readouterr().err
            )


def _procedural_walk(tmp_path):
    """The procedural walk (judging/walk.py) as a BVH file: (its path, the Clip)."""
    from judging.rigs import format_rig
    from judging.walk import procedural_walk

    path = tmp_path / "walk.bvh"
    path.write_text(format_rig(procedural_walk().rig))
    return path, read_bvh(path)


def test_a_frame_or_start_outside_the_limits_table_names_its_flag(tmp_path, capsys):
    """The refusal named only "seed pose DOF ...", neither --frame nor --limits."""
    clip_path, clip = _procedural_walk(tmp_path)
    knee = clip.skeleton.dof_names.index("LeftKnee.Zrotation")
    value = np.degrees(clip.poses()[5, knee])
    table = tmp_path / "tight.json"
    table.write_text(json.dumps({"LeftKnee.Zrotation": [value + 1, value + 2]}))
    argv = [
        "solve",
        str(clip_path),
        "--frame",
        "5",
        "--limits",
        str(table),
        "--reach",
        "LeftAnkle_end",
        "0.3",
        "1",
        "0.3",
    ]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    said = f"deik: error: --frame 5: DOF 'LeftKnee.Zrotation' = {value:.4g} degrees lies outside --limits {table}"
    assert err.startswith(said), err


def test_the_first_frame_keeps_its_written_euler_values_where_its_twin_leaves_the_limits(tmp_path):
    """canonical_frames writes a first frame's triple nearest 0, unless that twin lies outside
    the skeleton's limits and the values as written do not."""
    from deik.io.euler import canonical_frames

    sk = _procedural_walk(tmp_path)[1].skeleton
    chest = [d for d, n in enumerate(sk.dof_names) if n.startswith("Chest.") and "rotation" in n]
    frames = np.zeros((3, sk.n_dofs))
    frames[:, chest] = np.radians([170.0, 40.0, 170.0])  # its twin (-10, 140, -10) lies nearer 0
    free = canonical_frames(sk, frames)
    assert np.allclose(np.degrees(free[0, chest]), [-10.0, 140.0, -10.0])
    lower, upper = sk.lower.copy(), sk.upper.copy()
    lower[chest], upper[chest] = np.radians([150.0, 30.0, 150.0]), np.radians([180.0, 50.0, 180.0])
    limited = canonical_frames(dataclasses.replace(sk, lower=lower, upper=upper), frames)
    assert np.allclose(limited, frames)
