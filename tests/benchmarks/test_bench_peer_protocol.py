"""The robot benchmark's protocol: the peers' shared random restarts and the solvers' turns on chunks.

Runs in the deik venv alone: nothing here needs the peers venv (.venv-peers).
"""

import time
from collections import Counter

import numpy as np
import pytest

from benchmarks.harness import chunk_bounds, take_turns, turn_order
from benchmarks.peer_process import PeerFailed
from benchmarks.peers.common import POS_TOL, solve_with_restarts

LOWER, UPPER = -np.ones(3), np.ones(3)
TARGET, ORIGIN = np.array([0.5, -0.25, 0.75]), np.zeros(3)


def fk(q):
    """A 'robot' whose tip position is its joint vector (orientation fixed)."""
    return np.asarray(q, dtype=float), np.eye(3)


class Clock:
    """A clock that moves only when an attempt runs: `step` units per attempt."""

    def __init__(self, step: float):
        self.now, self.step = 0.0, step

    def __call__(self) -> float:
        return self.now


def restarts(attempt, seed=7, budget=5.0, clock=None, start=ORIGIN):
    return solve_with_restarts(attempt, fk, (TARGET, np.eye(3)), start, (LOWER, UPPER), seed, budget, clock)


def test_restarts_stop_at_the_first_success():
    calls = []

    def attempt(q0, left):  # succeeds on its third call
        calls.append(q0.copy())
        return TARGET + (0 if len(calls) == 3 else 0.1)

    q, attempts = restarts(attempt, budget=10.0)
    assert attempts == 3 == len(calls)
    np.testing.assert_array_equal(q, TARGET)
    np.testing.assert_array_equal(calls[0], np.zeros(3))  # the first attempt starts at `start`
    assert all(((c >= LOWER) & (c <= UPPER)).all() for c in calls[1:])


def test_a_success_out_of_limits_is_not_a_success():
    def attempt(q0, left):
        return np.array([2.0, 0.0, 0.0]) if q0[0] == 0 else TARGET

    _, attempts = restarts(attempt, start=np.zeros(3), budget=10.0)
    assert attempts == 2


def test_restarts_stop_at_the_budget_and_pass_the_time_left():
    clock, lefts = Clock(1.0), []

    def attempt(q0, left):  # never reaches the target; each attempt takes one unit
        lefts.append(left)
        clock.now += clock.step
        return q0

    q, attempts = restarts(attempt, budget=5.0, clock=clock)
    assert attempts == 5 and lefts == [5.0, 4.0, 3.0, 2.0, 1.0]
    assert np.linalg.norm(q - TARGET) > POS_TOL


def test_restarts_keep_to_the_wall_clock_budget():
    def attempt(q0, left):
        time.sleep(0.001)
        return q0

    t0 = time.perf_counter()
    _, attempts = restarts(attempt, budget=0.005, clock=time.perf_counter)
    elapsed = time.perf_counter() - t0
    assert 0.005 <= elapsed < 0.1 and 1 <= attempts <= 5


def test_restarts_are_deterministic_for_a_seed_and_return_the_nearest_answer():
    def run(seed):
        clock, starts = Clock(1.0), []

        def attempt(q0, left):
            starts.append(q0.copy())
            clock.now += clock.step
            return q0

        q, _ = restarts(attempt, seed=seed, budget=20.0, clock=clock)
        return q, np.array(starts)

    (q_a, a), (q_b, b), (_, c) = run([2718, 3]), run([2718, 3]), run([2718, 4])
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(q_a, q_b)
    assert not np.allclose(a[1:], c[1:])
    nearest = a[np.argmin(np.linalg.norm(a - TARGET, axis=1))]
    np.testing.assert_array_equal(q_a, nearest)


@pytest.mark.parametrize(("n", "chunks"), [(1000, 10), (23, 10), (7, 10), (1, 3)])
def test_every_solver_sees_every_target_once(n, chunks):
    solvers = ["deik", "deik-solver", "deik-batch", "pink", "rtb"]
    order = turn_order(n, chunks, solvers)
    for name in solvers:
        seen = [k for s, a, b in order if s == name for k in range(a, b)]
        assert seen == list(range(n))
    sizes = [b - a for a, b in chunk_bounds(n, chunks)]
    assert min(sizes) >= 1 and max(sizes) - min(sizes) <= 1 and len(sizes) == min(n, chunks)


@pytest.mark.parametrize(
    "solvers", [["deik", "placo", "tracik"], ["deik", "deik-solver", "deik-batch", "rtb", "tracik"], list("abcd")]
)
def test_turns_alternate_chunk_by_chunk_and_every_solver_follows_every_other_alike(solvers):
    k = len(solvers)
    cycle = 2 * k if k % 2 else k
    order = turn_order(10 * cycle, cycle, solvers)
    follows = Counter()
    for chunk in range(cycle):  # every solver has its turn on a chunk before the next chunk starts
        turns = [name for name, _, _ in order[k * chunk : k * chunk + k]]
        assert len({(a, b) for _, a, b in order[k * chunk : k * chunk + k]}) == 1 and sorted(turns) == sorted(solvers)
        follows.update(zip(turns, turns[1:]))
    # within the chunks, every ordered pair of solvers is adjacent equally often
    assert set(follows) == {(a, b) for a in solvers for b in solvers if a != b}
    assert len(set(follows.values())) == 1


def test_take_turns_joins_outputs_in_target_order_and_drops_a_failed_peer():
    log = []

    def runner(name, fail_at=None):
        def run(a, b):
            log.append((name, a))
            if a == fail_at:
                raise PeerFailed("crashed")
            return {"targets": list(range(a, b)), "wall": [b - a]}

        return run

    out = take_turns({"deik": runner("deik"), "peer": runner("peer", fail_at=4), "other": runner("other")}, 10, 5)
    assert out["deik"]["targets"] == list(range(10)) and out["deik"]["wall"] == [2] * 5
    assert out["other"]["targets"] == list(range(10))
    assert out["peer"] == {"skipped": "crashed"}
    assert [name for name, _ in log[:3]] == ["deik", "peer", "other"] and {name for name, _ in log[3:6]} == {
        "deik",
        "peer",
        "other",
    }
    assert ("peer", 6) not in log
