"""The paper's serial DE (Algorithm 1) compiled for one CPU thread: the "serial CPU" baseline.

The same maths as the parallel kernels (deik.device: terms.evaluate, evolution.within_limits,
counter-based random numbers), run the way Algorithm 1 runs: each of an epoch's P iterations
picks a random target x, three distinct donors a, b, c (none equal to x) and a forced gene, builds
the candidate a + F (b - c) on the genes where a uniform number falls below CR, evaluates that one
pose and replaces population[x] in place when it is not worse, so later iterations of the epoch
already read it. deik.experiments.serial_numpy.SerialDE is the same algorithm in NumPy (the readable oracle);
this one measures what a compiled serial implementation costs. CompiledSerialDE is its host side.
It is a compiled kernel itself, so it calls the device maths directly, as the back-ends do (the
one module above deik.solver that imports deik.device and deik.backends: tests/model/test_layers.py).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from deik.backends.targets import cpu as dev
from deik.device.layout import LOWER, UPPER, WORK_SIZE, Buffers, PackedSkeleton, PackedTerms, Scratch
from deik.errors import InputError
from deik.solver.engine import Engine
from deik.solver.problem import Problem
from deik.solver.settings import LIMIT_CODES, Settings

PROBLEM = 0  # the counter's problem index: Algorithm 1 solves one problem


@njit(cache=True)
def serial_epochs(
    state: Buffers,
    skel: PackedSkeleton,
    terms: PackedTerms,
    limit_mode: int,
    F: float,
    CR: float,
    seed: int,
    gen_start: int,
    n_epochs: int,
    history: np.ndarray,
) -> None:
    """Run n_epochs epochs of Algorithm 1 in place on problem 0 of the Buffers `state` (pop
    (1, P, D), levels, total, raw); history (n_epochs, 2) receives the best and mean total after
    each epoch."""
    pop, levels, total, raw = state.pop, state.levels, state.total, state.raw
    P, D = pop.shape[1], pop.shape[2]
    t = pop.dtype
    frames = dev.frame_count(skel)
    scratch = Scratch(np.empty(frames * 9, t), np.empty(frames * 3, t), np.empty(WORK_SIZE, t))
    trial, lv, rw = np.empty(D, t), np.empty(levels.shape[2], t), np.empty(raw.shape[2], t)
    limits = skel.limits
    for e in range(n_epochs):
        gen = gen_start + e
        for j in range(P):
            key = dev.stream(seed, PROBLEM, gen, j)
            x = dev.below(P, key, 0)
            a = dev.donor(P, x, 0, 0, 1, key, 1)
            b = dev.donor(P, x, a, 0, 2, key, 2)
            c = dev.donor(P, x, a, b, 3, key, 3)
            forced = dev.below(D, key, 4)
            for d in range(D):
                v = pop[0, x, d]
                if d == forced or dev.unit(key, 5 + d) < CR:
                    v = pop[0, a, d] + F * (pop[0, b, d] - pop[0, c, d])
                trial[d] = dev.within_limits(v, limits[d, LOWER], limits[d, UPPER], limit_mode)
            tot = dev.evaluate(trial, PROBLEM, skel, terms, scratch, lv, rw)
            if dev.not_worse(lv, levels[0, x]):
                for d in range(D):
                    pop[0, x, d] = trial[d]
                for k in range(lv.shape[0]):
                    levels[0, x, k] = lv[k]
                for k in range(rw.shape[0]):
                    raw[0, x, k] = rw[k]
                total[0, x] = tot
        best, mean = 0, 0.0
        for i in range(P):
            mean += total[0, i]
            if not dev.not_worse(levels[0, best], levels[0, i]):
                best = i
        history[e, 0], history[e, 1] = total[0, best], mean / P


class CompiledSerialDE:
    """Algorithm 1 compiled for one CPU thread (deik.experiments.serial_compiled): the paper's "serial CPU",
    with the kernels' maths and counter-based random numbers. The first population is the
    engine's (uniform in the limits, evaluated); `run(n)` runs n epochs; `best_pose`,
    `best_errors`, `best_total` and `history` ((G, 2)) describe the result."""

    def __init__(
        self,
        problem: Problem,
        population: int = 500,
        F: float = 0.5,
        CR: float = 0.5,
        seed: int = 0,
        dtype: str = "float32",
    ):
        if problem.batch_size != 1:
            raise InputError(f"CompiledSerialDE solves one problem at a time, got a batch of {problem.batch_size}")
        self.problem = problem
        settings = Settings(population=population, F=F, CR=CR, seed=seed, dtype=dtype, adaptive=False, polish=0)
        self._engine = Engine(problem, settings)
        self._limit_mode = LIMIT_CODES[problem.limits]
        state = self._engine.init()
        self._buffers = tuple(a.copy() for a in state.buffers)
        self.generation, self._history = 0, np.zeros((0, 2))

    def run(self, generations: int) -> CompiledSerialDE:
        """Run `generations` more epochs in place."""
        e = self._engine
        history = np.empty((int(generations), 2))
        t = np.dtype(e.settings.dtype).type
        serial_epochs(
            Buffers(*self._buffers),
            e.skel,
            e.terms,
            np.int64(self._limit_mode),
            t(e.settings.F),
            t(e.settings.CR),
            np.uint64(e.settings.seed),
            np.int64(self.generation),
            np.int64(generations),
            history,
        )
        self.generation += int(generations)
        self._history = np.concatenate([self._history, history])
        return self

    @property
    def best_index(self) -> int:
        """Index of the best individual by strict priority (first of ties)."""
        levels = self._buffers[1][0]
        return int(np.lexsort(levels.T[::-1])[0])

    @property
    def best_pose(self) -> np.ndarray:
        return self._buffers[0][0, self.best_index].astype(np.float64)

    @property
    def best_errors(self) -> np.ndarray:
        """Raw error of each term (T,) of the best pose, in the kernel's dtype."""
        return self._buffers[3][0, self.best_index].astype(np.float64)

    @property
    def best_total(self) -> float:
        return float(self._buffers[2][0, self.best_index])

    @property
    def history(self) -> np.ndarray:
        """(G, 2): best and mean total fitness after each epoch."""
        return self._history.copy()
