"""Host side of the CPU kernels: chunking, thread count and argument order (deik.kernels.cpu)."""

from __future__ import annotations

import numba
import numpy as np

from deik.kernels import cpu


def _chunks_for(n_individuals: int, skel) -> int:
    """Work units for a loop over n_individuals (1: the calling thread; see cpu._chunks)."""
    return int(cpu._chunks(n_individuals, 1, skel, numba.get_num_threads()))


_ENTRIES = {}  # (kernel, dtype) -> the compiled entry point Numba's dispatch chose for them


def _call(kernel, *args):
    """kernel(*args) through the compiled entry point of its overload for this dtype (that of
    args[0], a Buffers). Numba's dispatcher types every argument on every call (some 40 arrays
    in NamedTuples: 6 us of a 40 us robot solve), while an Engine's arguments are always the
    same types for a dtype: the same NamedTuples of C-contiguous, writable arrays and the same
    scalar types (solver/engine.py builds them so). The first call per kernel and dtype in a
    process dispatches (compiling or loading) and keeps the overload's entry point."""
    key = (kernel, args[0].pop.dtype)
    entry = _ENTRIES.get(key)
    if entry is not None:
        return entry(*args)
    out = kernel(*args)
    _ENTRIES[key] = kernel.overloads[tuple(numba.typeof(a) for a in args)].entry_point
    return out


class CpuBackend:
    name = "cpu"

    def initialise(self, buffers, status, skel, terms, settings, initial, n_initial):
        """Fill buffers with a first population and status with its best and leaders."""
        chunks = _chunks_for(buffers.pop.shape[0] * buffers.pop.shape[1], skel)
        cpu.initialise(buffers, status, skel, terms, settings, initial, np.int64(n_initial), chunks)

    def start(self, cur, nxt, status, skel, terms, settings, memetic, control, history, initial, n_initial, n_gens):
        """initialise then run from generation 0 in one compiled call (cpu.start); returns as run."""
        swaps = int(
            _call(
                cpu.start,
                cur,
                nxt,
                status,
                skel,
                terms,
                settings,
                memetic,
                control,
                history,
                initial,
                np.int64(n_initial),
                np.int64(n_gens),
                numba.get_num_threads(),
            )
        )
        return (cur if swaps % 2 == 0 else nxt), swaps

    def run(self, cur, nxt, skel, terms, settings, memetic, status, control, history, gen_start, n_gens):
        """Returns (final buffers, generations advanced); status and the first `advanced` rows
        of history (n_gens, B, 2) are updated."""
        swaps = int(
            _call(
                cpu.run_generations,
                cur,
                nxt,
                skel,
                terms,
                settings,
                memetic,
                status,
                control,
                history,
                np.int64(gen_start),
                np.int64(n_gens),
                numba.get_num_threads(),
            )
        )
        return (cur if swaps % 2 == 0 else nxt), swaps


def evaluate_poses(poses, problem_index, skel, terms, n_levels: int):
    """(levels (N, L), total (N,), raw (N, T)) of poses (N, D), pose n against problem
    problem_index[n], in the dtype of the packed arrays."""
    N, T = len(poses), terms.term_int.shape[0]
    dtype = skel.joint_frame.dtype
    levels, total, raw = np.empty((N, n_levels), dtype), np.empty(N, dtype), np.empty((N, T), dtype)
    cpu.evaluate_poses(
        np.ascontiguousarray(poses, dtype), problem_index, skel, terms, levels, total, raw, _chunks_for(N, skel)
    )
    return levels, total, raw


def point_jacobians(poses, frames, skel):
    """(x (N, G, 3), jacobian (N, G, 3, D)) of frames (G,) (-1: the centre of mass) at poses
    (N, D), in the dtype of the packed skeleton (cpu.point_jacobians)."""
    dtype = skel.joint_frame.dtype
    poses = np.ascontiguousarray(poses, dtype)
    N, D = poses.shape
    x, jacobian = np.empty((N, len(frames), 3), dtype), np.empty((N, len(frames), 3, D), dtype)
    cpu.point_jacobians(poses, np.ascontiguousarray(frames, np.int64), skel, x, jacobian, _chunks_for(N, skel))
    return x, jacobian
