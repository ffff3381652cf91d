"""The memetic parts of the solver: analytic Jacobians against finite differences, the
Levenberg-Marquardt polish (precision, limits), jDE rates, restarts and the time budget."""

import numpy as np
import pytest

import deik
from helpers import finite_difference_check, shared_path


def _panda():
    return deik.read_urdf(shared_path("robots", "panda.urdf"), "panda_link0", "panda_hand_tcp")


def _random_poses(sk, n, seed):
    return np.random.default_rng(seed).uniform(sk.lower, sk.upper, (n, sk.n_dofs))


def test_jacobians_match_finite_differences_on_a_urdf_arm(shared_data):
    sk = _panda()
    poses = _random_poses(sk, 6, 0)
    far = deik.forward_kinematics(sk, _random_poses(sk, 1, 1))
    goals = [
        deik.Position("panda_hand_tcp", far.position("panda_hand_tcp")[0]),
        deik.Orientation("panda_hand_tcp", far.rotation("panda_hand_tcp")[0]),
        deik.Position("panda_link4", [0.3, 0.1, 0.5]),
        deik.CentreOfMass([0.1, 0.0, 0.4]),
    ]
    finite_difference_check(sk, goals, poses)


def test_jacobians_match_finite_differences_on_a_bvh_character(shared_data):
    clip = deik.read_bvh(shared_path("humanoid", "humanoid3d_walk.bvh"))
    sk = clip.skeleton
    poses = clip.poses()[::10] + np.random.default_rng(2).normal(0, 0.2, (4, sk.n_dofs))
    site = sk.site_names[1]
    goals = [
        deik.Position(site, [0.3, 0.2, 0.1]),
        deik.Orientation(site, np.eye(3)),
        deik.CentreOfMass([0.0, 0.9, 0.0]),
        deik.ComOverSupport([0.1, 0.0, 0.2]),
    ]
    finite_difference_check(sk, goals, poses)


def _pose_problem(sk, tip, q, **tolerances):
    kin = deik.forward_kinematics(sk, q)
    return deik.Problem(
        sk,
        [
            deik.Position(tip, kin.position(tip), tolerance=tolerances.get("position", 1e-6)),
            deik.Orientation(tip, kin.rotation(tip), tolerance=tolerances.get("angle", 1e-5)),
        ],
    )


def test_polish_converges_to_a_micrometre_from_near_a_solution(shared_data):
    sk = _panda()
    truth = _random_poses(sk, 8, 3)
    near = np.clip(truth + np.random.default_rng(4).normal(0, 0.05, truth.shape), sk.lower, sk.upper)
    for q, start in zip(truth, near):
        problem = _pose_problem(sk, "panda_hand_tcp", q)
        polished = deik.solve(problem, initial=start[None], population=8, generations=1, dtype="float64", seed=1)
        assert polished.converged, [float(g.error) for g in polished.goals]
        assert polished.goals[0].error < 1e-6 and polished.goals[1].error < 1e-5
        unpolished = deik.solve(
            problem, initial=start[None], population=8, generations=1, dtype="float64", seed=1, polish=0
        )
        assert unpolished.goals[0].error > 1e-4  # one DE generation alone does not get there


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_polish_never_leaves_the_joint_limits(shared_data, dtype):
    sk = _panda()
    truth = _random_poses(sk, 12, 5)
    truth[:, ::2] = np.where(truth[:, ::2] > 0, sk.upper[::2], sk.lower[::2])  # targets with joints at a limit
    problem = deik.Problem(
        sk,
        [
            deik.Position(
                "panda_hand_tcp", deik.forward_kinematics(sk, truth).position("panda_hand_tcp"), tolerance=1e-4
            )
        ],
    )
    engine = deik.Engine(problem, deik.Settings(population=16, dtype=dtype, seed=2, polish_count=16, polish_every=1))
    state = engine.run(engine.init(), 30)
    assert (state.pop >= sk.lower.astype(dtype)).all() and (state.pop <= sk.upper.astype(dtype)).all()
    assert state.converged.mean() > 0.9


def test_jde_rates_adapt_within_their_ranges_and_fixed_rates_do_not():
    sk = deik.chain(8, dims=3)
    q = _random_poses(sk, 1, 6)[0]
    problem = deik.Problem(sk, [deik.Position("tip", deik.forward_kinematics(sk, q).position("tip"))])
    settings = deik.Settings(population=32, seed=3, polish=0, stop_on_converged=False, patience=10_000)
    engine = deik.Engine(problem, settings)
    state = engine.run(engine.init(), 60)
    F, CR = state.rates[..., 0], state.rates[..., 1]
    assert (F >= 0.1 - 1e-7).all() and (F <= 1.0).all() and (CR >= 0).all() and (CR <= 1).all()
    assert len(np.unique(F)) > 5 and len(np.unique(CR)) > 5  # individuals carry their own rates
    fixed = deik.Engine(problem, deik.Settings(**{**vars(settings), "adaptive": False}))
    rates = fixed.run(fixed.init(), 60).rates
    assert (rates[..., 0] == np.float32(0.5)).all() and (rates[..., 1] == np.float32(0.9)).all()
    again = engine.run(engine.init(), 60)
    np.testing.assert_array_equal(again.pop, state.pop)
    np.testing.assert_array_equal(again.rates, state.rates)


def _conflicting_problem(*more_goals):
    """Tip and elbow targets 4 apart with 2 links between them: no pose meets both, so the
    search can only stagnate; `more_goals` are added."""
    sk = deik.chain(4)
    return deik.Problem(
        sk,
        [
            deik.Position("tip", [2.5, 0.0, 0.0], tolerance=1e-4),
            deik.Position("link2", [-1.5, 0.0, 0.0], tolerance=1e-4),
            *more_goals,
        ],
    )


def test_restarts_keep_the_best_and_are_reproducible():
    # an aim the polish cannot differentiate: restarts wait for `patience` generations of stagnation
    problem = _conflicting_problem(deik.Aim("tip", [0.0, 3.0, 0.0], axis=(1.0, 0.0, 0.0), tolerance=1e-4))
    kw = dict(population=16, generations=400, patience=20, restarts=5, seed=4)
    result = deik.solve(problem, **kw)
    best = result.history[:, 0]
    assert (np.diff(best) <= 1e-12).all(), "the elite kept through a restart must never get worse"
    engine = deik.Engine(problem, deik.Settings(**kw))
    state = engine.run(engine.init(), 400)
    assert state.restarts[0] == 5 and not state.active[0]
    again = deik.solve(problem, **kw)
    np.testing.assert_array_equal(again.angles, result.angles)
    none = deik.Engine(problem, deik.Settings(**{**kw, "restarts": 0}))
    assert none.run(none.init(), 400).generation < state.generation


def test_a_polish_round_that_meets_nothing_restarts_at_once():
    # every goal has a tolerance and residual rows, so the polish sees the whole problem: a
    # round whose 16 polished starts all miss restarts without waiting for `patience`
    kw = dict(population=16, generations=400, patience=1000, restarts=3, seed=4, polish_every=10)
    engine = deik.Engine(_conflicting_problem(), deik.Settings(**kw))
    state = engine.run(engine.init(), 15)
    assert state.restarts[0] >= 1 and state.active[0]
    # with an aim the polish cannot differentiate, the same round waits for the patience
    seeing_less = deik.Engine(
        _conflicting_problem(deik.Aim("tip", [0.0, 3.0, 0.0], tolerance=1e-4)), deik.Settings(**kw)
    )
    assert seeing_less.run(seeing_less.init(), 15).restarts[0] == 0


def test_time_limit_stops_a_search_that_cannot_converge():
    problem = _conflicting_problem()
    deik.solve(problem, population=16, generations=5)  # compile first
    result = deik.solve(problem, population=64, generations=10**7, patience=10**6, time_limit=0.5, seed=1)
    assert 0.5 <= result.wall_time < 1.5
    assert 1 < result.generations < 10**7 and not result.converged


def test_time_limit_must_be_positive():
    with pytest.raises(ValueError, match="time_limit"):
        deik.Settings(time_limit=0)
    with pytest.raises(ValueError, match="polish"):
        deik.Settings(polish=-1)
    with pytest.raises(ValueError, match="polish_count must be at most 128"):
        deik.Settings(population=256, polish_count=129)


def test_panda_poses_solved_to_ten_micrometres_from_the_mid_pose(shared_data):
    sk = _panda()
    truth = _random_poses(sk, 40, 8)
    kin = deik.forward_kinematics(sk, truth)
    start = (sk.lower + sk.upper) / 2
    for n in range(len(truth)):
        problem = deik.Problem(
            sk,
            [
                deik.Position("panda_hand_tcp", kin.position("panda_hand_tcp")[n], tolerance=1e-5),
                deik.Orientation("panda_hand_tcp", kin.rotation("panda_hand_tcp")[n], tolerance=1e-4),
            ],
        )
        result = deik.solve(problem, initial=start[None], population=32, patience=100, dtype="float64", seed=n)
        assert result.converged, n
        assert (result.angles >= sk.lower).all() and (result.angles <= sk.upper).all()
