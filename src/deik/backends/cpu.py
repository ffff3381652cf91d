"""Host side of the CPU kernels: chunking, thread count and argument order (deik.backends.cpu_kernels).

Every launch goes through the one compiled kernel `cpu.launch`, so a solve compiles one kernel per
dtype. A solve without the LM polish passes no Memetic (None), which compiles a kernel without the
LM, unless the kernel with it is compiled already (deik.solver.readiness): it gives the same
answers with the polish turned off, and one kernel loads faster than two compile.
"""

from __future__ import annotations

from functools import cache

import numba
import numpy as np
from numba.core import types

from deik.backends import cpu_kernels as cpu
from deik.backends.pack import kernel_array

# argument positions in cpu.launch's signature
LAUNCH_BUFFERS, LAUNCH_MEMETIC = 1, 7


def launch_kind(signature) -> tuple[str, bool]:
    """(dtype, with the LM polish) of a cpu.launch signature (a tuple of Numba types)."""
    return str(signature[LAUNCH_BUFFERS].types[0].dtype), not isinstance(signature[LAUNCH_MEMETIC], types.NoneType)


def evaluate_dtype(signature) -> str:
    """The dtype of a cpu.evaluate_poses or cpu.point_jacobians signature (of its poses)."""
    return str(signature[0].dtype)


def launch_ready(dtype: str, polish: bool) -> bool:
    """Whether cpu.launch for `dtype` ("float32", "float64") with the LM polish (or without) is
    compiled in this process or cached on disk."""
    return (dtype, polish) in map(launch_kind, cpu.launch.ready_signatures())


def report_ready() -> bool:
    """Whether the float64 evaluation of a float32 solve's report (cpu.evaluate_poses) is ready."""
    return "float64" in map(evaluate_dtype, cpu.evaluate_poses.ready_signatures())


def jacobians_ready() -> bool:
    """Whether the clip warm start's float64 point Jacobians (cpu.point_jacobians) are ready."""
    return "float64" in map(evaluate_dtype, cpu.point_jacobians.ready_signatures())


@cache
def _without_polish(dtype: str) -> bool:
    """Whether a polish-free launch in `dtype` compiles the kernel without the LM (decided once a
    process: the disk check costs milliseconds)."""
    return not launch_ready(dtype, polish=True)


def _memetic(memetic, dtype):
    """The Memetic to pass, or None for the kernel without the polish (see the module doc)."""
    return None if memetic.iterations == 0 and _without_polish(np.dtype(dtype).name) else memetic


_ENTRIES = {}  # (dtype, with the polish) -> the compiled entry point of cpu.launch for them


def _launch(fresh, cur, nxt, status, skel, terms, settings, memetic, control, history, initial, n_initial, gen, n_gens):
    """cpu.launch with the argument types it is compiled for; returns the buffer swaps.

    Numba's dispatcher types every argument on every call (some 40 arrays in NamedTuples: 6 us
    of a 40 us robot solve), while an Engine's arguments are always the same types for a dtype
    and Memetic or None: the same NamedTuples of C-contiguous, writable arrays (kernel_array)
    and the same scalar types. The first launch of each kind in a process dispatches (compiling
    or loading) and keeps the overload's entry point, which later launches call directly."""
    args = (
        fresh,
        cur,
        nxt,
        status,
        skel,
        terms,
        settings,
        _memetic(memetic, cur.pop.dtype),
        control,
        history,
        initial,
        np.int64(n_initial),
        np.int64(gen),
        np.int64(n_gens),
        numba.get_num_threads(),
    )
    key = (cur.pop.dtype, args[LAUNCH_MEMETIC] is None)
    entry = _ENTRIES.get(key)
    if entry is not None:
        return int(entry(*args))
    kernel = cpu.launch.entry
    swaps = kernel(*args)
    _ENTRIES[key] = kernel.overloads[tuple(numba.typeof(a) for a in args)].entry_point
    return int(swaps)


class CpuBackend:
    name = "cpu"

    def initialise(self, buffers, status, skel, terms, settings, memetic, control, initial, n_initial):
        """Fill buffers with a first population and status with its best and leaders (a launch
        of no generations)."""
        history = np.empty((0, buffers.pop.shape[0], 2))
        _launch(
            True, buffers, buffers, status, skel, terms, settings, memetic, control, history, initial, n_initial, 0, 0
        )

    def start(self, cur, nxt, status, skel, terms, settings, memetic, control, history, initial, n_initial, n_gens):
        """initialise then run from generation 0 in one compiled call; returns as run."""
        args = (cur, nxt, status, skel, terms, settings, memetic, control, history, initial, n_initial)
        swaps = _launch(True, *args, 0, n_gens)
        return (cur if swaps % 2 == 0 else nxt), swaps

    def run(self, cur, nxt, skel, terms, settings, memetic, status, control, history, gen_start, n_gens):
        """Returns (final buffers, generations advanced); status and the first `advanced` rows
        of history (n_gens, B, 2) are updated."""
        no_initial = np.empty((0, 0, 0), cur.pop.dtype)
        args = (cur, nxt, status, skel, terms, settings, memetic, control, history, no_initial, 0)
        swaps = _launch(False, *args, gen_start, n_gens)
        return (cur if swaps % 2 == 0 else nxt), swaps


def evaluate_poses(poses, problem_index, skel, terms, n_levels: int):
    """(levels (N, L), total (N,), raw (N, T)) of poses (N, D), pose n against problem
    problem_index[n], in the dtype of the packed arrays."""
    N, T = len(poses), terms.term_int.shape[0]
    dtype = skel.joint_frame.dtype
    levels, total, raw = np.empty((N, n_levels), dtype), np.empty(N, dtype), np.empty((N, T), dtype)
    cpu.evaluate_poses(
        kernel_array(poses, dtype),
        kernel_array(problem_index, np.int64),
        skel,
        terms,
        levels,
        total,
        raw,
        0,
        numba.get_num_threads(),
    )
    return levels, total, raw


def point_jacobians(poses, frames, skel):
    """(x (N, G, 3), jacobian (N, G, 3, D)) of frames (G,) (-1: the centre of mass) at poses
    (N, D), in the dtype of the packed skeleton (cpu.point_jacobians)."""
    dtype = skel.joint_frame.dtype
    poses = kernel_array(poses, dtype)
    N, D = poses.shape
    x, jacobian = np.empty((N, len(frames), 3), dtype), np.empty((N, len(frames), 3, D), dtype)
    cpu.point_jacobians(poses, kernel_array(frames, np.int64), skel, x, jacobian, 0, numba.get_num_threads())
    return x, jacobian
