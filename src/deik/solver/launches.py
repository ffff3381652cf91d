"""How many generations each kernel launch of a solve runs.

Python sees progress reports only between launches, so a solve runs in launches of about
LAUNCH_SECONDS each (the time limit and Ctrl-C also reach inside a launch: deik.solver.halting). The first is
sized from an estimate of its work (individuals x frames per generation over an assumed rate)
to end within GUARD_SECONDS, which spares it the watchdog, later ones from the measured pace
of the one before, growing at most GROWTH-fold per launch so
that a first launch slowed by compilation does not set the pace. A time limit makes the first
launch a probe of TIME_PROBE generations and caps each later one at a quarter of the time left;
progress reports come every PROGRESS_CHUNK generations.
"""

from __future__ import annotations

import math
import time

from deik.solver.halting import GUARD_SECONDS
from deik.solver.settings import Settings

LAUNCH_SECONDS = 0.25
FRAME_EVALUATIONS_PER_SECOND = {"cpu": 2e7, "gpu": 1e9}  # conservative first guesses, before any measurement
POLISH_FLOPS_PER_SECOND = {"cpu": 1e9, "gpu": 1e10}  # likewise, for the LM polish's multiply-adds
GROWTH = 4
PROGRESS_CHUNK = 100
TIME_PROBE = 4  # generations of the first launch under a time limit


def polish_flops(n_dofs: int, n_terms: int, n_frames: int) -> float:
    """Multiply-adds of one LM iteration on one individual, about: the Cholesky factorisation
    (D^3 / 6), the normal equations (three rows per term, D^2 each) and the kinematics."""
    return n_dofs**3 / 6 + 3 * n_terms * n_dofs**2 + 50 * n_frames


class Launches:
    """Plans the launches of one solve: `next(done)` -> generations to run now, `ran(count,
    seconds)` records a launch, `expected_seconds(count)` says how long one may take.
    `frame_work`: individuals x kinematic frames of one generation; `polish_work`: multiply-adds
    of one polish of every problem's first individual (polish_flops x iterations x problems)."""

    def __init__(self, settings: Settings, frame_work: int, polish_work: float, progress: bool, start: float):
        self.budget = settings.generations
        self.deadline = start + settings.time_limit if settings.time_limit else math.inf
        self.chunk = PROGRESS_CHUNK if progress else self.budget
        rate = FRAME_EVALUATIONS_PER_SECOND[settings.device]
        self.pace = None  # seconds per generation of the last launch
        self._first_seconds = polish_work / POLISH_FLOPS_PER_SECOND[settings.device]
        self._generation_seconds = (
            frame_work / rate + self._first_seconds * settings.polish_count / settings.polish_every
        )
        # the first launch stays within GUARD_SECONDS by the estimate, so that it runs unguarded
        # (arming the watchdog is 5 us of a 0.1 ms robot solve, which most often ends in it)
        unguarded = int((GUARD_SECONDS - self._first_seconds) / self._generation_seconds)
        self.size = max(1, min(int(LAUNCH_SECONDS * rate / max(frame_work, 1)), unguarded))

    def expected_seconds(self, count: int) -> float:
        """About how long a launch of `count` generations takes: the last launch's pace, or
        before any, the estimates (a first launch also polishes every problem once)."""
        if self.pace is not None:
            return self.pace * count
        return self._first_seconds + self._generation_seconds * count

    def more(self, done: int, any_active: bool) -> bool:
        """Whether to launch again: budget left, a problem still running, time left (the first
        generation always runs)."""
        return done < self.budget and any_active and (done == 0 or time.perf_counter() < self.deadline)

    def next(self, done: int) -> int:
        """Generations for the next launch, after `done` generations."""
        count = min(self.size, self.chunk, self.budget - done)
        if math.isfinite(self.deadline):
            # unmeasured, a launch could overrun the limit: probe a few generations first
            left = 0.25 * (self.deadline - time.perf_counter())
            count = min(count, TIME_PROBE if self.pace is None else int(left / self.pace))
        return max(1, count)

    def ran(self, count: int, seconds: float) -> None:
        """Record a launch of `count` generations that took `seconds`."""
        self.pace = max(seconds, 1e-9) / count
        self.size = max(1, min(GROWTH * count, int(LAUNCH_SECONDS / self.pace)))
