"""Timing of the serial (Algorithm 1) and parallel (Figure 1) DE on the paper's chains.

Shared by Figs. 8 and 9 and by `benchmarks/serial_vs_parallel.py`. The problem is the
paper's planar chain `deik.chain(n)` with one Position goal on its tip whose target is the
forward kinematics of a random in-limit pose. Serial: `deik.experiments.serial_numpy.SerialDE`
(NumPy, one candidate evaluated at a time, in-place replacement). Parallel: `deik.Engine`
with `Settings.paper` (rand/1/bin, F 0.5, CR 0.5), `stop_on_converged=False` and a huge
patience so every generation runs, warmed up once so compilation is excluded.
"""

from __future__ import annotations

import os
import platform
import sys
import time

import numba
import numpy as np

import deik
from deik.experiments.serial_numpy import SerialDE
from deik.experiments.shared import CONVERGED_FRACTION
from deik.model.kinematics import forward_kinematics
from deik.solver.problem import Problem


def make_problem(n_links: int, seed: int) -> deik.Problem:
    """deik.chain(n_links) (planar, D = n_links) with Position("tip", FK of a random pose), met
    within the paper's 1 % of the reach (user goals default to an absolute 0.001 length units)."""
    sk = deik.chain(n_links)
    # its own stream: SerialDE(seed) draws its first population from default_rng(seed), which
    # would otherwise start with the target pose itself
    pose = np.random.default_rng((seed, n_links, 1)).uniform(sk.lower, sk.upper)
    target = forward_kinematics(sk, pose).position("tip")
    return deik.Problem(sk, [deik.Position("tip", target, tolerance=CONVERGED_FRACTION * sk.reach)])


def time_serial(problem: Problem, population: int, epochs: int, seed: int) -> dict:
    """Seconds per generation (epoch) of SerialDE, averaged over `epochs` epochs, and the best
    tip error (length units) reached."""
    de = SerialDE(problem, population=population, F=0.5, CR=0.5, seed=seed).init()
    de.iterate()  # touch every code path once before timing
    start = time.perf_counter()
    for _ in range(epochs):
        de.epoch()
    seconds = (time.perf_counter() - start) / epochs
    return {"seconds_per_generation": seconds, "epochs_timed": epochs, "best_tip_error": float(de.best_errors[0])}


def time_serial_compiled(
    problem: Problem, population: int, generations: int, repeats: int, seed: int, dtype: str
) -> dict:
    """Seconds per generation of the compiled serial Algorithm 1 (one CPU thread, the kernels'
    maths): best of `repeats` runs of `generations` epochs after a warm-up epoch (compilation
    excluded); "all_seconds_per_generation" lists every repeat."""
    from deik.experiments.serial_compiled import CompiledSerialDE  # loads Numba and the device maths

    de = CompiledSerialDE(problem, population=population, F=0.5, CR=0.5, seed=seed, dtype=dtype).run(1)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        de.run(generations)
        times.append(time.perf_counter() - start)
    return {
        "seconds_per_generation": min(times) / generations,
        "generations_timed": generations,
        "repeats": repeats,
        "all_seconds_per_generation": [t / generations for t in times],
        "best_tip_error": float(de.best_errors[0]),
    }


def time_parallel(
    problem: Problem, population: int, generations: int, repeats: int, seed: int, dtype: str, device: str = "cpu"
) -> dict:
    """Seconds per generation of the parallel engine on `device` ("cpu" or "gpu"): best of
    `repeats` runs of `generations` generations each from the same warmed-up state;
    "all_seconds_per_generation" lists every repeat."""
    settings = deik.Settings.paper(
        population=population,
        stop_on_converged=False,
        patience=10**9,
        generations=max(generations, 1),
        seed=seed,
        dtype=dtype,
        device=device,
    )
    engine = deik.Engine(problem, settings)
    state = engine.init()
    state = engine.run(state, 2)  # warm-up: compilation (or cache load) excluded from timing
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        out = engine.run(state, generations)
        times.append(time.perf_counter() - start)
        if out.generation != state.generation + generations:
            raise RuntimeError(f"engine stopped early at {out.generation - state.generation} generations")
    best = out.raw[0, out.best[0], 0]
    return {
        "seconds_per_generation": min(times) / generations,
        "generations_timed": generations,
        "repeats": repeats,
        "all_seconds_per_generation": [t / generations for t in times],
        "best_tip_error": float(best),
        "strategy": settings.strategy,
        "F": settings.F,
        "CR": settings.CR,
        "dtype": settings.dtype,
        "device": device,
    }


def environment() -> dict:
    """Platform, CPU count, Numba threads and threading layer, load average and versions."""
    return {
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpu_count": os.cpu_count(),
        "cpu_affinity": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
        "numba_threads": numba.get_num_threads(),
        "numba_threading_layer": threading_layer(),
        "load_average_1_5_15": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "numba": numba.__version__,
        "deik": deik.__version__,
    }


def threading_layer() -> str | None:
    """Numba's threading layer, or None before the first parallel region has run."""
    try:
        return numba.threading_layer()
    except ValueError:  # no parallel region has run yet
        return None


def cpu_model() -> str:
    """The CPU's marketing name from /proc/cpuinfo (falls back to platform.processor())."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as file:
            for line in file:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def gpu_status() -> tuple[bool, str]:
    """(available, description): the CUDA GPU's name when numba.cuda sees one, else why not."""
    try:
        from numba import cuda
    except ImportError as error:  # pragma: no cover - numba always ships numba.cuda
        return False, f"numba.cuda cannot be imported ({error})"
    from numba import config

    if config.ENABLE_CUDASIM:
        return True, "Numba's CUDA simulator (NUMBA_ENABLE_CUDASIM=1): checks code paths, its timings mean nothing"
    try:
        if not cuda.is_available():
            return False, "no CUDA GPU is available here (numba.cuda.is_available() is False)"
        name = cuda.get_current_device().name
        return True, name.decode() if isinstance(name, bytes) else str(name)
    except Exception as error:  # a broken driver is reported, not raised
        return False, f"CUDA is not usable here ({error})"


def machine_line() -> str:
    """One line naming this machine for reports: CPU model, cores, Numba threads, platform."""
    env = environment()
    return (
        f"{cpu_model()}, {env['cpu_count']} CPUs, {env['numba_threads']} Numba threads, "
        f"{env['platform']}, Python {env['python']}, NumPy {env['numpy']}, Numba {env['numba']}"
    )


def load_line() -> str:
    """ "Load average now: 1, 5, 15 minutes" (other processes make parallel timings noisy)."""
    if not hasattr(os, "getloadavg"):
        return ""
    one, five, fifteen = os.getloadavg()
    return f"Load average at the end: {one:.2f}, {five:.2f}, {fifteen:.2f} on {os.cpu_count()} CPUs."


GPU_COMMAND = "deik experiments fig8 fig9 --device gpu --out DIR"


def gpu_plan(device: str) -> tuple[bool, str | None]:
    """(time the GPU?, note for the report) for the runner's `device` ("cpu", "gpu" or "auto"):
    the GPU is timed when asked for ("gpu") or present ("auto"); otherwise the note says the
    GPU column is pending and gives the command to run on a GPU machine."""
    if device == "cpu":
        return False, f"GPU column not measured (--device cpu); on a GPU machine run `{GPU_COMMAND}`"
    available, description = gpu_status()
    if available:
        return True, None
    return False, (
        f"GPU column pending: it needs an NVIDIA GPU ({description}); on a machine with one run `{GPU_COMMAND}`"
    )
