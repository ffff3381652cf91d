"""`deik solve --orient FRAME FORM ...`: each named form solved to the rotation scipy reads
from the same numbers, degrees for angles; the old unnamed form and bad numbers get one line;
pose.json holds the solved frames' world poses and is read back by --start only for the
skeleton it names."""

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import deik
from deik.cli.app import main

SKELETON = "chain3d:4"
RUN = ["--population", "32", "--dtype", "float64", "--seed", "0"]


def _target(seed):
    sk = deik.chain(4, dims=3)
    kin = deik.forward_kinematics(sk, np.random.default_rng(seed).uniform(sk.lower, sk.upper))
    return sk, kin.position("tip"), Rotation.from_matrix(kin.rotation("tip"))


def _numbers(form, rotation):
    if form == "rpy":
        return np.degrees(rotation.as_euler("xyz"))  # scipy lower case: fixed axes X, Y, Z
    if form == "xyz":
        return np.degrees(rotation.as_euler("XYZ"))  # scipy upper case: intrinsic
    if form == "quat-xyzw":
        return rotation.as_quat()
    if form == "quat-wxyz":
        return rotation.as_quat()[[3, 0, 1, 2]]
    return rotation.as_matrix().ravel()


@pytest.mark.parametrize("form", ["rpy", "xyz", "quat-wxyz", "quat-xyzw", "matrix"])
def test_each_orient_form_reaches_scipys_rotation(tmp_path, capsys, form):
    sk, position, rotation = _target(seed=["rpy", "xyz", "quat-wxyz", "quat-xyzw", "matrix"].index(form))
    out = tmp_path / "pose.json"
    argv = ["solve", SKELETON, "--reach", "tip", *map(str, position), "--orient", "tip", form]
    argv += [*map(repr, _numbers(form, rotation).tolist()), *RUN, "--out", str(out)]
    assert main(argv) == 0, capsys.readouterr().err
    printed = capsys.readouterr().out
    # default tolerances, an angle's in degrees, a chain's length in link lengths
    assert "0.1 deg" in printed and "0.001 link lengths" in printed
    data = json.loads(out.read_text())
    kin = deik.forward_kinematics(sk, data["angles"])
    assert np.linalg.norm(kin.position("tip") - position) <= 1e-3
    assert np.degrees((rotation.inv() * Rotation.from_matrix(kin.rotation("tip"))).magnitude()) <= 0.1
    w, x, y, z = data["sites"]["tip"]["quaternion_wxyz"]
    np.testing.assert_allclose(Rotation.from_quat([x, y, z, w]).as_matrix(), kin.rotation("tip"), atol=1e-9)
    np.testing.assert_allclose(data["sites"]["tip"]["position"], kin.position("tip"), atol=1e-12)


@pytest.mark.parametrize(
    "orient, fragment",
    [
        (["tip", "10", "20", "30"], "after FRAME name the form (rpy, xyz, quat-wxyz, quat-xyzw, matrix), got '10'"),
        (["tip", "rpy", "10", "20"], "--orient tip rpy takes 3 numbers"),
        (["tip", "quat-wxyz", "1", "0", "0", "0.5"], "length 1.11803, not 1"),
        (["tip", "matrix", *"2 0 0 0 1 0 0 0 1".split()], "is not a rotation matrix"),
        (["tip", "xyz", "a", "0", "0"], "'a' is not a number"),
    ],
)
def test_orient_mistakes_get_one_line(tmp_path, capsys, orient, fragment):
    out = tmp_path / "pose.json"
    argv = ["solve", SKELETON, "--reach", "tip", "1", "1", "1", "--orient", *orient, "--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("deik: error:") and fragment in err and err.count("\n") == 1
    assert not out.exists()


def test_start_pose_json_must_name_this_skeleton_s_dofs(tmp_path, capsys):
    pose = tmp_path / "pose.json"
    assert main(["solve", "chain:3", "--reach", "tip", "2", "1", "0", *RUN, "--out", str(pose)]) == 0
    capsys.readouterr()
    other = tmp_path / "other.json"
    data = json.loads(pose.read_text())
    other.write_text(json.dumps({**data, "dof_names": ["a", "b", "c"]}))
    argv = ["solve", "chain:3", "--reach", "tip", "1", "2", "0", "--start", str(other)]
    assert main(argv) == 2
    assert "its dof_names ['a', 'b', 'c'] are not this skeleton's" in capsys.readouterr().err
    assert main([*argv[:-1], str(pose), *RUN]) == 0
