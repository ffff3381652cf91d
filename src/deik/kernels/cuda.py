"""GPU kernels (numba-cuda): one thread block per problem runs every generation in one launch.

Threads stride over the population, so any population size fits one block; the block
ping-pongs its problem's buffers in global memory and synchronises between generations, and
thread 0 does the per-problem bookkeeping (device.update_status) in between. The maths is the
same source as the CPU kernels (deik.kernels.device_*.py compiled with cuda.jit). Runs in Numba's
CUDA simulator when NUMBA_ENABLE_CUDASIM=1 (how CI tests it).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numba import cuda, float32, float64

from deik.kernels.targets import cuda_device

THREADS_PER_BLOCK = 128
INIT_GENERATION = -1


def _bucket(n: int) -> int:
    """Round local-array sizes up to a power of two so similar skeletons share a compile."""
    return 1 << max(int(n) - 1, 1).bit_length()


@lru_cache(maxsize=16)
def make_kernels(n_frames: int, n_dofs: int, n_terms: int, n_levels: int, dtype_name: str):
    """Compile (initialise, run) for local arrays of these (bucketed) sizes and dtype."""
    dev = cuda_device()
    evaluate, make_trial, not_worse = dev.evaluate, dev.make_trial, dev.not_worse
    update_status, uniform, copy_individual = dev.update_status, dev.uniform, dev.copy_individual
    ftype = float32 if dtype_name == "float32" else float64
    n_r, n_p, n_d, n_t, n_l = 9 * n_frames, 3 * n_frames, n_dofs, n_terms, n_levels

    @cuda.jit
    def initialise(pop, levels, total, raw, skel, terms, seed, initial, n_initial):
        b = cuda.blockIdx.x
        scratch = (cuda.local.array(n_r, ftype), cuda.local.array(n_p, ftype), cuda.local.array(32, ftype))
        limits = skel[8]
        P, D = pop.shape[1], pop.shape[2]
        for i in range(cuda.threadIdx.x, P, cuda.blockDim.x):
            for d in range(D):
                if i < n_initial:
                    pop[b, i, d] = initial[b, i, d]
                else:
                    u = uniform(seed, b, INIT_GENERATION, i, d)
                    pop[b, i, d] = limits[d, 0] + (limits[d, 1] - limits[d, 0]) * u
            total[b, i] = evaluate(pop[b, i], b, skel, terms, scratch, levels[b, i], raw[b, i])

    @cuda.jit
    def run(cur, nxt, skel, terms, settings, status, control, history, gen_start, n_gens, advanced):
        b, tid, stride = cuda.blockIdx.x, cuda.threadIdx.x, cuda.blockDim.x
        scratch = (cuda.local.array(n_r, ftype), cuda.local.array(n_p, ftype), cuda.local.array(32, ftype))
        trial, lv, rw = cuda.local.array(n_d, ftype), cuda.local.array(n_l, ftype), cuda.local.array(n_t, ftype)
        best, active = status[0], status[1]
        limits = skel[8]
        P, D, T, L = cur[0].shape[1], cur[0].shape[2], cur[3].shape[2], cur[1].shape[2]
        swaps = 0
        for g in range(n_gens):
            cuda.syncthreads()
            if not active[b]:
                break
            pop, levels = cur[0], cur[1]
            npop, nlevels, ntotal, nraw = nxt
            for i in range(tid, P, stride):
                make_trial(pop, b, i, best[b], gen_start + g, settings, limits, trial)
                tot = evaluate(trial, b, skel, terms, scratch, lv, rw)
                if not_worse(lv, levels[b, i]):
                    for d in range(D):
                        npop[b, i, d] = trial[d]
                    for t in range(T):
                        nraw[b, i, t] = rw[t]
                    for lvl in range(L):
                        nlevels[b, i, lvl] = lv[lvl]
                    ntotal[b, i] = tot
                else:
                    copy_individual(cur, nxt, b, i)
            cur, nxt = nxt, cur
            swaps += 1
            cuda.syncthreads()
            if tid == 0:
                update_status(b, gen_start + g, cur, terms, status, control, history)
        if swaps % 2 == 1:
            for i in range(tid, P, stride):
                copy_individual(cur, nxt, b, i)
        if tid == 0:
            advanced[b] = swaps

    return initialise, run


class CudaBackend:
    """Host side: copies buffers to the GPU, launches one block per problem, copies back."""

    name = "gpu"

    def __init__(self):
        if not cuda.is_available():
            raise RuntimeError(
                "device='gpu' needs an NVIDIA GPU with numba-cuda: pip install \"deik[gpu]\" "
                "(or run on the CPU with device='cpu')"
            )

    def _kernels(self, skel, buffers):
        pop, levels, _, raw = buffers
        frames = skel[0].shape[0] + skel[4].shape[0]
        return make_kernels(_bucket(frames), _bucket(pop.shape[2]), _bucket(raw.shape[2]),
                            _bucket(levels.shape[2]), pop.dtype.name)

    def _to_device(self, arrays):
        return tuple(cuda.to_device(np.ascontiguousarray(a)) for a in arrays)

    def _threads(self, population: int) -> int:
        return min(THREADS_PER_BLOCK, 32 * -(-population // 32))

    def initialise(self, buffers, skel, terms, seed, initial, n_initial):
        initialise, _ = self._kernels(skel, buffers)
        d_buf = self._to_device(buffers)
        B, P = buffers[0].shape[:2]
        initialise[B, self._threads(P)](*d_buf, self._to_device(skel), self._to_device(terms), seed,
                                        cuda.to_device(initial), np.int64(n_initial))
        for host, device in zip(buffers, d_buf):
            device.copy_to_host(host)

    def run(self, cur, nxt, skel, terms, settings, status, control, history, gen_start, n_gens):
        """Returns (final buffers, generations advanced); status and history are updated."""
        _, run = self._kernels(skel, cur)
        d_cur, d_nxt, d_status = self._to_device(cur), self._to_device(nxt), self._to_device(status)
        d_history = cuda.to_device(history)
        B, P = cur[0].shape[:2]
        advanced = cuda.to_device(np.zeros(B, np.int64))
        run[B, self._threads(P)](d_cur, d_nxt, self._to_device(skel), self._to_device(terms), settings,
                                 d_status, control, d_history, np.int64(gen_start), np.int64(n_gens), advanced)
        for host, device in zip(cur + status + (history,), d_cur + d_status + (d_history,)):
            device.copy_to_host(host)
        return cur, int(advanced.copy_to_host().max())
