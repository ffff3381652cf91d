"""Compile deik's CUDA kernels for sm_90 without a GPU, through the CUDA back-end's own launches
and numba-cuda's disk cache, and print one JSON object: per kernel its compile seconds, whether
it came from the cache, its PTX size and what ptxas reports (registers, spills, stack, local
and shared memory).

    PYTHONPATH=src python tests/scripts/compile_cuda.py DTYPE CASE [--without-row-stack] [--record FILE]

CASE "humanoid" (a reach and comfort, population 64, one problem) or "arm" (a 7-joint arm's 6-D
targets, population 32, five problems): two different problems, which must share one compile.
Each case also solves a second problem whose goals all have tolerances (on the humanoid: a
3-joint chain's tip targets; on the arm: the arm's own with a thread per problem), so that all
three kernels compile: evolve, first_polish and first_polish_team.
--without-row-stack deletes numpy.row_stack first, as NumPy 2.5 did (deik's guard must put it
back before numba-cuda compiles). --record FILE keeps the result in a JSON record, one entry
per dtype (benchmarks/results/gpu/kernel_resources.json, which a test checks against the budget).

No GPU is used: numba-cuda's questions to the driver are answered here (compute capability 9.0,
132 multiprocessors), device arrays are NumPy arrays, and a launch compiles the kernel for its
arguments' types instead of running it. Compilation is numba-cuda's own: NVVM to PTX, then
ptxas inside nvJitLink to SASS for sm_90a (verbose, for the resource lines), both from the
`numba-cuda[cu13]` wheels; the result is saved to and loaded from the disk cache as on a GPU.
"""

import importlib.metadata
import json
import os
import pathlib
import platform
import re
import sys
import time
from types import SimpleNamespace

import numpy as np

if "--without-row-stack" in sys.argv and "row_stack" in vars(np):
    del np.row_stack

import numba.cuda.codegen as codegen  # noqa: E402
import numba.cuda.dispatcher as dispatcher  # noqa: E402
from numba import cuda, typeof  # noqa: E402
from numba.cuda.cudadrv import driver  # noqa: E402
from numba.cuda.cudadrv.runtime import runtime  # noqa: E402

CC = (9, 0, "a")
DEVICE = SimpleNamespace(compute_capability=CC[:2], MULTIPROCESSOR_COUNT=132, name="sm_90 (offline)")


class HostArray(np.ndarray):
    """A NumPy array standing in for a device array (same Numba type as a contiguous one)."""

    def copy_to_host(self, host):
        np.copyto(host, self)

    def copy_to_device(self, host):
        np.copyto(self, host)


def _as_device(a):
    return np.array(a).view(HostArray)


COMPILED = {}  # kernel name -> {seconds, signature}


def _launch(self, griddim):
    def compile_for(*args):
        signature = tuple(typeof(a) for a in args)
        if self.py_func.__name__ in COMPILED:
            return
        began = time.perf_counter()
        self.compile(signature)
        seconds = time.perf_counter() - began
        COMPILED[self.py_func.__name__] = {"dispatcher": self, "signature": signature, "seconds": seconds}

    return compile_for


def _verbose_options(linker, ptx):
    options = _original_options(linker, ptx)
    options.verbose = True
    return options


dispatcher.get_current_device = lambda: DEVICE
codegen.CUDACodeLibrary._ensure_cc = lambda self, cc: CC if cc is None else cc
codegen.JITCUDACodegen.magic_tuple = lambda self: (runtime.get_version(), DEVICE.compute_capability)
dispatcher._Kernel.bind = lambda self: self._codelibrary.get_cubin()
_original_options = driver._Linker._get_linker_options
driver._Linker._get_linker_options = _verbose_options
dispatcher.CUDADispatcher.__getitem__ = _launch
cuda.is_available = lambda: True
cuda.get_current_device = lambda: DEVICE
cuda.to_device = _as_device
cuda.device_array = lambda shape, dtype: np.zeros(shape, dtype).view(HostArray)

import deik  # noqa: E402


def problem(case):
    if case == "humanoid":
        human = deik.humanoid()
        rest = deik.forward_kinematics(human, human.reference)
        goals = [deik.Position("left_hand", rest.position("left_hand")), deik.Comfort(level=1)]
        return deik.Problem(human, goals), 64
    arm = deik.chain(7, dims=3)
    kin = deik.forward_kinematics(arm, np.random.default_rng(0).uniform(-1, 1, (5, arm.n_dofs)))
    goals = [deik.Position("tip", kin.position("tip"), tolerance=1e-5), deik.Orientation("tip", kin.rotation("tip"))]
    return deik.Problem(arm, goals), 32


def second_problem(case):
    """The case's other problem: one that the team polish takes (every goal with a tolerance)."""
    if case == "humanoid":
        chain = deik.chain(3, dims=3)
        kin = deik.forward_kinematics(chain, np.random.default_rng(1).uniform(-1, 1, (3, chain.n_dofs)))
        return deik.Problem(chain, [deik.Position("tip", kin.position("tip"), tolerance=1e-4)]), 16
    return problem(case)


def resources(info: str) -> dict:
    """ptxas's lines for the kernel (the entry's, the last function ptxas reports)."""

    def last(pattern):
        found = re.findall(pattern, info)
        return int(found[-1]) if found else None

    return {
        "registers": last(r"Used (\d+) registers"),
        "spill_store_bytes": last(r"(\d+) bytes spill stores"),
        "spill_load_bytes": last(r"(\d+) bytes spill loads"),
        "stack_frame_bytes": last(r"(\d+) bytes stack frame"),
        "local_bytes": last(r"(\d+) bytes lmem"),
        "shared_bytes": last(r"(\d+) bytes smem"),
    }


dtype, case = sys.argv[1], sys.argv[2]
prob, population = problem(case)
began = time.perf_counter()
other, other_population = second_problem(case)
other_settings = deik.Settings(population=other_population, dtype=dtype, device="gpu", stop_on_converged=True)
deik.Engine(other, other_settings).start(2)  # first_polish_team
settings = deik.Settings(population=population, dtype=dtype, device="gpu", stop_on_converged=True)
engine = deik.Engine(prob, settings)
engine.init()  # evolve, sampling a first population
engine.backend.cooperative_polish = False
engine.start(2)  # first_polish (the fake answers say every problem was met: evolve is not launched again)
report = {"dtype": dtype, "case": case, "total_seconds": time.perf_counter() - began, "kernels": {}}
for name, entry in sorted(COMPILED.items()):
    kernel = entry["dispatcher"].overloads[entry["signature"]]
    library = kernel._codelibrary
    report["kernels"][name] = {
        "seconds": entry["seconds"],
        "from_cache": sum(entry["dispatcher"].stats.cache_hits.values()) > 0,
        "ptx_bytes": len(library.get_asm_str(cc=CC)),
        "sass_bytes": len(library.get_cubin(cc=CC).code),
        **resources(library.get_linkerinfo(CC)),
    }
print(json.dumps(report))
if "--record" in sys.argv:
    path = pathlib.Path(sys.argv[sys.argv.index("--record") + 1])
    record = json.loads(path.read_text()) if path.exists() else {}
    record.update(
        what="deik's CUDA kernels compiled for sm_90a without a GPU: NVVM and nvJitLink's ptxas from the "
        "numba-cuda[cu13] wheels (tests/scripts/compile_cuda.py); seconds on the CPU that compiled them",
        numba_cuda=importlib.metadata.version("numba-cuda"),
        nvjitlink=importlib.metadata.version("nvidia-nvjitlink"),
        cpu=platform.processor() or platform.machine(),
        load_average=os.getloadavg()[0],
    )
    record["compiles"] = [row for row in record.get("compiles", []) if row["dtype"] != dtype] + [report]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(record, indent=1) + "\n")
