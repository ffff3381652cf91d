"""`deik solve` and `deik info` on real files: URDF robots posed to reachable targets (FK of
random in-limit poses), BVH clip frames, and the errors users meet first."""

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import deik
from deik.cli.app import main
from deik.io.urdf import read_urdf
from deik.model.joints import ROTATE

ROBOT_CHAINS = {  # robot: (base, tip, up)
    "panda": ("panda_link0", "panda_hand_tcp", None),
    "kuka_iiwa": ("lbr_iiwa_link_0", "lbr_iiwa_link_7", None),
    "human": ("middle_pelvis", "left_hand", ("0", "1", "0")),
}


def _target(path, base, tip, seed):
    sk = read_urdf(path, base, tip)
    q = np.random.default_rng(seed).uniform(sk.lower, sk.upper)
    kin = deik.forward_kinematics(sk, q)
    return sk, kin.position(tip), Rotation.from_matrix(kin.rotation(tip))


# each robot's --orient in another form, its numbers read from scipy's Rotation
ORIENT_FORMS = {
    "panda": ("rpy", lambda r: np.degrees(r.as_euler("xyz"))),  # URDF roll, pitch, yaw (fixed axes)
    "kuka_iiwa": ("quat-wxyz", lambda r: r.as_quat()[[3, 0, 1, 2]]),
    "human": ("xyz", lambda r: np.degrees(r.as_euler("XYZ"))),  # intrinsic
}


@pytest.mark.parametrize("robot", sorted(ROBOT_CHAINS))
def test_cli_poses_urdf_chain_to_a_reachable_pose(shared_data, tmp_path, capsys, robot):
    base, tip, up = ROBOT_CHAINS[robot]
    path = shared_data / "robots" / f"{robot}.urdf"
    sk, xyz, rotation = _target(path, base, tip, seed=7)
    form, numbers = ORIENT_FORMS[robot]
    out = tmp_path / "pose.json"
    argv = [
        "solve",
        "--skeleton",
        str(path),
        "--base",
        base,
        "--tip",
        tip,
        "--reach",
        tip,
        *map(str, xyz),
        "--orient",
        tip,
        form,
        *map(str, numbers(rotation)),
        "--tolerance",
        "0.001",
        "--angle-tolerance",
        "0.5",
        "--seed",
        "0",
        "--generations",
        "4000",
        "--population",
        "64",
        "--out",
        str(out),
    ] + (["--up", *up] if up else [])
    assert main(argv) == 0, capsys.readouterr().err
    data = json.loads(out.read_text())
    assert data["dof_names"] == list(sk.dof_names)
    q = np.array(data["angles"])
    assert np.all(q >= sk.lower) and np.all(q <= sk.upper)
    kin = deik.forward_kinematics(sk, q)
    assert np.linalg.norm(kin.position(tip) - xyz) <= 0.001
    assert Rotation.from_matrix(kin.rotation(tip).T @ rotation.as_matrix()).magnitude() <= np.radians(0.5)
    assert list(data["angles_by_joint"]) == list(sk.dof_names)  # URDF joint names, as dof_names


def test_info_on_every_shared_file(shared_data, capsys):
    files = sorted(shared_data.glob("robots/*.urdf")) + sorted(shared_data.glob("humanoid/*.bvh"))
    assert {p.name for p in files} >= {"panda.urdf", "kuka_iiwa.urdf", "human.urdf", "humanoid3d_walk.bvh"}
    for path in files:
        assert main(["info", str(path)]) == 0, capsys.readouterr().err
        text = capsys.readouterr().out
        sk = deik.io.load.load_skeleton(str(path)).skeleton
        assert f"{sk.n_joints} joints, {sk.n_dofs} DOFs" in text
        for name in sk.dof_names:
            assert name in text
        assert "mass:" in text


def test_info_lists_the_ball_joints_of_the_pybullet_source(shared_data, capsys):
    assert main(["info", "--quiet", str(shared_data / "humanoid" / "humanoid_deepmimic_source.urdf")]) == 0
    out = capsys.readouterr().out
    assert "13 joints, 28 DOFs" in out
    for joint in ("chest", "neck", "right_hip", "left_ankle", "right_shoulder"):
        assert all(f"{joint}.{axis}rotation" in out for axis in "ZXY")


@pytest.mark.parametrize(
    "argv,fragment",
    [
        (
            [
                "solve",
                "--skeleton",
                "{robots}/panda.urdf",
                "--tip",
                "panda_hnd",
                "--reach",
                "panda_hand",
                "0",
                "0",
                "0.5",
            ],
            "tip link 'panda_hnd' is not in",
        ),
        (
            ["solve", "--skeleton", "{robots}/panda.urdf", "--frame", "3", "--reach", "panda_hand", "0", "0", "0.5"],
            "--frame only applies to a BVH clip",
        ),
        (["solve", "chain:3", "--base", "a", "--reach", "tip", "1", "0", "0"], "--base only apply to a URDF robot"),
        (
            [
                "solve",
                "--skeleton",
                "{robots}/panda.urdf",
                "--segments",
                "x.json",
                "--reach",
                "panda_hand",
                "0",
                "0",
                "0.5",
            ],
            "--segments only applies to a BVH character",
        ),
        (
            [
                "solve",
                "--skeleton",
                "{robots}/panda.urdf",
                "--reach",
                "panda_hand",
                "0",
                "0",
                "0.5",
                "--out",
                "pose.txt",
            ],
            "must end in .json or .bvh",
        ),
        (["solve", "--skeleton", "{robots}/nothere.urdf", "--reach", "a", "0", "0", "0"], "no such URDF file"),
        (["info", "{robots}/panda.urdf", "--tip", "panda_link3", "--base", "panda_link5"], "is not below base link"),
    ],
)
def test_file_cli_mistakes_exit_2_with_one_line(shared_data, tmp_path, monkeypatch, capsys, argv, fragment):
    monkeypatch.chdir(tmp_path)
    argv = [a.format(robots=shared_data / "robots") for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("deik: error: ") and err.count("\n") == 1 and fragment in err, err
    assert list(tmp_path.iterdir()) == []


def _clip_target(path, frame, seed):
    """Left-hand position after moving the left arm of `frame` by up to 0.4 rad per DOF."""
    from deik.io.bvh import read_bvh

    clip = read_bvh(path)
    sk = clip.skeleton
    pose = clip.pose(frame)
    arm = [d for d, name in enumerate(sk.dof_names) if name.startswith(("LeftShoulder.", "LeftElbow.Z"))]
    pose[arm] += np.random.default_rng(seed).uniform(-0.4, 0.4, len(arm))
    return clip, deik.forward_kinematics(sk, pose).position("LeftElbow_end")


def test_cli_poses_a_bvh_frame_and_writes_the_clip_with_only_that_frame_changed(shared_data, tmp_path, capsys):
    from deik.io.bvh import read_bvh

    path = shared_data / "humanoid" / "humanoid3d_walk.bvh"
    clip, target = _clip_target(path, 12, seed=1)
    out = tmp_path / "fixed.bvh"
    argv = [
        "solve",
        "--skeleton",
        str(path),
        "--frame",
        "12",
        "--reach",
        "LeftElbow_end",
        *map(str, target),
        "--tolerance",
        "0.005",
        "--comfort",
        "0.3",
        "--generations",
        "500",
        "--seed",
        "0",
        "--out",
        str(out),
    ]
    assert main(argv) == 0, capsys.readouterr().err
    assert "comfort keeps the pose near frame" not in capsys.readouterr().err  # --comfort was given
    original, fixed = path.read_text().splitlines(), out.read_text().splitlines()
    motion = original.index("MOTION") + 3
    assert fixed[:motion] == original[:motion]  # hierarchy, frame count and time unchanged
    changed = [k for k, (a, b) in enumerate(zip(original[motion:], fixed[motion:])) if a != b]
    assert changed == [12]
    solved = read_bvh(out)
    kin = deik.forward_kinematics(solved.skeleton, solved.frames[12])
    assert np.linalg.norm(kin.position("LeftElbow_end") - target) <= 0.005
    # Euler channels stay continuous: no channel jumps by a half turn against the original frame
    assert np.abs(solved.frames[12] - clip.frames[12]).max() < np.pi


@pytest.mark.parametrize("clip_name", ["walk", "run", "jump"])
def test_cli_bvh_frame_to_json_records_the_frame(shared_data, tmp_path, capsys, clip_name):
    path = shared_data / "humanoid" / f"humanoid3d_{clip_name}.bvh"
    clip, target = _clip_target(path, 3, seed=2)
    out = tmp_path / "pose.json"
    argv = [
        "solve",
        str(path),
        "--frame",
        "3",
        "--reach",
        "LeftElbow_end",
        *map(str, target),
        "--segments",
        str(path.with_suffix(".segments.json")),
        "--generations",
        "300",
        "--out",
        str(out),
    ]
    assert main(argv) == 0
    assert "comfort keeps the pose near frame 3" in capsys.readouterr().err
    data = json.loads(out.read_text())
    assert data["frame"] == 3 and len(data["angles"]) == clip.skeleton.n_dofs
    hand = deik.forward_kinematics(clip.skeleton, np.array(data["angles"])).position("LeftElbow_end")
    assert np.linalg.norm(hand - target) <= 0.01 * clip.skeleton.reach  # the default tolerance


@pytest.mark.parametrize(
    "extra,fragment",
    [
        ([], "choose one with --frame N"),
        (["--frame", "39"], "frame 39 is out of range; valid frames: 0..38"),
        (["--frame", "2", "--base", "Hips"], "--base only apply to a URDF robot"),
        (["--frame", "2", "--segments", "{data}/robots/panda.urdf"], "panda.urdf"),
    ],
)
def test_bvh_cli_mistakes_exit_2_and_write_nothing(shared_data, tmp_path, capsys, extra, fragment):
    argv = [
        "solve",
        "--skeleton",
        str(shared_data / "humanoid" / "humanoid3d_walk.bvh"),
        "--reach",
        "LeftElbow_end",
        "0.3",
        "0.9",
        "0",
        "--out",
        str(tmp_path / "x.bvh"),
    ]
    assert main(argv + [e.format(data=shared_data) for e in extra]) == 2
    err = capsys.readouterr().err
    assert err.startswith("deik: error: ") and err.count("\n") == 1 and fragment in err, err
    assert list(tmp_path.iterdir()) == []


def test_urdf_pose_cannot_be_written_as_bvh(shared_data, tmp_path, capsys):
    path = shared_data / "robots" / "kuka_iiwa.urdf"
    out = tmp_path / "pose.bvh"
    argv = [
        "solve",
        str(path),
        "--reach",
        "lbr_iiwa_link_7",
        "0.3",
        "0.2",
        "0.8",
        "--generations",
        "50",
        "--out",
        str(out),
    ]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "has a fixed rest rotation, which BVH cannot carry" in err or "not a coordinate axis" in err, err
    assert list(tmp_path.iterdir()) == []


def test_builtin_humanoid_pose_written_as_bvh_reads_back(tmp_path, capsys):
    from deik.io.bvh import read_bvh

    out = tmp_path / "pose.bvh"
    assert (
        main(
            [
                "solve",
                "humanoid",
                "--reach",
                "left_hand",
                "0.4",
                "1.2",
                "0.35",
                "--generations",
                "60",
                "--seed",
                "2",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    clip = read_bvh(out)
    assert clip.n_frames == 1
    assert "position left_hand" in capsys.readouterr().out
    sk = deik.humanoid()
    assert set(clip.skeleton.joint_names) == set(sk.joint_names)
    # the written frame puts the hand where the solve did: within the default 1 % of reach
    joint = sk.joint_names[sk.site_joint[sk.site_names.index("left_hand")]]
    siblings = [n for n, j in zip(sk.site_names, sk.site_joint) if sk.joint_names[j] == joint]
    k = siblings.index("left_hand")
    end_site = f"{joint}_end" + (str(k + 1) if k else "")  # BVH End Sites have no names of their own
    hand = deik.forward_kinematics(clip.skeleton, clip.frames[0]).position(end_site)
    assert np.linalg.norm(hand - [0.4, 1.2, 0.35]) <= 0.01 * sk.reach


def test_cli_start_pose_seeds_the_search_and_keeps_the_answer_near_it(shared_data, tmp_path, capsys):
    base, tip, _ = ROBOT_CHAINS["panda"]
    path = shared_data / "robots" / "panda.urdf"
    sk = read_urdf(path, base, tip)
    start = np.random.default_rng(3).uniform(sk.lower, sk.upper)
    moved = np.clip(start + 0.1, sk.lower, sk.upper)
    target = deik.forward_kinematics(sk, moved).position(tip)  # a nearby pose reaches it
    first = tmp_path / "start.json"
    assert (
        main(
            [
                "solve",
                "--skeleton",
                str(path),
                "--base",
                base,
                "--tip",
                tip,
                "--reach",
                tip,
                *map(str, deik.forward_kinematics(sk, start).position(tip)),
                "--start",
                *map(str, np.where(sk.dof_kind == ROTATE, np.degrees(start), start)),  # degrees at the CLI
                "--tolerance",
                "0.0001",
                "--out",
                str(first),
            ]
        )
        == 0
    )
    assert "near the --start pose" in capsys.readouterr().err
    out = tmp_path / "pose.json"
    argv = [
        "solve",
        "--skeleton",
        str(path),
        "--base",
        base,
        "--tip",
        tip,
        "--reach",
        tip,
        *map(str, target),
        "--tolerance",
        "0.0001",
        "--start",
        str(first),
        "--seed",
        "1",
        "--out",
        str(out),
    ]
    assert main(argv) == 0, capsys.readouterr().err
    q = np.array(json.loads(out.read_text())["angles"])
    assert np.linalg.norm(deik.forward_kinematics(sk, q).position(tip) - target) <= 1e-4
    assert np.abs(q - start).max() < 0.5  # stays near the start, not any of the arm's other solutions
    for bad, fragment in ((["1", "2"], "needs 7 values"), ([str(tmp_path / "missing.json")], "cannot read a pose")):
        assert (
            main(
                [
                    "solve",
                    "--skeleton",
                    str(path),
                    "--base",
                    base,
                    "--tip",
                    tip,
                    "--reach",
                    tip,
                    *map(str, target),
                    "--start",
                    *bad,
                ]
            )
            == 2
        )
        assert fragment in capsys.readouterr().err


def test_toml_problem_on_a_urdf_robot_relative_to_the_file(shared_data, tmp_path, capsys):
    """skeleton = a URDF path relative to the problem file, with base and tip, solved by the CLI."""
    import shutil

    base, tip, _ = ROBOT_CHAINS["panda"]
    robots = tmp_path / "robots"
    robots.mkdir()
    shutil.copy(shared_data / "robots" / "panda.urdf", robots / "panda.urdf")
    sk, xyz, _ = _target(robots / "panda.urdf", base, tip, seed=11)
    problem = tmp_path / "problems" / "reach.toml"
    problem.parent.mkdir()
    problem.write_text(
        f'skeleton = "../robots/panda.urdf"\nbase = "{base}"\ntip = ["{tip}"]\nup = [0, 0, 1]\n'
        f"[settings]\nseed = 0\npopulation = 32\n"
        f'[[goal]]\ntype = "position"\nframe = "{tip}"\ntarget = {list(map(float, xyz))}\ntolerance = 1e-5\n'
    )
    out = tmp_path / "pose.json"
    assert main(["solve", "--problem", str(problem), "--out", str(out)]) == 0, capsys.readouterr().err
    angles = np.array(json.loads(out.read_text())["angles"])
    assert np.all(angles >= sk.lower) and np.all(angles <= sk.upper)
    assert np.linalg.norm(deik.forward_kinematics(sk, angles).position(tip) - xyz) <= 1e-5


def test_toml_problem_on_a_bvh_frame_writes_the_clip_back(shared_data, tmp_path, capsys):
    """frame = N seeds the search, makes comfort goals keep that frame's pose, and --out x.bvh
    replaces only that frame of the clip."""
    from deik.io.bvh import read_bvh
    from deik.solver.problem_file import load_problem

    path = shared_data / "humanoid" / "humanoid3d_walk.bvh"
    clip, target = _clip_target(path, 5, seed=3)
    problem = tmp_path / "walk.toml"
    problem.write_text(
        f'skeleton = "{path}"\nsegments = "{path.with_suffix(".segments.json")}"\nframe = 5\n'
        f"[settings]\nseed = 1\ngenerations = 300\n"
        f'[[goal]]\ntype = "position"\nframe = "LeftElbow_end"\ntarget = {list(map(float, target))}\n'
        f'[[goal]]\ntype = "comfort"\nweight = 0.1\nlevel = 1\n'
    )
    loaded = load_problem(problem)
    assert loaded.frame == 5 and loaded.loaded.kind == "bvh"
    np.testing.assert_array_equal(loaded.problem.reference[0, 1], clip.pose(5))  # comfort: near frame 5
    out = tmp_path / "walk_fixed.bvh"
    assert main(["solve", "--problem", str(problem), "--out", str(out)]) == 0, capsys.readouterr().err
    assert "masses" in capsys.readouterr().err
    solved = read_bvh(out)
    changed = np.flatnonzero(np.abs(solved.frames - clip.frames).max(axis=1) > 1e-6)
    assert changed.tolist() == [5]
    hand = deik.forward_kinematics(clip.skeleton, solved.pose(5)).position("LeftElbow_end")
    assert np.linalg.norm(hand - target) <= 0.01 * clip.skeleton.reach  # the default tolerance


@pytest.mark.parametrize(
    "lines, fragment",
    [
        (
            'skeleton = "chain:3"\nbase = "link0"\n',
            "field 'base' only applies to a URDF robot, not skeleton = 'chain:3'",
        ),
        ('skeleton = "{data}/robots/panda.urdf"\nframe = 2\n', "field 'frame' only applies to a BVH clip"),
        (
            'skeleton = "{data}/humanoid/humanoid3d_walk.bvh"\nframe = 39\n',
            "field 'frame' must be a frame number from 0 to 38",
        ),
        ('skeleton = "{data}/robots/panda.urdf"\ntip = 3\n', "field 'tip' must be a link name or a list of link names"),
        ('skeleton = "{data}/robots/panda.urdf"\ntip = "panda_hnd"\n', "field 'skeleton'"),
        ('skeleton = "missing.urdf"\n', "field 'skeleton'"),
    ],
)
def test_toml_skeleton_file_errors_name_the_field(shared_data, tmp_path, lines, fragment):
    from deik.solver.problem_file import load_problem

    problem = tmp_path / "bad.toml"
    problem.write_text(lines.format(data=shared_data) + '[[goal]]\ntype = "comfort"\n')
    with pytest.raises(ValueError) as caught:
        load_problem(problem)
    assert str(caught.value).startswith(str(problem)) and fragment in str(caught.value)
