"""CPU kernels: the parallel ping-pong DE of Figure 1 with numba prange.

Plain Python as written here (run as such, they call the device maths as Python); compiled, a
copy of every function joins the device maths in one namespace per build
(deik.backends.targets.cpu_build: `linked` marks how each is compiled), and Python calls a
kernel through its entry point (deik.backends.targets.cpu_entry).

Every generation reads the current Buffers (pop, levels, total, raw, rates; deik.device.layout)
and writes the next; individuals are split into chunks of whole blocks of LANES, one scratch
allocation per chunk, and each block is bred (or a first population evaluated) together in SIMD
lanes by device/lanes.py, whose trial, scoring and selection of each individual are
device/driver.py's, the code the GPU kernels run. Results depend neither on the thread count nor
on the split into chunks and blocks: each individual's trial depends only on (seed, problem,
generation, individual) and the current population, every lane computes what the one-pose code
computes, and the per-problem bookkeeping runs in index order.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from deik.backends.linking import linked
from deik.device import driver as device_driver
from deik.device import evolution as device_evolution
from deik.device import lanes as device_lanes
from deik.device import maths as device_maths
from deik.device import terms as device_terms
from deik.device.layout import LANES, WORK_SIZE, LaneScratch, LmScratch, Scratch

CHUNKS_PER_THREAD = 8
SERIAL_WORK = 4096  # individuals x frames per loop below which one thread is faster


@linked()
def thread_scratch(skel, dtype_probe, n_terms, n_levels, n_dofs):
    """(Scratch, trial (D,), lv (L,), rw (T,)) of one thread, in dtype_probe's dtype."""
    frames, t = device_maths.frame_count(skel), dtype_probe.dtype
    scratch = Scratch(np.empty(frames * 9, t), np.empty(frames * 3, t), np.empty(WORK_SIZE, t))
    return scratch, np.empty(n_dofs, t), np.empty(n_levels, t), np.empty(n_terms, t)


@linked()
def _lane_span(c, chunks, n):
    """Individuals [start, end) of chunk c of `chunks` over n: whole blocks of LANES, so only the
    last block of all is short (the split never changes a result)."""
    blocks = (n + LANES - 1) // LANES
    return min(n, c * blocks // chunks * LANES), min(n, (c + 1) * blocks // chunks * LANES)


@linked()
def lane_scratch(skel, dtype_probe, n_terms, n_levels, n_dofs):
    """A LaneScratch of one thread, in dtype_probe's dtype; poses start at zero, so lanes a short
    last block leaves unused compute on finite numbers."""
    frames, t = device_maths.frame_count(skel), dtype_probe.dtype
    return LaneScratch(
        np.empty((LANES, n_dofs), t),
        np.zeros((n_dofs, LANES), t),
        np.empty((LANES, 2), t),
        np.empty((frames * 12, LANES), t),
        np.empty((frames * 9, LANES), t),
        np.empty((frames * 3, LANES), t),
        np.empty((LANES, n_levels), t),
        np.empty((LANES, n_terms), t),
        np.empty(WORK_SIZE, t),
    )


@linked()
def polish_scratch(skel, dtype_probe, n_terms, n_levels, n_dofs):
    """(axes (N*6,), LmScratch) for device_lm.polish."""
    D, t = n_dofs, dtype_probe.dtype
    matrices, vectors, jac = np.empty((2, D * D), t), np.empty((3, D), t), np.empty(3 * D, t)
    pose_levels, pose_raw = np.empty(n_levels, t), np.empty(n_terms, t)
    lm = LmScratch(matrices[0], matrices[1], vectors[0], jac, vectors[1], vectors[2], pose_levels, pose_raw)
    return np.empty(6 * skel.motion_int.shape[0], t), lm


@linked(parallel=True)
def initialise(state, status, skel, terms, settings, initial, n_initial, n_chunks):
    """Fill the Buffers `state`: pop (B, P, D) uniformly inside the limits (the first n_initial
    individuals of each problem copy initial (B, n_initial, D)), every individual's F and CR
    the settings', then evaluated (device_driver.initialise_individual); then each problem's
    best, leaders and best total in the Status `status`. n_chunks: work units (a few per
    thread; 1 runs in the calling thread); it changes the split of work, never the result."""
    n = state.pop.shape[0] * state.pop.shape[1]
    n_chunks = max(1, min(n, n_chunks))
    if n_chunks == 1:
        _initialise_chunk(0, 1, state, skel, terms, settings, initial, n_initial)
    else:
        for c in prange(n_chunks):
            _initialise_chunk(np.int64(c), n_chunks, state, skel, terms, settings, initial, n_initial)
    for b in range(state.pop.shape[0]):
        device_evolution.rank_first(b, state, status)


@linked()
def launch(
    fresh, cur, nxt, status, skel, terms, settings, schedule, rules, history, initial, n_initial, gen, n_gens, threads
):
    """The DE kernel every launch runs, so a solve compiles one kernel per dtype: with `fresh`,
    the first population (_first_population) first; then run_generations from generation
    `gen`; returns its buffer swaps. schedule None compiles the kernel without the LM polish."""
    lazy = False
    if fresh:
        lazy = _first_population(cur, status, skel, terms, settings, schedule, rules, initial, n_initial, threads)
    swaps = run_generations(
        cur, nxt, skel, terms, settings, schedule, status, rules, history, gen, n_gens, threads, lazy
    )
    if fresh:
        _stopped_first(cur, nxt, status, swaps)
    return swaps


@linked()
def _stopped_first(cur, nxt, status, swaps):
    """Copy the problems a lazy first population stopped (inactive with no generation) from cur
    into nxt, where every stopped problem must also lie (run_generations), unless no launch can
    read nxt: no swap and no problem left to run (most batches of easy problems, which then
    never touch the second buffer set)."""
    if swaps % 2 == 0:
        any_active = False
        for b in range(status.active.shape[0]):
            any_active = any_active or status.active[b]
        if not any_active:
            return
    for b in range(status.active.shape[0]):
        if not status.active[b] and status.generations[b] == 0:
            for i in range(cur.pop.shape[1]):
                device_evolution.copy_individual(cur, nxt, b, i, i)


@linked()
def _first_population(cur, status, skel, terms, settings, schedule, rules, initial, n_initial, threads):
    """Fill cur with a first population and status with its best and leaders. When the polish
    is on and problems stop once every tolerance is met, it is lazy: each problem's individual
    0 is polished first (device_driver.polish_first); a problem it meets stops there (its
    other individuals are copies of it; launch copies it into nxt where needed, _stopped_first),
    and the rest of the population is sampled and evaluated, in SIMD lanes, only for the
    problems it leaves unmet (most robot targets never need it). Otherwise as initialise.
    Returns whether it was lazy."""
    B, P = cur.pop.shape[0], cur.pop.shape[1]
    if schedule is not None and schedule.iterations > 0 and rules.stop_on_converged:
        met = np.empty(B, np.bool_)
        chunks = chunk_count(B, 3 * schedule.iterations, skel, threads)
        _polish_first(chunks, cur, status, skel, terms, settings, schedule, rules, initial, n_initial, met)
        unmet, n_unmet = _active_problems(~met)
        n = n_unmet * (P - 1)
        _complete(chunk_count(n, 1, skel, threads), n, unmet, cur, skel, terms, settings, initial, n_initial)
        for k in range(n_unmet):
            _settle_first(unmet[k], cur, status, terms, rules)
        return True
    initialise(cur, status, skel, terms, settings, initial, n_initial, chunk_count(B * P, 1, skel, threads))
    return False


@linked()
def _settle_first(b, cur, status, terms, rules):
    """Problem b's bookkeeping once its first population is complete: best, leaders and
    convergence after one polish (not a round: no restart)."""
    device_evolution.rank_first(b, cur, status)
    device_evolution.settle_after_polish(b, 0, cur, terms, status, rules, False)


@linked(parallel=True)
def _polish_first(chunks, cur, status, skel, terms, settings, schedule, rules, initial, n_initial, met):
    """Every problem's individual 0 initialised and polished (device_driver.polish_first);
    met (B,) receives whether it meets every tolerance, and such a problem is completed and
    settled at once (_first_population)."""
    if chunks == 1:
        _polish_first_chunk(0, 1, cur, status, skel, terms, settings, schedule, rules, initial, n_initial, met)
    else:
        for c in prange(chunks):
            _polish_first_chunk(
                np.int64(c), chunks, cur, status, skel, terms, settings, schedule, rules, initial, n_initial, met
            )


@linked()
def _polish_first_chunk(c, chunks, cur, status, skel, terms, settings, schedule, rules, initial, n_initial, met):
    """Chunk c of `chunks` of _polish_first's problems."""
    B, P, D = cur.pop.shape[0], cur.pop.shape[1], cur.pop.shape[2]
    scratch, q, lv, rw = thread_scratch(skel, cur.pop, cur.raw.shape[2], cur.levels.shape[2], D)
    axes, lm = polish_scratch(skel, cur.pop, cur.raw.shape[2], cur.levels.shape[2], D)
    for b in range(c * B // chunks, (c + 1) * B // chunks):
        met[b] = device_driver.polish_first(
            b, cur, skel, terms, settings, schedule, initial, n_initial, scratch, axes, lm, q, lv, rw, status.halt
        )
        if met[b]:
            for i in range(1, P):  # device_driver.complete_individual's copies
                device_evolution.copy_individual(cur, cur, b, 0, i)
            _settle_first(b, cur, status, terms, rules)


@linked(parallel=True)
def _complete(chunks, n, unmet, state, skel, terms, settings, initial, n_initial):
    """Individuals 1.. of the problems unmet (n_unmet,) after _polish_first, n = n_unmet * (P - 1)
    of them in `chunks` work units, LANES at a time (device_lanes.initialise_lanes)."""
    if chunks == 1:
        _complete_chunk(0, 1, n, unmet, state, skel, terms, settings, initial, n_initial)
    else:
        for c in prange(chunks):
            _complete_chunk(np.int64(c), chunks, n, unmet, state, skel, terms, settings, initial, n_initial)


@linked()
def _complete_chunk(c, chunks, n, unmet, state, skel, terms, settings, initial, n_initial):
    """Chunk c of `chunks` of _complete's individuals."""
    lanes = lane_scratch(skel, state.pop, state.raw.shape[2], state.levels.shape[2], state.pop.shape[2])
    start, end = _lane_span(c, chunks, n)
    for first in range(start, end, LANES):
        device_lanes.initialise_lanes(
            first, min(LANES, end - first), unmet, 1, state, skel, terms, settings, initial, n_initial, lanes
        )


@linked()
def _initialise_chunk(c, n_chunks, state, skel, terms, settings, initial, n_initial):
    """Chunk c of `n_chunks` of initialise's individuals, LANES at a time."""
    B, P, D = state.pop.shape
    lanes = lane_scratch(skel, state.pop, state.raw.shape[2], state.levels.shape[2], D)
    start, end = _lane_span(c, n_chunks, B * P)
    every = np.arange(B)
    for first in range(start, end, LANES):
        device_lanes.initialise_lanes(
            first, min(LANES, end - first), every, 0, state, skel, terms, settings, initial, n_initial, lanes
        )


@linked()
def chunk_count(n_jobs, work_per_job, skel, threads):
    """Work units for a loop of n_jobs: 1 (run in the calling thread, no parallel region) when
    the work is small, since waking the pool costs more than it saves and on a loaded machine
    a descheduled thread stalls the loop; else a few per thread."""
    if n_jobs * work_per_job * device_maths.frame_count(skel) < SERIAL_WORK:
        return 1
    return max(1, min(n_jobs, CHUNKS_PER_THREAD * threads))


@linked()
def _active_problems(active):
    """(indices of the active problems, their count)."""
    order = np.empty(active.shape[0], np.int64)
    n = 0
    for b in range(active.shape[0]):
        if active[b]:
            order[n] = b
            n += 1
    return order, n


@linked()
def _polish_due(order, n_active, fresh, round_due):
    """(the active problems in order (n_active,) that a polish round refines now, their
    count): all of them when the round is due (every polish_every generations), else those
    whose last generation was a restart's, whose fresh random poses a round tries at once
    instead of after DE has pulled them back towards the elite."""
    due = np.empty(n_active, np.int64)
    n = 0
    for k in range(n_active):
        if round_due or fresh[order[k]]:
            due[n] = order[k]
            n += 1
    return due, n


@linked(parallel=True)
def _breed(chunks, n, cur, nxt, skel, terms, settings, status, order, gen):
    """One generation's trials over the n active individuals, in `chunks` work units. (A parallel
    function of its own: Numba's parfors rebuild a NamedTuple argument of the loop body only
    from a function argument, not from run_generations' swapped buffers.)"""
    if chunks == 1:
        _breed_chunk(0, 1, n, cur, nxt, skel, terms, settings, status, order, gen)
    else:
        for c in prange(chunks):
            _breed_chunk(np.int64(c), chunks, n, cur, nxt, skel, terms, settings, status, order, gen)


@linked()
def _breed_chunk(c, chunks, n, cur, nxt, skel, terms, settings, status, order, gen):
    """Chunk c of `chunks` of _breed's individuals, LANES at a time (device_lanes.breed_lanes)."""
    lanes = lane_scratch(skel, cur.pop, cur.raw.shape[2], cur.levels.shape[2], cur.pop.shape[2])
    start, end = _lane_span(c, chunks, n)
    for first in range(start, end, LANES):
        device_lanes.breed_lanes(
            first, min(LANES, end - first), order, gen, cur, nxt, skel, terms, settings, status, lanes
        )


@linked(parallel=True)
def _polish(chunks, n, state, skel, terms, status, schedule, order, first_round):
    """A polish round over the n active problems in `chunks` work units (parallel on its own as
    _breed); first_round: the round after a lazy first population (polished_just_now)."""
    if chunks == 1:
        _polish_chunk(0, 1, n, state, skel, terms, status, schedule, order, first_round)
    else:
        for c in prange(chunks):
            _polish_chunk(np.int64(c), chunks, n, state, skel, terms, status, schedule, order, first_round)


@linked()
def _polish_chunk(c, chunks, n, state, skel, terms, status, schedule, order, first_round):
    """Chunk c of `chunks` of a polish round: LM on up to `count` individuals of each problem,
    in order, until one meets every tolerance (the GPU kernel polishes them side by side and
    undoes those after the first that does: the same result)."""
    P, D = state.pop.shape[1], state.pop.shape[2]
    scratch, q, lv, rw = thread_scratch(skel, state.pop, state.raw.shape[2], state.levels.shape[2], D)
    axes, lm = polish_scratch(skel, state.pop, state.raw.shape[2], state.levels.shape[2], D)
    for job in range(c * n // chunks, (c + 1) * n // chunks):
        b = order[job]
        for k in range(schedule.count):
            i = device_evolution.polish_target(status.leaders[b], k, schedule.count, P)
            if device_evolution.polished_just_now(i, first_round):
                continue
            if device_driver.polish_individual(
                b, i, state, skel, terms, schedule, scratch, axes, lm, q, lv, rw, status.halt
            ):
                break


@linked()
def run_generations(
    cur, nxt, skel, terms, settings, schedule, status, rules, history, gen_start, n_gens, threads, lazy_first
):
    """Run up to n_gens generations; returns how many buffer swaps happened (the final state
    lies in `cur` when even, in `nxt` when odd). cur and nxt (layout.Buffers) must both hold
    every inactive problem: only active problems are worked on, and a problem that stops is
    copied into both. threads: the pool's size (small loops run on the caller's). schedule: the
    polish (layout.PolishSchedule), or None: compiled without it. lazy_first: the population was
    just begun lazily (_first_population), so the first round passes over individual 0."""
    P = cur.pop.shape[1]
    active = status.active
    fresh = np.zeros(active.shape[0], np.bool_)  # whose last generation restarted (random poses)
    swaps = 0
    for g in range(n_gens):
        if status.halt[0] != 0:  # the host's time limit or Ctrl-C (Status.halt)
            break
        gen = gen_start + g
        order, n_active = _active_problems(active)
        if schedule is not None and n_active and schedule.iterations > 0:
            # polish before breeding, so a problem the polish solves stops without a generation
            due, n_due = _polish_due(order, n_active, fresh, gen % schedule.every == 0)
            if n_due:
                chunks = chunk_count(n_due, 3 * schedule.iterations * schedule.count, skel, threads)
                _polish(chunks, n_due, cur, skel, terms, status, schedule, due, lazy_first and g == 0)
                for k in range(n_due):
                    b = due[k]
                    device_evolution.settle_after_polish(b, gen, cur, terms, status, rules, True)
                    if not active[b]:
                        for i in range(P):
                            device_evolution.copy_individual(cur, nxt, b, i, i)
                order, n_active = _active_problems(active)
        if n_active == 0:
            break
        for k in range(n_active):
            fresh[order[k]] = status.restarting[order[k]]
        n = n_active * P
        _breed(chunk_count(n, 1, skel, threads), n, cur, nxt, skel, terms, settings, status, order, gen)
        cur, nxt = nxt, cur
        swaps += 1
        for k in range(n_active):
            b = order[k]
            device_evolution.update_status(b, gen, g, cur, terms, status, rules, history)
            if not active[b]:
                for i in range(P):
                    device_evolution.copy_individual(cur, nxt, b, i, i)
    return swaps


@linked(parallel=True)
def evaluate_poses(poses, problem_index, skel, terms, levels, total, raw, n_chunks, threads):
    """Evaluate poses (N, D), pose n against problem problem_index[n]; fills levels (N, L),
    total (N,), raw (N, T). n_chunks as for initialise, or 0: as many as pay off on `threads`
    threads (chunk_count)."""
    N = poses.shape[0]
    n_chunks = max(1, min(N, n_chunks if n_chunks > 0 else chunk_count(N, 1, skel, threads)))
    if n_chunks == 1:
        _evaluate_chunk(0, 1, poses, problem_index, skel, terms, levels, total, raw)
    else:
        for c in prange(n_chunks):
            _evaluate_chunk(np.int64(c), n_chunks, poses, problem_index, skel, terms, levels, total, raw)


@linked()
def _evaluate_chunk(c, n_chunks, poses, problem_index, skel, terms, levels, total, raw):
    """Chunk c of `n_chunks` of evaluate_poses' poses."""
    N, D = poses.shape
    scratch, _, _, _ = thread_scratch(skel, poses, raw.shape[1], levels.shape[1], D)
    for n in range(c * N // n_chunks, (c + 1) * N // n_chunks):
        total[n] = device_terms.evaluate(poses[n], problem_index[n], skel, terms, scratch, levels[n], raw[n])
