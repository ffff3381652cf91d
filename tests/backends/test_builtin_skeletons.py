"""The compiled kernels on built-in skeletons, so that a clone without the real files still checks
them: the humanoid, a 3-D chain, and a robot arm built in code with the URDF features (rest
rotations, a prismatic and a mimic DOF, a rotated tool frame; helpers.robot_arm).

- the LM polish's analytic Jacobian rows against finite differences of its residuals;
- the point and centre-of-mass Jacobians of the clip warm start against finite differences of
  the NumPy forward kinematics;
- the compiled evaluation of every goal kind against the NumPy oracle (deik.objectives.reference);
- the float32 kernels' joint limits inside the float64 ones.

The real robots and clips get the same checks in tests/solver/test_polish.py and tests/cleanup/.
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import deik
from deik.backends.pack import pack_skeleton
from deik.cleanup.warmstart import position_jacobian
from deik.model.joints import TRANSLATE
from deik.objectives import reference
from deik.objectives.registry import KIND_NAMES
from helpers import BUILTIN_FRAMES, BUILTIN_SKELETONS, finite_difference_check, kernel_fitness, random_poses

SKELETONS = sorted(BUILTIN_SKELETONS)


def _skeleton(name):
    sk = BUILTIN_SKELETONS[name]()
    end, middle, support = BUILTIN_FRAMES[name]
    return sk, end, middle, support


def test_the_robot_arm_has_the_urdf_features():
    sk = BUILTIN_SKELETONS["robot_arm"]()
    assert sk.mimic_names == ("finger_joint",) and "finger_joint" not in sk.dof_names
    assert (sk.dof_kind == TRANSLATE).sum() == 1
    assert sk.joint_rotation is not None and not np.allclose(sk.joint_rotation, np.eye(3))  # rest rotations
    assert not np.allclose(sk.site_rotation[sk.site_names.index("tool")], np.eye(3))  # a rotated tool frame
    assert (sk.mass_value > 0).all() and tuple(sk.up) == (0.0, 0.0, 1.0)


@pytest.mark.parametrize("name", SKELETONS)
def test_polish_jacobians_match_finite_differences(name):
    sk, end, middle, _ = _skeleton(name)
    poses = random_poses(sk, 5, 0)
    target = deik.forward_kinematics(sk, random_poses(sk, 1, 1)[0])
    com = deik.forward_kinematics(sk, sk.reference).p_world_com
    goals = [
        deik.Position(end, target.position(end)),
        deik.Orientation(end, target.rotation(end)),
        deik.Position(middle, target.position(middle) + 0.1),
        deik.CentreOfMass(com + 0.05),
        deik.ComOverSupport(com + 0.1),
    ]
    finite_difference_check(sk, goals, poses)


@pytest.mark.parametrize("name", SKELETONS)
def test_point_and_com_jacobians_match_finite_differences(name):
    sk, end, middle, support = _skeleton(name)
    names = [end, middle, *support]
    poses = random_poses(sk, 4, 2)
    x, jac = position_jacobian(sk, poses, names, centre_of_mass=True)
    index = [sk.frame_index(n) for n in names]

    def points(q):
        kin = deik.forward_kinematics(sk, q)
        return np.concatenate([kin.p_world_frame[:, index], kin.p_world_com[:, None]], axis=1)

    np.testing.assert_allclose(x, points(poses), atol=1e-12)
    h = 1e-6
    for d in range(sk.n_dofs):
        step = np.zeros(sk.n_dofs)
        step[d] = h
        np.testing.assert_allclose(
            jac[..., d], (points(poses + step) - points(poses - step)) / (2 * h), atol=1e-8, err_msg=sk.dof_names[d]
        )


def _every_goal_problem(sk, end, middle, support):
    kin = deik.forward_kinematics(sk, sk.reference)
    centre = 0.5 * (kin.position(end) + kin.position(middle))
    return deik.Problem(
        sk,
        [
            deik.Position(end, kin.position(end) - 0.1, tolerance=0.02),
            deik.Orientation(end, Rotation.from_euler("XYZ", [0.2, -0.3, 0.4]).as_matrix(), level=1, tolerance=0.05),
            deik.Aim(end, kin.position(end) + [0.3, 0.1, 1.0], axis=(0, 0, 2.0), weight=0.5, mu=2.0),
            deik.CentreOfMass(kin.p_world_com + 0.05),
            deik.ComOverSupport(kin.position(support[0]), level=1, tolerance=0.02),
            deik.ComInPolygon(support, weight=0.8),
            deik.Comfort("sum", joint_weights="start", level=2),
            deik.Comfort("max", weight=-0.3, level=2),
            deik.Obstacle(centre, 0.05, bone_radius=0.02, level=1),
            deik.SelfCollision(margin=0.02, level=1),
            deik.Floor(float(kin.position(middle) @ sk.up), level=1),  # the lower half of the body beneath
        ],
        limits="penalty",
    )


@pytest.mark.parametrize("name", SKELETONS)
def test_every_goal_kind_kernel_equals_oracle(name):
    sk, end, middle, support = _skeleton(name)
    problem = _every_goal_problem(sk, end, middle, support)
    assert set(problem.table.kinds.tolist()) == set(range(len(KIND_NAMES))), "every term kind"
    rng = np.random.default_rng(3)
    span = sk.upper - sk.lower
    poses = np.vstack(
        [
            sk.reference[None],
            sk.reference + rng.normal(0.0, 0.05, (4, sk.n_dofs)),
            rng.uniform(sk.lower - 0.3 * span, sk.upper + 0.3 * span, (8, sk.n_dofs)),
        ]
    )
    lv_k, tot_k, raw_k = kernel_fitness(problem, poses)
    lv_r, tot_r, raw_r = reference.fitness(problem, poses)
    np.testing.assert_allclose(raw_k, raw_r, rtol=0, atol=1e-9)
    np.testing.assert_allclose(lv_k, lv_r, rtol=0, atol=1e-9)
    np.testing.assert_allclose(tot_k, tot_r, rtol=0, atol=1e-9)


@pytest.mark.parametrize("name", SKELETONS)
def test_float32_kernel_limits_lie_inside_the_float64_limits(name):
    """Limits such as pi or the arm's -2.9 have no exact float32 value: the float32 kernels' limits
    are rounded inwards, so a float32 solution never lies outside the float64 limits."""
    sk = BUILTIN_SKELETONS[name]()
    assert (sk.lower.astype(np.float32) != sk.lower).any()  # some limit must need rounding
    limits = pack_skeleton(sk, np.float32)[8].astype(np.float64)
    assert np.all(limits[:, 0] >= sk.lower) and np.all(limits[:, 1] <= sk.upper)
