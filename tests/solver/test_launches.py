"""How a solve cuts its generations into kernel launches (deik.solver.launches): each about a
quarter of a second at the measured pace, growing at most GROWTH-fold from a first guess, and
within the budget. Paces are given, not timed, so nothing here depends on the machine."""

import math

import pytest

import deik
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
