"""Goals active in only some problems of a batch (`active=`): the kernels, the NumPy oracle
and the Result agree, and an inactive goal neither pulls the pose nor blocks convergence."""

import numpy as np
import pytest

import deik
from deik.objectives import reference
from helpers import kernel_fitness


def _problem(active):
    sk = deik.chain(6, dims=3)
    q = np.random.default_rng(0).uniform(sk.lower, sk.upper, (2, sk.n_dofs))
    kin = deik.forward_kinematics(sk, q)
    return deik.Problem(
        sk,
        [
            deik.Position("tip", kin.position("tip"), level=0),
            deik.Position("link3", kin.position("link3") + [0.0, 0.0, 0.5], active=active, level=0),
            deik.Comfort(level=1),
        ],
    )


def test_kernel_fitness_with_gains_matches_the_oracle():
    problem = _problem(np.array([True, False]))
    sk = problem.skeleton
    poses = np.random.default_rng(1).uniform(sk.lower, sk.upper, (40, sk.n_dofs))
    idx = np.arange(40) % 2
    k_levels, k_total, k_raw = kernel_fitness(problem, poses, idx)
    r_levels, r_total, r_raw = reference.fitness(problem, poses, idx)
    np.testing.assert_allclose(k_raw, r_raw, atol=1e-12)
    np.testing.assert_allclose(k_levels, r_levels, atol=1e-12)
    np.testing.assert_allclose(k_total, r_total, atol=1e-12)
    # problem 1 ignores the second goal entirely: the same as a problem without it
    without = deik.Problem(sk, [problem.goals[0], problem.goals[2]])
    odd = idx == 1
    np.testing.assert_allclose(r_total[odd], reference.fitness(without, poses[odd], idx[odd])[1], atol=1e-12)


def test_inactive_goal_does_not_block_convergence():
    result = deik.solve(_problem(np.array([True, False])), population=128, seed=3, generations=400)
    extra = result.goals[1]
    assert extra.active.tolist() == [True, False]
    assert bool(extra.met[1])  # not active: met whatever its error
    # the tip target of problem 1 is a real pose, so it is reached
    assert result.goals[0].met[1]
    assert result.to_dict()["goals"][1]["active"] == [True, False]


@pytest.mark.parametrize(
    "active,message",
    [
        ([1, 0], "active must be a non-empty 1-D bool array"),
        (np.array([], bool), "active must be a non-empty 1-D bool array"),
        (np.array([True, False, True]), "different batch sizes"),
    ],
)
def test_bad_active(active, message):
    with pytest.raises(ValueError, match=message):
        _ = _problem(active).table  # the goals are checked when the term table is built


def test_a_target_where_the_goal_is_off_need_not_be_reachable():
    """A clip's contact holds its plant in some frames and a placeholder elsewhere: only the
    frames it applies in are checked for reach (a walk captured 5 m from the origin could not be
    cleaned while the placeholder, at the origin, was)."""
    sk = deik.chain(6, dims=3)
    q = np.random.default_rng(2).uniform(sk.lower, sk.upper, (3, sk.n_dofs))
    targets = deik.forward_kinematics(sk, q).position("tip")
    far = targets.copy()
    far[1] = [100.0 * sk.reach, 0.0, 0.0]  # beyond reach, in the problem where the goal is off
    active = np.array([True, False, True])
    result = deik.solve(deik.Problem(sk, [deik.Position("tip", far, active=active)]), seed=3)
    for b in (0, 2):
        tip = deik.forward_kinematics(sk, result.angles[b]).position("tip")
        assert np.linalg.norm(tip - targets[b]) <= 1e-3 * sk.reach
    with pytest.raises(deik.InputError, match="unreachable"):  # where it applies, it is checked
        deik.Problem(sk, [deik.Position("tip", far, active=np.array([True, True, False]))])
    with pytest.raises(deik.InputError, match="unreachable"):
        deik.Problem(sk, [deik.Position("tip", far)])
