"""Which kernels a command must compile before it can solve, about how long that takes, and
the one line it prints first, so that nobody waits in silence.

A CPU solve runs one compiled kernel per dtype (deik.backends.cpu_kernels.launch, with or without the LM
polish) and, in float32, the float64 evaluation of its report; a clip fix also the float64 point
Jacobians of its warm start; a GPU solve the two CUDA kernels of its dtype
(deik.backends.cuda_kernels) and the same report. Each is compiled on first use and cached on
disk (deik.backends.targets). The estimate is the compile time measured on this machine, which a
command records beside the cache after compiling, else the time benchmarks/cold_start.py
measured on the reference machine below.
"""

from __future__ import annotations

import contextlib
import os

from deik.io.atomic import write_json_atomically
from deik.io.files import read_json

# seconds each compile took on the reference machine, a shared 2-core AMD EPYC VM (Numba's compile
# timers of the first solves of benchmarks/cold_start.py, median of its runs, 2026-11-25)
REFERENCE_SECONDS = {
    "DE float32": 18.4,
    "DE float32 without polish": 14.1,
    "DE float64": 14.4,
    "DE float64 without polish": 9.4,
    "report float64": 5.5,
    "clip warm start float64": 2.0,
    # the CUDA kernels compiled to PTX and SASS on the same kind of machine, without a GPU: CPU
    # seconds (tests/scripts/compile_cuda.py, benchmarks/results/gpu/kernel_resources.json)
    "CUDA kernels float32": 149.0,
    "CUDA kernels float64": 147.0,
}
REFERENCE_MACHINE = "a 2-core machine"
RECORD_FILE = "deik-compile-seconds.json"


def _launch_name(dtype: str, polish: bool) -> str:
    return f"DE {dtype}" + ("" if polish else " without polish")


def pending(dtype: str, polish: bool = True, clip: bool = False, device: str = "cpu") -> list[str]:
    """Names of the kernels a solve in `dtype` ("float32", "float64") on `device` ("cpu", "gpu"),
    with the LM polish or without (which on the CPU uses the kernel with it when that one is
    ready), must compile first; `clip`: a clip fix, which also needs the warm start's Jacobians."""
    from deik.backends import cpu as cpu_backend

    names = []
    if device == "gpu":
        if not cuda_ready(dtype):
            names.append(f"CUDA kernels {dtype}")
    elif not (cpu_backend.launch_ready(dtype, polish) or (not polish and cpu_backend.launch_ready(dtype, True))):
        names.append(_launch_name(dtype, polish))
    if dtype == "float32" and not cpu_backend.report_ready():
        names.append("report float64")
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
    from deik.backends import cpu_kernels as cpu

    try:
        return cpu.launch.entry._cache._cache_path
    except AttributeError:  # caching off, or another Numba's internals
        return None


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


def estimate(names: list[str]) -> tuple[float, bool]:
    """(seconds to compile `names`, whether every part was measured on this machine)."""
    measured = measured_seconds()
    return sum(measured.get(n, REFERENCE_SECONDS[n]) for n in names), all(n in measured for n in names)


def compile_note(names: list[str], certain: bool = True) -> str:
    """The one line to print before compiling `names` (from pending); not `certain`: the
    command may need only some of them (a clip fix whose warm start meets every goal runs no DE)."""
    seconds, here = estimate(names)
    where = "on this machine, as measured here before" if here else f"on {REFERENCE_MACHINE}"
    doing, wait = ("compiling", "about") if certain else ("may compile", "up to about")
    which = "GPU and CPU" if any(n.startswith("CUDA") for n in names) else "CPU"
    return (
        f"deik: {doing} the {which} kernels first ({', '.join(names)}): {wait} {seconds:.0f} s {where}; "
        "once after an install or upgrade (`deik warmup` does it ahead of time)"
    )


def record_compiles() -> dict:
    """Add the compile times of the kernels compiled in this process to this machine's record
    (best effort: a read-only cache keeps none); returns {name: seconds} added."""
    from deik.backends import cpu as cpu_backend
    from deik.backends import cpu_kernels as cpu

    compiled = {}
    for sig, seconds in cpu.launch.compile_seconds().items():
        compiled[_launch_name(*cpu_backend.launch_kind(sig))] = seconds
    for sig, seconds in cpu.evaluate_poses.compile_seconds().items():
        if cpu_backend.evaluate_dtype(sig) == "float64":
            compiled["report float64"] = seconds
    for sig, seconds in cpu.point_jacobians.compile_seconds().items():
        if cpu_backend.evaluate_dtype(sig) == "float64":
            compiled["clip warm start float64"] = seconds
    path = _record_path()
    if compiled and path:
        write_json(path, {**measured_seconds(), **compiled})
    return compiled


def write_json(path: str, data: dict) -> None:
    """Replace the file at `path` with `data` in one step (deik.io.atomic: a reader never sees
    half of it); a folder that refuses it is left as it was."""
    with contextlib.suppress(OSError):
        write_json_atomically(path, data)
