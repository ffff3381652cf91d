"""Solver: one problem's structure set up once, then solved again and again with new targets.

A robot or a character posed many times (a control loop, a stream of targets) keeps its
skeleton, goal kinds, weights, tolerances and settings; only the targets change. `deik.solve`
rebuilds the Problem, the Engine and the buffers on every call, most of a small robot's solve.
A Solver keeps all three: each solve checks the new targets once (Goal.target_params), writes
them into its own copy of the target parameters, which the kernels read, and runs in the same
buffers (solver/workspace.py); the Result copies out what it reports::

    ik = deik.Solver(problem, population=32, dtype="float64")
    result = ik.solve({"position tip": p, "orientation tip": R}, initial=q_now[None], seed=k)

A Solver solves one thing at a time: its buffers are shared by its solves, so a solve started
while another runs in a second thread raises SolveError at once (use one Solver per thread, or
deik.solve, whose kept engines serve one call at a time).
"""

from __future__ import annotations

import threading
from typing import Unpack

import numpy as np
from numpy.typing import ArrayLike

from deik.console import Progress
from deik.errors import InputError, SolveError, UnknownNameError
from deik.objectives.kinds import GAIN
from deik.solver.engine import Engine, seeded
from deik.solver.problem import Problem
from deik.solver.result import Result
from deik.solver.settings import Settings, SettingsChanges
from deik.solver.solve import merge_settings, run_engine
from deik.solver.workspace import Workspace


class Solver:
    """Solves `problem` (a deik.Problem) with settings from `settings` and keyword overrides
    (as deik.solve); `solve(targets)` swaps goal targets between calls."""

    def __init__(self, problem: Problem, settings: Settings | None = None, **overrides: Unpack[SettingsChanges]):
        if not isinstance(problem, Problem):
            raise TypeError(f"Solver takes a deik.Problem, got {type(problem).__name__}")
        self.problem = problem
        self.settings = merge_settings("Solver()", settings, overrides)
        # an engine of the Solver's own: each solve rewrites its target parameters and seed
        self._engine = engine = Engine(problem, self.settings).for_problem(problem)
        self.settings = engine.settings  # with device="auto" resolved for this problem's size
        _ = engine.report_terms  # worked out once
        self._kernel_settings = engine.kernel_settings
        self._params = tuple({id(t.params): t.params for t in (engine.terms, engine.terms64)}.values())
        self._workspace = Workspace()
        self._labels = problem.table.labels[: len(problem.goals)]
        self._index = {label: t for t, label in enumerate(self._labels)}
        # per goal: its quick check of one new target (Goal.quick_target), or None
        self._quick = tuple(
            goal.quick_target(problem.skeleton) if hasattr(goal, "target") else None for goal in problem.goals
        )
        self._swapped = set()  # goals whose parameters hold another target than the problem's
        self._busy = threading.Lock()  # held while a solve runs: a second thread is refused

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
        new target is checked as a new goal would be (shape, NaN, reach, rotation). SolveError
        if this Solver is solving in another thread meanwhile."""
        if not self._busy.acquire(blocking=False):
            raise SolveError(
                "this Solver is already solving in another thread, and its buffers serve one solve at a "
                "time; give each thread a Solver of its own"
            )
        try:
            return self._solve(targets, initial, seed, progress)
        finally:
            self._busy.release()

    def _solve(self, targets, initial, seed, progress) -> Result:
        """solve() while holding the Solver."""
        batched = self._swap_targets(targets or {})
        engine = self._engine
        if seed is None or seed == self.settings.seed:
            engine.settings, engine.kernel_settings = self.settings, self._kernel_settings
        else:  # the engine is the Solver's own: set its seed rather than copy it (Engine.with_seed)
            engine.settings = self.settings.with_seed(seed)
            engine.kernel_settings = seeded(self._kernel_settings, seed)
        shape = (self.problem.batch_size,) if batched else self.problem.batch_shape
        return run_engine(self.problem, engine, initial, progress, self._workspace, shape)

    def _swap_targets(self, targets: dict) -> bool:
        """Check each new target and write its parameters over its goal's, then restore the
        problem's own for goals swapped before but not now; returns whether a new target
        carries a batch axis. A target without a batch axis takes its goal's quick check
        (Goal.quick_target); any other, or one the quick check declines, target_params."""
        batched, given = False, set()
        for key, target in targets.items():
            t = self._index.get(key) if type(key) is str else None
            if t is None:
                t = self._goal_index(key)
            quick = self._quick[t]
            values = None if quick is None else quick(target)
            if values is None:
                values, goal_batched = self._checked(t, target)
                batched |= goal_batched
            for params in self._params:
                params[:, t, : values.shape[-1]] = values  # a target without a batch axis broadcasts
            given.add(t)
            self._swapped.add(t)  # so that a later target's error leaves nothing of this one behind
        for t in self._swapped - given:
            for params in self._params:
                params[:, t, :GAIN] = self.problem.table.params[:, t, :GAIN]
        self._swapped = given
        return batched

    def _checked(self, t: int, target: ArrayLike) -> tuple[np.ndarray, bool]:
        """(parameters (1 or B, GAIN), batched) of goal t with `target`, checked by the goal's
        target_params and against the problem's batch size."""
        goal, B = self.problem.goals[t], self.problem.batch_size
        if not hasattr(goal, "target"):
            raise TypeError(f"goal {t} ({self._labels[t]}) has no target to swap; build a new Problem instead")
        values, batched = goal.target_params(self.problem.skeleton, target)
        if values.shape[0] not in (1, B):
            raise InputError(
                f"goal {t} ({self._labels[t]}): {values.shape[0]} targets for a problem batch of "
                f"{B}; give one target or {B}"
            )
        return values[:, :GAIN], batched

    def _goal_index(self, key) -> int:
        """The index in problem.goals of goal `key` (an index or a label)."""
        if isinstance(key, str) and key in self._index:
            return self._index[key]
        if isinstance(key, (int, np.integer)) and not isinstance(key, bool):
            if 0 <= key < len(self._labels):
                return int(key)
            raise IndexError(f"goal index {key} out of range: the problem has {len(self._labels)} goals")
        raise UnknownNameError(f"no goal {key!r}; the goals are {list(self._labels)}")
