"""Solver: one problem's structure set up once, then solved again and again with new targets.

A robot or a character posed many times (a control loop, a stream of targets) keeps its
skeleton, goal kinds, weights, tolerances and settings; only the targets change. `deik.solve`
rebuilds the Problem, the Engine and the buffers on every call, most of a small robot's solve.
A Solver keeps all three: each solve checks the new targets once (Goal.target_params), writes
them into its own copy of the target parameters, which the kernels read, and runs in the same
buffers (solver/workspace.py); the Result copies out what it reports::

    ik = deik.Solver(problem, population=32, dtype="float64")
    result = ik.solve({"position tip": p, "orientation tip": R}, initial=q_now[None], seed=k)

A Solver is not for use from several threads at once (its buffers are shared by its solves).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from deik.console import Progress
from deik.objectives.kinds import GAIN
from deik.solver.engine import Engine
from deik.solver.problem import Problem
from deik.solver.result import Result
from deik.solver.settings import Settings
from deik.solver.solve import merge_settings, run_engine
from deik.solver.workspace import Workspace


class Solver:
    """Solves `problem` (a deik.Problem) with settings from `settings` and keyword overrides
    (as deik.solve); `solve(targets)` swaps goal targets between calls."""

    def __init__(self, problem: Problem, settings: Settings | None = None, **overrides: object):
        if not isinstance(problem, Problem):
            raise TypeError(f"Solver takes a deik.Problem, got {type(problem).__name__}")
        self.problem = problem
        self.settings = merge_settings("Solver()", settings, overrides)
        # an engine whose target parameters are the Solver's own: each solve rewrites them
        self._engine = Engine(problem, self.settings).for_problem(problem)
        _ = self._engine.report_terms  # worked out once, shared by the copies with_seed makes
        self._workspace = Workspace()
        self._labels = problem.table.labels[: len(problem.goals)]
        self._index = {label: t for t, label in enumerate(self._labels)}
        self._swapped = set()  # goals whose parameters hold another target than the problem's

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
        batched = self._swap_targets(targets or {})
        engine = self._engine if seed is None or seed == self.settings.seed else self._engine.with_seed(seed)
        shape = (self.problem.batch_size,) if batched else self.problem.batch_shape
        return run_engine(self.problem, engine, initial, progress, self._workspace, shape)

    def _swap_targets(self, targets: dict) -> bool:
        """Check every new target, then write their parameters over the goals' and restore
        the problem's own for goals swapped before but not now; returns whether a new target
        carries a batch axis."""
        problem, skeleton, B = self.problem, self.problem.skeleton, self.problem.batch_size
        rows, batched = {}, False
        for key, target in targets.items():
            t = self._goal_index(key)
            goal = problem.goals[t]
            if not hasattr(goal, "target"):
                raise TypeError(f"goal {t} ({self._labels[t]}) has no target to swap; build a new Problem instead")
            rows[t], goal_batched = goal.target_params(skeleton, target)
            batched |= goal_batched
            if rows[t].shape[0] not in (1, B):
                raise ValueError(
                    f"goal {t} ({self._labels[t]}): {rows[t].shape[0]} targets for a problem batch of "
                    f"{B}; give one target or {B}"
                )
        engine = self._engine
        terms = (engine.terms,) if engine.terms64 is engine.terms else (engine.terms, engine.terms64)
        for t in self._swapped - rows.keys():
            for packed in terms:
                packed.params[:, t, :GAIN] = problem.table.params[:, t, :GAIN]
        for t, values in rows.items():
            for packed in terms:
                packed.params[:, t, :GAIN] = values[:, :GAIN]
        self._swapped = set(rows)
        return batched

    def _goal_index(self, key) -> int:
        """The index in problem.goals of goal `key` (an index or a label)."""
        if isinstance(key, str) and key in self._index:
            return self._index[key]
        if isinstance(key, (int, np.integer)) and not isinstance(key, bool):
            if 0 <= key < len(self._labels):
                return int(key)
            raise IndexError(f"goal index {key} out of range: the problem has {len(self._labels)} goals")
        raise KeyError(f"no goal {key!r}; the goals are {list(self._labels)}")
