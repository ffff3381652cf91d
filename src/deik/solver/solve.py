"""solve(): pose one problem (or a batch of them) with the parallel DE engine."""

from __future__ import annotations

import logging
import time
from collections.abc import Mapping, Sequence
from contextlib import nullcontext
from dataclasses import fields
from typing import Unpack

import numpy as np
from numpy.typing import ArrayLike

from deik.console import Progress, compile_bars, generation_reporter
from deik.solver.engine import Engine, EvolutionState
from deik.solver.halting import guarded
from deik.solver.kept import kept_engine
from deik.solver.launches import Launches, polish_flops
from deik.solver.problem import Problem
from deik.solver.readiness import prepare
from deik.solver.result import BestPoses, Result
from deik.solver.settings import Settings, SettingsChanges
from deik.solver.workspace import Workspace

log = logging.getLogger(__name__)
_SETTING_NAMES = frozenset(f.name for f in fields(Settings))
_MERGED: dict = {}  # merge_settings' checked Settings by (settings, overrides but the seed)
MAX_MERGED = 64
_NO_SEED = object()  # merge_settings: no seed among the overrides


def solve(
    problem: Problem,
    settings: Settings | None = None,
    *,
    initial: ArrayLike | None = None,
    progress: Progress = None,
    **overrides: Unpack[SettingsChanges],
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
    with kept_engine(problem, merge_settings("solve()", settings, overrides)) as (engine, workspace):
        return run_engine(problem, engine, initial, progress, workspace)


def run_engine(
    problem: Problem,
    engine: Engine,
    initial: ArrayLike | None = None,
    progress: Progress = None,
    workspace: Workspace | None = None,
    batch_shape: tuple[int, ...] | None = None,
) -> Result:
    """Initialise `engine` (bound to `problem`) and run it to its settings' end: generation
    budget, time limit, or every problem stopped; the Result (solve() without the set-up).
    Generations run in short launches (solver/launches.py), each stopped early by the time
    limit or Ctrl-C (solver/halting.py), all in the buffers of one Workspace (`workspace`: one
    kept from an earlier solve of the same sizes, as a Solver does; else a new one).
    batch_shape: the Result's (default the problem's; a Solver's new targets may add a batch
    axis)."""
    settings = engine.settings
    start = time.perf_counter()
    skeleton = problem.skeleton
    n_frames = skeleton.n_joints + len(skeleton.site_names)
    frame_work = problem.batch_size * settings.population * n_frames
    polish = polish_flops(skeleton.n_dofs, problem.table.n_terms, n_frames) * settings.polish * problem.batch_size
    work = Workspace() if workspace is None else workspace
    work.prepare(engine)
    _load_kernels(engine, work, initial, True if progress is True else compile_bars())
    # no progress asked (a reused Solver's solves): no generator-based context to enter and leave
    reporter = (
        nullcontext() if progress is None else generation_reporter(progress, settings.generations, problem.batch_size)
    )
    with reporter as report:
        launches = Launches(settings, frame_work, polish, report is not None, start)
        first = True
        while first or launches.more(work.generation, work.active.any()):
            count = launches.next(work.generation)
            began = time.perf_counter()
            # the first launch sets up the population in the same call
            with guarded(work.status.halt, launches.deadline, launches.expected_seconds(count)):
                if first:
                    work.begin(engine, count, initial)
                    first = False
                else:
                    work.advance(count)
            launches.ran(count, time.perf_counter() - began)
            if log.isEnabledFor(logging.DEBUG):  # a robot solve is 0.1 ms: no formatting unless asked
                log.debug(
                    "launch of %d generations: %.3f s, %d done, %d of %d problems running",
                    count,
                    time.perf_counter() - began,
                    work.generation,
                    int(work.active.sum()),
                    problem.batch_size,
                )
            if report:
                best = float(work.total[np.arange(len(work.best)), work.best].min())
                report(work.generation, best, int(work.active.sum()))
    wall = time.perf_counter() - start
    if log.isEnabledFor(logging.DEBUG):
        log.debug(
            "solved %d problem(s) of %d DOFs, population %d, %s on %s: %d generations in %.3f s",
            problem.batch_size,
            skeleton.n_dofs,
            settings.population,
            settings.dtype,
            settings.device,
            work.generation,
            wall,
        )
    return make_result(problem, engine, work, wall, batch_shape)


def prepare_solve(
    problem: Problem, settings: Settings, initial: ArrayLike | None = None, show: bool | None = None
) -> None:
    """Load the kernels a solve of `problem` with `settings` (and `initial` poses) runs, compiling
    any not compiled before, side by side with a bar (`show`: console.progress_bar's flag; default
    the command's, console.compile_bars), as solve() does first: a command calls it before it
    draws bars of its own."""
    with kept_engine(problem, settings) as (engine, workspace):
        workspace.prepare(engine)
        _load_kernels(engine, workspace, initial, compile_bars() if show is None else show)


def _load_kernels(engine: Engine, work: Workspace, initial: ArrayLike | None, show) -> None:
    """Once per engine: load (or compile) the kernels it runs (deik.solver.readiness.prepare)."""
    if not engine.kernels_ready:
        prepare(engine, work.work, engine.initial_poses(initial), show)
        engine.kernels_ready = True


def solve_batch(
    problems: Sequence[Problem],
    settings: Settings | None = None,
    *,
    initial: ArrayLike | None = None,
    progress: Progress = None,
    **overrides: Unpack[SettingsChanges],
) -> Result:
    """Solve several problems on one skeleton in one launch: `problems` differ only in
    targets, weights, reference poses and active masks (see Problem.stack). The Result is
    batched in the order given, one row per problem (a problem with a batch of B gives B)."""
    return solve(Problem.stack(problems), settings, initial=initial, progress=progress, **overrides)


def merge_settings(
    caller: str,
    settings: Settings | None,
    overrides: Mapping[str, object],
    defaults: Mapping[str, object] | None = None,
) -> Settings:
    """Settings from `defaults`, then `settings`, then keyword `overrides`; unknown keywords
    raise a TypeError naming `caller` and the valid names."""
    if not _SETTING_NAMES.issuperset(overrides):
        unknown = sorted(set(overrides) - _SETTING_NAMES)
        raise TypeError(f"unknown {caller} settings {unknown}; choose from {sorted(_SETTING_NAMES)}")
    if defaults:
        return Settings(**{**defaults, **(vars(settings) if settings else {}), **overrides})
    # a loop of solves passes the same settings with a new seed each call: the rest is checked once
    unseeded = dict(overrides)
    seed = unseeded.pop("seed", _NO_SEED)
    key = (settings, tuple(unseeded.items()), tuple(map(type, unseeded.values())))  # types: 1 == 1.0 == True
    try:
        merged = _MERGED.get(key)
    except TypeError:  # an unhashable value: checked below as it is
        key = merged = None
    if merged is None:
        merged = Settings(**{**(vars(settings) if settings else {}), **unseeded})
        if key is not None:
            if len(_MERGED) >= MAX_MERGED:
                _MERGED.clear()
            _MERGED[key] = merged
    return merged if seed is _NO_SEED else merged.with_seed(seed)


def make_result(
    problem: Problem,
    engine: Engine,
    state: EvolutionState | Workspace,
    wall_time: float,
    batch_shape: tuple[int, ...] | None = None,
) -> Result:
    """Result from a final EvolutionState (or a Workspace), shaped by `batch_shape` (default
    problem.batch_shape). Errors are float64: a float64 run reports the final state's raw
    errors of each problem's best individual, a float32 run re-evaluates that individual in
    float64 (Engine.raw_errors)."""
    shape = problem.batch_shape if batch_shape is None else batch_shape
    best_index = (np.arange(len(state.best)), state.best)
    best = state.pop[best_index].astype(np.float64, copy=False)  # indexing copies already
    raw = state.raw[best_index] if state.raw.dtype == np.float64 else engine.raw_errors(best)
    generations = state.generations.copy()
    # a Workspace's history is joined only when the Result's is read
    history = state.history_reader(generations) if isinstance(state, Workspace) else state.history.copy()
    best_poses = BestPoses(angles=best, raw=raw, generations=generations, history=history)
    return engine.report_terms.result(problem.skeleton, best_poses, shape, wall_time, engine.settings)
