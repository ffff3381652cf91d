"""How a solve cuts its generations into kernel launches (deik.solver.launches): each about a
quarter of a second at the measured pace, growing at most GROWTH-fold from a first guess, and
within the budget. Paces are given, not timed, so nothing here depends on the machine."""

import math

import numpy as np
import pytest

import deik
from deik.solver.halting import GUARD_SECONDS, guarded
from deik.solver.launches import GROWTH, LAUNCH_SECONDS, PROGRESS_CHUNK, Launches


def test_launches_settle_at_a_quarter_second_of_generations():
    launches = Launches(deik.Settings(generations=10**9), frame_work=10**6, polish_work=0.0, progress=False, start=0.0)
    pace, done, sizes = 1e-4, 0, []  # seconds per generation
    for _ in range(12):
        count = launches.next(done)
        assert not sizes or count <= GROWTH * sizes[-1]  # a first launch slowed by compiling sets no pace
        launches.ran(count, count * pace)
        done, sizes = done + count, sizes + [count]
    assert sizes[-1] * pace == pytest.approx(LAUNCH_SECONDS, rel=0.01)


def test_launches_stop_at_the_budget_and_report_progress_in_chunks():
    launches = Launches(deik.Settings(generations=250), frame_work=1, polish_work=0.0, progress=True, start=0.0)
    assert launches.next(0) == PROGRESS_CHUNK and launches.next(200) == 50
    assert not launches.more(250, any_active=True) and not launches.more(10, any_active=False)
    assert launches.more(0, any_active=True) and not math.isfinite(launches.deadline)


def test_a_first_launch_ends_within_the_guard_and_splitting_changes_no_answer():
    sk = deik.chain(8, dims=3)
    settings = deik.Settings(population=24, polish=0, patience=10**5, generations=10**5, dtype="float64")
    n_frames = sk.n_joints + len(sk.site_names)
    launches = Launches(settings, frame_work=24 * n_frames, polish_work=0.0, progress=False, start=0.0)
    first = launches.next(0)
    assert 1 < first < settings.generations and launches.expected_seconds(first) < GUARD_SECONDS
    assert not guarded(np.zeros(1, np.int64), math.inf, launches.expected_seconds(first))._armed
    huge = Launches(settings, frame_work=10**9, polish_work=0.0, progress=False, start=0.0)
    assert huge.next(0) == 1  # a generation past the guard's time: the launch is guarded
    # a solve past its first launch answers as one cut into progress chunks does, bit for bit
    q = np.random.default_rng(5).uniform(sk.lower, sk.upper, sk.n_dofs)
    kin = deik.forward_kinematics(sk, q)
    goals = [deik.Position("tip", kin.position("tip"), tolerance=1e-12), deik.Orientation("tip", kin.rotation("tip"))]
    problem = deik.Problem(sk, goals)
    budget = dict(vars(settings), generations=first + 150)
    whole = deik.solve(problem, **budget)
    chunked = deik.solve(problem, **budget, progress=lambda generation, best: None)
    assert int(whole.generations) == first + 150
    np.testing.assert_array_equal(whole.angles, chunked.angles)
    np.testing.assert_array_equal(whole.history, chunked.history)
