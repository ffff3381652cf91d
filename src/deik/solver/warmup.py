"""deik.warmup(): compile every kernel the commands use, ahead of time (`deik warmup`): the CPU
kernels, and with device "gpu" the CUDA kernels too.

The kernels are compiled on first use and cached on disk (deik.backends.targets); running this
once after an install or upgrade moves that wait to a moment of the user's choosing. Each step
solves or evaluates a tiny problem so that exactly the kernels real work needs are compiled: the
DE kernel with its polish for each dtype (a solve without the polish uses it too), the float64
error report of float32 solves, and the clip fix's float64 Jacobians. The compile times are
recorded for the estimates that commands print (deik.solver.readiness).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable

import numpy as np

from deik.console import progress_bar
from deik.errors import InputError
from deik.model.builders import chain
from deik.model.kinematics import forward_kinematics
from deik.objectives.goals import Comfort, Position
from deik.solver.jacobians import point_jacobians
from deik.solver.problem import Problem
from deik.solver.readiness import pending, record_compiles
from deik.solver.routing import require_gpu
from deik.solver.solve import solve

DTYPES = ("float32", "float64")


def _solve(dtype: str, device: str = "cpu") -> None:
    """A small solve with every stage (initialise, generations, polish, report) in `dtype` on `device`."""
    sk = chain(3, dims=3)
    target = forward_kinematics(sk, np.full(sk.n_dofs, 0.3)).position("tip")
    problem = Problem(sk, [Position("tip", target, tolerance=1e-3), Comfort(level=1)])
    solve(problem, population=8, generations=2, dtype=dtype, seed=0, device=device)
    if device == "gpu":  # a solve whose problems stop once met: the GPU's first-polish kernel
        solve(Problem(sk, problem.goals[:1]), population=8, generations=2, dtype=dtype, device=device)


def _jacobians() -> None:
    """The clip warm start's point Jacobians (float64)."""
    sk = chain(3, dims=3)
    point_jacobians(sk, np.zeros(sk.n_dofs), [sk.frame_index("tip")])


def steps(dtypes: Iterable[str] = DTYPES, device: str = "cpu") -> list[tuple[str, Callable[[], None]]]:
    """(description, function) of every compile step for these dtypes (and the GPU's, for device "gpu")."""
    out = [(f"DE, polish and report ({dtype})", lambda dtype=dtype: _solve(dtype)) for dtype in dtypes]
    if device == "gpu":
        out += [(f"CUDA kernels ({dtype})", lambda dtype=dtype: _solve(dtype, "gpu")) for dtype in dtypes]
    return out + [("clip warm start Jacobians (float64)", _jacobians)]


def kernels_to_compile(dtypes: Iterable[str] = DTYPES, device: str = "cpu") -> list[str]:
    """Names of the kernels warmup(dtypes, device) would compile (those not in the cache yet)."""
    devices = ("cpu", "gpu") if device == "gpu" else ("cpu",)
    return list(dict.fromkeys(n for d in dtypes for where in devices for n in pending(d, clip=True, device=where)))


def warmup(dtypes: Iterable[str] = DTYPES, device: str = "cpu", progress: bool | None = False) -> dict:
    """Compile (or load from the cache) the CPU kernels for `dtypes` ("float32", "float64"), and
    with `device` "gpu" the CUDA kernels too (DeviceError without a usable GPU), with a bar over
    the steps when `progress` (deik.console.progress_bar's `show`), and record the compile
    times. Returns {"dtypes", "device", "compiled": the kernels that were not cached, "seconds":
    wall time}."""
    dtypes = list(dtypes)
    unknown = [dtype for dtype in dtypes if dtype not in DTYPES]
    if unknown or device not in ("cpu", "gpu"):
        raise InputError(
            f"dtype {unknown[0]!r}: use {' or '.join(DTYPES)}" if unknown else f"device {device!r}: use cpu or gpu"
        )
    if device == "gpu":
        require_gpu()
    began = time.perf_counter()
    names = kernels_to_compile(dtypes, device)
    todo = steps(dtypes, device)
    with progress_bar(len(todo), "deik warmup", "step", progress) as bar:
        for description, step in todo:
            bar.set_postfix_str(description)
            step()
            bar.update()
    record_compiles()
    return {"dtypes": dtypes, "device": device, "compiled": names, "seconds": time.perf_counter() - began}
