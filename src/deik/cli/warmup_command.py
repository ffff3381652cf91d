"""`deik warmup`: compile every kernel a command uses, ahead of time, with a progress bar (the CPU
kernels, and with --device gpu the CUDA kernels too).

The kernels are compiled on first use and cached on disk (deik.backends.targets); running this
once after an install or upgrade moves that wait to a moment of the user's choosing. It compiles
the CPU kernels' build for every goal kind (deik.backends.builds), which then serves every
problem: the DE kernel with its polish for each dtype (a solve without the polish uses it too),
the float64 error report of float32 solves and the clip fix's float64 Jacobians, side by side in
worker processes (deik.backends.compiling); with --device gpu then a small solve per dtype on
the GPU. The compile times are recorded for the estimates that commands print
(deik.solver.readiness).
"""

from __future__ import annotations

import argparse
import logging
import time

import numpy as np

from deik.console import add_output_flags, show_progress

DTYPES = ("float32", "float64")


def _gpu_solve(dtype: str) -> None:
    """Small GPU solves in `dtype` that run both CUDA kernels: the generations and, for a
    problem whose goals stop once met, the first polish."""
    import deik

    sk = deik.chain(3, dims=3)
    target = deik.forward_kinematics(sk, np.full(sk.n_dofs, 0.3)).position("tip")
    problem = deik.Problem(sk, [deik.Position("tip", target, tolerance=1e-3), deik.Comfort(level=1)])
    deik.solve(problem, population=8, generations=2, dtype=dtype, seed=0, device="gpu")
    deik.solve(deik.Problem(sk, problem.goals[:1]), population=8, generations=2, dtype=dtype, device="gpu")


def run_warmup(args: argparse.Namespace) -> int:
    """Compile the kernels for args.dtype (default both) and report how long it took."""
    from deik.cli.arguments import check_device
    from deik.solver.readiness import compile_note, cuda_ready, warmup

    dtypes, device = args.dtype or list(DTYPES), args.device
    check_device(device)
    began = time.perf_counter()
    compiled = warmup(dtypes, show_progress(args))
    if device == "gpu":
        cuda = [f"CUDA kernels {dtype}" for dtype in dtypes if not cuda_ready(dtype)]
        if cuda:
            logging.getLogger(__name__).info(compile_note(cuda))
        for dtype in dtypes:
            _gpu_solve(dtype)
        compiled += cuda
    state = "are compiled and cached" if compiled else "were already compiled (loaded from the cache)"
    which = "CPU and GPU" if device == "gpu" else "CPU"
    print(f"deik's {which} kernels for {', '.join(dtypes)} {state}: {time.perf_counter() - began:.1f} s")
    return 0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The `deik warmup` flags on subparser `parser`."""
    parser.add_argument("--dtype", action="append", choices=DTYPES, help="only this precision (repeatable)")
    parser.add_argument(
        "--device", choices=("cpu", "gpu"), default="cpu", help="gpu: the CUDA kernels too (needs an NVIDIA GPU)"
    )
    add_output_flags(parser)
