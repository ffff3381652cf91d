"""Host side of the CPU kernels: the build that serves a problem, chunking, thread count and
argument order (deik.backends.cpu_kernels, deik.backends.builds).

Every launch goes through the one compiled kernel `launch` of a build, so a solve compiles one
kernel per dtype, and only for the kinds of its goals (or loads a build for more kinds compiled
before). A solve without the LM polish passes no PolishSchedule (None), which compiles a kernel
without the LM, unless a kernel with it is compiled already: it gives the same answers with the
polish turned off, and one kernel loads faster than two compile.
"""

from __future__ import annotations

import numba
import numpy as np
from numba.core import types

from deik.backends import builds
from deik.backends.contract import KernelInputs, Seeds, SolveBuffers
from deik.backends.pack import kernel_array
from deik.backends.targets import cpu_entry

# argument positions in cpu_kernels.launch's signature
LAUNCH_BUFFERS, LAUNCH_SCHEDULE = 1, 7


def launch_kind(signature) -> tuple[str, bool]:
    """(dtype, with the LM polish) of a cpu_kernels.launch signature (a tuple of Numba types)."""
    return str(signature[LAUNCH_BUFFERS].types[0].dtype), not isinstance(signature[LAUNCH_SCHEDULE], types.NoneType)


def evaluate_dtype(signature) -> str:
    """The dtype of a cpu_kernels.evaluate_poses or cpu_pose_kernels.point_jacobians signature (of its poses)."""
    return str(signature[0].dtype)


_LAUNCHES = {}  # (dtype, polish wanted, switches) -> (the build that serves it, with the polish)


def launch_build(dtype: str, polish: bool, switches: frozenset[str]) -> tuple[frozenset[str], bool]:
    """(build, with the LM polish) of the launch kernel a solve in `dtype` with the polish (or
    without) on a problem needing `switches` runs: a ready one that covers them (without the
    polish: one without it first, else one with it), else its own, to compile. Decided once per
    process: the disk check costs milliseconds."""
    key = (dtype, polish, switches)
    if key not in _LAUNCHES:
        _LAUNCHES[key] = (switches, polish)
        for with_polish in (True,) if polish else (False, True):
            build = builds.ready_build("launch", switches, lambda sig, p=with_polish: launch_kind(sig) == (dtype, p))
            if build is not None:
                _LAUNCHES[key] = (build, with_polish)
                break
    return _LAUNCHES[key]


_REPORTS = {}  # switches -> the build whose float64 evaluate_poses serves them


def report_build(switches: frozenset[str]) -> frozenset[str]:
    """The build whose float64 evaluate_poses evaluates a problem needing `switches`: a ready
    one that covers them, else their own (decided once per process)."""
    if switches not in _REPORTS:
        ready = builds.ready_build("evaluate_poses", switches, is_report)
        _REPORTS[switches] = switches if ready is None else ready
    return _REPORTS[switches]


def launch_args(
    fresh: bool,
    inputs: KernelInputs,
    work: SolveBuffers,
    seeds: Seeds,
    generations: tuple[int, int],
    with_polish: bool | None = None,
):
    """The arguments of cpu_kernels.launch for a launch, in the types it is compiled for;
    generations (first, count). The PolishSchedule is None where the kernel has no LM: the
    serving kernel's (launch_build), or as `with_polish` says."""
    cur = work.current
    if with_polish is None:
        polish = inputs.polish.iterations > 0
        _, with_polish = launch_build(cur.pop.dtype.name, polish, builds.switches_of(inputs.terms.term_int))
    return (
        fresh,
        cur,
        work.spare,
        work.status,
        inputs.skeleton,
        inputs.terms,
        inputs.evolution,
        inputs.polish if with_polish else None,
        inputs.rules,
        work.history,
        seeds.poses,
        np.int64(seeds.count),
        np.int64(generations[0]),
        np.int64(generations[1]),
        numba.get_num_threads(),
    )


def launch_ready(dtype: str, polish: bool, build: frozenset[str]) -> bool:
    """Whether the launch kernel of `build` in `dtype` with the LM polish (or without) is
    compiled in this process or cached on disk."""
    return (dtype, polish) in map(launch_kind, cpu_entry("launch", build).ready_signatures())


def is_report(signature) -> bool:
    """Whether an evaluate_poses signature is the float64 report's."""
    return evaluate_dtype(signature) == "float64"


def jacobians_ready() -> bool:
    """Whether the clip warm start's float64 point Jacobians (cpu_pose_kernels.point_jacobians) are ready."""
    return "float64" in map(evaluate_dtype, cpu_entry("point_jacobians").ready_signatures())


def launch_job(
    inputs: KernelInputs, work: SolveBuffers, seeds: Seeds, build: frozenset[str] | None = None
) -> tuple[str, frozenset[str], tuple] | None:
    """("launch", build, signature) of the DE kernel a solve with these inputs runs, or None when
    this process has loaded it; `build`: that build's instead, with the polish as the inputs ask
    (which decides nothing about which build serves them: that build may not be compiled yet)."""
    switches = builds.switches_of(inputs.terms.term_int)
    key = (work.current.pop.dtype, bool(inputs.polish.iterations > 0), switches)
    if build is not None:
        args = launch_args(True, inputs, work, seeds, (0, 0), with_polish=key[1])
        return "launch", build, tuple(numba.typeof(a) for a in args)
    if key in _ENTRY_POINTS:
        return None
    serving, _ = launch_build(key[0].name, key[1], switches)
    return "launch", serving, tuple(numba.typeof(a) for a in launch_args(True, inputs, work, seeds, (0, 0)))


def report_job(skel, terms, build: frozenset[str] | None = None) -> tuple[str, frozenset[str], tuple] | None:
    """("evaluate_poses", build, signature) of the float64 report of a float32 solve whose packed
    float64 skeleton and terms these are, or None when this process has loaded it; `build`: that
    build's instead (deciding nothing about which build serves them)."""
    signature = tuple(numba.typeof(a) for a in _evaluate_args(np.zeros((1, 1)), skel, terms, 1)[0])
    if build is not None:
        return "evaluate_poses", build, signature
    serving = report_build(builds.switches_of(terms.term_int))
    if (np.dtype(np.float64), serving) in _ENTRY_POINTS:
        return None
    return "evaluate_poses", serving, signature


def jacobians_job(skel) -> tuple[str, frozenset[str], tuple] | None:
    """("point_jacobians", build, signature) of the clip warm start's float64 point Jacobians
    (skel: a float64 packed skeleton), or None when this process has loaded them."""
    if "point_jacobians" in _ENTRY_POINTS:
        return None
    return (
        "point_jacobians",
        builds.ALL_KINDS,
        tuple(numba.typeof(a) for a in _jacobian_args(np.zeros((1, 1)), [0], skel)[0]),
    )


# the compiled kernel each runs: (dtype, polish wanted, switches) -> (launch, with the polish);
# (dtype, build) -> evaluate_poses; "point_jacobians" -> point_jacobians
_ENTRY_POINTS = {}


def _launch(fresh: bool, inputs: KernelInputs, work: SolveBuffers, seeds: Seeds, generations: tuple[int, int]) -> int:
    """cpu_kernels.launch of the serving build; returns the buffer swaps.

    Numba's dispatcher types every argument on every call (some 40 arrays in NamedTuples: 6 us
    of a 40 us robot solve), while an Engine's arguments are always the same types for a dtype
    and PolishSchedule or None: the same NamedTuples of C-contiguous, writable arrays
    (kernel_array) and the same scalar types. The first launch of each kind in a process loads
    (or compiles) the kernel and keeps its compiled function, which later launches call."""
    key = (work.current.pop.dtype, bool(inputs.polish.iterations > 0), builds.switches_of(inputs.terms.term_int))
    entry, with_polish = _ENTRY_POINTS.get(key, (None, None))
    args = launch_args(fresh, inputs, work, seeds, generations, with_polish)
    if entry is None:
        build, with_polish = launch_build(key[0].name, key[1], key[2])
        entry = cpu_entry("launch", build).entry_point(args)
        _ENTRY_POINTS[key] = (entry, with_polish)
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


def _evaluate_args(poses, skel, terms, n_levels: int, problem_index=None) -> tuple[tuple, np.ndarray]:
    """(the arguments of cpu_kernels.evaluate_poses for poses (N, D), the array of the results
    levels, total, raw they fill)."""
    N, T = len(poses), terms.term_int.shape[0]
    dtype = skel.joint_frame.dtype
    index = np.zeros(N, np.int64) if problem_index is None else kernel_array(problem_index, np.int64)
    levels, total, raw = np.empty((N, n_levels), dtype), np.empty(N, dtype), np.empty((N, T), dtype)
    args = (kernel_array(poses, dtype), index, skel, terms, levels, total, raw, 0, numba.get_num_threads())
    return args, (levels, total, raw)


def evaluate_poses(poses, problem_index, skel, terms, n_levels: int):
    """(levels (N, L), total (N,), raw (N, T)) of poses (N, D), pose n against problem
    problem_index[n], in the dtype of the packed arrays (float32: the build for every kind;
    float64, the report of every solve: the build that serves the terms' kinds)."""
    dtype = skel.joint_frame.dtype
    build = report_build(builds.switches_of(terms.term_int)) if dtype == np.float64 else builds.ALL_KINDS
    args, results = _evaluate_args(poses, skel, terms, n_levels, problem_index)
    key = (dtype, build)
    entry = _ENTRY_POINTS.get(key)
    if entry is None:
        entry = _ENTRY_POINTS[key] = cpu_entry("evaluate_poses", build).entry_point(args)
    entry(*args)
    return results


def _jacobian_args(poses, frames, skel) -> tuple[tuple, tuple[np.ndarray, np.ndarray]]:
    """(the arguments of cpu_pose_kernels.point_jacobians, the arrays x and jacobian they fill)."""
    dtype = skel.joint_frame.dtype
    poses = kernel_array(poses, dtype)
    N, D = poses.shape
    x, jacobian = np.empty((N, len(frames), 3), dtype), np.empty((N, len(frames), 3, D), dtype)
    return (poses, kernel_array(frames, np.int64), skel, x, jacobian, 0, numba.get_num_threads()), (x, jacobian)


def point_jacobians(poses, frames, skel):
    """(x (N, G, 3), jacobian (N, G, 3, D)) of frames (G,) (-1: the centre of mass) at poses
    (N, D), in the dtype of the packed skeleton (cpu_pose_kernels.point_jacobians)."""
    args, results = _jacobian_args(poses, frames, skel)
    entry = _ENTRY_POINTS.get("point_jacobians")
    if entry is None or skel.joint_frame.dtype != np.float64:
        entry = cpu_entry("point_jacobians").entry_point(args)
        if skel.joint_frame.dtype == np.float64:
            _ENTRY_POINTS["point_jacobians"] = entry
    entry(*args)
    return results
