"""deik.Solver: the same answers as deik.solve on a rebuilt Problem, for new targets, seeds and
batches, and clear errors for goals it cannot retarget."""

import numpy as np
import pytest

import deik


def _arm():
    """A 6-link 3-D chain, targets from the FK of random in-limit poses, with a comfort goal."""
    sk = deik.chain(6, dims=3)
    poses = np.random.default_rng(7).uniform(sk.lower, sk.upper, (6, sk.n_dofs))
    kin = deik.forward_kinematics(sk, poses)
    return sk, kin.position("tip"), kin.rotation("link5")


def _problem(sk, position, rotation):
    return deik.Problem(
        sk,
        [
            deik.Position("tip", position, tolerance=1e-4),
            deik.Orientation("link5", rotation, tolerance=1e-3),
            deik.Comfort(weight=0.1, level=1),
        ],
    )


def test_solver_gives_the_answers_of_solve_on_a_rebuilt_problem():
    sk, positions, rotations = _arm()
    solver = deik.Solver(_problem(sk, positions[0], rotations[0]), population=32, dtype="float64")
    for k in range(1, 4):
        got = solver.solve({"position tip": positions[k], 1: rotations[k]}, seed=k)
        want = deik.solve(_problem(sk, positions[k], rotations[k]), population=32, dtype="float64", seed=k)
        np.testing.assert_array_equal(got.angles, want.angles)
        assert got.generations == want.generations and got.converged == want.converged
        for a, b in zip(got.goals, want.goals):
            assert a.label == b.label and a.error == b.error


def test_solver_keeps_its_problem_and_other_targets():
    sk, positions, rotations = _arm()
    problem = _problem(sk, positions[0], rotations[0])
    before = problem.table.params.copy()
    solver = deik.Solver(problem, population=32, dtype="float64")
    moved = solver.solve({"position tip": positions[2]}, seed=0)
    np.testing.assert_array_equal(problem.table.params, before)  # the problem is never changed
    kin = deik.forward_kinematics(sk, moved.angles)
    assert np.linalg.norm(kin.position("tip") - positions[2]) <= 1e-4 + 1e-9
    again = solver.solve(seed=0)  # no targets: the problem as built
    np.testing.assert_array_equal(again.angles, deik.solve(problem, population=32, dtype="float64", seed=0).angles)


def test_solver_retargets_a_batch():
    sk, positions, rotations = _arm()
    solver = deik.Solver(_problem(sk, positions[:3], rotations[:3]), population=32, dtype="float64")
    result = solver.solve({0: positions[3:6], 1: rotations[3:6]}, seed=5)
    kin = deik.forward_kinematics(sk, result.angles)
    assert result.angles.shape == (3, sk.n_dofs) and result.converged.all()
    assert (np.linalg.norm(kin.position("tip") - positions[3:6], axis=1) <= 1e-4 + 1e-9).all()
    with pytest.raises(ValueError, match=r"goal 0 \(position tip\): 2 targets for a problem batch of 3"):
        solver.solve({0: positions[:2]})


def test_solver_errors_name_the_goal():
    sk, positions, rotations = _arm()
    solver = deik.Solver(_problem(sk, positions[0], rotations[0]))
    with pytest.raises(KeyError, match=r"no goal 'position hand'; the goals are \['position tip'"):
        solver.solve({"position hand": positions[1]})
    with pytest.raises(IndexError, match="goal index 5 out of range: the problem has 3 goals"):
        solver.solve({5: positions[1]})
    with pytest.raises(TypeError, match=r"goal 2 \(comfort \(sum\)\) has no target to swap"):
        solver.solve({2: positions[1]})
    with pytest.raises(ValueError, match="NaN"):
        solver.solve({0: [np.nan, 0.0, 0.0]})
    with pytest.raises(ValueError, match="unreachable"):
        solver.solve({0: [100.0, 0.0, 0.0]})
    with pytest.raises(ValueError, match="not a rotation matrix"):
        solver.solve({1: 2 * np.eye(3)})
    with pytest.raises(TypeError, match="Solver takes a deik.Problem"):
        deik.Solver("problem")
