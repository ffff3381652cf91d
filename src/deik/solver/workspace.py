"""Workspace: the buffers a solve works in, launch after launch, in place.

`Engine.run` leaves the caller's EvolutionState unchanged, so every call copies both
ping-pong buffer sets: 60 MB per launch for a batch of 10,000 Panda problems, which made a
solve of many short launches (solver/launches.py) spend most of its time copying. A solve owns
its buffers, so `run_engine` hands the back-end a Workspace's current and spare sets each
launch and takes the set the kernel ended in as the current one; the history rows of each
launch are kept and joined once at the end. A `Solver` keeps one Workspace from solve to solve:
the first launch resets every Status field in the kernel (device_evolution.rank_first), so
nothing is filled or allocated again while the sizes stay the same.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from deik.backends.contract import SolveBuffers
from deik.device.layout import Status

if TYPE_CHECKING:
    from deik.solver.engine import Engine


class Workspace:
    """The buffers of solves of one size: `begin(engine, n, initial)` sets up a population and
    runs its first n generations, `advance(n)` runs more. Between launches `pop`, `raw`,
    `total` (the current Buffers', on the GPU only each problem's best individual), `best`,
    `generations`, `active` (the Status') and `generation` describe the state; `history_reader`
    joins the launches' rows, (B, G, 2)."""

    def __init__(self):
        self._sizes, self.generation = None, 0

    def prepare(self, engine: Engine) -> None:
        """Buffers and Status for engine's problem and settings, unless those of the last
        solve have the same sizes (call before begin)."""
        sizes = engine.sizes
        if sizes == self._sizes:
            return
        engine.check_memory()
        B = sizes[0]
        self.work = SolveBuffers(
            current=engine.new_buffers(),
            spare=engine.new_buffers(),
            status=engine.new_status(),
            history=np.empty((0, B, 2)),
        )
        self._steps = self.work.history
        self._everyone = np.arange(B)
        self._sizes = sizes
        # the Status arrays stay for every solve of these sizes: attributes, not properties
        self.status: Status = self.work.status
        self.best, self.generations, self.active = self.status.best, self.status.generations, self.status.active

    def begin(self, engine: Engine, n_generations: int, initial: ArrayLike | None = None) -> None:
        """A first population for engine's problem (seeded with `initial` poses, checked as
        Engine.init checks them), then up to n_generations, in one back-end call."""
        seeds = engine.initial_poses(initial)
        self.engine, self.generation, self._rows = engine, 0, []
        self._history_rows(n_generations)
        advanced = engine.backend.start(engine.inputs, self.work, seeds, n_generations)
        self._ran(advanced, self._everyone)

    def advance(self, n_generations: int) -> None:
        """Up to n_generations more (each problem stops on convergence or stagnation)."""
        engine = self.engine
        running = np.flatnonzero(self.status.active)  # only these write history rows
        self._history_rows(n_generations)
        advanced = engine.backend.run(engine.inputs, self.work, self.generation, n_generations)
        self._ran(advanced, running)

    def _history_rows(self, n_generations: int) -> None:
        """History rows (n, B, 2) for a launch: a prefix of a buffer kept between launches."""
        if self._steps.shape[0] < n_generations:
            self._steps = np.empty((n_generations,) + self._steps.shape[1:])
        self.work.history = self._steps[:n_generations]

    def _ran(self, advanced: int, running: np.ndarray) -> None:
        """After a launch: the history rows it wrote for the problems `running` at its start
        are kept (a batch's last launches run few of its problems: the rows of the others are
        never read). The rows from where each problem stopped are NaN'd once, in `history`: a
        problem's generations only grow within a solve."""
        if advanced:
            steps = self.work.history[:advanced]
            rows = steps.copy() if running is self._everyone else steps[:, running]  # indexing copies
            self._rows.append((self.generation, running, rows))
        self.generation += advanced

    @property
    def pop(self) -> np.ndarray:
        return self.work.current.pop

    @property
    def raw(self) -> np.ndarray:
        return self.work.current.raw

    @property
    def total(self) -> np.ndarray:
        return self.work.current.total

    def history_reader(self, generations: np.ndarray) -> Callable[[], np.ndarray]:
        """A function that joins this solve's history, best and mean total per generation (B, G,
        2), NaN once a problem had stopped, from what it holds: the rows kept of each launch
        (a later solve starts a list of its own) and `generations` (B,), a copy of each
        problem's count. A Result joins it only when its history is read."""
        return partial(_joined_history, tuple(self._rows), self.generation, generations)


def _joined_history(launches: tuple, n_generations: int, generations: np.ndarray) -> np.ndarray:
    """History (B, G, 2) from each launch's (first generation, problems running, rows (n, R, 2))."""
    history = np.full((len(generations), n_generations, 2), np.nan)
    for first, running, rows in launches:
        history[running, first : first + len(rows)] = rows.transpose(1, 0, 2)
    if launches:
        history[np.arange(n_generations) >= generations[:, None]] = np.nan
    return history
