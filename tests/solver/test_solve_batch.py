"""solve_batch / Problem.stack: problems that differ in targets, weights and reference poses
share one term table and one launch, and each keeps its own fitness."""

import numpy as np
import pytest

import deik
from deik.objectives.kinds import GAIN
from deik.objectives.reference import fitness


def _problems(sk, n, seed):
    rng = np.random.default_rng(seed)
    truth = rng.uniform(sk.lower, sk.upper, (n, sk.n_dofs))
    tips = deik.forward_kinematics(sk, truth).position("tip")
    return [
        deik.Problem(
            sk,
            [
                deik.Position("tip", tips[k], tolerance=1e-3, weight=1.0 - 0.1 * k),
                deik.Comfort(weight=0.1 * (k + 1), reference=rng.uniform(-1, 1, sk.n_dofs), level=1),
            ],
        )
        for k in range(n)
    ], truth


def test_stacked_problems_keep_each_problems_own_fitness():
    sk = deik.chain(6, dims=3)
    problems, _ = _problems(sk, 4, 0)
    stacked = deik.Problem.stack(problems)
    assert stacked.batch_size == 4
    poses = np.random.default_rng(1).uniform(sk.lower, sk.upper, (4, sk.n_dofs))
    for k, problem in enumerate(problems):
        own_levels, own_total, own_raw = fitness(problem, poses[k : k + 1])
        levels, total, raw = fitness(stacked, poses[k : k + 1], [k])
        np.testing.assert_allclose(raw, own_raw, rtol=1e-12)
        np.testing.assert_allclose(total, own_total, rtol=1e-12)
        np.testing.assert_allclose(levels, own_levels, rtol=1e-12)


def test_solve_batch_solves_every_problem_in_one_call():
    sk = deik.chain(8, dims=3)
    problems, _ = _problems(sk, 6, 2)
    result = deik.solve_batch(problems, population=32, seed=3)
    assert result.angles.shape == (6, sk.n_dofs) and result.converged.all()
    tips = deik.forward_kinematics(sk, result.angles).position("tip")
    for k, problem in enumerate(problems):
        assert np.linalg.norm(tips[k] - problem.goals[0].target) <= 1e-3


def test_stack_refuses_problems_that_differ_in_more_than_data():
    sk = deik.chain(4)
    a = deik.Problem(sk, [deik.Position("tip", [1.0, 1.0, 0.0])])
    with pytest.raises(ValueError, match="another skeleton"):
        deik.Problem.stack([a, deik.Problem(deik.chain(4), [deik.Position("tip", [1.0, 1.0, 0.0])])])
    with pytest.raises(ValueError, match="goal 0"):
        deik.Problem.stack([a, deik.Problem(sk, [deik.Position("link2", [1.0, 0.0, 0.0])])])
    with pytest.raises(ValueError, match="terms"):
        deik.Problem.stack([a, deik.Problem(sk, [deik.Position("tip", [1.0, 1.0, 0.0]), deik.Comfort()])])
    with pytest.raises(ValueError, match="positive weights"):
        deik.Problem.stack([a, deik.Problem(sk, [deik.Position("tip", [1.0, 1.0, 0.0], weight=-0.5)])])
    with pytest.raises(TypeError):
        deik.Problem.stack([])


def _island_state(migration):
    sk = deik.chain(6, dims=3)
    target = deik.forward_kinematics(sk, np.full(sk.n_dofs, 0.3)).position("tip")
    problem = deik.Problem(sk, [deik.Position("tip", target, tolerance=1e-9)])
    settings = deik.Settings(
        population=32,
        islands=4,
        migration=migration,
        seed=5,
        polish=0,
        restarts=0,
        patience=10_000,
        stop_on_converged=False,
    )
    engine = deik.Engine(problem, settings)
    return engine.run(engine.init(), 6)


def _leader_copied_to_next_island(state):
    pop, size = state.pop[0], 8
    return [
        any(
            np.array_equal(pop[state.leaders[0, j]], pop[i])
            for i in range(((j + 1) % 4) * size, ((j + 1) % 4 + 1) * size)
        )
        for j in range(4)
    ]


def test_islands_pass_their_leader_to_the_next_island_when_they_migrate():
    assert all(_leader_copied_to_next_island(_island_state(migration=1)))
    assert not any(_leader_copied_to_next_island(_island_state(migration=10**6)))


def test_islands_solve_and_must_split_the_population_evenly():
    sk = deik.chain(8, dims=3)
    problems, _ = _problems(sk, 3, 4)
    assert deik.solve_batch(problems, population=64, islands=4, seed=1).converged.all()
    with pytest.raises(ValueError, match="islands"):
        deik.Settings(population=30, islands=4)


def test_stacked_parts_with_batches_keep_their_targets_and_carry_their_weights_as_gains():
    sk = deik.chain(4)
    targets = deik.forward_kinematics(sk, np.random.default_rng(3).uniform(-1, 1, (5, sk.n_dofs))).position("tip")
    three = deik.Problem(sk, [deik.Position("tip", targets[:3], weight=0.8, tolerance=1e-3), deik.Comfort()])
    two = deik.Problem(sk, [deik.Position("tip", targets[3:], weight=0.2, tolerance=1e-3), deik.Comfort()])
    stacked = deik.Problem.stack([three, two, three])
    assert stacked.batch_size == 8
    params = stacked.table.params
    np.testing.assert_array_equal(params[:, 0, :3], np.concatenate([targets[:3], targets[3:], targets[:3]]))
    gains = params[:, 0, GAIN]
    np.testing.assert_allclose(gains, [1, 1, 1, 0.25, 0.25, 1, 1, 1])  # weight 0.8 is the largest: gains w / 0.8
    np.testing.assert_array_equal(params[:, 1, GAIN], 1.0)
    assert stacked.rows[0].weight == 0.8
    np.testing.assert_array_equal(three.table.params[:, 0, GAIN], 1.0)  # the parts are left as they were
