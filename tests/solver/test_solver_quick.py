"""deik.Solver's quick path: a single new target is checked in plain Python (Goal.quick_target)
instead of by target_params. It must never pass what target_params refuses, must give the
parameters target_params gives, must take the targets forward kinematics makes, and a Solver
using it must answer as one checking every target the slow way; a Result works out fitness,
goals and converged on first use, with the values an eager report gives."""

import dataclasses
import pickle

import numpy as np
import pytest

import deik
from deik.objectives.kinds import GAIN, MU, SCALE, WEIGHT


def _arm(n=40, seed=3):
    """A 6-link 3-D chain and the tip positions and link5 rotations of n random in-limit poses."""
    sk = deik.chain(6, dims=3)
    poses = np.random.default_rng(seed).uniform(sk.lower, sk.upper, (n, sk.n_dofs))
    kin = deik.forward_kinematics(sk, poses)
    return sk, kin.position("tip"), kin.rotation("link5")


def _slow(goal, sk, target):
    """target_params' leading columns (N_PARAMS,) of one target, or None where it refuses it."""
    try:
        params, batched = goal.target_params(sk, target)
    except ValueError:
        return None
    assert not batched and params.shape[0] == 1
    return params[0, :GAIN]


def _agrees(goal, sk, target) -> bool:
    """Whether the quick check passes `target`, after asserting that it passes nothing that
    target_params refuses and that its parameters are target_params'."""
    got = goal.quick_target(sk)(target)
    if got is None:
        return False
    want = _slow(goal, sk, target)
    assert want is not None, f"the quick check passed {target!r}, which target_params refuses"
    np.testing.assert_array_equal(want[: len(got)], got)
    assert not want[len(got) :].any()  # the columns the quick path leaves are zero for this kind
    return True


def test_quick_checks_take_forward_kinematics_targets_with_target_params_values():
    sk, positions, rotations = _arm()
    position, orientation = deik.Position("tip", positions[0]), deik.Orientation("link5", rotations[0])
    assert all(_agrees(position, sk, p) for p in positions)
    assert all(_agrees(position, sk, p.tolist()) for p in positions)  # lists too
    assert all(_agrees(orientation, sk, R) for R in rotations)


def test_quick_checks_pass_nothing_target_params_refuses_near_its_bounds():
    sk, positions, rotations = _arm()
    rng = np.random.default_rng(11)
    position, orientation = deik.Position("tip", positions[0]), deik.Orientation("link5", rotations[0])
    reach = sk.path_length(sk.frame_index("tip"))
    passed = refused = 0
    for p in positions:  # along the ray through each target, across the reach (1 + 1e-9 of the chain)
        for scale in 1 + np.array([-1e-6, -1e-9, -1e-12, 0.0, 1e-12, 5e-10, 1e-9, 2e-9, 1e-6, 1.0]):
            ok = _agrees(position, sk, p / np.linalg.norm(p) * reach * scale)
            passed, refused = passed + ok, refused + (not ok)
    for R in rotations:  # off a rotation by about the tolerance (1e-5 on R R^T - I), and reflected
        for size in (1e-7, 3e-6, 5e-6, 1e-5, 3e-5, 1e-3):
            _agrees(orientation, sk, R + size * rng.standard_normal((3, 3)))
        assert not _agrees(orientation, sk, -R) and not _agrees(orientation, sk, R * (1 + 1e-3))
    assert passed and refused  # both sides of the reach were tried
    for bad in ([np.nan, 0, 0], [np.inf, 0, 0], [1e150, 1e150, 1e150], np.zeros(4)):
        assert position.quick_target(sk)(bad) is None and _slow(position, sk, bad) is None
    with pytest.raises(ValueError, match="must be real numbers"):  # as target_params says
        position.quick_target(sk)("tip")
    for bad in (np.full((3, 3), np.nan), np.eye(4), rotations[:2], 2 * np.eye(3), np.diag([1.0, 1.0, -1.0])):
        assert orientation.quick_target(sk)(bad) is None
    assert deik.Orientation("link5", [1.0, 0, 0, 0], form="quat-wxyz").quick_target(sk) is None  # no quick form


def _solver(sk, positions, rotations, quick=True):
    goals = [
        deik.Position("tip", positions[0], tolerance=1e-4),
        deik.Orientation("link5", rotations[0], tolerance=1e-3),
        deik.Comfort(weight=0.1, level=1),
    ]
    solver = deik.Solver(deik.Problem(sk, goals), population=16, generations=60, dtype="float64")
    if not quick:
        solver._quick = (None,) * len(goals)  # every target through target_params, as before the quick path
    return solver


def test_a_solver_answers_as_with_every_target_checked_the_slow_way():
    sk, positions, rotations = _arm(6)
    quick, slow = _solver(sk, positions, rotations), _solver(sk, positions, rotations, quick=False)
    for k in range(1, 6):
        targets = {"position tip": positions[k], 1: rotations[k]}
        a, b = quick.solve(targets, seed=k), slow.solve(targets, seed=k)
        np.testing.assert_array_equal(a.angles, b.angles)
        assert a.converged == b.converged and a.fitness == b.fitness
        assert [g.error for g in a.goals] == [g.error for g in b.goals]
        # the same target with a batch axis of one (target_params' path) poses the same problem
        c = quick.solve({0: positions[k][None], 1: rotations[k][None]}, seed=k)
        np.testing.assert_array_equal(c.angles[0], a.angles)
    kin = deik.forward_kinematics(sk, a.angles)
    assert np.linalg.norm(kin.position("tip") - positions[5]) <= 1e-4 + 1e-9


def test_a_refused_target_leaves_nothing_of_the_targets_before_it():
    sk, positions, rotations = _arm(4)
    solver = _solver(sk, positions, rotations)
    with pytest.raises(ValueError, match="not a rotation matrix"):
        solver.solve({0: positions[2], 1: 2 * np.eye(3)})
    with pytest.raises(ValueError, match="unreachable"):
        solver.solve({1: rotations[2], 0: positions[2] * 100})
    # goal 0 was written before goal 1 failed, and goal 1 before goal 0 failed: neither stays
    got = solver.solve({}, seed=4)
    want = _solver(sk, positions, rotations, quick=False).solve({}, seed=4)
    np.testing.assert_array_equal(got.angles, want.angles)
    np.testing.assert_array_equal(solver._engine.terms.params, solver.problem.table.params)


def test_a_result_works_out_its_report_on_first_use_as_an_eager_one_would():
    sk, positions, rotations = _arm(3)
    problem = deik.Problem(sk, [deik.Position("tip", positions[:3], tolerance=1e-4), deik.Comfort(weight=0.1, level=1)])
    result = deik.solve(problem, population=16, generations=40, dtype="float64", seed=1)
    assert "goals" not in vars(result) and "fitness" not in vars(result)  # nothing worked out yet
    raw = result.evaluation.raw
    table = problem.table
    normalised = -np.expm1(-table.term_float[:, MU] * raw / table.term_float[:, SCALE])
    np.testing.assert_allclose(result.fitness, (normalised * table.term_float[:, WEIGHT]).sum(axis=1), rtol=1e-15)
    kin = deik.forward_kinematics(sk, result.angles)
    np.testing.assert_allclose(result.goals[0].error, np.linalg.norm(kin.position("tip") - positions[:3], axis=1))
    np.testing.assert_array_equal(result.converged, result.goals[0].error <= 1e-4)
    assert result.goals is result.goals  # worked out once, then kept
    for value in (result.fitness, result.converged, result.angles, result.goals[0].error):
        with pytest.raises(ValueError, match="read-only"):
            value[...] = 0
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.fitness = None
    first = dataclasses.replace(result, angles=result.angles[0])  # as experiments/fig45_humanoid does
    assert first.angles.shape == (sk.n_dofs,) and first.goals[0].error.shape == (3,)
    again = pickle.loads(pickle.dumps(result))
    np.testing.assert_array_equal(again.fitness, result.fitness)
    assert "fitness=" in repr(result) and "goals=" in repr(result)
    with pytest.raises(AttributeError, match="no attribute 'fitnes'"):
        _ = result.fitnes
