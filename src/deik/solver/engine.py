"""The parallel DE engine: explicit state, `init`, `step` and `run`, on CPU or GPU.

State is immutable from the caller's side: `run` works in fresh ping-pong buffers and returns
a new EvolutionState; the one passed in is never changed.
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike

from deik.backends.contract import KernelInputs, Seeds, SolveBuffers, backend_for
from deik.backends.pack import kernel_array, pack_skeleton, pack_terms
from deik.device.layout import Buffers, KernelSettings, PackedTerms, PolishSchedule, SearchRules, Status
from deik.errors import InputError
from deik.memory import check_memory
from deik.objectives.kinds import TOLERANCE, WEIGHT
from deik.solver.footprint import solve_bytes
from deik.solver.problem import Problem
from deik.solver.result import ReportTerms
from deik.solver.routing import choose_device
from deik.solver.settings import LIMIT_CODES, STRATEGIES, Settings

STAGNATION = 1e-3  # a best that improves by less than this fraction in `patience` generations stagnates


@dataclass(frozen=True, eq=False)
class EvolutionState:
    """Population (B, P, D), levels (B, P, L), total (B, P), raw (B, P, T), rates (B, P, 2)
    (each individual's F and CR); per problem: best index, active, generations used,
    converged, best total and levels (B, L) seen, generation of last improvement, restarts used, restart due,
    the elite kept through the last restart (-1: none), leaders (B, islands): the best of each
    island but the elite, halt (1,): the host's stop flag (layout.Status);
    history (B, G, 2) of best and mean total fitness (NaN once a problem of a batch has
    stopped while others run on); `generation` counter."""

    pop: np.ndarray
    levels: np.ndarray
    total: np.ndarray
    raw: np.ndarray
    rates: np.ndarray
    best: np.ndarray
    active: np.ndarray
    generations: np.ndarray
    converged: np.ndarray
    best_seen: np.ndarray
    best_levels: np.ndarray
    last_improved: np.ndarray
    restarts: np.ndarray
    restarting: np.ndarray
    elite: np.ndarray
    leaders: np.ndarray
    halt: np.ndarray
    history: np.ndarray
    generation: int

    @property
    def buffers(self) -> Buffers:
        return Buffers(*(getattr(self, name) for name in Buffers._fields))

    @property
    def status(self) -> Status:
        return Status(*(getattr(self, name) for name in Status._fields))


class Engine:
    """Binds a Problem and Settings to a backend; `init` -> state, `step`/`run` -> new state."""

    def __init__(self, problem: Problem, settings: Settings | None = None):
        settings = Settings() if settings is None else settings
        if settings.device == "auto":  # the engine runs where this problem's size is fastest
            settings = dataclasses.replace(settings, device=choose_device(problem, settings))
        self.problem, self.settings = problem, settings
        dtype = np.dtype(settings.dtype)
        self.sizes = _sizes(problem, settings)
        self.skel = pack_skeleton(problem.skeleton, dtype)
        self.terms = pack_terms(problem.table, problem.reference, dtype)
        # the float64 report of a float32 run (raw_errors) reads these, packed once
        wide = dtype == np.float64
        self.skel64 = self.skel if wide else pack_skeleton(problem.skeleton, np.float64)
        self.terms64 = self.terms if wide else pack_terms(problem.table, problem.reference, np.float64)
        self.kernel_settings = KernelSettings(
            strategy=np.int64(STRATEGIES[settings.strategy]),
            limit_mode=np.int64(LIMIT_CODES[problem.limits]),
            F=dtype.type(settings.F),
            CR=dtype.type(settings.CR),
            seed=np.uint64(settings.seed),
            adaptive=bool(settings.adaptive),
            islands=np.int64(settings.islands),
        )
        self.polish_schedule = PolishSchedule(
            iterations=np.int64(settings.polish),
            every=np.int64(settings.polish_every),
            count=np.int64(min(settings.polish_count, settings.population)),
        )
        stop = settings.stop_on_converged
        if stop is None:
            weight, tolerance = problem.table.term_float[:, WEIGHT], problem.table.term_float[:, TOLERANCE]
            stop = not bool(((weight > 0) & (tolerance < 0)).any())
        self.search_rules = SearchRules(
            patience=np.int64(settings.patience),
            rel_improvement=STAGNATION,
            stop_on_converged=bool(stop),
            max_restarts=np.int64(settings.restarts),
            migration=np.int64(settings.migration),
        )
        self.backend = backend_for(settings.device)
        self.kernels_ready = False  # set once the kernels it runs are loaded (readiness.prepare)

    @property
    def inputs(self) -> KernelInputs:
        """What the kernels read (deik.backends.contract), bundled from this engine's parts."""
        return KernelInputs(
            skeleton=self.skel,
            terms=self.terms,
            evolution=self.kernel_settings,
            polish=self.polish_schedule,
            rules=self.search_rules,
        )

    def for_problem(self, problem: Problem) -> Engine:
        """A copy bound to `problem`, which shares this engine's skeleton and terms and differs
        only in targets and comfort reference poses: those are packed again, into arrays of the
        copy's own (a Solver and a kept engine write new ones into them)."""
        new = copy.copy(self)
        new.__dict__.pop("report_terms", None)  # worked out again for the new problem when asked
        new.problem, new.sizes = problem, _sizes(problem, self.settings)
        new.terms = _with_targets(self.terms, problem)
        new.terms64 = new.terms if self.terms64 is self.terms else _with_targets(self.terms64, problem)
        return new

    def with_seed(self, seed: int) -> Engine:
        """A copy that draws its random numbers from `seed` (and shares everything else)."""
        new = copy.copy(self)
        new.settings = self.settings.with_seed(seed)
        new.kernel_settings = seeded(self.kernel_settings, seed)
        return new

    def initial_poses(self, initial: ArrayLike | None) -> Seeds:
        """Seeds: poses (B, n, D) in the engine's dtype and their count n, from `initial` poses
        (D,), (n, D) or (B, n, D) (None: n = 0), checked against the skeleton and the population size."""
        B, P, D, _, _, dtype, _ = self.sizes
        if initial is None:
            return Seeds(np.zeros((B, 1, D), dtype), 0)
        init = self.problem.skeleton.check_angles(initial, "initial poses")
        if init.ndim > 3:
            raise InputError(f"initial poses must be (D,), (n, D) or (B, n, D), got {init.shape}")
        init = init.reshape((1,) * (3 - init.ndim) + init.shape) if init.ndim < 3 else init
        if init.shape[0] not in (1, B) or init.shape[1] > P:
            raise InputError(f"initial poses must be (n, D) or (B, n, D) with n <= population, got {init.shape}")
        if init.shape[0] != B:
            init = np.broadcast_to(init, (B,) + init.shape[1:])
        return Seeds(kernel_array(init, dtype), init.shape[1])

    def check_memory(self) -> None:
        """SolveError with the estimate and the fix when a solve's buffers would not fit
        (deik.memory)."""
        B, P, D, T, L, dtype, _ = self.sizes
        needed = solve_bytes(B, P, D, T, L, dtype.itemsize, self.settings.generations)
        check_memory(needed, self.settings.memory_limit, f"a solve of {B} problem(s) x population {P}")

    def new_buffers(self) -> Buffers:
        """One unfilled set of population buffers: poses (B, P, D), levels (B, P, L), total
        (B, P), raw errors (B, P, T) and rates (B, P, 2), in the solve's dtype."""
        B, P, D, T, L, dtype, _ = self.sizes
        return Buffers(
            np.empty((B, P, D), dtype),
            np.empty((B, P, L), dtype),
            np.empty((B, P), dtype),
            np.empty((B, P, T), dtype),
            np.empty((B, P, 2), dtype),
        )

    def new_status(self) -> Status:
        """A Status of B active problems that have not started (the kernels' start resets it)."""
        B, _, _, _, L, _, islands = self.sizes
        return Status(
            best=np.zeros(B, np.int64),
            active=np.ones(B, np.bool_),
            generations=np.zeros(B, np.int64),
            converged=np.zeros(B, np.bool_),
            best_seen=np.zeros(B, np.float64),
            best_levels=np.zeros((B, L), np.float64),
            last_improved=np.zeros(B, np.int64),
            restarts=np.zeros(B, np.int64),
            restarting=np.zeros(B, np.bool_),
            elite=np.full(B, -1, np.int64),
            leaders=np.zeros((B, islands), np.int64),
            halt=np.zeros(1, np.int64),
        )

    def _fresh(self, initial, n_generations: int) -> tuple[SolveBuffers, Seeds]:
        """Unfilled buffers for a new population and history rows for n_generations, and the seeds."""
        self.check_memory()
        seeds = self.initial_poses(initial)
        current = self.new_buffers()
        spare = Buffers(*(np.empty_like(a) for a in current))
        history = np.empty((n_generations, current.pop.shape[0], 2))
        return SolveBuffers(current=current, spare=spare, status=self.new_status(), history=history), seeds

    def init(self, initial: ArrayLike | None = None) -> EvolutionState:
        """Random first population inside the limits (seeded with `initial` poses), evaluated."""
        work, seeds = self._fresh(initial, 0)
        self.backend.initialise(self.inputs, work, seeds)
        return _advanced(work, np.zeros((len(work.status.best), 0, 2)), 0, 0)

    def start(self, n_generations: int, initial: ArrayLike | None = None) -> EvolutionState:
        """init(initial) then run(state, n_generations) as one backend call (on the CPU one
        compiled call: no Python between set-up, generations, polish and stopping)."""
        _check_generations(n_generations)
        work, seeds = self._fresh(initial, n_generations)
        advanced = self.backend.start(self.inputs, work, seeds, n_generations)
        self.backend.fetch(work)
        return _advanced(work, np.zeros((len(work.status.best), 0, 2)), 0, advanced)

    def run(self, state: EvolutionState, n_generations: int) -> EvolutionState:
        """Run up to n_generations more (each problem stops on convergence or stagnation)."""
        _check_generations(n_generations)
        B = state.pop.shape[0]
        # generation-major and left unfilled: a launch touches only the rows it runs, however
        # large the budget (a batch of 10,000 x 2,000 generations would be 320 MB to fill)
        work = SolveBuffers(
            current=Buffers(*(a.copy() for a in state.buffers)),
            spare=Buffers(*(a.copy() for a in state.buffers)),  # stopped problems must be in both
            status=Status(*(a.copy() for a in state.status)),
            history=np.empty((n_generations, B, 2)),
        )
        advanced = self.backend.run(self.inputs, work, state.generation, n_generations)
        self.backend.fetch(work)
        return _advanced(work, state.history, state.generation, advanced)

    @cached_property
    def report_terms(self) -> ReportTerms:
        """What each Result reports per term (solver/result.py), worked out once."""
        return ReportTerms.of(self.problem.table, self.problem.skeleton)

    def raw_errors(self, poses: np.ndarray) -> np.ndarray:
        """Raw error (metres or radians) of every term, (B, T) float64, for poses (B, D), pose b
        measured against problem b by the CPU kernel's own maths in float64."""
        from deik.backends.cpu import evaluate_poses

        return evaluate_poses(poses, np.arange(len(poses)), self.skel64, self.terms64, self.problem.table.n_levels)[2]

    def step(self, state: EvolutionState) -> EvolutionState:
        """One generation."""
        return self.run(state, 1)


_SEED_FIELD = KernelSettings._fields.index("seed")


def seeded(kernel_settings: KernelSettings, seed: int) -> KernelSettings:
    """`kernel_settings` with `seed` (the NamedTuple built directly: its _replace took 2 us of
    a 0.1 ms robot solve)."""
    return tuple.__new__(
        KernelSettings, (*kernel_settings[:_SEED_FIELD], np.uint64(seed), *kernel_settings[_SEED_FIELD + 1 :])
    )


def _check_generations(n_generations: int) -> None:
    """ValueError unless `n_generations` is a whole number >= 0 (the generations to run)."""
    if isinstance(n_generations, (bool, np.bool_)) or not isinstance(n_generations, (int, np.integer)):
        raise InputError(f"n_generations must be a whole number >= 0, got {n_generations!r}")
    if n_generations < 0:
        raise InputError(f"n_generations must be >= 0 (the generations to run), got {n_generations}")


def _sizes(problem: Problem, settings: Settings) -> tuple:
    """(B, P, D, T, L, dtype, islands): the sizes of a solve's buffers (solver/workspace.py)."""
    table = problem.table
    return (
        problem.batch_size,
        settings.population,
        problem.skeleton.n_dofs,
        table.n_terms,
        table.n_levels,
        np.dtype(settings.dtype),
        settings.islands,
    )


def _with_targets(terms: PackedTerms, problem: Problem) -> PackedTerms:
    """Packed terms (pack_terms) with the target parameters (B, T, N_PARAMS) and comfort
    reference poses (B, T, D) replaced by copies of the problem's."""
    dtype = terms.params.dtype
    return terms._replace(
        params=kernel_array(problem.table.params, dtype), reference=kernel_array(problem.reference, dtype)
    )


def _advanced(work: SolveBuffers, history, generation: int, advanced: int) -> EvolutionState:
    """The state after a launch that ran `advanced` generations from `generation`: its buffers
    and status, and the history (B, G, 2) grown by the rows work.history (n, B, 2) it wrote
    (NaN where a problem had stopped)."""
    status = work.status
    ran = generation + np.arange(advanced)
    new = np.where((ran[:, None] < status.generations[None, :])[..., None], work.history[:advanced], np.nan)
    history = np.concatenate([history, new.transpose(1, 0, 2)], axis=1)
    return EvolutionState(
        **work.current._asdict(), **status._asdict(), history=history, generation=generation + advanced
    )
