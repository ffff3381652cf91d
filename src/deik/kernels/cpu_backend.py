"""Host side of the CPU kernels: chunking, thread count and argument order (deik.kernels.cpu)."""

from __future__ import annotations

from contextlib import contextmanager

import numba
import numpy as np

from deik.kernels import cpu
from deik.kernels.cpu import CHUNKS_PER_THREAD, SERIAL_WORK


@contextmanager
def _threads_for(n_individuals, skel):
    """Run small generations on one thread: waking the pool costs more than it saves, and on a
    loaded machine a descheduled thread stalls every parallel region. Results do not depend on
    the thread count."""
    work = n_individuals * (skel[0].shape[0] + skel[4].shape[0])
    before = numba.get_num_threads()
    if work < SERIAL_WORK:
        numba.set_num_threads(1)
    try:
        yield numba.get_num_threads() * CHUNKS_PER_THREAD
    finally:
        numba.set_num_threads(before)


class CpuBackend:
    name = "cpu"

    def initialise(self, buffers, skel, terms, settings, initial, n_initial):
        with _threads_for(buffers[0].shape[0] * buffers[0].shape[1], skel) as chunks:
            cpu.initialise(*buffers, skel, terms, settings, initial, np.int64(n_initial), chunks)

    def run(self, cur, nxt, skel, terms, settings, memetic, status, control, history, gen_start, n_gens):
        """Returns (final buffers, generations advanced); status and history are updated."""
        swaps = int(cpu.run_generations(cur, nxt, skel, terms, settings, memetic, status, control, history,
                                        np.int64(gen_start), np.int64(n_gens), numba.get_num_threads()))
        return (cur if swaps % 2 == 0 else nxt), swaps


def evaluate_poses(poses, problem_index, skel, terms, n_levels: int):
    """(levels (N, L), total (N,), raw (N, T)) of poses (N, D), pose n against problem
    problem_index[n], in the dtype of the packed arrays."""
    N, T = len(poses), terms[0].shape[0]
    dtype = skel[1].dtype
    levels, total, raw = np.empty((N, n_levels), dtype), np.empty(N, dtype), np.empty((N, T), dtype)
    with _threads_for(N, skel):
        cpu.evaluate_poses(np.ascontiguousarray(poses, dtype), problem_index, skel, terms, levels, total, raw)
    return levels, total, raw
