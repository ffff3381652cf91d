"""deik.solve keeps the engine and buffers of small problem structures between calls
(solver/kept.py): the answers are those of an engine built afresh, earlier Results and the
Problems are never changed, and another structure gets its own engine."""

import numpy as np

import deik
from deik.solver.engine import Engine
from deik.solver.solve import run_engine

SETTINGS = dict(population=16, dtype="float64", seed=3)


def _problems(n):
    """n problems of one structure: a tip target made by FK of a random in-limit pose and a
    comfort goal with its own reference pose each."""
    sk = deik.chain(5, dims=3)
    rng = np.random.default_rng(11)
    poses = rng.uniform(sk.lower, sk.upper, (n, sk.n_dofs))
    targets = deik.forward_kinematics(sk, poses).position("tip")
    references = rng.uniform(sk.lower, sk.upper, (n, sk.n_dofs)) * 0.5
    return sk, [
        deik.Problem(
            sk,
            [deik.Position("tip", targets[k], tolerance=1e-4), deik.Comfort(reference=references[k], level=1)],
        )
        for k in range(n)
    ]


def test_solves_of_one_structure_give_the_answers_of_a_fresh_engine():
    sk, problems = _problems(4)
    params = [p.table.params.copy() for p in problems]
    references = [p.reference.copy() for p in problems]
    results = [deik.solve(p, **SETTINGS) for p in problems]
    kept_angles = [r.angles.copy() for r in results]
    for k, problem in enumerate(problems):
        fresh = run_engine(problem, Engine(problem, deik.Settings(**SETTINGS)))
        np.testing.assert_array_equal(results[k].angles, fresh.angles)
        np.testing.assert_array_equal(results[k].history, fresh.history)
        assert [g.error for g in results[k].goals] == [g.error for g in fresh.goals]
        # later solves changed neither this Result nor this Problem
        np.testing.assert_array_equal(results[k].angles, kept_angles[k])
        np.testing.assert_array_equal(problem.table.params, params[k])
        np.testing.assert_array_equal(problem.reference, references[k])
        tip = deik.forward_kinematics(sk, results[k].angles).position("tip")
        assert np.linalg.norm(tip - problem.goals[0].target) <= 1e-4 + 1e-12


def test_another_structure_or_seed_is_not_confused_with_a_kept_one():
    sk, problems = _problems(2)
    first = deik.solve(problems[0], **SETTINGS)
    looser = deik.Problem(sk, [deik.Position("tip", problems[0].goals[0].target, tolerance=0.05)])
    loose = deik.solve(looser, **SETTINGS)
    assert loose.goals[0].tolerance == 0.05 and len(loose.goals) == 1
    again = deik.solve(problems[0], **SETTINGS)
    np.testing.assert_array_equal(again.angles, first.angles)
    other_seed = deik.solve(problems[0], **{**SETTINGS, "seed": 4})
    fresh = run_engine(problems[0], Engine(problems[0], deik.Settings(**{**SETTINGS, "seed": 4})))
    np.testing.assert_array_equal(other_seed.angles, fresh.angles)
    assert other_seed.settings.seed == 4 and again.settings.seed == 3
