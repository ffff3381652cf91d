"""Which kernels a solve must compile before it can run, about how long that takes, the one line
a command prints first, and compiling them side by side with a bar, so that nobody waits in
silence or longer than needed.

A CPU solve runs one compiled kernel per dtype (deik.backends.cpu_kernels.launch, with or
without the LM polish) and, in float32, the float64 evaluation of its report, each in the build
for its goals' term kinds or a build for more kinds compiled before (deik.backends.builds); a
clip fix also the float64 point Jacobians of its warm start; a GPU solve the two CUDA kernels of
its dtype (deik.backends.cuda_kernels) and the same report. Each is compiled once and cached on
disk (deik.backends.targets); missing CPU kernels compile side by side in worker processes
(deik.backends.compiling). The estimate is each kernel's compile time measured on this machine,
which is recorded beside the cache after compiling, else the reference machine's below, scaled
by how this machine's earlier compiles compared with it.
"""

from __future__ import annotations

import contextlib
import logging
import os
import statistics
from typing import TYPE_CHECKING

from deik.io.atomic import write_json_atomically
from deik.io.files import read_json

if TYPE_CHECKING:
    from deik.backends.contract import Seeds, SolveBuffers
    from deik.device.layout import PackedSkeleton
    from deik.solver.engine import Engine

# Seconds each kernel of the build for every kind takes to compile alone on an idle 2-core AMD EPYC
# VM (two runs of benchmarks/cold_start.py, at 4070ea6 and 2bd66e4: a first float32 reach solve
# 18.8 s wall, `deik warmup` 26.4-26.9 s, each compiling side by side in workers, before a lone DE
# kernel got a helper (deik.backends.compiling.SPLIT); a third run took 17.1 and 24.4 s, a fourth
# 18.6 and 25.0 s: docs/performance.md),
# from Numba's compile timers in the two: the DE kernels of the position builds a first solve compiles (the mean of
# four) over BASE_SHARE, its report likewise, the clip Jacobians as `deik warmup` compiled them
REFERENCE_SECONDS = {
    "DE float32": 19.8,
    "DE float32 without polish": 9.3,
    "DE float64": 19.7,
    "DE float64 without polish": 9.3,
    "report float64": 2.4,
    "clip warm start float64": 2.3,
    # the CUDA kernels compiled to PTX and SASS on the same kind of machine, without a GPU: CPU
    # seconds (tests/scripts/compile_cuda.py, benchmarks/results/gpu/kernel_resources.json)
    "CUDA kernels float32": 149.0,
    "CUDA kernels float64": 147.0,
}
# The share of a build's compile that the build for position goals alone takes (its DE kernel
# took 0.86-0.91 of the full build's in benchmarks/cold_start.py's runs of 2026-11-27,
# results/compare/cold_start_*_b90ee42.json), and what each other switch of
# deik.device.compiled_kinds adds to it: the rest split by how much device code each kind's
# branch holds (estimated, not timed).
BASE_SHARE = 0.88
SWITCH_SHARE = {
    "POSITION_ON": 0.0,
    "ORIENTATION_ON": 0.02,
    "AIM_ON": 0.01,
    "COM_ON": 0.02,
    "SUPPORT_POLYGON_ON": 0.02,
    "COMFORT_ON": 0.01,
    "LIMITS_ON": 0.01,
    "OBSTACLE_ON": 0.01,
    "SELF_COLLISION_ON": 0.02,
    "FLOOR_ON": 0.0,
}
REFERENCE_MACHINE = "a 2-core machine"
RECORD_FILE = "deik-compile-seconds.json"
# the workers' start and this process's loads: a first solve's wall time less its DE kernel's
# compile timer, 1.1-1.5 s in the runs above
STARTUP_SECONDS = 1.3


def launch_name(dtype: str, polish: bool, switches: frozenset[str] | None = None) -> str:
    """A DE kernel's name in notes, e.g. "DE float32" (every kind) or "DE float32 [position]"."""
    return f"DE {dtype}" + ("" if polish else " without polish") + _kinds(switches)


def report_name(switches: frozenset[str] | None = None) -> str:
    """The float64 report's name in notes, e.g. "report float64 [position]"."""
    return "report float64" + _kinds(switches)


def _kinds(switches: frozenset[str] | None) -> str:
    from deik.backends.builds import ALL_KINDS, name_of

    return "" if switches is None or switches == ALL_KINDS else f" [{name_of(switches)}]"


def pending(
    dtype: str, polish: bool = True, clip: bool = False, device: str = "cpu", switches: frozenset[str] | None = None
) -> list[str]:
    """Names of the kernels a solve in `dtype` ("float32", "float64") on `device` ("cpu", "gpu"),
    with the LM polish or without, of goals needing `switches` (default: every kind) must
    compile first; `clip`: a clip fix, which also needs the warm start's Jacobians."""
    from deik.backends import cpu as cpu_backend
    from deik.backends.builds import ALL_KINDS, ready_build

    switches = ALL_KINDS if switches is None else switches
    names = []
    if device == "gpu":
        if not cuda_ready(dtype):
            names.append(f"CUDA kernels {dtype}")
    else:
        build, with_polish = cpu_backend.launch_build(dtype, polish, switches)
        if build == switches and with_polish == polish and not cpu_backend.launch_ready(dtype, polish, build):
            names.append(launch_name(dtype, polish, switches))
    if dtype == "float32" and ready_build("evaluate_poses", switches, cpu_backend.is_report) is None:
        names.append(report_name(switches))
    if clip and not cpu_backend.jacobians_ready():
        names.append("clip warm start float64")
    return names


def cuda_ready(dtype: str) -> bool:
    """Whether both CUDA kernels for `dtype` are cached on disk for this GPU (numba-cuda's cache
    index is private API: when it cannot be read, they count as not ready, and the worst outcome
    is an unneeded note)."""
    try:
        from deik.backends import cuda_kernels

        for kernel, buffers in ((cuda_kernels.first_polish, 0), (cuda_kernels.evolve, 3)):
            index = kernel._cache._cache_file._load_index()
            if not any(str(key[0][buffers].types[0].dtype) == dtype for key in index):
                return False
        return True
    except Exception:  # noqa: BLE001 - no numba-cuda, no cache, or another numba-cuda's internals
        return False


def cache_folder() -> str | None:
    """The folder of the CPU kernels' disk cache, where per-machine records are kept (None if
    there is no cache)."""
    from deik.backends.targets import cpu_entry

    return cpu_entry("launch").cache_folder


def _record_path() -> str | None:
    """The measured compile times' file, beside the kernel cache (None if there is no cache)."""
    folder = cache_folder()
    return None if folder is None else os.path.join(folder, RECORD_FILE)


def measured_seconds() -> dict:
    """{kernel name: compile seconds} recorded on this machine (empty if none or unreadable)."""
    return read_record(_record_path())


def read_record(path: str | None) -> dict:
    """The JSON object deik recorded at `path` (a compile-time or crossover record), through the one
    input reader; empty when there is none or it is damaged (deik's own record, never an input)."""
    if path is None or not os.path.exists(path):
        return {}
    try:
        data = read_json(path, "deik record", record=False)
        return {str(k): float(v) for k, v in data.items()}
    except (TypeError, ValueError, AttributeError, OverflowError):
        return {}


def reference_seconds(name: str) -> float:
    """The reference machine's compile seconds of a kernel named as in notes: a build's share of
    its full build's seconds."""
    base, _, kinds = name.partition(" [")
    seconds = REFERENCE_SECONDS[base]
    if not kinds:
        return seconds
    from deik.backends.builds import switches_named

    return seconds * (BASE_SHARE + sum(SWITCH_SHARE[s] for s in switches_named(kinds.rstrip("]"))))


def machine_factor(measured: dict) -> float | None:
    """How much longer this machine's recorded compiles took than the reference machine's
    (median of the ratios), or None before any."""
    ratios = [seconds / reference_seconds(name) for name, seconds in measured.items() if _known(name)]
    return statistics.median(ratios) if ratios else None


def _known(name: str) -> bool:
    return name.partition(" [")[0] in REFERENCE_SECONDS


def kernel_seconds(names: list[str]) -> tuple[dict[str, float], str]:
    """({name: expected compile seconds}, where the figures come from: "measured" on this
    machine, "scaled" from the reference by this machine's earlier compiles, or "reference")."""
    measured = measured_seconds()
    factor = machine_factor(measured)
    expected = {n: measured.get(n, reference_seconds(n) * (factor or 1.0)) for n in names}
    source = "measured" if all(n in measured for n in names) else "scaled" if factor is not None else "reference"
    return expected, source


def estimate(names: list[str]) -> tuple[float, str]:
    """(seconds to compile `names` side by side, where the figures come from: kernel_seconds)."""
    from deik.backends.compiling import KernelJob, expected_seconds

    seconds, source = kernel_seconds(names)
    cpu = [  # a DE kernel as the "launch" job it is, which may get a helper (deik.backends.compiling)
        KernelJob("launch" if n.startswith("DE ") else "", frozenset(), (), n, s)
        for n, s in seconds.items()
        if not n.startswith("CUDA")
    ]
    gpu = sum(s for n, s in seconds.items() if n.startswith("CUDA"))
    return (STARTUP_SECONDS + expected_seconds(cpu) if cpu else 0.0) + gpu, source


WHERE = {
    "measured": "on this machine, as measured here before",
    "scaled": "on this machine, scaled from its earlier compiles",
    "reference": f"on {REFERENCE_MACHINE}",
}


def compile_note(names: list[str], certain: bool = True) -> str:
    """The one line to print before compiling `names` (from pending); not `certain`: the
    command may need only some of them (a clip fix whose warm start meets every goal runs no DE)."""
    seconds, source = estimate(names)
    doing, wait = ("compiling", "about") if certain else ("may compile", "up to about")
    which = "GPU and CPU" if any(n.startswith("CUDA") for n in names) else "CPU"
    return (
        f"deik: {doing} the {which} kernels first ({', '.join(names)}): {wait} {seconds:.0f} s {WHERE[source]}; "
        "once after an install or upgrade (`deik warmup` does it ahead of time)"
    )


def record(compiled: dict[str, float]) -> None:
    """Add compile seconds {kernel name: seconds} measured in this run to this machine's record
    (best effort: a read-only cache keeps none)."""
    path = _record_path()
    if compiled and path:
        write_json(path, {**measured_seconds(), **compiled})


def prepare(engine: Engine, work: SolveBuffers, seeds: Seeds, show: bool | None = False) -> None:
    """Before a solve's first launch: load the CPU kernels it runs (its DE kernel on the CPU,
    the float64 report of a float32 solve) into this process, compiling the missing ones side by
    side with a bar (`show`: console.progress_bar's flag) after the compile note (the "deik"
    logger), and record their compile seconds. engine: an Engine; work, seeds: its SolveBuffers
    and Seeds (deik.backends.contract)."""
    from deik.backends import cpu as cpu_backend

    found = []
    if engine.settings.device == "cpu":
        found.append(cpu_backend.launch_job(engine.inputs, work, seeds))
    if engine.settings.dtype == "float32":
        found.append(cpu_backend.report_job(engine.skel64, engine.terms64))
    load_kernels([job for job in found if job is not None], show)


def prepare_jacobians(skel: PackedSkeleton, show: bool | None = False) -> None:
    """prepare() for the clip warm start's float64 point Jacobians (skel: a float64 packed skeleton)."""
    from deik.backends import cpu as cpu_backend

    job = cpu_backend.jacobians_job(skel)
    load_kernels([] if job is None else [job], show)


def load_kernels(found: list[tuple], show: bool | None) -> list[str]:
    """Load the (kernel, build, signature) entry points `found` (deik.backends.cpu's launch_job,
    report_job, jacobians_job), compiling the missing ones side by side after the compile note,
    with a bar (`show`: console.progress_bar's flag), and record their seconds; returns the
    names of those compiled."""
    from deik.backends import cpu as cpu_backend
    from deik.backends.compiling import KernelJob, compile_all, missing

    if not found:
        return []
    names = [_name(kernel, build, signature, cpu_backend) for kernel, build, signature in found]
    seconds, _ = kernel_seconds(names)
    jobs = [KernelJob(*job, name, seconds[name]) for job, name in zip(found, names)]
    to_compile = [job.label for job in missing(jobs)]
    if to_compile:
        logging.getLogger(__name__).info(compile_note(to_compile))
    record(compile_all(jobs, show))
    return to_compile


def _name(kernel: str, build: frozenset[str], signature: tuple, cpu_backend) -> str:
    """A kernel's name in notes from its entry (kernel, build, signature)."""
    if kernel == "launch":
        return launch_name(*cpu_backend.launch_kind(signature), build)
    if kernel == "evaluate_poses":
        return report_name(build)
    return "clip warm start float64"


def write_json(path: str, data: dict) -> None:
    """Replace the file at `path` with `data` in one step (deik.io.atomic: a reader never sees
    half of it); a folder that refuses it is left as it was."""
    with contextlib.suppress(OSError):
        write_json_atomically(path, data)
