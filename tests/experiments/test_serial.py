"""The paper's serial DE reference (Algorithm 1, deik.experiments.serial_numpy)."""

import numpy as np
import pytest

import deik
from deik.experiments.serial_numpy import SerialDE, apply_limits, not_worse
from deik.model.kinematics import forward_kinematics
from deik.objectives.reference import fitness


def chain_problem(n_links=5, seed=12345, limits="reflect"):
    sk = deik.chain(n_links)
    q = np.random.default_rng(seed).uniform(sk.lower, sk.upper)
    target = forward_kinematics(sk, q).position("tip")
    return deik.Problem(sk, [deik.Position("tip", target)], limits=limits)


def test_converges_within_one_percent_of_reach():
    problem = chain_problem()
    reach = problem.skeleton.reach
    de = SerialDE(problem, population=30, seed=0).init()
    start = de.best_errors[0]
    assert start > 0.01 * reach  # not solved by the first population
    de.run(150, tolerance=0.01 * reach)
    assert de.best_errors[0] <= 0.01 * reach
    assert de.generation < 150
    best = de.history[:, 0]
    assert len(best) == de.generation
    assert np.all(np.diff(best) <= 0)  # elitist: the best never gets worse
    assert best[-1] < best[0]


def test_best_fitness_matches_reference():
    problem = chain_problem()
    de = SerialDE(problem, population=20, seed=3).init()
    de.run(5)
    levels, total, raw = fitness(problem, de.best_pose[None])
    np.testing.assert_allclose(de.best_errors, raw[0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(de.best_levels, levels[0], rtol=0, atol=1e-12)
    assert de.best_total == pytest.approx(total[0], abs=1e-12)
    # the cached fitness of every individual is exact (one pose at a time equals the batch)
    levels, total, raw = fitness(problem, de.pop)
    np.testing.assert_allclose(de.total, total, atol=1e-12)
    np.testing.assert_allclose(de.raw, raw, atol=1e-12)
    assert de.best_index == int(np.lexsort(levels.T[::-1])[0])


def test_population_starts_inside_limits():
    problem = chain_problem(limits="penalty")
    sk = problem.skeleton
    de = SerialDE(problem, population=50, seed=1).init()
    assert de.pop.shape == (50, sk.n_dofs)
    assert np.all(de.pop >= sk.lower) and np.all(de.pop <= sk.upper)
    assert np.all(sk.lower == -np.pi) and np.all(sk.upper == np.pi)  # the paper's -pi..pi


def test_iteration_replaces_exactly_the_target_when_better():
    problem = chain_problem()
    de = SerialDE(problem, population=12, seed=7).init()
    seen_accept = seen_reject = False
    for _ in range(200):
        before = de.pop.copy()
        before_levels = de.levels.copy()
        it = de.iterate()
        changed = np.flatnonzero((de.pop != before).any(axis=1))
        cand_levels = fitness(problem, it.candidate[None])[0][0]
        assert it.accepted == not_worse(cand_levels, before_levels[it.x])
        if it.accepted:
            seen_accept = True
            assert set(changed) <= {it.x}
            np.testing.assert_array_equal(de.pop[it.x], it.candidate)
            np.testing.assert_allclose(de.levels[it.x], cand_levels, atol=1e-12)
        else:
            seen_reject = True
            assert changed.size == 0
            np.testing.assert_array_equal(de.levels, before_levels)
    assert seen_accept and seen_reject


def test_epoch_is_in_place():
    """Replaying an epoch's log shows that each iteration reads the population as already
    changed by the earlier iterations of the same epoch (Algorithm 1, not ping-pong)."""
    problem = chain_problem()
    sk = problem.skeleton
    de = SerialDE(problem, population=10, seed=2).init()
    pop = de.pop.copy()
    log = de.epoch(record=True)
    assert len(log) == 10 and de.generation == 1
    reads_replaced = False
    replaced = set()
    for it in log:
        a, b, c = it.donors
        mutant = pop[a] + de.F * (pop[b] - pop[c])
        expected = apply_limits(np.where(it.mask, mutant, pop[it.x]), sk.lower, sk.upper, problem.limits)
        np.testing.assert_array_equal(it.candidate, expected)
        reads_replaced |= bool(replaced & {it.x, a, b, c})
        if it.accepted:
            pop[it.x] = it.candidate
            replaced.add(it.x)
    np.testing.assert_array_equal(de.pop, pop)
    assert reads_replaced  # some iteration used an individual replaced earlier in the epoch


def test_donors_distinct_and_forced_gene_crosses():
    problem = chain_problem()
    de = SerialDE(problem, population=4, CR=0.0, seed=5).init()
    for _ in range(3):
        for it in de.epoch(record=True):
            assert len({it.x, *it.donors}) == 4
            assert it.mask[it.forced] and it.mask.sum() == 1  # CR = 0: only the forced gene


def test_seeded_runs_reproducible():
    problem = chain_problem()
    a = SerialDE(problem, population=20, seed=11).run(4)
    b = SerialDE(problem, population=20, seed=11).run(4)
    c = SerialDE(problem, population=20, seed=12).run(4)
    np.testing.assert_array_equal(a.pop, b.pop)
    np.testing.assert_array_equal(a.history, b.history)
    assert not np.array_equal(a.pop, c.pop)
    a.init()  # init() restarts the same seeded stream
    np.testing.assert_array_equal(a.pop, SerialDE(problem, population=20, seed=11).init().pop)


def test_limit_modes():
    lo, hi = np.full(3, -1.0), np.full(3, 1.0)
    v = np.array([-1.5, 0.5, 1.25])
    np.testing.assert_allclose(apply_limits(v, lo, hi, "reflect"), [-0.5, 0.5, 0.75])
    np.testing.assert_allclose(apply_limits(v, lo, hi, "clip"), [-1.0, 0.5, 1.0])
    np.testing.assert_allclose(apply_limits(v, lo, hi, "penalty"), v)
    w = np.array([7.0, -7.5, 1.0])
    expected = [7.0 / (7.0 - 2 * np.pi), -7.5 / (7.5 - 2 * np.pi), 1.0]
    np.testing.assert_allclose(apply_limits(w, lo, hi, "paper"), expected)


def test_not_worse_is_lexicographic():
    assert not_worse(np.array([0.1, 9.0]), np.array([0.2, 0.0]))
    assert not not_worse(np.array([0.2, 0.0]), np.array([0.1, 9.0]))
    assert not_worse(np.array([0.1, 0.5]), np.array([0.1, 0.5]))
    assert not not_worse(np.array([0.1, 0.6]), np.array([0.1, 0.5]))


def test_argument_checks():
    problem = chain_problem()
    with pytest.raises(ValueError):
        SerialDE(problem, population=3)
    with pytest.raises(ValueError):
        SerialDE(problem, F=0.0)
    with pytest.raises(ValueError):
        SerialDE(problem, CR=1.5)
    with pytest.raises(TypeError):
        SerialDE("not a problem")
    with pytest.raises(RuntimeError):
        SerialDE(problem).iterate()


def _draws(device_maths, device_evolution, P, D, CR, seed, j):
    """Iteration j of epoch 0: target x, donors a, b, c, forced gene and crossover mask (D,)."""
    key = device_maths.stream(seed, 0, 0, j)
    x = int(device_maths.below(P, key, 0))
    a = int(device_evolution.donor(P, x, 0, 0, 1, key, 1))
    b = int(device_evolution.donor(P, x, a, 0, 2, key, 2))
    c = int(device_evolution.donor(P, x, a, b, 3, key, 3))
    forced = int(device_maths.below(D, key, 4))
    mask = np.array([device_maths.unit(key, 5 + d) < CR for d in range(D)])
    mask[forced] = True
    return x, a, b, c, forced, mask


def test_compiled_serial_epoch_is_algorithm_1_replayed_in_python():
    """One epoch of the compiled serial DE equals a Python replay of Algorithm 1 that draws the
    same counter-based numbers (the device functions run as plain Python) and scores candidates
    with the NumPy oracle: in-place replacement, donors distinct from x, forced gene, reflect."""
    from deik.device import evolution as device_evolution
    from deik.device import maths as device_maths
    from deik.experiments.serial_compiled import CompiledSerialDE

    sk = deik.chain(5, dims=3)
    q = np.random.default_rng(4).uniform(sk.lower, sk.upper)
    problem = deik.Problem(sk, [deik.Position("tip", forward_kinematics(sk, q).position("tip"))])
    P, F, CR, seed = 12, 0.7, 0.6, 9
    compiled = CompiledSerialDE(problem, population=P, F=F, CR=CR, seed=seed, dtype="float64")
    pop = compiled._buffers[0][0].copy()
    levels = fitness(problem, pop)[0]
    for j in range(P):
        with np.errstate(over="ignore"):  # the counter hash multiplies modulo 2**64 on purpose
            x, a, b, c, forced, mask = _draws(device_maths, device_evolution, P, sk.n_dofs, CR, seed, j)
        assert len({x, a, b, c}) == 4
        candidate = apply_limits(np.where(mask, pop[a] + F * (pop[b] - pop[c]), pop[x]), sk.lower, sk.upper, "reflect")
        new_levels = fitness(problem, candidate[None])[0][0]
        if not_worse(new_levels, levels[x]):
            pop[x], levels[x] = candidate, new_levels
    compiled.run(1)
    np.testing.assert_allclose(compiled._buffers[0][0], pop, rtol=0, atol=1e-12)


def test_compiled_serial_converges_like_the_numpy_reference():
    from deik.experiments.serial_compiled import CompiledSerialDE

    sk = deik.chain(8)
    q = np.random.default_rng(2).uniform(sk.lower, sk.upper)
    problem = deik.Problem(sk, [deik.Position("tip", forward_kinematics(sk, q).position("tip"))])
    compiled = CompiledSerialDE(problem, population=100, seed=3).run(300)
    assert compiled.best_errors[0] < 0.01 * sk.reach
    assert np.all(np.diff(compiled.history[:, 0]) <= 0)  # the best never gets worse
