"""GPU kernels (numba-cuda): one thread block per problem runs every generation in one launch.

Threads stride over the population, so any population size fits one block; the block
ping-pongs its problem's buffers in global memory and synchronises between generations, and
thread 0 does the per-problem bookkeeping (device_evolution.update_status) in between. What one
thread does for one individual is the CPU kernels' own code (device/driver.py, compiled with
cuda.jit); the kernels here take the NamedTuples of deik.device.layout, device arrays inside.
Runs in Numba's CUDA simulator when NUMBA_ENABLE_CUDASIM=1 (how CI tests it).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numba import cuda, float32, float64, int32

from deik.backends.targets import cuda_device
from deik.device.layout import THREADS_PER_BLOCK, WORK_SIZE, LmScratch, Scratch


def _bucket(n: int) -> int:
    """Round local-array sizes up to a power of two so similar skeletons share a compile."""
    return 1 << max(int(n) - 1, 1).bit_length()


@lru_cache(maxsize=16)
def make_kernels(n_frames: int, n_dofs: int, n_terms: int, n_levels: int, n_motions: int, dtype_name: str):
    """Compile (initialise, start, run) for local arrays of these (bucketed) sizes and dtype."""
    dev = cuda_device()
    initialise_individual, breed_individual, polish_individual = (
        dev.initialise_individual,
        dev.breed_individual,
        dev.polish_individual,
    )
    polish_first, complete_individual = dev.polish_first, dev.complete_individual
    update_status, settle, rank_first = dev.update_status, dev.settle_after_polish, dev.rank_first
    copy_individual, polish_target = dev.copy_individual, dev.polish_target
    ftype = float32 if dtype_name == "float32" else float64
    n_r, n_p, n_d, n_t, n_l, n_a = 9 * n_frames, 3 * n_frames, n_dofs, n_terms, n_levels, 6 * n_motions
    n_jac = 3 * n_dofs

    @cuda.jit
    def initialise(state, status, skel, terms, settings, initial, n_initial):
        b = cuda.blockIdx.x
        scratch = Scratch(
            cuda.local.array(n_r, ftype), cuda.local.array(n_p, ftype), cuda.local.array(WORK_SIZE, ftype)
        )
        for i in range(cuda.threadIdx.x, state.pop.shape[1], cuda.blockDim.x):
            initialise_individual(b, i, state, skel, terms, settings, initial, n_initial, scratch)
        cuda.syncthreads()
        if cuda.threadIdx.x == 0:
            rank_first(b, state, status)

    @cuda.jit
    def start(state, status, skel, terms, settings, memetic, control, initial, n_initial, polish_matrix):
        """A lazy first population (cpu._first_population): thread 0 polishes individual 0, then
        the block completes the population (copies of it when it met every tolerance) and
        settles."""
        b, tid, stride = cuda.blockIdx.x, cuda.threadIdx.x, cuda.blockDim.x
        scratch = Scratch(
            cuda.local.array(n_r, ftype), cuda.local.array(n_p, ftype), cuda.local.array(WORK_SIZE, ftype)
        )
        met = cuda.shared.array(1, int32)
        if tid == 0:
            q, lv, rw = cuda.local.array(n_d, ftype), cuda.local.array(n_l, ftype), cuda.local.array(n_t, ftype)
            axes, matrices = cuda.local.array(n_a, ftype), polish_matrix[b, 0]
            half = matrices.shape[0] // 2
            lm = LmScratch(
                matrices[:half],
                matrices[half:],
                cuda.local.array(n_d, ftype),
                cuda.local.array(n_jac, ftype),
                cuda.local.array(n_d, ftype),
                cuda.local.array(n_d, ftype),
                cuda.local.array(n_l, ftype),
                cuda.local.array(n_t, ftype),
            )
            met[0] = polish_first(
                b, state, skel, terms, settings, memetic, initial, n_initial, scratch, axes, lm, q, lv, rw
            )
        cuda.syncthreads()
        for i in range(1 + tid, state.pop.shape[1], stride):
            complete_individual(b, i, met[0], state, skel, terms, settings, initial, n_initial, scratch)
        cuda.syncthreads()
        if tid == 0:
            rank_first(b, state, status)
            settle_after_polish(b, 0, state, terms, status, control, False)

    @cuda.jit
    def run(
        cur, nxt, skel, terms, settings, memetic, status, control, history, gen_start, n_gens, advanced, polish_matrix
    ):
        b, tid, stride = cuda.blockIdx.x, cuda.threadIdx.x, cuda.blockDim.x
        scratch = Scratch(
            cuda.local.array(n_r, ftype), cuda.local.array(n_p, ftype), cuda.local.array(WORK_SIZE, ftype)
        )
        trial, lv, rw = cuda.local.array(n_d, ftype), cuda.local.array(n_l, ftype), cuda.local.array(n_t, ftype)
        trial_rates, axes = cuda.local.array(2, ftype), cuda.local.array(n_a, ftype)
        # the polish's two D x D matrices live in global memory, one pair per polishing thread: as
        # local arrays every resident thread would reserve them (64 KiB each at the 128-DOF bucket)
        matrices = polish_matrix[b, min(tid, polish_matrix.shape[1] - 1)]
        half = matrices.shape[0] // 2
        lm = LmScratch(
            matrices[:half],
            matrices[half:],
            cuda.local.array(n_d, ftype),
            cuda.local.array(n_jac, ftype),
            cuda.local.array(n_d, ftype),
            cuda.local.array(n_d, ftype),
            cuda.local.array(n_l, ftype),
            cuda.local.array(n_t, ftype),
        )
        met = cuda.shared.array(THREADS_PER_BLOCK, int32)
        P = cur.pop.shape[1]
        swaps = 0
        fresh = False  # the last generation restarted (cpu.run_generations polishes it at once)
        for g in range(n_gens):
            cuda.syncthreads()
            if not status.active[b]:
                break
            if memetic.iterations > 0 and ((gen_start + g) % memetic.every == 0 or fresh):
                # polish side by side before breeding, then undo every polish after the first
                # that meets all tolerances: the CPU's in-order round with its early stop (nxt
                # is scratch until the breeding writes it)
                target = polish_target(status.leaders[b], tid, memetic.count, P)
                if tid < memetic.count:
                    copy_individual(cur, nxt, b, target, target)
                    met[tid] = polish_individual(b, target, cur, skel, terms, memetic, scratch, axes, lm, trial, lv, rw)
                cuda.syncthreads()
                if tid < memetic.count:
                    for k in range(tid):
                        if met[k]:
                            copy_individual(nxt, cur, b, target, target)
                            break
                cuda.syncthreads()
                if tid == 0:
                    settle_after_polish(b, gen_start + g, cur, terms, status, control, True)
                cuda.syncthreads()
                if not status.active[b]:
                    break
            fresh = status.restarting[b]
            for i in range(tid, P, stride):
                breed_individual(
                    b, i, gen_start + g, cur, nxt, skel, terms, settings, status, scratch, trial, trial_rates, lv, rw
                )
            cur, nxt = nxt, cur
            swaps += 1
            cuda.syncthreads()
            if tid == 0:
                update_status(b, gen_start + g, g, cur, terms, status, control, history)
        if swaps % 2 == 1:
            for i in range(tid, P, stride):
                copy_individual(cur, nxt, b, i, i)
        if tid == 0:
            advanced[b] = swaps

    return initialise, start, run


def kernels_for(skel, buffers):
    """(initialise, start, run) compiled for this skeleton's and these buffers' bucketed sizes."""
    frames = skel.joint_int.shape[0] + skel.site_joint.shape[0]
    return make_kernels(
        _bucket(frames),
        _bucket(buffers.pop.shape[2]),
        _bucket(buffers.raw.shape[2]),
        _bucket(buffers.levels.shape[2]),
        _bucket(skel.motion_int.shape[0]),
        buffers.pop.dtype.name,
    )


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
        """The same NamedTuple of arrays, each copied to the GPU."""
        return type(arrays)(*(cuda.to_device(np.ascontiguousarray(a)) for a in arrays))

    def _threads(self, population: int) -> int:
        return min(THREADS_PER_BLOCK, 32 * -(-population // 32))

    def initialise(self, buffers, status, skel, terms, settings, memetic, control, initial, n_initial):
        """Fill buffers with a first population and status with its best and leaders (memetic
        and control: unused here, as in the CPU back-end's signature)."""
        initialise, _, _ = kernels_for(skel, buffers)
        d_buf, d_status = self._to_device(buffers), self._to_device(status)
        B, P = buffers.pop.shape[:2]
        initialise[B, self._threads(P)](
            d_buf,
            d_status,
            self._to_device(skel),
            self._to_device(terms),
            settings,
            cuda.to_device(initial),
            np.int64(n_initial),
        )
        for host, device in zip(buffers + status, d_buf + d_status):
            device.copy_to_host(host)

    def start(self, cur, nxt, status, skel, terms, settings, memetic, control, history, initial, n_initial, n_gens):
        """The first population (lazy as cpu._first_population's when the polish is on and
        problems stop once met), then run from generation 0: two launches."""
        if memetic.iterations > 0 and control.stop_on_converged:
            _, start, _ = kernels_for(skel, cur)
            d_buf, d_status = self._to_device(cur), self._to_device(status)
            B, P, D = cur.pop.shape
            start[B, self._threads(P)](
                d_buf,
                d_status,
                self._to_device(skel),
                self._to_device(terms),
                settings,
                memetic,
                control,
                cuda.to_device(initial),
                np.int64(n_initial),
                cuda.device_array((B, 1, 2 * D * D), cur.pop.dtype),
            )
            for host, device in zip(cur + status, d_buf + d_status):
                device.copy_to_host(host)
        else:
            self.initialise(cur, status, skel, terms, settings, memetic, control, initial, n_initial)
        return self.run(cur, nxt, skel, terms, settings, memetic, status, control, history, 0, n_gens)

    def run(self, cur, nxt, skel, terms, settings, memetic, status, control, history, gen_start, n_gens):
        """Returns (final buffers, generations advanced); status and the first `advanced` rows
        of history (n_gens, B, 2) are updated."""
        _, _, run = kernels_for(skel, cur)
        d_cur, d_nxt, d_status = self._to_device(cur), self._to_device(nxt), self._to_device(status)
        d_history = cuda.device_array(history.shape, history.dtype)  # written by the kernel, never read
        B, P, D = cur.pop.shape
        advanced = cuda.to_device(np.zeros(B, np.int64))
        shape = (B, int(memetic.count), 2 * D * D) if memetic.iterations > 0 else (B, 1, 2)
        polish_matrix = cuda.device_array(shape, cur.pop.dtype)
        run[B, self._threads(P)](
            d_cur,
            d_nxt,
            self._to_device(skel),
            self._to_device(terms),
            settings,
            memetic,
            d_status,
            control,
            d_history,
            np.int64(gen_start),
            np.int64(n_gens),
            advanced,
            polish_matrix,
        )
        for host, device in zip(cur + status, d_cur + d_status):
            device.copy_to_host(host)
        swaps = int(advanced.copy_to_host().max())
        if swaps:
            d_history[:swaps].copy_to_host(history[:swaps])  # only the generations that ran
        return cur, swaps
