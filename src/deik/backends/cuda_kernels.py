"""GPU kernels (numba-cuda), compiled once per dtype and cached on disk: no size is built in.

Two kernels run a solve, each a module-level `cuda.jit(cache=True)` function that reads every
size from its arrays, so one compile serves any robot, population, batch and goal mix (a new
dtype or a new deik compiles again; the cache stamp is the CPU kernels', deik.backends.targets):

- `first_polish`: one thread per problem polishes its individual 0 (device_driver.polish_first)
  and, when that meets every tolerance, stops the problem there (its population copies of it),
  as the CPU's lazy first population does. Robot targets nearly all stop here (median 0
  generations), so this is most of a solve's work; where a team of threads per problem can
  take it, deik.backends.cuda_team.first_polish_team does it instead, and this kernel serves
  skeletons beyond a team's shared slab and goals without tolerance.
- `evolve`: one block per problem of a list (the unmet ones), threads striding over the
  population: completes or samples a first population, then runs generations with ping-pong
  buffers, polish rounds side by side (one thread per polished individual) and the
  per-problem bookkeeping between them, until the problem stops or the launch's generations
  end. Blocks loop over the list (grid-stride), so the grid, and the scratch, stay the size
  of what the GPU holds at once.

Per-thread scratch is carved from preallocated global arrays laid out element-major and thread-
minor (`pool[e, thread]`), so neighbouring threads touch neighbouring words; nothing is a local
array of a built-in size. What one thread does for one individual is the CPU kernels' own code
(deik.device, compiled with cuda.jit(device=True)). Runs in Numba's CUDA simulator too
(NUMBA_ENABLE_CUDASIM=1), which is how CI checks it against the CPU.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

from numba import int32

from deik.backends import targets
from deik.backends.gpu import numba_cuda, simulated
from deik.device.layout import THREADS_PER_BLOCK, WORK_SIZE, LmScratch, Scratch

cuda = numba_cuda()
targets.register_cuda_kernel_cache()

if TYPE_CHECKING:  # what a reader's go-to-definition reaches: the device maths as plain Python
    from deik.device import driver as device_driver
    from deik.device import evolution as device_evolution
    from deik.device import maths as device_maths
else:  # what runs: the same functions compiled with cuda.jit(device=True) (deik.backends.targets)
    device_driver = device_evolution = device_maths = targets.cuda_device()

# evolve's register cap: 4 blocks of 128 threads resident per multiprocessor (65,536 registers);
# uncapped, ptxas gave it 255 (2 blocks). first_polish stays uncapped: a thread per problem, and
# a batch of 10,000 problems is 76 threads per multiprocessor of an H100, far below any limit.
EVOLVE_REGISTERS = 128
EVOLVE_OPTIONS = {} if simulated() else {"max_registers": EVOLVE_REGISTERS}  # the simulator takes no cap
# evolve's modes: how a launch begins
CONTINUE, COMPLETE_FIRST, SAMPLE_FIRST = 0, 1, 2
# the columns of an answer row (float64): Status fields, the best individual's total, pose and errors
# and the generations the last launch ran for the problem
ANSWER_BEST, ANSWER_ACTIVE, ANSWER_GENERATIONS, ANSWER_CONVERGED, ANSWER_RESTARTS, ANSWER_RAN = range(6)
ANSWER_TOTAL, ANSWER_POSE = 6, 7


class KernelSizes(NamedTuple):
    """The sizes the host allocates the kernels' buffers and scratch for."""

    problems: int  # B
    population: int  # P
    dofs: int  # D
    levels: int  # L
    terms: int  # T
    frames: int  # F: joints, then sites
    motions: int  # N


def thread_rows(sizes: KernelSizes) -> int:
    """Rows of one thread's column of the scratch pool (carve_scratch's layout)."""
    F, D, L, T = sizes.frames, sizes.dofs, sizes.levels, sizes.terms
    return 12 * F + WORK_SIZE + 6 * sizes.motions + 7 * D + 2 + 2 * L + 2 * T


def matrix_rows(sizes: KernelSizes) -> int:
    """Rows of one polishing thread's column of the matrix pool: the LM's two D x D matrices."""
    return 2 * sizes.dofs * sizes.dofs


def answer_width(sizes: KernelSizes) -> int:
    """Columns of an answer row: the Status fields, the total, the pose (D) and the raw errors
    (T). The answers hold B + 1 rows: the last counts the problems first_polish left unmet."""
    return ANSWER_POSE + sizes.dofs + sizes.terms


@cuda.jit(device=True)
def take(column, start, n):
    """(column[start:start + n], start + n): the next n rows of a scratch column."""
    return column[start : start + n], start + n


@cuda.jit(device=True)
def carve_scratch(column, matrices, skel, D, L, T):
    """One thread's scratch from its column of the pool (thread_rows long) and of the matrix
    pool: (Scratch, axes (6N,), trial (D,), trial_rates (2,), lv (L,), rw (T,), LmScratch)."""
    F = device_maths.frame_count(skel)
    R, o = take(column, 0, 9 * F)
    p, o = take(column, o, 3 * F)
    work, o = take(column, o, WORK_SIZE)
    axes, o = take(column, o, 6 * skel.motion_int.shape[0])
    trial, o = take(column, o, D)
    trial_rates, o = take(column, o, 2)
    lv, o = take(column, o, L)
    rw, o = take(column, o, T)
    gradient, o = take(column, o, D)
    jac, o = take(column, o, 3 * D)
    delta, o = take(column, o, D)
    pose, o = take(column, o, D)
    pose_levels, o = take(column, o, L)
    pose_raw, o = take(column, o, T)
    lm = LmScratch(matrices[0 : D * D], matrices[D * D : 2 * D * D], gradient, jac, delta, pose, pose_levels, pose_raw)
    return Scratch(R, p, work), axes, trial, trial_rates, lv, rw, lm


@cuda.jit(device=True)
def write_answer(b, slot, ran, state, status, answers):
    """Problem b's Status fields, the generations the launch ran for it and its best individual
    into answers[slot] (float64): the first polish writes row b of the whole batch's answers,
    evolve row `slot` of its own list's, which the host copies back as one prefix."""
    k = status.best[b]
    row = answers[slot]
    row[ANSWER_RAN] = ran
    row[ANSWER_BEST] = k
    row[ANSWER_ACTIVE] = 1.0 if status.active[b] else 0.0
    row[ANSWER_GENERATIONS] = status.generations[b]
    row[ANSWER_CONVERGED] = 1.0 if status.converged[b] else 0.0
    row[ANSWER_RESTARTS] = status.restarts[b]
    row[ANSWER_TOTAL] = state.total[b, k]
    D = state.pop.shape[2]
    for d in range(D):
        row[ANSWER_POSE + d] = state.pop[b, k, d]
    for t in range(state.raw.shape[2]):
        row[ANSWER_POSE + D + t] = state.raw[b, k, t]


@cuda.jit(cache=True)
def first_polish(cur, status, skel, terms, settings, schedule, rules, initial, n_initial, unmet, answers, pool):
    """Each problem's individual 0 seeded, evaluated and polished, one thread per problem
    (grid-stride); a problem it meets stops with its population all copies of it and its answer
    written; the others are listed in unmet (B,) for `evolve`, their count in the extra answer
    row answers[B, 0] (zero before the launch), so that one copy brings both out."""
    B, P, D = cur.pop.shape[0], cur.pop.shape[1], cur.pop.shape[2]
    L, T = cur.levels.shape[2], cur.raw.shape[2]
    start, stride = cuda.grid(1), cuda.gridsize(1)
    column = pool[:, start]
    scratch, axes, q, _, lv, rw, lm = carve_scratch(column, column[pool.shape[0] - 2 * D * D :], skel, D, L, T)
    for b in range(start, B, stride):
        met = device_driver.polish_first(
            b, cur, skel, terms, settings, schedule, initial, n_initial, scratch, axes, lm, q, lv, rw, status.halt
        )
        if met:
            for i in range(1, P):
                device_evolution.copy_individual(cur, cur, b, 0, i)
            device_evolution.rank_first(b, cur, status)
            device_evolution.settle_after_polish(b, 0, cur, terms, status, rules, False)
            write_answer(b, b, 0, cur, status, answers)
        else:
            unmet[int(cuda.atomic.add(answers, (B, 0), 1.0))] = b


@cuda.jit(cache=True, **EVOLVE_OPTIONS)
def evolve(
    mode,
    order,
    n_order,
    cur,
    nxt,
    status,
    skel,
    terms,
    settings,
    schedule,
    rules,
    history,
    initial,
    n_initial,
    gen_start,
    n_gens,
    answers,
    history_rows,
    pool,
    matrices,
):
    """Problems order[0:n_order], one block each (grid-stride over the list): begin as `mode`
    says (CONTINUE; COMPLETE_FIRST: individuals 1.. of a lazy first population, then its
    settling; SAMPLE_FIRST: a whole first population), then up to n_gens generations from
    gen_start, as deik.backends.cpu_kernels.run_generations does for one problem: a polish
    round (side by side, undone after the first success) when due, breeding, bookkeeping. The
    final state of every problem is left in `cur`; the answer of order[slot] goes to
    answers[slot] and its history rows to history_rows[:, slot] (n_gens, n_order, 2), so that
    the host copies back only the rows of the problems this launch ran."""
    tid, threads = cuda.threadIdx.x, cuda.blockDim.x
    P, D = cur.pop.shape[1], cur.pop.shape[2]
    L, T = cur.levels.shape[2], cur.raw.shape[2]
    column = pool[:, cuda.blockIdx.x * threads + tid]
    polisher = cuda.blockIdx.x * max(schedule.count, 1) + min(tid, max(schedule.count, 1) - 1)
    scratch, axes, trial, trial_rates, lv, rw, lm = carve_scratch(column, matrices[:, polisher], skel, D, L, T)
    met = cuda.shared.array(THREADS_PER_BLOCK, int32)
    halted = cuda.shared.array(1, int32)
    for slot in range(cuda.blockIdx.x, n_order, cuda.gridDim.x):
        b = order[slot]
        a, z = cur, nxt
        if mode == COMPLETE_FIRST:
            for i in range(1 + tid, P, threads):
                device_driver.initialise_individual(b, i, a, skel, terms, settings, initial, n_initial, scratch)
            cuda.syncthreads()
            if tid == 0:
                device_evolution.rank_first(b, a, status)
                device_evolution.settle_after_polish(b, 0, a, terms, status, rules, False)
        elif mode == SAMPLE_FIRST:
            for i in range(tid, P, threads):
                device_driver.initialise_individual(b, i, a, skel, terms, settings, initial, n_initial, scratch)
            cuda.syncthreads()
            if tid == 0:
                device_evolution.rank_first(b, a, status)
        swaps = 0
        fresh = False  # the last generation restarted: polish it at once, as the CPU does
        for g in range(n_gens):
            cuda.syncthreads()
            if tid == 0:
                halted[0] = status.halt[0]
            cuda.syncthreads()
            if not status.active[b] or halted[0] != 0:
                break
            gen = gen_start + g
            if schedule.iterations > 0 and (gen % schedule.every == 0 or fresh):
                # side by side, then every polish after the first that met all tolerances undone
                # (nxt is scratch until the breeding writes it): the CPU's in-order round
                target = device_evolution.polish_target(status.leaders[b], tid, schedule.count, P)
                polishes = tid < schedule.count and not device_evolution.polished_just_now(
                    target, mode == COMPLETE_FIRST and g == 0
                )
                if tid < schedule.count:
                    met[tid] = 0
                if polishes:
                    device_evolution.copy_individual(a, z, b, target, target)
                    met[tid] = device_driver.polish_individual(
                        b, target, a, skel, terms, schedule, scratch, axes, lm, trial, lv, rw, status.halt
                    )
                cuda.syncthreads()
                if polishes:
                    for k in range(tid):
                        if met[k]:
                            device_evolution.copy_individual(z, a, b, target, target)
                            break
                cuda.syncthreads()
                if tid == 0:
                    device_evolution.settle_after_polish(b, gen, a, terms, status, rules, True)
                cuda.syncthreads()
                if not status.active[b]:
                    break
            fresh = status.restarting[b]
            for i in range(tid, P, threads):
                device_driver.breed_individual(
                    b, i, gen, a, z, skel, terms, settings, status, scratch, trial, trial_rates, lv, rw
                )
            a, z = z, a
            swaps += 1
            cuda.syncthreads()
            if tid == 0:
                device_evolution.update_status(b, gen, g, a, terms, status, rules, history)
        cuda.syncthreads()
        if swaps % 2 == 1:  # the final state is in nxt: copy it back, so that cur holds every problem
            for i in range(tid, P, threads):
                device_evolution.copy_individual(nxt, cur, b, i, i)
        cuda.syncthreads()
        if tid == 0:
            write_answer(b, slot, swaps, cur, status, answers)
            for g in range(swaps):
                history_rows[g, slot, 0] = history[g, b, 0]
                history_rows[g, slot, 1] = history[g, b, 1]
