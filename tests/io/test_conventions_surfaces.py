"""docs/conventions.md on the surfaces not covered elsewhere: an angle tolerance in degrees in a
problem file, limits tables keyed by DOF names that say which key to give for a joint or a
URDF link, and angles in degrees in the demo's report."""

import math

import numpy as np
import pytest

import deik
from deik.errors import FileFormatError
from deik.experiments.demo import chain_scenarios, run_demo
from deik.io.limits import read_limits
from deik.solver.problem_file import load_problem

ARM = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/><link name="upper"/><link name="tool"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
    <axis xyz="0 0 1"/><limit lower="-2" upper="2"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="tool"/>
    <origin xyz="0 0 0.5"/><axis xyz="0 1 0"/><limit lower="-2" upper="2"/></joint>
</robot>
"""


def _orientation_problem(tmp_path, tolerance_lines: str):
    path = tmp_path / "problem.toml"
    path.write_text(
        'skeleton = "chain3d:3"\n[[goal]]\ntype = "orientation"\nframe = "tip"\n'
        f"rpy_degrees = [10, 20, 30]\n{tolerance_lines}"
    )
    return load_problem(path)


def test_a_problem_file_gives_an_angle_tolerance_in_degrees(tmp_path):
    goal = _orientation_problem(tmp_path, "tolerance_degrees = 0.05\n").problem.goals[0]
    assert goal.tolerance == pytest.approx(math.radians(0.05))
    assert _orientation_problem(tmp_path, "tolerance = 0.002\n").problem.goals[0].tolerance == 0.002
    with pytest.raises(ValueError, match=r"give 'tolerance' \(radians\) or 'tolerance_degrees', not both"):
        _orientation_problem(tmp_path, "tolerance = 0.002\ntolerance_degrees = 0.1\n")


def test_a_length_goal_has_no_tolerance_in_degrees(tmp_path):
    path = tmp_path / "problem.toml"
    path.write_text('skeleton = "chain:3"\n[[goal]]\ntype = "position"\nframe = "tip"\ntarget = [1, 1, 0]\n')
    path.write_text(path.read_text() + "tolerance_degrees = 1\n")
    with pytest.raises(ValueError, match="unknown field 'tolerance_degrees'"):
        load_problem(path)


def test_a_limits_table_keyed_by_a_urdf_link_names_the_joint_to_use(tmp_path):
    (tmp_path / "arm.urdf").write_text(ARM)
    arm = deik.read_urdf(tmp_path / "arm.urdf")
    assert arm.dof_names == ("shoulder", "elbow")  # a robot's DOFs are keyed by its joint names
    table = tmp_path / "limits.json"
    table.write_text('{"elbow": [-30, 45]}')
    assert read_limits(table, arm) == {"elbow": pytest.approx((math.radians(-30), math.radians(45)))}
    table.write_text('{"tool": [-30, 45]}')
    with pytest.raises(
        FileFormatError, match=r"'tool' is a link \(a frame\); its degrees of freedom belong to joint 'elbow'"
    ):
        read_limits(table, arm)


def test_a_limits_table_keyed_by_a_joint_lists_its_dof_names(tmp_path):
    human = deik.humanoid()
    table = tmp_path / "limits.json"
    table.write_text('{"left_knee": [-150, 0]}')
    names = ", ".join(human.dof_names[human.joint_dofs("left_knee")])
    with pytest.raises(
        FileFormatError, match=f"'left_knee' is a joint; a limits table is keyed by its DOF names \\({names}\\)"
    ):
        read_limits(table, human)


def test_the_demo_reports_angles_in_degrees(tmp_path, capsys):
    rows = run_demo(tmp_path, chain_scenarios(n_links=3, seed=1))
    table = capsys.readouterr().out
    comfort = [row for row in rows if row["unit"] == "rad"]
    assert comfort and " rad" not in table  # the comfort rows' errors, in radians in demo.json
    shown = f"{np.degrees(comfort[0]['error']):.6g} deg"
    assert shown in table
