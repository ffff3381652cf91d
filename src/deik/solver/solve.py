"""solve(): pose one problem (or a batch of them) with the parallel DE engine."""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import fields

import numpy as np
from numpy.typing import ArrayLike

from deik.console import Progress, generation_reporter
from deik.objectives.kinds import GAIN, TERM_LEVEL, TOLERANCE, WEIGHT
from deik.objectives.registry import kind_of
from deik.solver.engine import Engine, EvolutionState
from deik.solver.launches import Launches
from deik.solver.problem import Problem
from deik.solver.result import GoalReport, Result
from deik.solver.settings import Settings

log = logging.getLogger(__name__)


def solve(
    problem: Problem,
    settings: Settings | None = None,
    *,
    initial: ArrayLike | None = None,
    progress: Progress = None,
    **overrides: object,
) -> Result:
    """Solve `problem`; settings from `settings` and/or keyword overrides (population,
    generations, time_limit, strategy, F, CR, adaptive, polish, restarts, seed, patience,
    device, dtype). `initial`: poses (n, D) or (B, n, D) seeding the population.
    `progress=True` shows a progress bar over generations on stderr; a callable
    `progress(generation, best_fitness)` is called instead every 100 generations at most
    (launches.PROGRESS_CHUNK); the default shows nothing (deik.console). Returns an
    immutable Result."""
    if not isinstance(problem, Problem):
        raise TypeError(f"solve() takes a deik.Problem, got {type(problem).__name__}")
    return run_engine(problem, Engine(problem, merge_settings("solve()", settings, overrides)), initial, progress)


def run_engine(problem: Problem, engine: Engine, initial: ArrayLike | None = None, progress: Progress = None) -> Result:
    """Initialise `engine` (bound to `problem`) and run it to its settings' end: generation
    budget, time limit, or every problem stopped; the Result (solve() without the set-up).
    Generations run in short launches (solver/launches.py), so Ctrl-C stops a solve quickly."""
    settings = engine.settings
    start = time.perf_counter()
    skeleton = problem.skeleton
    frame_work = problem.batch_size * settings.population * (skeleton.n_joints + len(skeleton.site_names))
    with generation_reporter(progress, settings.generations, problem.batch_size) as report:
        launches = Launches(settings, frame_work, report is not None, start)
        state = None
        while state is None or launches.more(state.generation, state.active.any()):
            count = launches.next(0 if state is None else state.generation)
            began = time.perf_counter()
            # the first launch sets up the population in the same call
            state = engine.start(count, initial) if state is None else engine.run(state, count)
            launches.ran(count, time.perf_counter() - began)
            log.debug(
                "launch of %d generations: %.3f s, %d done, %d of %d problems running",
                count,
                time.perf_counter() - began,
                state.generation,
                int(state.active.sum()),
                problem.batch_size,
            )
            if report:
                best = float(state.total[np.arange(len(state.best)), state.best].min())
                report(state.generation, best, int(state.active.sum()))
    wall = time.perf_counter() - start
    log.debug(
        "solved %d problem(s) of %d DOFs, population %d, %s on %s: %d generations in %.3f s",
        problem.batch_size,
        skeleton.n_dofs,
        settings.population,
        settings.dtype,
        settings.device,
        state.generation,
        wall,
    )
    return make_result(problem, engine, state, wall)


def solve_batch(
    problems: Sequence[Problem],
    settings: Settings | None = None,
    *,
    initial: ArrayLike | None = None,
    progress: Progress = None,
    **overrides: object,
) -> Result:
    """Solve several problems on one skeleton in one launch: `problems` differ only in
    targets, weights, reference poses and active masks (see Problem.stack). The Result is
    batched in the order given, one row per problem (a problem with a batch of B gives B)."""
    return solve(Problem.stack(problems), settings, initial=initial, progress=progress, **overrides)


def merge_settings(
    caller: str, settings: Settings | None, overrides: dict[str, object], defaults: dict[str, object] | None = None
) -> Settings:
    """Settings from `defaults`, then `settings`, then keyword `overrides`; unknown keywords
    raise a TypeError naming `caller` and the valid names."""
    names = {f.name for f in fields(Settings)}
    unknown = sorted(set(overrides) - names)
    if unknown:
        raise TypeError(f"unknown {caller} settings {unknown}; choose from {sorted(names)}")
    return Settings(**{**(defaults or {}), **(vars(settings) if settings else {}), **overrides})


def make_result(problem: Problem, engine: Engine, state: EvolutionState, wall_time: float) -> Result:
    """Result from a final EvolutionState, shaped by problem.batch_shape. Errors are float64: a
    float64 run reports the final state's raw errors of each problem's best individual, a
    float32 run re-evaluates that individual in float64 (Engine.raw_errors)."""
    B, table, shape = problem.batch_size, problem.table, problem.batch_shape
    best_index = (np.arange(B), state.best)
    best = state.pop[best_index].astype(np.float64)
    raw = state.raw[best_index] if state.raw.dtype == np.float64 else engine.raw_errors(best)
    norm = table.normalise(raw)
    gain = table.params[:, :, GAIN]

    def batched(a: np.ndarray) -> np.ndarray:
        """(B, ...) -> (*batch, ...)."""
        return a.reshape(shape + a.shape[1:])

    goals = tuple(
        GoalReport(
            label,
            kind_of(kind).name,
            kind_of(kind).unit_for(problem.skeleton),
            batched(raw[:, t]),
            batched(norm[:, t]),
            float(table.term_float[t, WEIGHT]),
            float(table.term_float[t, TOLERANCE]),
            int(table.term_int[t, TERM_LEVEL]),
            batched(gain[:, t] > 0),
        )
        for t, (label, kind) in enumerate(zip(table.labels, table.kinds))
    )
    return Result(
        skeleton=problem.skeleton,
        angles=batched(best),
        fitness=batched((norm * table.term_float[:, WEIGHT] * gain).sum(axis=1)),
        goals=goals,
        generations=batched(state.generations.copy()),
        converged=np.asarray(np.logical_and.reduce([g.met | (g.weight <= 0) for g in goals])),
        history=batched(state.history.copy()),
        wall_time=wall_time,
        device=engine.settings.device,
        settings=engine.settings,
    )
