"""The paper's serial Differential Evolution (Algorithm 1) as a plain NumPy reference.

One epoch (generation) runs POP_SIZE iterations. Each picks a random target x, three distinct
random donors a, b, c (also distinct from x, as in the parallel engine), a random forced gene R,
and builds a candidate from x whose gene i is a + F (b - c) where i == R or rand < CR. Only
the candidate is evaluated, one pose at a time with `deik.objectives.reference.fitness`, as a
serial CPU would, and it replaces population[x] *in place* when it is not worse. Later
iterations of the same epoch therefore already read the replaced individual (and x may be
picked, and overwritten, several times); the parallel ping-pong engine (Figure 1,
`deik.solver.engine`) removes exactly this dependency by reading one buffer and writing
another.

Deliberate choices, all matching the parallel engine:
- F defaults to 0.5: the paper prints FW = 2, which makes DE diverge.
- Candidates are compared by their priority-level vectors lexicographically (strict priority,
  the kernels' `not_worse`); ties are accepted.
- Trial genes go through the problem's joint-limit mode (reflect, clip, penalty or the paper's
  Algorithm 2) and the first population is uniform inside the skeleton's limits.

This is a readable reference for tests and the serial-vs-parallel benchmark, not a fast solver;
it uses numpy.random.Generator rather than the engine's counter-based random numbers.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from deik.errors import InputError
from deik.objectives.reference import fitness
from deik.solver.problem import Problem

_TWO_PI = 2.0 * np.pi


class Iteration(NamedTuple):
    """One iteration of an epoch: target x, donors (a, b, c), forced gene, crossover mask,
    the (limit-handled) candidate and whether it replaced population[x]."""

    x: int
    donors: tuple[int, int, int]
    forced: int
    mask: np.ndarray
    candidate: np.ndarray
    accepted: bool


def not_worse(a: np.ndarray, b: np.ndarray) -> bool:
    """Strict priority: is level vector a at least as good as b (lexicographic, ties True)?"""
    for x, y in zip(a, b):
        if x < y:
            return True
        if x > y:
            return False
    return True


def apply_limits(v: np.ndarray, lower: np.ndarray, upper: np.ndarray, mode: str) -> np.ndarray:
    """Trial genes v (D,) after the problem's limit mode, as the engine's make_trial does."""
    if mode == "reflect":
        v = np.where(v < lower, 2 * lower - v, np.where(v > upper, 2 * upper - v, v))
        return np.clip(v, lower, upper)
    if mode == "clip":
        return np.clip(v, lower, upper)
    if mode == "paper":  # Algorithm 2: pull |theta| > 2 pi back by 1 / (|theta| - 2 pi)
        over = np.abs(v) > _TWO_PI
        return np.where(over, v / np.where(over, np.abs(v) - _TWO_PI, 1.0), v)
    return v  # "penalty": genes may leave their limits; a top-priority term ranks that last


class SerialDE:
    """Algorithm 1 on one problem. `init()` draws and evaluates the first population, `epoch()`
    runs one generation, `run(generations, tolerance)` several; `best_pose`, `best_errors`,
    `best_levels`, `best_total` and `history` ((G, 2): best and mean total per generation)
    describe the result."""

    def __init__(self, problem: Problem, population: int = 500, F: float = 0.5, CR: float = 0.5, seed: int = 0):
        if not isinstance(problem, Problem):
            raise TypeError(f"SerialDE takes a deik.Problem, got {type(problem).__name__}")
        if problem.batch_size != 1:
            raise InputError(f"SerialDE solves one problem at a time, got a batch of {problem.batch_size}")
        if not (isinstance(population, (int, np.integer)) and population >= 4):
            raise InputError(f"population must be an integer >= 4 (x and 3 distinct donors), got {population!r}")
        if not (0 < F <= 2):
            raise InputError(f"F (differential weight) must lie in (0, 2], got {F!r}")
        if not 0 <= CR <= 1:
            raise InputError(f"CR (crossover probability) must lie in [0, 1], got {CR!r}")
        self.problem, self.population, self.F, self.CR, self.seed = problem, int(population), F, CR, seed
        self.rng = np.random.default_rng(seed)
        self.pop = self.levels = self.total = self.raw = None
        self.generation, self._history = 0, []

    # -- setup and evaluation --------------------------------------------------------------
    def init(self) -> SerialDE:
        """Uniform random population inside the skeleton's limits, evaluated (in one batch)."""
        sk = self.problem.skeleton
        self.rng = np.random.default_rng(self.seed)
        self.pop = self.rng.uniform(sk.lower, sk.upper, size=(self.population, sk.n_dofs))
        self.levels, self.total, self.raw = fitness(self.problem, self.pop)
        self.generation, self._history = 0, []
        return self

    def evaluate(self, pose: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
        """(levels (L,), total, raw (T,)) of one pose: the serial fitness call."""
        levels, total, raw = fitness(self.problem, pose[None])
        return levels[0], float(total[0]), raw[0]

    # -- Algorithm 1 ----------------------------------------------------------------------
    def _donors(self, x: int) -> tuple[int, int, int]:
        """Three distinct random indices, none equal to x (rejection sampling)."""
        chosen: list[int] = []
        while len(chosen) < 3:
            r = int(self.rng.integers(self.population))
            if r != x and r not in chosen:
                chosen.append(r)
        return chosen[0], chosen[1], chosen[2]

    def iterate(self) -> Iteration:
        """One inner iteration of Epoch(): pick, mutate, cross over, evaluate, replace in place."""
        if self.pop is None:
            raise RuntimeError("call init() first")
        sk, D = self.problem.skeleton, self.problem.skeleton.n_dofs
        x = int(self.rng.integers(self.population))
        a, b, c = self._donors(x)
        forced = int(self.rng.integers(D))
        mask = self.rng.random(D) < self.CR
        mask[forced] = True
        mutant = self.pop[a] + self.F * (self.pop[b] - self.pop[c])
        candidate = apply_limits(np.where(mask, mutant, self.pop[x]), sk.lower, sk.upper, self.problem.limits)
        levels, total, raw = self.evaluate(candidate)
        accepted = not_worse(levels, self.levels[x])
        if accepted:  # in place: later iterations of this epoch already see it
            self.pop[x], self.levels[x], self.total[x], self.raw[x] = candidate, levels, total, raw
        return Iteration(x=x, donors=(a, b, c), forced=forced, mask=mask, candidate=candidate, accepted=accepted)

    def epoch(self, record: bool = False) -> int | list[Iteration]:
        """One generation: POP_SIZE iterations. Returns the number of replacements, or the list
        of Iterations when `record`."""
        log = [self.iterate() for _ in range(self.population)]
        self.generation += 1
        self._history.append((self.best_total, float(self.total.mean())))
        return log if record else sum(it.accepted for it in log)

    def run(self, generations: int, tolerance: float | None = None) -> SerialDE:
        """Up to `generations` epochs (init() first if needed); with `tolerance`, stop once every
        raw error of the best pose (metres or radians) is at most `tolerance`."""
        if self.pop is None:
            self.init()
        for _ in range(int(generations)):
            if tolerance is not None and self.converged(tolerance):
                break
            self.epoch()
        return self

    # -- results --------------------------------------------------------------------------
    def converged(self, tolerance: float) -> bool:
        return bool(np.all(self.best_errors <= tolerance))

    @property
    def best_index(self) -> int:
        """Index of the best individual by strict priority (first of ties)."""
        return int(np.lexsort(self.levels.T[::-1])[0])

    @property
    def best_pose(self) -> np.ndarray:
        return self.pop[self.best_index].copy()

    @property
    def best_errors(self) -> np.ndarray:
        """Raw error of each term (T,) for the best pose, in the table's order (labels)."""
        return self.raw[self.best_index].copy()

    @property
    def best_levels(self) -> np.ndarray:
        return self.levels[self.best_index].copy()

    @property
    def best_total(self) -> float:
        return float(self.total[self.best_index])

    @property
    def labels(self) -> tuple[str, ...]:
        return self.problem.table.labels

    @property
    def history(self) -> np.ndarray:
        """(G, 2): best and mean total fitness after each epoch."""
        return np.array(self._history, dtype=np.float64).reshape(-1, 2)
