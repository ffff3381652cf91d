"""Orientation targets in every named form compile to the same term as the rotation matrix,
batch axes are found per form, pose_goals splits a 4x4 pose, and the default tolerances of
user goals are absolute (0.001 length units, 0.1 degree) while the paper's chain experiments
keep 1 % of the reach."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import deik
from deik.experiments.timing import make_problem
from deik.objectives.goals import ANGLE_TOLERANCE, LENGTH_TOLERANCE

ROTATIONS = Rotation.random(5, random_state=11)


def _forms():
    xyzw = ROTATIONS.as_quat()
    T = np.tile(np.eye(4), (5, 1, 1))
    T[:, :3, :3] = ROTATIONS.as_matrix()
    return {
        "matrix": ROTATIONS.as_matrix(),
        "pose": T,
        "quat-wxyz": xyzw[:, [3, 0, 1, 2]],
        "quat-xyzw": xyzw,
        "rpy": ROTATIONS.as_euler("xyz"),
        "xyz": ROTATIONS.as_euler("XYZ"),
    }


@pytest.mark.parametrize("batched", [False, True])
def test_every_form_packs_the_matrix_form_s_parameters(batched):
    sk = deik.chain(3, dims=3)
    expected = deik.Orientation("tip", ROTATIONS.as_matrix()[0 if not batched else slice(None)]).row(sk).params
    for name, value in _forms().items():
        form = "matrix" if name == "pose" else name
        goal = deik.Orientation("tip", value if batched else value[0], form)
        assert goal.batched() == batched, name
        np.testing.assert_allclose(goal.row(sk).params, expected, atol=1e-12, err_msg=name)
        assert deik.Problem(sk, [goal]).batch_shape == ((5,) if batched else ())


def test_pose_goals_place_and_turn_the_frame():
    T = _forms()["pose"][2]
    T[:3, 3] = [0.5, 1.0, -0.5]
    position, orientation = deik.pose_goals("tip", T, tolerance=0.002, level=1)
    assert (position.frame, position.tolerance, position.level) == ("tip", 0.002, 1)
    np.testing.assert_array_equal(position.target, [0.5, 1.0, -0.5])
    assert orientation.tolerance is None and orientation.level == 1
    np.testing.assert_allclose(orientation.rotation()[0], T[:3, :3], atol=1e-15)
    T[3, 3] = 2.0
    with pytest.raises(ValueError, match=r"pose target for 'tip' is a 4x4 pose whose last row is not 0 0 0 1"):
        deik.pose_goals("tip", T)


def test_user_goals_default_to_absolute_tolerances():
    sk = deik.humanoid()
    rest = deik.forward_kinematics(sk, sk.reference)
    goals = [
        deik.Position("left_hand", rest.position("left_hand")),
        deik.Orientation("head", np.eye(3)),
        deik.Aim("head", [0, 1.6, 2]),
        deik.CentreOfMass(rest.p_world_com),
        deik.ComOverSupport(rest.position("left_heel")),
    ]
    tolerances = [goal.row(sk).tolerance for goal in goals]
    assert LENGTH_TOLERANCE == 1e-3 and ANGLE_TOLERANCE == pytest.approx(math.radians(0.1))
    assert tolerances == [1e-3, ANGLE_TOLERANCE, ANGLE_TOLERANCE, 1e-3, 1e-3]
    # the paper's chain experiments keep their share of the reach
    problem = make_problem(10, seed=0)
    assert problem.goals[0].row(problem.skeleton).tolerance == pytest.approx(0.01 * problem.skeleton.reach)
