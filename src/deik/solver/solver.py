"""Solver: one problem's structure set up once, then solved again and again with new targets.

A robot or a character posed many times (a control loop, a stream of targets) keeps its
skeleton, goal kinds, weights, tolerances and settings; only the targets change. `deik.solve`
rebuilds the Problem and the Engine on every call, about a quarter of a small robot's solve.
A Solver checks and packs only the new targets::

    ik = deik.Solver(problem, population=32, dtype="float64")
    result = ik.solve({"position tip": p, "orientation tip": R}, initial=q_now[None], seed=k)
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike

from deik.console import Progress
from deik.objectives.kinds import GAIN
from deik.solver.engine import Engine
from deik.solver.problem import Problem
from deik.solver.result import Result
from deik.solver.settings import Settings
from deik.solver.solve import merge_settings, run_engine


class Solver:
    """Solves `problem` (a deik.Problem) with settings from `settings` and keyword overrides
    (as deik.solve); `solve(targets)` swaps goal targets between calls."""

    def __init__(self, problem: Problem, settings: Settings | None = None, **overrides: object):
        if not isinstance(problem, Problem):
            raise TypeError(f"Solver takes a deik.Problem, got {type(problem).__name__}")
        self.problem = problem
        self.settings = merge_settings("Solver()", settings, overrides)
        self._engine = Engine(problem, self.settings)
        self._labels = problem.table.labels[: len(problem.goals)]

    def solve(
        self,
        targets: dict[str | int, ArrayLike] | None = None,
        *,
        initial: ArrayLike | None = None,
        seed: int | None = None,
        progress: Progress = None,
    ) -> Result:
        """Solve with `targets` {goal: new target} replacing those goals' targets (a goal is
        named by its index in problem.goals or its label, e.g. "position tip"; a target has the
        goal's shape in the goal's own form (a quaternion for an Orientation built with form
        "quat-wxyz"; docs/conventions.md), with or without the problem's batch axis, and a batch axis makes the
        Result batched as for deik.solve); other goals keep theirs.
        `initial` and `progress` as in deik.solve; `seed` overrides the settings' seed. Each
        new target is checked as a new goal would be (shape, NaN, reach, rotation)."""
        problem = self._retargeted(targets) if targets else self.problem
        return run_engine(problem, self._engine.for_problem(problem, seed), initial, progress)

    def _retargeted(self, targets: dict) -> Problem:
        problem, skeleton = self.problem, self.problem.skeleton
        goals = list(problem.goals)
        params = problem.table.params.copy()
        for key, target in targets.items():
            t = self._goal_index(key)
            if not hasattr(goals[t], "target"):
                raise TypeError(f"goal {t} ({self._labels[t]}) has no target to swap; build a new Problem instead")
            goals[t] = replace(goals[t], target=target)
            goals[t].row(skeleton)  # the checks a new goal gets
            rows = goals[t].params(skeleton)
            if rows.shape[0] not in (1, problem.batch_size):
                raise ValueError(
                    f"goal {t} ({self._labels[t]}): {rows.shape[0]} targets for a problem batch of "
                    f"{problem.batch_size}; give one target or {problem.batch_size}"
                )
            params[:, t, :GAIN] = rows[:, :GAIN]
        return problem.with_goal_targets(tuple(goals), params)

    def _goal_index(self, key) -> int:
        """The index in problem.goals of goal `key` (an index or a label)."""
        if isinstance(key, (int, np.integer)) and not isinstance(key, bool):
            if 0 <= key < len(self._labels):
                return int(key)
            raise IndexError(f"goal index {key} out of range: the problem has {len(self._labels)} goals")
        if key in self._labels:
            return self._labels.index(key)
        raise KeyError(f"no goal {key!r}; the goals are {list(self._labels)}")
