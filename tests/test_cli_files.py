"""`deik solve` and `deik info` on real files: URDF robots posed to reachable targets (FK of
random in-limit poses), BVH clip frames, and the errors users meet first."""

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import deik
from deik.cli import main
from deik.io.urdf import read_urdf

ROBOT_CHAINS = {  # robot: (base, tip, up)
    "panda": ("panda_link0", "panda_hand_tcp", None),
    "kuka_iiwa": ("lbr_iiwa_link_0", "lbr_iiwa_link_7", None),
    "human": ("middle_pelvis", "left_hand", ("0", "1", "0")),
}


def _target(path, base, tip, seed):
    sk = read_urdf(path, base, tip)
    q = np.random.default_rng(seed).uniform(sk.lower, sk.upper)
    kin = deik.forward_kinematics(sk, q)
    xyz = kin.position(tip)
    angles = np.degrees(Rotation.from_matrix(kin.rotation(tip)).as_euler("XYZ"))
    return sk, xyz, angles


@pytest.mark.parametrize("robot", sorted(ROBOT_CHAINS))
def test_cli_poses_urdf_chain_to_a_reachable_pose(shared_data, tmp_path, capsys, robot):
    base, tip, up = ROBOT_CHAINS[robot]
    path = shared_data / "robots" / f"{robot}.urdf"
    sk, xyz, angles = _target(path, base, tip, seed=7)
    out = tmp_path / "pose.json"
    argv = ["solve", "--skeleton", str(path), "--base", base, "--tip", tip,
            "--reach", tip, *map(str, xyz), "--orient", tip, *map(str, angles),
            "--tolerance", "0.001", "--angle-tolerance", "0.5", "--seed", "0", "--generations", "4000", "--population", "512",
            "--out", str(out)] + (["--up", *up] if up else [])
    assert main(argv) == 0, capsys.readouterr().err
    data = json.loads(out.read_text())
    assert data["dof_names"] == list(sk.dof_names)
    q = np.array(data["angles"])
    assert np.all(q >= sk.lower) and np.all(q <= sk.upper)
    kin = deik.forward_kinematics(sk, q)
    assert np.linalg.norm(kin.position(tip) - xyz) <= 0.001
    target = Rotation.from_euler("XYZ", np.radians(angles)).as_matrix()
    assert Rotation.from_matrix(kin.rotation(tip).T @ target).magnitude() <= np.radians(0.5)


def test_info_on_every_shared_file(shared_data, capsys):
    files = sorted(shared_data.glob("robots/*.urdf")) + sorted(shared_data.glob("humanoid/*.bvh"))
    assert len(files) == 6
    for path in files:
        assert main(["info", str(path)]) == 0, capsys.readouterr().err
        text = capsys.readouterr().out
        sk = deik.io.load.load_skeleton(str(path)).skeleton
        assert f"{sk.n_joints} joints, {sk.n_dofs} DOFs" in text
        for name in sk.dof_names:
            assert name in text
        assert "mass:" in text


def test_info_refuses_the_pybullet_only_source_with_its_line(shared_data, capsys):
    assert main(["info", str(shared_data / "humanoid" / "humanoid_deepmimic_source.urdf")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "joint type 'spherical' is not supported" in err and ".urdf:" in err


@pytest.mark.parametrize("argv,fragment", [
    (["solve", "--skeleton", "{robots}/panda.urdf", "--tip", "panda_hnd", "--reach", "panda_hand", "0", "0", "0.5"],
     "tip link 'panda_hnd' is not in"),
    (["solve", "--skeleton", "{robots}/panda.urdf", "--frame", "3", "--reach", "panda_hand", "0", "0", "0.5"],
     "--frame only applies to a BVH clip"),
    (["solve", "chain:3", "--base", "a", "--reach", "tip", "1", "0", "0"], "--base only apply to a URDF robot"),
    (["solve", "--skeleton", "{robots}/panda.urdf", "--segments", "x.json", "--reach", "panda_hand", "0", "0", "0.5"],
     "--segments only applies to a BVH character"),
    (["solve", "--skeleton", "{robots}/panda.urdf", "--reach", "panda_hand", "0", "0", "0.5", "--out", "pose.txt"],
     "must end in .json or .bvh"),
    (["solve", "--skeleton", "{robots}/nothere.urdf", "--reach", "a", "0", "0", "0"], "no such URDF file"),
    (["info", "{robots}/panda.urdf", "--tip", "panda_link3", "--base", "panda_link5"], "is not below base link"),
])
def test_file_cli_mistakes_exit_2_with_one_line(shared_data, tmp_path, monkeypatch, capsys, argv, fragment):
    monkeypatch.chdir(tmp_path)
    argv = [a.format(robots=shared_data / "robots") for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("deik: error: ") and err.count("\n") == 1 and fragment in err, err
    assert list(tmp_path.iterdir()) == []
