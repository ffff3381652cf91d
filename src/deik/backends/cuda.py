"""Host side of the GPU kernels (deik.backends.cuda_kernels): state kept on the device, copies counted.

The CUDA back-end of an Engine keeps on the GPU, from solve to solve, everything that does not
change while only the targets do: the skeleton, the goal table, the population buffers, the
Status, the scratch. A solve copies in the target parameters (and the comfort reference or
seed poses when given) and copies out one answer row per problem: its Status fields and best
individual (cuda_kernels.write_answer), plus the history rows of the generations it ran; an
`evolve` launch writes the rows of the problems it ran in its own order, so only those come back
(the few problems a batch's first polish leaves unmet no longer bring the whole batch's rows). A
batch of robot targets that the first polish meets is one launch (`first_polish_team`, a team
of threads per problem, deik.backends.cuda_team, where the skeleton and goals allow; else
`first_polish`, a thread per problem); problems it leaves unmet take a second (`evolve`).
`traffic` counts launches and bytes each way.

Every GPU call runs inside deik.backends.gpu.on_gpu, so any failure (compile, launch, out of
memory) reaches the caller as one DeviceError line.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from deik.backends.contract import KernelInputs, Seeds, SolveBuffers
from deik.backends.gpu import on_gpu, require_gpu, simulated
from deik.device.layout import THREADS_PER_BLOCK, Buffers, Status
from deik.objectives.kinds import TOLERANCE

RESIDENT_THREADS_PER_MULTIPROCESSOR = 2048  # Hopper; the grid never launches more threads than fit at once
SIMULATED_MULTIPROCESSORS = 2  # the simulator runs threads in Python: keep its grids small
FIRST_POLISH_THREADS = 32  # problems per block of first_polish (one per thread)
# the scratch pools of each kernel stay under this; beyond it the grid shrinks and its threads and
# blocks take several problems each (grid-stride): a 100-link chain's polish needs 90 KB a thread
SCRATCH_BYTES = 1 << 30


@dataclass
class Traffic:
    """What the back-end did since it was made: kernel launches and bytes copied each way."""

    launches: int = 0
    bytes_to_device: int = 0
    bytes_to_host: int = 0


class CudaBackend:
    """The GPU behind the back-end contract (deik.backends.contract.Backend)."""

    name = "gpu"

    def __init__(self):
        self.cuda = require_gpu()
        with on_gpu("loading the CUDA kernels"):
            from deik.backends import cuda_kernels, cuda_team

        self.kernels = cuda_kernels
        self.team = cuda_team
        # the first polish by a team of threads per problem where it can (cuda_team.fits and every
        # goal with a tolerance); False: a thread per problem (the benchmark compares the two)
        self.cooperative_polish = True
        self.traffic = Traffic()
        self._uploaded = {}  # id of a host input array -> (host array, device copy, bytes it held)
        self._sizes = None  # KernelSizes of the device buffers
        self._bound = None  # the SolveBuffers whose state the device buffers hold
        self._no_seeds = None  # the device placeholder for "no seed poses"
        cuda = self.cuda
        sms = SIMULATED_MULTIPROCESSORS if simulated() else cuda.get_current_device().MULTIPROCESSOR_COUNT
        self._resident_threads = sms * RESIDENT_THREADS_PER_MULTIPROCESSOR

    # copies, counted ------------------------------------------------------------------------

    def _to_device(self, host: np.ndarray):
        self.traffic.bytes_to_device += host.nbytes
        return self.cuda.to_device(host)

    def _to_host(self, device, host: np.ndarray) -> None:
        self.traffic.bytes_to_host += host.nbytes
        device.copy_to_host(host)

    def _copy_in(self, host: np.ndarray, device) -> None:
        self.traffic.bytes_to_device += host.nbytes
        device.copy_to_device(np.ascontiguousarray(host))

    def _resident(self, host: np.ndarray, changes: bool = False):
        """The device copy of an input array: uploaded once per array object, and when `changes`
        (targets a Solver rewrites in place) again whenever its bytes differ from the last upload."""
        kept = self._uploaded.get(id(host))
        if kept is None or kept[0] is not host or kept[1].shape != host.shape:
            device = self._to_device(np.ascontiguousarray(host))
            self._uploaded[id(host)] = (host, device, host.copy() if changes else None)
            return device
        if changes and not np.array_equal(kept[2], host):
            self._copy_in(host, kept[1])
            kept[2][...] = host
        return kept[1]

    def _inputs(self, inputs: KernelInputs) -> KernelInputs:
        """The inputs with device arrays: the skeleton and goal table kept, the targets and
        comfort references re-sent only when they changed."""
        terms = inputs.terms
        changing = {"params", "reference"}
        return inputs._replace(
            skeleton=type(inputs.skeleton)(*(self._resident(a) for a in inputs.skeleton)),
            terms=type(terms)(*(self._resident(getattr(terms, f), f in changing) for f in terms._fields)),
        )

    # device buffers ---------------------------------------------------------------------------

    def _allocate(self, inputs: KernelInputs, work: SolveBuffers) -> None:
        """Device buffers, scratch and answers for work's sizes (kept while they stay the same)."""
        kernels, cuda = self.kernels, self.cuda
        skel, cur = inputs.skeleton, work.current
        B, P, D = cur.pop.shape
        sizes = kernels.KernelSizes(
            problems=B,
            population=P,
            dofs=D,
            levels=cur.levels.shape[2],
            terms=cur.raw.shape[2],
            frames=skel.joint_int.shape[0] + skel.site_joint.shape[0],
            motions=skel.motion_int.shape[0],
        )
        count = max(1, int(inputs.polish.count))
        if sizes == self._sizes and self._polishers == count:
            return
        with on_gpu(f"allocating buffers for {B} problem(s) x population {P}"):
            self.cur = Buffers(*(cuda.device_array(a.shape, a.dtype) for a in cur))
            self.nxt = Buffers(*(cuda.device_array(a.shape, a.dtype) for a in cur))
            self.status = Status(*(cuda.device_array(a.shape, a.dtype) for a in work.status))
            self.status.halt.copy_to_device(np.zeros(1, np.int64))
            dtype = cur.pop.dtype
            rows, matrices = kernels.thread_rows(sizes), kernels.matrix_rows(sizes)
            self.threads = min(THREADS_PER_BLOCK, 32 * -(-P // 32))
            per_block = (self.threads * rows + count * max(matrices, 1)) * dtype.itemsize
            self.blocks = max(1, min(B, self._resident_threads // self.threads, SCRATCH_BYTES // per_block))
            per_thread = (rows + matrices) * dtype.itemsize
            threads = max(1, min(B, self._resident_threads, SCRATCH_BYTES // per_thread))
            self.polish_threads = FIRST_POLISH_THREADS * -(-threads // FIRST_POLISH_THREADS)  # one pool column each
            self.evolve_pool = cuda.device_array((rows, self.blocks * self.threads), dtype)
            self.polish_matrices = cuda.device_array((max(matrices, 1), self.blocks * count), dtype)
            self.first_pool = cuda.device_array((rows + matrices, self.polish_threads), dtype)
            self.team_pool = None  # allocated by the first team polish (_team_geometry)
            self.unmet = cuda.device_array(B, np.int64)
            self.order = self._to_device(np.arange(B, dtype=np.int64))
            self.answers = cuda.device_array((B + 1, kernels.answer_width(sizes)), np.float64)
            self.evolve_answers = cuda.device_array((B, kernels.answer_width(sizes)), np.float64)
            self.history = cuda.device_array((0, B, 2), np.float64)
            self.history_rows = cuda.device_array((0, 0, 2), np.float64)
        self.host_answers = np.empty((B + 1, kernels.answer_width(sizes)), np.float64)
        self.host_evolve_answers = np.empty((B, kernels.answer_width(sizes)), np.float64)
        self._sizes, self._polishers, self._bound = sizes, count, None

    def _team_geometry(self, inputs: KernelInputs) -> tuple[int, int] | None:
        """(blocks, threads per block) of first_polish_team for these inputs, its scratch pool
        allocated; None where the thread-per-problem first_polish runs instead (a skeleton of more
        DOFs than a team's shared slab holds, or a goal without tolerance: device_lm.relax)."""
        team, sizes = self.team, self._sizes
        D, B = sizes.dofs, sizes.problems
        if not (self.cooperative_polish and team.fits(D)) or (inputs.terms.term_float[:, TOLERANCE] < 0).any():
            return None
        teams = min(team.teams_per_block(D), B)  # a small batch: a small block, no idle teams
        threads = teams * team.TEAM_LANES
        rows = self.kernels.thread_rows(sizes)
        itemsize = self.cur.pop.dtype.itemsize
        fit = max(1, min(self._resident_threads, SCRATCH_BYTES // (rows * itemsize)) // threads)
        blocks = max(1, min(-(-B // teams), fit))
        if self.team_pool is None or self.team_pool.shape[1] != blocks * threads:
            with on_gpu(f"allocating the team polish's scratch for {B} problem(s)"):
                self.team_pool = self.cuda.device_array((rows, blocks * threads), self.cur.pop.dtype)
        return blocks, threads

    def _history_for(self, n_generations: int):
        """Device history rows (n, B, 2): a prefix of a buffer kept between launches."""
        if self.history.shape[0] < n_generations:
            with on_gpu("allocating the history"):
                self.history = self.cuda.device_array((n_generations,) + self.history.shape[1:], np.float64)
        return self.history[:n_generations]

    def _history_rows_for(self, n_generations: int, n: int):
        """Device history rows (n_generations, n, 2) of one launch's n problems, in its order: a
        buffer kept while a launch of the same shape follows, so its first rows are one block."""
        if self.history_rows.shape[:2] != (n_generations, n):
            with on_gpu("allocating the history"):
                self.history_rows = self.cuda.device_array((n_generations, n, 2), np.float64)
        return self.history_rows

    def _bind(self, work: SolveBuffers, upload: bool) -> None:
        """Make the device buffers hold work's state: uploaded when `upload` and work is not
        the state they hold already (Engine.run on a state of the caller's)."""
        if upload and self._bound is not work:
            with on_gpu("copying the population to the GPU"):
                for host, device in zip(work.current + work.status, self.cur + self.status):
                    self._copy_in(host, device)
        self._bound = work

    # the contract -----------------------------------------------------------------------------

    def initialise(self, inputs: KernelInputs, work: SolveBuffers, seeds: Seeds) -> None:
        """A random first population, evaluated, and its Status, into the host buffers."""
        self._evolve_all(inputs, work, seeds, self.kernels.SAMPLE_FIRST, (0, 0))
        self.fetch(work)

    def start(self, inputs: KernelInputs, work: SolveBuffers, seeds: Seeds, n_generations: int) -> int:
        """The first population (lazy, as the CPU's, when the polish is on and met problems
        stop), then up to n_generations; one launch when the first polish meets every problem."""
        if not (inputs.polish.iterations > 0 and inputs.rules.stop_on_converged):
            return self._evolve_all(inputs, work, seeds, self.kernels.SAMPLE_FIRST, (0, n_generations))
        self._allocate(inputs, work)
        self._bind(work, upload=False)
        kernels, device = self.kernels, self._inputs(inputs)
        initial = self._seeds(seeds)
        B = self._sizes.problems
        geometry = self._team_geometry(inputs)
        with on_gpu("running the first polish"):
            self._copy_in(np.zeros(1), self.answers[B, :1])
            if geometry is None:
                kernel, pool = kernels.first_polish, self.first_pool
                geometry = (-(-self.polish_threads // FIRST_POLISH_THREADS), FIRST_POLISH_THREADS)
            else:
                kernel, pool = self.team.first_polish_team, self.team_pool
            kernel[geometry](
                self.cur,
                self.status,
                *device,  # skeleton, terms, evolution, polish, rules
                initial,
                np.int64(seeds.count),
                self.unmet,
                self.answers,
                pool,
            )
            self.traffic.launches += 1
            self._to_host(self.answers, self.host_answers)
        n_unmet = int(self.host_answers[B, 0])
        if not n_unmet:
            self._apply(work, np.arange(B), self.host_answers[:B])
            return 0
        problems = (self.unmet[:n_unmet], n_unmet)
        self._evolve(device, problems, (initial, seeds.count), kernels.COMPLETE_FIRST, (0, n_generations))
        with on_gpu("copying the unmet problems' list"):
            unmet = np.empty(n_unmet, np.int64)
            self._to_host(self.unmet[:n_unmet], unmet)
        met = np.setdiff1d(np.arange(B), unmet, assume_unique=True)
        self._apply(work, met, self.host_answers[met])
        return self._answers(work, unmet)

    def run(self, inputs: KernelInputs, work: SolveBuffers, first_generation: int, n_generations: int) -> int:
        """Up to n_generations more from first_generation, for the problems still active."""
        self._allocate(inputs, work)
        self._bind(work, upload=True)
        active = np.flatnonzero(work.status.active)
        if active.size == 0:
            return 0
        device = self._inputs(inputs)
        with on_gpu("copying the running problems' list"):
            order = self._to_device(active.astype(np.int64))
        seeds = (self._seeds(Seeds(work.current.pop[:1, :1], 0)), 0)
        self._evolve(device, (order, active.size), seeds, self.kernels.CONTINUE, (first_generation, n_generations))
        return self._answers(work, active)

    def fetch(self, work: SolveBuffers) -> None:
        """Every individual and Status field into the host buffers."""
        with on_gpu("copying the population from the GPU"):
            for device, host in zip(self.cur + self.status, work.current + work.status):
                self._to_host(device, host)

    # launches ---------------------------------------------------------------------------------

    def _seeds(self, seeds: Seeds):
        """The seed poses on the device (a placeholder kept on the device when there are none)."""
        with on_gpu("copying the seed poses"):
            if seeds.count == 0:
                if self._no_seeds is None or self._no_seeds.dtype != seeds.poses.dtype:
                    self._no_seeds = self._to_device(np.zeros((1, 1, 1), seeds.poses.dtype))
                return self._no_seeds
            return self._to_device(np.ascontiguousarray(seeds.poses))

    def _evolve_all(self, inputs: KernelInputs, work: SolveBuffers, seeds: Seeds, mode: int, generations) -> int:
        """evolve over every problem from a first population (sampled or completed)."""
        self._allocate(inputs, work)
        self._bind(work, upload=False)
        B = self._sizes.problems
        self._evolve(self._inputs(inputs), (self.order, B), (self._seeds(seeds), seeds.count), mode, generations)
        return self._answers(work, np.arange(B))

    def _evolve(self, device: KernelInputs, problems: tuple, seeds: tuple, mode: int, generations: tuple) -> None:
        """One launch of cuda_kernels.evolve over `problems` (a device index list, its length)
        from `seeds` (device poses, count), `generations` (first, count)."""
        order, n = problems
        first_generation, n_generations = generations
        self._launch_history = self._history_for(n_generations)
        history_rows = self._history_rows_for(n_generations, n)
        with on_gpu("running the generations"):
            self.kernels.evolve[min(self.blocks, n), self.threads](
                np.int64(mode),
                order,
                np.int64(n),
                self.cur,
                self.nxt,
                self.status,
                *device,  # skeleton, terms, evolution, polish, rules
                self._launch_history,
                seeds[0],
                np.int64(seeds[1]),
                np.int64(first_generation),
                np.int64(n_generations),
                self.evolve_answers,
                history_rows,
                self.evolve_pool,
                self.polish_matrices,
            )
            self.traffic.launches += 1

    def _answers(self, work: SolveBuffers, problems: np.ndarray) -> int:
        """After an evolve launch over `problems` (n,), in its order: copy their answer rows
        and the history rows of the generations it ran out (the first n rows of each: nothing of
        the problems it did not run), write them into the host buffers; returns the most
        generations it ran for any of them."""
        n = len(problems)
        with on_gpu("copying the answers from the GPU"):
            rows = self.host_evolve_answers[:n]
            self._to_host(self.evolve_answers[:n], rows)
            advanced = int(rows[:, self.kernels.ANSWER_RAN].max()) if n else 0
            if advanced:
                steps = np.empty((advanced, n, 2))
                self._to_host(self.history_rows[:advanced], steps)
                work.history[:advanced, problems] = steps
        self._apply(work, problems, rows)
        return advanced

    def _apply(self, work: SolveBuffers, problems: np.ndarray, rows: np.ndarray) -> None:
        """Write `problems`' (n,) answer rows (n, width) into the host Status and best individuals."""
        k = self.kernels
        status, cur = work.status, work.current
        best = rows[:, k.ANSWER_BEST].astype(np.int64)
        status.best[problems] = best
        status.active[problems] = rows[:, k.ANSWER_ACTIVE] != 0
        status.generations[problems] = rows[:, k.ANSWER_GENERATIONS].astype(np.int64)
        status.converged[problems] = rows[:, k.ANSWER_CONVERGED] != 0
        status.restarts[problems] = rows[:, k.ANSWER_RESTARTS].astype(np.int64)
        D = cur.pop.shape[2]
        cur.total[problems, best] = rows[:, k.ANSWER_TOTAL]
        cur.pop[problems, best] = rows[:, k.ANSWER_POSE : k.ANSWER_POSE + D]
        cur.raw[problems, best] = rows[:, k.ANSWER_POSE + D :]
