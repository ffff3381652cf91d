"""The Result's one shape rule: batched fields lead with problem.batch_shape, () for a problem
whose goals carry no batch axis and (B,) when any goal's target, active mask or reference pose
carries one (even B = 1) or the problem was stacked; and the float64 report reuses the state."""

import numpy as np
import pytest

import deik
from deik.solver.engine import Engine
from deik.solver.settings import Settings
from deik.solver.solve import make_result

SETTINGS = {"population": 16, "generations": 30, "seed": 2}


def _targets(n, seed=0):
    sk = deik.chain(5, dims=3)
    poses = np.random.default_rng(seed).uniform(sk.lower, sk.upper, (n, sk.n_dofs))
    return sk, deik.forward_kinematics(sk, poses).position("tip")


def _check_shapes(result, batch, D, T):
    assert result.angles.shape == batch + (D,)
    for value in (result.fitness, result.generations, result.converged):
        assert isinstance(value, np.ndarray) and value.shape == batch
    assert result.history.shape[: len(batch)] == batch and result.history.shape[-1] == 2
    assert result.history.ndim == len(batch) + 2 and len(result.goals) == T
    for goal in result.goals:
        for value in (goal.error, goal.normalised, goal.active, goal.met):
            assert isinstance(value, np.ndarray) and value.shape == batch, goal.label


def test_a_problem_without_a_batch_axis_gives_0d_fields():
    sk, tips = _targets(1)
    problem = deik.Problem(sk, [deik.Position("tip", tips[0], tolerance=1e-3), deik.Comfort(weight=0.1, level=1)])
    assert problem.batch_shape == ()
    _check_shapes(deik.solve(problem, **SETTINGS), (), sk.n_dofs, 2)


@pytest.mark.parametrize("how", ["target", "active", "reference", "stack"])
def test_a_batch_axis_of_one_is_kept(how):
    sk, tips = _targets(1)
    position = deik.Position(
        "tip",
        tips[:1] if how == "target" else tips[0],
        tolerance=1e-3,
        active=np.array([True]) if how == "active" else None,
    )
    comfort = deik.Comfort(weight=0.1, level=1, reference=sk.reference[None] if how == "reference" else None)
    problem = deik.Problem(sk, [position, comfort])
    if how == "stack":
        problem = deik.Problem.stack([problem])
    assert problem.batch_shape == (1,) and problem.batch_size == 1
    result = deik.solve(problem, **SETTINGS)
    _check_shapes(result, (1,), sk.n_dofs, 2)
    # the batch member's pose places the tip as its report says (independent FK)
    tip = deik.forward_kinematics(sk, result.angles).position("tip")
    np.testing.assert_allclose(np.linalg.norm(tip - tips[:1], axis=-1), result.goals[0].error, rtol=1e-9, atol=1e-12)


def test_a_batch_of_three_and_solver_retargeting_keep_the_axis():
    sk, tips = _targets(4)
    problem = deik.Problem(sk, [deik.Position("tip", tips[:3], tolerance=1e-3)])
    assert problem.batch_shape == (3,)
    _check_shapes(deik.solve(problem, **SETTINGS), (3,), sk.n_dofs, 1)
    single = deik.Solver(deik.Problem(sk, [deik.Position("tip", tips[0], tolerance=1e-3)]), **SETTINGS)
    _check_shapes(single.solve({0: tips[1]}), (), sk.n_dofs, 1)
    _check_shapes(single.solve({0: tips[1:2]}), (1,), sk.n_dofs, 1)


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_reported_errors_are_float64_and_match_an_independent_fk(dtype):
    sk, tips = _targets(3, seed=4)
    problem = deik.Problem(sk, [deik.Position("tip", tips, tolerance=1e-3), deik.Comfort(weight=0.1, level=1)])
    engine = Engine(problem, Settings(**SETTINGS, dtype=dtype))
    state = engine.run(engine.init(), 20)
    result = make_result(problem, engine, state, 0.0)
    assert result.goals[0].error.dtype == np.float64
    # the state's own raw errors (float64 run) equal a fresh float64 evaluation of the same poses
    np.testing.assert_allclose(
        np.stack([g.error for g in result.goals], axis=1), engine.raw_errors(result.angles), rtol=1e-12, atol=1e-15
    )
    tip = deik.forward_kinematics(sk, result.angles).position("tip")
    np.testing.assert_allclose(result.goals[0].error, np.linalg.norm(tip - tips, axis=-1), rtol=1e-9, atol=1e-12)
    comfort = np.abs(result.angles - sk.reference).sum(axis=1)
    np.testing.assert_allclose(result.goals[1].error, comfort, rtol=1e-9, atol=1e-12)
