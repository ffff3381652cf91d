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
from numba import cuda, float32, float64, int32

from deik.kernels.layout import THREADS_PER_BLOCK
from deik.kernels.targets import cuda_device

INIT_GENERATION = -1


def _bucket(n: int) -> int:
    """Round local-array sizes up to a power of two so similar skeletons share a compile."""
    return 1 << max(int(n) - 1, 1).bit_length()


@lru_cache(maxsize=16)
def make_kernels(n_frames: int, n_dofs: int, n_terms: int, n_levels: int, n_motions: int, dtype_name: str):
    """Compile (initialise, run) for local arrays of these (bucketed) sizes and dtype."""
    dev = cuda_device()
    evaluate, make_trial, not_worse, keep_trial = dev.evaluate, dev.make_trial, dev.not_worse, dev.keep_trial
    update_status, uniform, copy_individual = dev.update_status, dev.uniform, dev.copy_individual
    polish, polish_target, within_tolerances = dev.polish, dev.polish_target, dev.within_tolerances
    ftype = float32 if dtype_name == "float32" else float64
    n_r, n_p, n_d, n_t, n_l, n_a = 9 * n_frames, 3 * n_frames, n_dofs, n_terms, n_levels, 6 * n_motions
    n_jac = 3 * n_dofs

    @cuda.jit
    def initialise(pop, levels, total, raw, rates, skel, terms, settings, initial, n_initial):
        b = cuda.blockIdx.x
        scratch = (cuda.local.array(n_r, ftype), cuda.local.array(n_p, ftype), cuda.local.array(32, ftype))
        limits, seed = skel[8], settings[4]
        P, D = pop.shape[1], pop.shape[2]
        for i in range(cuda.threadIdx.x, P, cuda.blockDim.x):
            for d in range(D):
                if i < n_initial:
                    pop[b, i, d] = initial[b, i, d]
                else:
                    u = uniform(seed, b, INIT_GENERATION, i, d)
                    pop[b, i, d] = limits[d, 0] + (limits[d, 1] - limits[d, 0]) * u
            rates[b, i, 0], rates[b, i, 1] = settings[2], settings[3]
            total[b, i] = evaluate(pop[b, i], b, skel, terms, scratch, levels[b, i], raw[b, i])

    @cuda.jit
    def run(cur, nxt, skel, terms, settings, memetic, status, control, history, gen_start, n_gens, advanced,
            polish_matrix):
        b, tid, stride = cuda.blockIdx.x, cuda.threadIdx.x, cuda.blockDim.x
        scratch = (cuda.local.array(n_r, ftype), cuda.local.array(n_p, ftype), cuda.local.array(32, ftype))
        trial, lv, rw = cuda.local.array(n_d, ftype), cuda.local.array(n_l, ftype), cuda.local.array(n_t, ftype)
        trial_rates, axes = cuda.local.array(2, ftype), cuda.local.array(n_a, ftype)
        # the polish's D x D matrix lives in global memory, one per polishing thread: as a local
        # array every resident thread would reserve it (64 KiB each at the 128-DOF bucket)
        lm = (polish_matrix[b, min(tid, polish_matrix.shape[1] - 1)], cuda.local.array(n_d, ftype),
              cuda.local.array(n_jac, ftype), cuda.local.array(n_d, ftype))
        met = cuda.shared.array(THREADS_PER_BLOCK, int32)
        best, active, restarting, leader = status[0], status[1], status[7], status[9]
        iterations, every, count = memetic
        limits = skel[8]
        P = cur[0].shape[1]
        island_size = P // settings[6]
        swaps = 0
        for g in range(n_gens):
            cuda.syncthreads()
            if not active[b]:
                break
            pop, levels, rates = cur[0], cur[1], cur[4]
            for i in range(tid, P, stride):
                make_trial(pop, rates, b, i, leader[b, i // island_size], gen_start + g, settings, limits, trial, trial_rates, restarting[b])
                tot = evaluate(trial, b, skel, terms, scratch, lv, rw)
                if (i != best[b]) if restarting[b] else not_worse(lv, levels[b, i]):
                    keep_trial(nxt, b, i, trial, lv, rw, tot, trial_rates)
                else:
                    copy_individual(cur, nxt, b, i, i)
            cur, nxt = nxt, cur
            swaps += 1
            cuda.syncthreads()
            if iterations > 0 and (gen_start + g) % every == 0:
                # polish side by side, then undo every polish after the first that meets all
                # tolerances: the CPU's in-order round with its early stop (nxt is scratch here)
                target = polish_target(leader[b], tid, count, P)
                if tid < count:
                    copy_individual(cur, nxt, b, target, target)
                    polish(b, target, cur, iterations, skel, terms, scratch, axes, lm, trial, lv, rw)
                    met[tid] = within_tolerances(b, cur[3][b, target], terms, cur[3].shape[2])
                cuda.syncthreads()
                if tid < count:
                    for k in range(tid):
                        if met[k]:
                            copy_individual(nxt, cur, b, target, target)
                            break
                cuda.syncthreads()
            if tid == 0:
                update_status(b, gen_start + g, g, cur, terms, status, control, history)
        if swaps % 2 == 1:
            for i in range(tid, P, stride):
                copy_individual(cur, nxt, b, i, i)
        if tid == 0:
            advanced[b] = swaps

    return initialise, run


def kernels_for(skel, buffers):
    """(initialise, run) compiled for this skeleton's and these buffers' bucketed sizes."""
    pop, levels, raw = buffers[0], buffers[1], buffers[3]
    frames = skel[0].shape[0] + skel[4].shape[0]
    return make_kernels(_bucket(frames), _bucket(pop.shape[2]), _bucket(raw.shape[2]),
                        _bucket(levels.shape[2]), _bucket(skel[2].shape[0]), pop.dtype.name)


class CudaBackend:
    """Host side: copies buffers to the GPU, launches one block per problem, copies back."""

    name = "gpu"

    def __init__(self):
        if not cuda.is_available():
            raise RuntimeError(
                "device='gpu' needs an NVIDIA GPU with numba-cuda: pip install \"deik[gpu]\" "
                "(or run on the CPU with device='cpu')"
            )

    def _to_device(self, arrays):
        return tuple(cuda.to_device(np.ascontiguousarray(a)) for a in arrays)

    def _threads(self, population: int) -> int:
        return min(THREADS_PER_BLOCK, 32 * -(-population // 32))

    def initialise(self, buffers, skel, terms, settings, initial, n_initial):
        initialise, _ = kernels_for(skel, buffers)
        d_buf = self._to_device(buffers)
        B, P = buffers[0].shape[:2]
        initialise[B, self._threads(P)](*d_buf, self._to_device(skel), self._to_device(terms), settings,
                                        cuda.to_device(initial), np.int64(n_initial))
        for host, device in zip(buffers, d_buf):
            device.copy_to_host(host)

    def run(self, cur, nxt, skel, terms, settings, memetic, status, control, history, gen_start, n_gens):
        """Returns (final buffers, generations advanced); status and the first `advanced` rows
        of history (n_gens, B, 2) are updated."""
        _, run = kernels_for(skel, cur)
        d_cur, d_nxt, d_status = self._to_device(cur), self._to_device(nxt), self._to_device(status)
        d_history = cuda.device_array(history.shape, history.dtype)  # written by the kernel, never read
        B, P = cur[0].shape[:2]
        advanced = cuda.to_device(np.zeros(B, np.int64))
        iterations, _, count = memetic
        D = cur[0].shape[2]
        polish_matrix = cuda.device_array((B, int(count), D * D) if iterations > 0 else (B, 1, 1), cur[0].dtype)
        run[B, self._threads(P)](d_cur, d_nxt, self._to_device(skel), self._to_device(terms), settings, memetic,
                                 d_status, control, d_history, np.int64(gen_start), np.int64(n_gens), advanced,
                                 polish_matrix)
        for host, device in zip(cur + status, d_cur + d_status):
            device.copy_to_host(host)
        swaps = int(advanced.copy_to_host().max())
        if swaps:
            d_history[:swaps].copy_to_host(history[:swaps])  # only the generations that ran
        return cur, swaps
