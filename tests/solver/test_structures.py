"""A problem of a goal structure compiled before takes the kept rows and table with its own
targets (solver/structures.py): its table is the one a full compile gives, bad targets fail as
before, and anything that changes the structure compiles afresh. deik.solve's settings merge
checks a loop's settings once and still gives each call its own seed."""

import numpy as np
import pytest

import deik
from deik.errors import InputError
from deik.solver import structures
from deik.solver.solve import merge_settings


def _arm():
    """A 6-DOF spatial chain and FK targets (positions, rotations) of 20 random in-limit poses."""
    sk = deik.chain(6, dims=3)
    poses = np.random.default_rng(4).uniform(sk.lower, sk.upper, (20, sk.n_dofs))
    kin = deik.forward_kinematics(sk, poses)
    return sk, kin.position("tip"), kin.rotation("tip")


def _goals(p, R, **position):
    return [deik.Position("tip", p, **position), deik.Orientation("tip", R, tolerance=1e-4, level=1)]


def _assert_same_table(problem, sk, goals, limits="reflect"):
    fresh = deik.Problem(sk, goals, limits)._compile_rows()  # every row checked and packed
    for name in ("term_int", "term_float", "params", "dof_weight", "pair_int", "pair_radius"):
        np.testing.assert_array_equal(getattr(problem.table, name), getattr(fresh.table, name), err_msg=name)
    assert problem.table.labels == fresh.table.labels and problem.batch_shape == fresh.batch_shape == ()
    np.testing.assert_array_equal(problem.reference, fresh.reference)


@pytest.mark.parametrize("limits", ["reflect", "penalty"])
def test_problems_of_one_structure_compile_to_the_full_compiles_table(limits):
    sk, P, R = _arm()
    first = deik.Problem(sk, _goals(P[0], R[0], tolerance=1e-5), limits)
    for k in range(1, 20):
        goals = _goals(P[k], R[k], tolerance=1e-5)
        problem = deik.Problem(sk, goals, limits)
        assert problem.table.term_int is first.table.term_int  # the kept structure was taken
        _assert_same_table(problem, sk, goals, limits)
    np.testing.assert_array_equal(first.table.params[0, 0, :3], P[0])  # the first keeps its own targets


def test_a_changed_weight_tolerance_frame_or_mask_compiles_afresh():
    sk, P, R = _arm()
    base = deik.Problem(sk, _goals(P[0], R[0], tolerance=1e-5))
    for goals in (
        _goals(P[1], R[1], tolerance=1e-3),
        _goals(P[1], R[1], tolerance=1e-5, weight=0.5),
        [deik.Position("link3", P[1] * 0.3), deik.Orientation("tip", R[1], tolerance=1e-4, level=1)],
        _goals(P[1], R[1], tolerance=1e-5, active=np.array([True])),
    ):
        problem = deik.Problem(sk, goals)
        assert problem.table.term_float is not base.table.term_float  # compiled, not taken
        full = deik.Problem(sk, goals)._compile_rows()
        np.testing.assert_array_equal(problem.table.term_float, full.table.term_float)
        np.testing.assert_array_equal(problem.table.params, full.table.params)


def test_targets_the_quick_checks_decline_compile_in_full_and_fail_as_before():
    sk, P, R = _arm()
    deik.Problem(sk, _goals(P[0], R[0], tolerance=1e-5))
    batched = deik.Problem(sk, _goals(P[:3], R[:3], tolerance=1e-5))  # a batch axis
    assert batched.batch_shape == (3,)
    np.testing.assert_array_equal(batched.table.params[:, 0, :3], P[:3])
    with pytest.raises(InputError, match="unreachable"):
        deik.Problem(sk, _goals(P[1] * 100, R[1], tolerance=1e-5))
    with pytest.raises(InputError, match="NaN"):
        deik.Problem(sk, _goals(np.array([np.nan, 0, 0]), R[1], tolerance=1e-5))
    with pytest.raises(InputError):
        deik.Problem(sk, _goals(P[1], R[1] * 2, tolerance=1e-5))  # not a rotation
    with pytest.raises(InputError, match="shape"):
        deik.Problem(sk, _goals(P[1][:2], R[1], tolerance=1e-5))


def test_a_goal_with_an_array_field_has_no_plain_structure_and_is_never_kept():
    sk, P, R = _arm()
    comfort = deik.Comfort(reference=np.zeros(sk.n_dofs))
    assert comfort.structure() is None and deik.Comfort().structure() is not None
    assert deik.Position("tip", P[0], weight=1).structure() != deik.Position("tip", P[0], weight=1.0).structure()
    before = len(structures._known)
    deik.Problem(sk, [deik.Position("tip", P[0]), comfort])
    assert len(structures._known) == before


def test_a_solve_of_a_recalled_problem_answers_its_own_target():
    sk, P, R = _arm()
    for k in range(5):
        problem = deik.Problem(sk, _goals(P[k], R[k], tolerance=1e-6))
        result = deik.solve(problem, population=16, dtype="float64", seed=k)
        kin = deik.forward_kinematics(sk, result.angles)
        assert np.linalg.norm(kin.position("tip") - P[k]) < 1e-6


def test_merged_settings_carry_each_calls_seed_and_are_checked():
    first = merge_settings("solve()", None, {"population": 24, "seed": 5})
    again = merge_settings("solve()", None, {"population": 24, "seed": 9})
    unseeded = merge_settings("solve()", None, {"population": 24})
    assert (first.seed, again.seed, unseeded.seed) == (5, 9, deik.Settings().seed)
    assert first.population == again.population == unseeded.population == 24
    base = deik.Settings(seed=7, population=40)
    assert merge_settings("solve()", base, {}).seed == 7
    assert merge_settings("solve()", base, {"seed": 2}) == deik.Settings(seed=2, population=40)
    with pytest.raises(InputError, match="seed"):
        merge_settings("solve()", None, {"population": 24, "seed": -1})
    with pytest.raises(InputError, match="population"):
        merge_settings("solve()", None, {"population": True})  # a bool is not an integer, though True == 1
    assert merge_settings("solve()", None, {"population": np.int64(24)}).population == 24
