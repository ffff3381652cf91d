"""deik.warmup(): compile every kernel the commands use, ahead of time (`deik warmup`): the CPU
kernels, and with device "gpu" the CUDA kernels too.

The kernels are compiled on first use and cached on disk (deik.backends.targets); running this
once after an install or upgrade moves that wait to a moment of the user's choosing. It compiles
the CPU kernels' build for every goal kind (deik.backends.builds), which then serves every
problem: the DE kernel with its polish for each dtype (a solve without the polish uses it too),
the float64 error report of float32 solves and the clip fix's float64 Jacobians, side by side in
worker processes with a bar (deik.backends.compiling); with device "gpu" then small solves per
dtype on the GPU. The compile times are recorded for the estimates that commands print
(deik.solver.readiness).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterable

import numpy as np

from deik.errors import InputError
from deik.model.builders import chain
from deik.model.kinematics import forward_kinematics
from deik.objectives.goals import Comfort, Position
from deik.solver.engine import Engine
from deik.solver.problem import Problem
from deik.solver.readiness import compile_note, cuda_ready, load_kernels, pending
from deik.solver.routing import require_gpu
from deik.solver.settings import Settings
from deik.solver.solve import solve
from deik.solver.workspace import Workspace

DTYPES = ("float32", "float64")


def _cpu_kernels(dtypes: list[str], progress: bool | None) -> list[str]:
    """Load or compile the CPU kernels of the build for every kind: the DE kernel with the polish
    in each of `dtypes`, the float64 report and the clip warm start's Jacobians, side by side
    with a bar; returns the names of those compiled."""
    from deik.backends import cpu as cpu_backend
    from deik.backends.builds import ALL_KINDS

    problem = Problem(chain(2, dims=3), [Position("tip", np.ones(3))])
    found = []
    for dtype in dtypes:
        engine = Engine(problem, Settings(population=8, dtype=dtype))
        work = Workspace()
        work.prepare(engine)
        found.append(cpu_backend.launch_job(engine.inputs, work.work, engine.initial_poses(None), ALL_KINDS))
    found.append(cpu_backend.report_job(engine.skel64, engine.terms64, ALL_KINDS))
    found.append(cpu_backend.jacobians_job(engine.skel64))
    return load_kernels([job for job in found if job is not None], progress)


def _gpu_solves(dtype: str) -> None:
    """Small GPU solves in `dtype` that run both CUDA kernels: the generations and, for a
    problem whose goals stop once met, the first polish."""
    sk = chain(3, dims=3)
    target = forward_kinematics(sk, np.full(sk.n_dofs, 0.3)).position("tip")
    problem = Problem(sk, [Position("tip", target, tolerance=1e-3), Comfort(level=1)])
    solve(problem, population=8, generations=2, dtype=dtype, seed=0, device="gpu")
    solve(Problem(sk, problem.goals[:1]), population=8, generations=2, dtype=dtype, device="gpu")


def kernels_to_compile(dtypes: Iterable[str] = DTYPES, device: str = "cpu") -> list[str]:
    """Names of the kernels warmup(dtypes, device) would compile (those not in the cache yet)."""
    devices = ("cpu", "gpu") if device == "gpu" else ("cpu",)
    return list(dict.fromkeys(n for d in dtypes for where in devices for n in pending(d, clip=True, device=where)))


def warmup(dtypes: Iterable[str] = DTYPES, device: str = "cpu", progress: bool | None = False) -> dict:
    """Compile (or load from the cache) the CPU kernels for `dtypes` ("float32", "float64"), and
    with `device` "gpu" the CUDA kernels too (DeviceError without a usable GPU), after a note
    on the "deik" logger and with a bar while they compile when `progress`
    (deik.console.progress_bar's `show`), and record the compile times. Returns {"dtypes",
    "device", "compiled": the kernels that were not cached, "seconds": wall time}."""
    dtypes = list(dtypes)
    unknown = [dtype for dtype in dtypes if dtype not in DTYPES]
    if unknown or device not in ("cpu", "gpu"):
        raise InputError(
            f"dtype {unknown[0]!r}: use {' or '.join(DTYPES)}" if unknown else f"device {device!r}: use cpu or gpu"
        )
    if device == "gpu":
        require_gpu()
    began = time.perf_counter()
    compiled = _cpu_kernels(dtypes, progress)
    if device == "gpu":
        cuda = [f"CUDA kernels {dtype}" for dtype in dtypes if not cuda_ready(dtype)]
        if cuda:
            logging.getLogger(__name__).info(compile_note(cuda))
        for dtype in dtypes:
            _gpu_solves(dtype)
        compiled += cuda
    return {"dtypes": dtypes, "device": device, "compiled": compiled, "seconds": time.perf_counter() - began}
