"""A continuous joint's angle is one angle modulo a turn: a comfort reference past its limits is
the same angle inside them (the solve reaches it, where it stopped at the limit), and so is a
seed pose, where any other DOF past its limits is refused with one line in radians and degrees.
The robot: a SCARA arm with a continuous roll at its flange."""

import numpy as np
import pytest

import deik
from deik.cli.app import main
from deik.objectives.reference import raw_errors
from deik.solver.seeding import poses_around

SCARA = """<?xml version="1.0"?>
<robot name="scara">
  <link name="base"/><link name="arm1"/><link name="arm2"/><link name="quill"/><link name="flange"/><link name="tcp"/>
  <joint name="j1" type="revolute"><origin xyz="0 0 0.4"/><parent link="base"/><child link="arm1"/>
    <axis xyz="0 0 1"/><limit lower="-2.5" upper="2.5" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><origin xyz="0.35 0 0"/><parent link="arm1"/><child link="arm2"/>
    <axis xyz="0 0 1"/><limit lower="-2.6" upper="2.6" effort="1" velocity="1"/></joint>
  <joint name="j3" type="prismatic"><origin xyz="0.30 0 0"/><parent link="arm2"/><child link="quill"/>
    <axis xyz="0 0 -1"/><limit lower="0" upper="0.2" effort="1" velocity="1"/></joint>
  <joint name="j4" type="continuous"><origin xyz="0 0 -0.05"/><parent link="quill"/><child link="flange"/>
    <axis xyz="0 0 1"/></joint>
  <joint name="tool" type="fixed"><origin xyz="0.02 0 -0.1"/><parent link="flange"/><child link="tcp"/></joint>
</robot>
"""


def _wrapped(angle):
    return (angle + np.pi) % (2 * np.pi) - np.pi


@pytest.fixture(scope="module")
def scara(tmp_path_factory):
    path = tmp_path_factory.mktemp("scara") / "scara.urdf"
    path.write_text(SCARA)
    return path, deik.read_urdf(path, "base", "tcp")


@pytest.mark.parametrize("reference", [5.0, 3.283, -3.0, -4.0, 2 * np.pi + 3.1])
def test_a_comfort_reference_on_a_continuous_joint_is_reached_as_the_same_angle(scara, reference):
    """The quill's position leaves the roll j4 free, so comfort alone sets it: the solve lands on
    the reference's own angle in [-pi, pi] (5 rad is -1.28 rad), not at the limit nearest 5."""
    _, sk = scara
    q = np.random.default_rng(1).uniform(sk.lower, sk.upper)
    quill = deik.forward_kinematics(sk, q).position("quill")
    pose = np.concatenate([q[:3], [reference]])
    comfort = deik.Comfort(reference=pose, joint_weights={"j4": 1.0}, level=1)
    result = deik.solve(deik.Problem(sk, [deik.Position("quill", quill, tolerance=1e-3), comfort]), seed=0)
    assert result.converged
    assert abs(result.angles[3] - _wrapped(reference)) < 1e-3, result.angles
    assert result.errors["comfort (sum)"] < 1e-3


def test_the_oracle_measures_from_the_wrapped_reference(scara):
    """A reference of 5 rad on j4 is -1.28: a pose at -1 is 0.28 from it; the revolute j1's
    reference of 2 is kept, 4 from -2."""
    _, sk = scara
    reference = np.array([2.0, 0.0, 0.0, 5.0])
    problem = deik.Problem(sk, [deik.Comfort(reference=reference, joint_weights={"j1": 1.0, "j4": 1.0})])
    error = raw_errors(problem, np.array([[-2.0, 0.0, 0.0, -1.0]]))[0, 0]
    assert error == pytest.approx(4.0 + abs(-1.0 - (5.0 - 2 * np.pi)))


def test_a_seed_past_a_continuous_joint_s_limit_is_the_same_angle(scara):
    _, sk = scara
    for turned in (np.radians(350), np.radians(-725), 2 * np.pi + 3.1):
        pose = np.array([0.1, 0.2, 0.05, turned])
        start = poses_around(sk, pose, 3, seed=0)
        assert start[0, 3] == pytest.approx(_wrapped(turned))
        np.testing.assert_array_equal(start[0, :3], pose[:3])


def test_the_command_line_wraps_a_continuous_start_and_names_any_other_in_degrees(scara, capsys):
    path, sk = scara
    target = deik.forward_kinematics(sk, np.array([0.3, -0.5, 0.1, 1.0])).position("tcp")
    reach = ["--reach", "tcp", *map(str, target)]
    assert main(["solve", str(path), "--tip", "tcp", *reach, "--start", "10", "10", "0.05", "350"]) == 0
    capsys.readouterr()
    assert main(["solve", str(path), "--tip", "tcp", *reach, "--start", "170", "10", "0.05", "0"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "'j1'" in err and "170 degrees" in err and "[-143.2, 143.2] degrees" in err, err
