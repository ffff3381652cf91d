"""Host side of the CPU kernels: chunking, thread count and argument order (deik.kernels.cpu)."""

from __future__ import annotations

import numba
import numpy as np

from deik.kernels import cpu


def _chunks_for(n_individuals: int, skel) -> int:
    """Work units for a loop over n_individuals (1: the calling thread; see cpu._chunks)."""
    return int(cpu._chunks(n_individuals, 1, skel, numba.get_num_threads()))


class CpuBackend:
    name = "cpu"

    def initialise(self, buffers, status, skel, terms, settings, initial, n_initial):
        """Fill buffers with a first population and status with its best and leaders."""
        chunks = _chunks_for(buffers.pop.shape[0] * buffers.pop.shape[1], skel)
        cpu.initialise(buffers, status, skel, terms, settings, initial, np.int64(n_initial), chunks)

    def start(self, cur, nxt, status, skel, terms, settings, memetic, control, history, initial, n_initial, n_gens):
        """initialise then run from generation 0 in one compiled call (cpu.start); returns as run."""
        swaps = int(
            cpu.start(
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
            cpu.run_generations(
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
