"""Host side of the CPU kernels: chunking, thread count and argument order (deik.backends.cpu_kernels).

Every launch goes through the one compiled kernel `cpu.launch`, so a solve compiles one kernel per
dtype. A solve without the LM polish passes no PolishSchedule (None), which compiles a kernel without the
LM, unless the kernel with it is compiled already (deik.solver.readiness): it gives the same
answers with the polish turned off, and one kernel loads faster than two compile.
"""

from __future__ import annotations

from functools import cache

import numba
import numpy as np
from numba.core import types

from deik.backends import cpu_kernels as cpu
from deik.backends.contract import KernelInputs, Seeds, SolveBuffers
from deik.backends.pack import kernel_array

# argument positions in cpu.launch's signature
LAUNCH_BUFFERS, LAUNCH_SCHEDULE = 1, 7


def launch_kind(signature) -> tuple[str, bool]:
    """(dtype, with the LM polish) of a cpu.launch signature (a tuple of Numba types)."""
    return str(signature[LAUNCH_BUFFERS].types[0].dtype), not isinstance(signature[LAUNCH_SCHEDULE], types.NoneType)


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


def _schedule(schedule, dtype):
    """The PolishSchedule to pass, or None for the kernel without the polish (see the module doc)."""
    return None if schedule.iterations == 0 and _without_polish(np.dtype(dtype).name) else schedule


_ENTRIES = {}  # (dtype, with the polish) -> the compiled entry point of cpu.launch for them


def _launch(fresh: bool, inputs: KernelInputs, work: SolveBuffers, seeds: Seeds, generations: tuple[int, int]) -> int:
    """cpu.launch with the argument types it is compiled for; generations (first, count);
    returns the buffer swaps.

    Numba's dispatcher types every argument on every call (some 40 arrays in NamedTuples: 6 us
    of a 40 us robot solve), while an Engine's arguments are always the same types for a dtype
    and PolishSchedule or None: the same NamedTuples of C-contiguous, writable arrays
    (kernel_array) and the same scalar types. The first launch of each kind in a process
    dispatches (compiling or loading) and keeps the overload's entry point, which later
    launches call directly."""
    cur = work.current
    args = (
        fresh,
        cur,
        work.spare,
        work.status,
        inputs.skeleton,
        inputs.terms,
        inputs.evolution,
        _schedule(inputs.polish, cur.pop.dtype),
        inputs.rules,
        work.history,
        seeds.poses,
        np.int64(seeds.count),
        np.int64(generations[0]),
        np.int64(generations[1]),
        numba.get_num_threads(),
    )
    key = (cur.pop.dtype, args[LAUNCH_SCHEDULE] is None)
    entry = _ENTRIES.get(key)
    if entry is None:
        kernel = cpu.launch.entry
        swaps = kernel(*args)
        _ENTRIES[key] = kernel.overloads[tuple(numba.typeof(a) for a in args)].entry_point
    else:
        swaps = entry(*args)
    if swaps % 2:
        work.current, work.spare = work.spare, work.current
    return int(swaps)


class CpuBackend:
    """The CPU kernels (deik.backends.cpu_kernels) behind the back-end contract
    (deik.backends.contract.Backend): the host buffers are the kernels' own."""

    name = "cpu"

    def initialise(self, inputs: KernelInputs, work: SolveBuffers, seeds: Seeds) -> None:
        """A first population and its Status (a launch of no generations that is never lazy)."""
        plain = inputs._replace(rules=inputs.rules._replace(stop_on_converged=False))
        _launch(True, plain, work, seeds, (0, 0))

    def start(self, inputs: KernelInputs, work: SolveBuffers, seeds: Seeds, n_generations: int) -> int:
        """A first population, then up to n_generations, in one compiled call."""
        return _launch(True, inputs, work, seeds, (0, n_generations))

    def run(self, inputs: KernelInputs, work: SolveBuffers, first_generation: int, n_generations: int) -> int:
        """Up to n_generations more from first_generation."""
        no_seeds = Seeds(np.empty((0, 0, 0), work.current.pop.dtype), 0)
        return _launch(False, inputs, work, no_seeds, (first_generation, n_generations))

    def fetch(self, work: SolveBuffers) -> None:
        """Nothing to do: the CPU kernels work in the host buffers."""


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
