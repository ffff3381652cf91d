"""The DE engine and solve(): convergence on targets made by forward kinematics, determinism,
thread-count independence, the Engine API, limit modes, strict priority, batches, seeding with
initial poses and a multi-goal humanoid."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import deik
from deik.objectives import reference

SRC = Path(__file__).resolve().parents[2] / "src"
STRATEGIES = ["current-to-best/1/bin", "rand/1/bin", "best/1/bin"]


def fk_target(sk, seed, frame="tip", n=None):
    """Target(s) made by forward kinematics of random in-limit pose(s)."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(sk.lower, sk.upper, (sk.n_dofs,) if n is None else (n, sk.n_dofs))
    return deik.forward_kinematics(sk, q).position(frame), q


def tip_error(sk, angles, target):
    """Independent check: forward kinematics of the returned angles."""
    return np.linalg.norm(deik.forward_kinematics(sk, angles).position("tip") - target, axis=-1)


def within_limits(sk, angles):
    return bool(((angles >= sk.lower) & (angles <= sk.upper)).all())


# --- (a) convergence ---------------------------------------------------------------------------


@pytest.mark.parametrize("n, dims", [(10, 2), (6, 3)])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_default_settings_converge_within_one_percent_of_reach(n, dims, seed):
    sk = deik.chain(n, dims=dims)
    target, _ = fk_target(sk, 100 + seed)
    result = deik.solve(deik.Problem(sk, [deik.Position("tip", target)]), seed=seed)
    assert result.converged
    err = tip_error(sk, result.angles, target)
    assert err <= 0.01 * sk.reach
    assert result.errors["position tip"] == pytest.approx(err, abs=1e-9)
    assert within_limits(sk, result.angles)
    assert result.generations < result.settings.generations


@pytest.mark.parametrize("strategy", STRATEGIES)
@pytest.mark.parametrize("n, dims", [(10, 2), (6, 3)])
def test_every_strategy_converges_or_improves(strategy, n, dims):
    sk = deik.chain(n, dims=dims)
    target, _ = fk_target(sk, 7)
    problem = deik.Problem(sk, [deik.Position("tip", target, tolerance=0.002 * sk.reach)])
    engine = deik.Engine(problem, deik.Settings(strategy=strategy, population=128, seed=3, patience=100))
    start = engine.init()
    first_best = float(start.raw[0, start.best[0], 0])
    end = engine.run(start, 300)
    best = end.pop[0, end.best[0]].astype(np.float64)
    err = tip_error(sk, best, target)
    assert end.converged[0] or err < 0.5 * first_best
    assert err < first_best


def test_float64_reaches_tolerances_float32_cannot():
    sk = deik.chain(4)
    target, _ = fk_target(sk, 41)
    problem = deik.Problem(sk, [deik.Position("tip", target, tolerance=1e-9)])
    r = deik.solve(problem, population=32, seed=0, dtype="float64", patience=100)
    assert r.converged and tip_error(sk, r.angles, target) <= 1e-9
    r32 = deik.solve(problem, population=32, seed=0, dtype="float32", patience=100)
    assert not r32.converged and tip_error(sk, r32.angles, target) < 1e-5


# --- (b, c) determinism -------------------------------------------------------------------------


def test_same_seed_same_result_and_different_seed_different_result():
    sk = deik.chain(6, dims=3)
    target, _ = fk_target(sk, 11)
    problem = deik.Problem(sk, [deik.Position("tip", target, tolerance=0.001)])
    kw = dict(population=64, generations=80, stop_on_converged=False, patience=1000)
    a, b = deik.solve(problem, seed=5, **kw), deik.solve(problem, seed=5, **kw)
    np.testing.assert_array_equal(a.angles, b.angles)
    np.testing.assert_array_equal(a.history, b.history)
    assert a.generations == b.generations == 80
    c = deik.solve(problem, seed=6, **kw)
    assert not np.array_equal(a.angles, c.angles)
    assert not np.array_equal(a.history, c.history)


THREAD_SCRIPT = """
import numba, numpy as np, deik
sk = deik.chain(5, dims=3)
q = np.random.default_rng(3).uniform(sk.lower, sk.upper, (3, sk.n_dofs))
targets = deik.forward_kinematics(sk, q).position("tip")
problem = deik.Problem(sk, [deik.Position("tip", targets, tolerance=1e-4), deik.Comfort(level=1)])
r = deik.solve(problem, population=48, generations=40, seed=9)
print(numba.get_num_threads())
print(repr(r.angles.tolist()))
print(repr(r.history.tolist()))
"""


def _run_with_threads(n_threads):
    env = dict(
        os.environ,
        NUMBA_NUM_THREADS=str(n_threads),
        PYTHONPATH=os.pathsep.join([str(SRC)] + [p for p in [os.environ.get("PYTHONPATH")] if p]),
    )
    out = subprocess.run(
        [sys.executable, "-c", THREAD_SCRIPT], env=env, cwd=SRC.parent, capture_output=True, text=True, timeout=300
    )
    assert out.returncode == 0, out.stderr
    threads, angles, history = out.stdout.strip().splitlines()[-3:]
    return int(threads), angles, history


def test_results_do_not_depend_on_the_thread_count():
    t1, angles1, history1 = _run_with_threads(1)
    t2, angles2, history2 = _run_with_threads(2)
    assert (t1, t2) == (1, 2)
    assert angles1 == angles2
    assert history1 == history2
    assert len(eval(angles1)) == 3  # noqa: S307  (our own repr of a list of floats)


# --- (d) Engine API -----------------------------------------------------------------------------


def _snapshot(state):
    return {k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in vars(state).items()}


def _assert_same(state, snapshot):
    for k, v in snapshot.items():
        now = getattr(state, k)
        if isinstance(v, np.ndarray):
            np.testing.assert_array_equal(now, v, err_msg=k)
        else:
            assert now == v, k


def test_engine_init_step_run():
    sk = deik.chain(6, dims=3)
    target, _ = fk_target(sk, 12)
    problem = deik.Problem(sk, [deik.Position("tip", target, tolerance=1e-5)])
    # DE alone: the polish solves this target in the first generation, and the test needs a search
    # that keeps improving over 40 generations
    settings = deik.Settings(population=32, seed=4, patience=10_000, stop_on_converged=False, polish=0)
    engine = deik.Engine(problem, settings)
    s0 = engine.init()
    assert s0.pop.shape == (1, 32, sk.n_dofs) and s0.generation == 0 and s0.history.shape == (1, 0, 2)
    assert ((s0.pop >= sk.lower.astype(np.float32)) & (s0.pop <= sk.upper.astype(np.float32))).all()
    # the initial evaluation agrees with the float64 oracle on the same poses
    levels, total, raw = reference.fitness(problem, s0.pop[0].astype(np.float64))
    np.testing.assert_allclose(s0.total[0], total, atol=1e-5)
    np.testing.assert_allclose(s0.raw[0], raw, atol=1e-5)
    assert s0.best[0] == int(np.argmin(total))

    before = _snapshot(s0)
    s25 = engine.run(s0, 25)
    _assert_same(s0, before)  # run never changes the state passed in
    assert s25.generation == 25
    assert s25.generations.tolist() == [25]
    assert s25.history.shape == (1, 25, 2)

    stepped = s0
    for _ in range(25):
        stepped = engine.step(stepped)
    np.testing.assert_array_equal(stepped.pop, s25.pop)
    np.testing.assert_array_equal(stepped.history, s25.history)
    assert stepped.generation == 25

    started = engine.start(25)  # set-up and generations in one call: the same state
    for name in ("pop", "total", "best", "leaders", "best_seen", "generations", "history"):
        np.testing.assert_array_equal(getattr(started, name), getattr(s25, name))

    more = engine.run(s25, 15)
    assert more.generation == 40 and more.generations.tolist() == [40]
    np.testing.assert_array_equal(more.history[:, :25], s25.history)

    best = more.history[0, :, 0]
    assert (np.diff(best) <= 0).all()  # the best never gets worse
    assert best[-1] < best[0]
    assert (more.history[0, :, 1] >= best - 1e-7).all()  # mean >= best
    assert best[-1] == pytest.approx(float(more.total[0, more.best[0]]))
    assert more.best[0] == int(np.argmin(more.total[0]))


def test_solve_reports_generations_and_history():
    sk = deik.chain(4)
    target, _ = fk_target(sk, 13)
    problem = deik.Problem(sk, [deik.Position("tip", target, tolerance=1e-6)])
    r = deik.solve(problem, population=16, generations=37, patience=10_000, stop_on_converged=False)
    assert r.generations == 37 and r.history.shape == (37, 2)
    assert (np.diff(r.history[:, 0]) <= 0).all()
    calls = []
    deik.solve(
        problem,
        population=16,
        generations=250,
        patience=10_000,
        stop_on_converged=False,
        progress=lambda g, f: calls.append(g),
    )
    assert calls == [100, 200, 250]


# --- (e) limit modes ----------------------------------------------------------------------------


def _limited_problem(limits):
    sk = deik.chain(4, lower=-0.5, upper=0.5)  # +-0.5 is exact in float32
    # reachable by the chain, but not within the joint limits: the search presses on them
    return deik.Problem(sk, [deik.Position("tip", [-1.0, 1.0, 0.0])], limits=limits)


@pytest.mark.parametrize("mode", ["reflect", "clip"])
def test_reflect_and_clip_keep_every_individual_within_limits(mode):
    problem = _limited_problem(mode)
    sk = problem.skeleton
    engine = deik.Engine(problem, deik.Settings(population=32, seed=1, stop_on_converged=False))
    state = engine.init()
    at_limit = 0
    for _ in range(30):
        state = engine.step(state)
        assert ((state.pop >= sk.lower) & (state.pop <= sk.upper)).all()
        at_limit = max(at_limit, int((np.abs(state.pop) > 0.49).sum()))
    assert at_limit > 0  # the population really pushes against the limits


def test_paper_mode_lets_angles_leave_the_limits():
    """Sanity check that the limit test above can fail: without folding, genes leave +-0.5."""
    engine = deik.Engine(_limited_problem("paper"), deik.Settings(population=32, seed=1, stop_on_converged=False))
    state = engine.run(engine.init(), 30)
    assert (np.abs(state.pop) > 0.5).any()


def test_penalty_mode_final_best_is_within_limits():
    problem = _limited_problem("penalty")
    sk = problem.skeleton
    outside = np.array([[2.0, 1.0, 0.5, 0.3], [-1.0, 2.5, 0.0, 0.0]])  # start with poses outside
    r = deik.solve(problem, initial=outside, population=32, seed=2, generations=200)
    assert within_limits(sk, r.angles)
    assert r.errors["joint limits"] == 0.0
    assert r.errors["position tip"] > 0.1  # the target itself stays out of reach within limits
    # and penalty mode does rank limit violations first: a free solve gets much closer
    free = deik.solve(deik.Problem(sk, problem.goals[:1], limits="paper"), population=32, seed=2, generations=200)
    assert not within_limits(sk, free.angles)
    assert free.errors["position tip"] < r.errors["position tip"]


# --- (f) strict priority ------------------------------------------------------------------------


def _two_targets():
    sk = deik.chain(3)
    a = deik.forward_kinematics(sk, np.array([0.3, 0.4, -0.2])).position("tip")
    b = deik.forward_kinematics(sk, np.array([-0.5, 0.6, 0.3])).position("tip")
    return sk, a, b, float(np.linalg.norm(a - b))


def test_strict_priority_meets_level_zero_first():
    sk, a, b, gap = _two_targets()
    goals = [deik.Position("tip", a, tolerance=0.05, weight=0.2), deik.Position("tip", b, tolerance=0.03, level=1)]
    r = deik.solve(deik.Problem(sk, goals), population=64, seed=3, patience=100)
    err_a, err_b = tip_error(sk, r.angles, a), tip_error(sk, r.angles, b)
    assert err_a <= 0.05 + 1e-6  # level 0 met despite its smaller weight
    assert err_b > err_a
    assert err_b == pytest.approx(gap - 0.05, abs=0.01)  # as close to B as level 0 allows
    assert not r.converged  # level 1 cannot be met as well


def test_weights_in_one_level_trade_off_instead():
    """Same goals, one level: the weighted sum decides. With the concave normalisation
    1 - exp(-x) the weighted optimum on the segment A-B is the heavier goal's end, B."""
    sk, a, b, gap = _two_targets()
    goals = [deik.Position("tip", a, tolerance=0.05, weight=0.2), deik.Position("tip", b, tolerance=0.03, weight=1.0)]
    r = deik.solve(deik.Problem(sk, goals), population=64, seed=3, patience=100)
    err_a, err_b = tip_error(sk, r.angles, a), tip_error(sk, r.angles, b)
    assert err_a + err_b == pytest.approx(gap, abs=0.02)  # on the segment between the targets
    assert err_b < 0.03 and err_a > 0.05  # the weighted compromise favours B, not A


# --- (g) batches --------------------------------------------------------------------------------


def test_batch_solves_each_problem():
    sk = deik.chain(6, dims=3)
    targets, _ = fk_target(sk, 21, n=4)
    batch = deik.solve(deik.Problem(sk, [deik.Position("tip", targets)]), seed=2)
    assert batch.angles.shape == (4, sk.n_dofs) and batch.converged.shape == (4,)
    assert batch.converged.all()
    assert (tip_error(sk, batch.angles, targets) <= 0.01 * sk.reach).all()
    assert batch.errors["position tip"].shape == (4,)
    for b in range(4):
        n = int(batch.generations[b])
        assert (np.diff(batch.history[b, :n, 0]) <= 0).all() and np.isfinite(batch.history[b, :n]).all()
        assert np.isnan(batch.history[b, n:]).all()  # after a problem stops, while others run on
        single = deik.solve(deik.Problem(sk, [deik.Position("tip", targets[b])]), seed=2)
        assert single.converged
        if b == 0:
            # problem 0 draws the same random numbers alone or in a batch
            np.testing.assert_array_equal(single.angles, batch.angles[0])
            assert single.generations == batch.generations[0]


# --- (h) initial poses --------------------------------------------------------------------------


def test_exact_initial_pose_converges_without_a_generation():
    """The polish round before generation 0 finds the seeded pose meets the goal: no breeding."""
    sk = deik.chain(10)
    target, q = fk_target(sk, 31)
    problem = deik.Problem(sk, [deik.Position("tip", target, tolerance=1e-3)])
    r = deik.solve(problem, initial=q, seed=0)
    assert r.converged and r.generations == 0 and r.history.shape == (0, 2)
    assert tip_error(sk, r.angles, target) < 1e-4
    cold = deik.solve(problem, seed=0, polish=0)  # without the hint, DE alone takes a while
    assert cold.generations > 1


# --- (i) multi-goal humanoid --------------------------------------------------------------------


def test_humanoid_planted_foot_balance_and_reach():
    h = deik.humanoid()
    kin = deik.forward_kinematics(h, h.reference)
    support = np.mean([kin.position(f"right_{s}") for s in ("heel", "toe_inner", "toe_outer")], axis=0)
    hand_target = kin.position("left_hand") + [0.15, 0.35, 0.35]
    goals = [
        deik.Position("right_heel", kin.position("right_heel"), tolerance=0.005),
        deik.Position("right_toe_tip", kin.position("right_toe_tip"), tolerance=0.005),
        deik.ComOverSupport(support, tolerance=0.02),
        deik.Position("left_hand", hand_target, level=1, tolerance=0.01),
        deik.Comfort(level=2),
    ]
    r = deik.solve(deik.Problem(h, goals), population=256, seed=1)
    assert r.converged
    assert within_limits(h, r.angles)
    got = deik.forward_kinematics(h, r.angles)
    assert np.linalg.norm(got.position("right_heel") - kin.position("right_heel")) <= 0.005
    assert np.linalg.norm(got.position("right_toe_tip") - kin.position("right_toe_tip")) <= 0.005
    horizontal = (got.p_world_com - support)[[0, 2]]  # Y is up
    assert np.linalg.norm(horizontal) <= 0.02 + 1e-6
    assert np.linalg.norm(got.position("left_hand") - hand_target) <= 0.01


def test_history_of_a_problem_that_stops_early_is_nan_after_it_stops():
    sk = deik.chain(3)
    kin = deik.forward_kinematics(sk, np.random.default_rng(4).uniform(-2, 2, (2, 3)))
    tips, elbows = kin.position("tip"), kin.position("link2")
    elbows[1] = -0.5 * tips[1]  # problem 1 cannot meet both goals: it runs until it stagnates
    problem = deik.Problem(
        sk, [deik.Position("tip", tips, tolerance=1e-3), deik.Position("link2", elbows, tolerance=1e-3)]
    )
    result = deik.solve(problem, seed=0, population=16, patience=5, restarts=0)
    n0, n1 = (int(n) for n in result.generations)
    assert result.converged.tolist() == [True, False] and n0 < n1 == result.history.shape[1]
    assert np.isfinite(result.history[0, :n0]).all() and np.isnan(result.history[0, n0:]).all()
    assert np.isfinite(result.history[1]).all() and (np.diff(result.history[1, :, 0]) <= 0).all()


def test_an_engine_with_another_seed_starts_as_one_built_with_it():
    sk = deik.chain(6, dims=3)
    target, _ = fk_target(sk, 3)
    problem = deik.Problem(sk, [deik.Position("tip", target, tolerance=1e-5)])
    settings = deik.Settings(population=16, seed=1, polish=0)
    moved = deik.Engine(problem, settings).with_seed(9)
    built = deik.Engine(problem, settings.with_seed(9))
    assert moved.settings.seed == 9 and settings.seed == 1  # the original keeps its own
    np.testing.assert_array_equal(moved.init().pop, built.init().pop)
    assert not np.array_equal(moved.init().pop, deik.Engine(problem, settings).init().pop)
    with pytest.raises(ValueError, match="seed must be an integer"):
        deik.Engine(problem, settings).with_seed(-1)
