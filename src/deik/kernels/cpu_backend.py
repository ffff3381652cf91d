"""Host side of the CPU kernels: chunking and argument order (deik.kernels.cpu)."""

from __future__ import annotations

import numba
import numpy as np

from deik.kernels import cpu

CHUNKS_PER_THREAD = 8


class CpuBackend:
    name = "cpu"

    @staticmethod
    def _chunks() -> int:
        return CHUNKS_PER_THREAD * numba.get_num_threads()

    def initialise(self, buffers, skel, terms, seed, initial, n_initial):
        cpu.initialise(*buffers, skel, terms, seed, initial, np.int64(n_initial), self._chunks())

    def run(self, cur, nxt, skel, terms, settings, status, control, history, gen_start, n_gens):
        """Returns (final buffers, generations advanced); status and history are updated."""
        swaps = int(cpu.run_generations(cur, nxt, skel, terms, settings, status, control, history,
                                        np.int64(gen_start), np.int64(n_gens), self._chunks()))
        return (cur if swaps % 2 == 0 else nxt), swaps
