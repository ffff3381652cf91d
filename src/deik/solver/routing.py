"""device="auto": each solve goes to the CPU or the GPU by its size.

A GPU solve pays a fixed cost per solve (launches, copies, the synchronisation that brings the
answers back) and then does far more per second than the CPU, so small solves belong on the CPU
and large ones on the GPU. Two regimes, two crossovers:

- the polish regime (the polish is on and met problems stop: robot targets), where nearly every
  problem is met by its first polish and the cost grows with the number of problems: the GPU
  from `polish_problems` problems up;
- the evolution regime (DE generations), where the cost grows with individuals x kinematic
  frames per generation: the GPU from `evolution_work` up.

The defaults come from the second measurement on an NVIDIA H200 beside 16 CPU cores of the
same machine (benchmarks/results/gpu/gpu_check.json, docs/gpu.md): a reused Solver's GPU solve of
strict Panda targets cost about 5 ms plus 4.0 us per problem against the CPU's 7.0 us per
problem, equal near 1,600 problems; DE on one 100-link problem at population 500 (50,000 frames
per generation) ran at 0.22x the CPU and 528 such problems at 13x the CPU's 64, equal near
225,000 frames per generation. A machine's own crossovers, measured by
`benchmarks/gpu_check.py --store-crossover`, are kept in
CROSSOVER_FILE beside the kernel cache and take precedence.
"""

from __future__ import annotations

import os
from functools import cache

from deik.solver.problem import Problem
from deik.solver.settings import Settings

DEFAULT_CROSSOVER = {"polish_problems": 1_600, "evolution_work": 225_000}
CROSSOVER_FILE = "deik-gpu-crossover.json"


def crossover_path() -> str | None:
    """This machine's crossover record, beside the CPU kernels' cache (None without a cache)."""
    from deik.solver.readiness import cache_folder

    folder = cache_folder()
    return None if folder is None else os.path.join(folder, CROSSOVER_FILE)


@cache
def crossover() -> dict:
    """{"polish_problems": n, "evolution_work": w}: this machine's measured values, else the defaults."""
    from deik.solver.readiness import read_record

    measured = read_record(crossover_path())
    return {**DEFAULT_CROSSOVER, **{k: v for k, v in measured.items() if k in DEFAULT_CROSSOVER}}


def store_crossover(values: dict) -> str | None:
    """Keep measured crossovers for this machine; returns the file written (None: no cache folder)."""
    from deik.solver.readiness import write_json

    path = crossover_path()
    if path is not None:
        write_json(path, {k: float(values[k]) for k in DEFAULT_CROSSOVER if k in values})
        crossover.cache_clear()
    return path


def require_gpu() -> None:
    """DeviceError, one line naming the fix, unless an NVIDIA GPU and numba-cuda are usable here
    (for the layers above the solver, which reach the back-ends only through it)."""
    from deik.backends import gpu

    gpu.require_gpu()


def polish_regime(problem: Problem, settings: Settings) -> bool:
    """Whether a solve of `problem` is mostly its first polish: the polish is on and problems
    stop once every tolerance is met (explicitly, or because every weighted goal has one)."""
    if settings.polish == 0 or settings.stop_on_converged is False:
        return False
    if settings.stop_on_converged:
        return True
    from deik.objectives.kinds import TOLERANCE, WEIGHT

    weight, tolerance = problem.table.term_float[:, WEIGHT], problem.table.term_float[:, TOLERANCE]
    return not bool(((weight > 0) & (tolerance < 0)).any())


def choose_device(problem: Problem, settings: Settings) -> str:
    """ "cpu" or "gpu" for a solve of `problem` with device="auto" (the CPU when no GPU is usable)."""
    from deik.backends.gpu import gpu_available

    if not gpu_available():
        return "cpu"
    limits = crossover()
    if polish_regime(problem, settings):
        return "gpu" if problem.batch_size >= limits["polish_problems"] else "cpu"
    skeleton = problem.skeleton
    work = problem.batch_size * settings.population * (skeleton.n_joints + len(skeleton.site_names))
    return "gpu" if work >= limits["evolution_work"] else "cpu"
