"""`deik warmup`: compile every CPU kernel a command uses, ahead of time, with a progress bar.

The kernels are compiled on first use and cached on disk (deik.backends.targets); running this
once after an install or upgrade moves that wait to a moment of the user's choosing. Each step
solves or evaluates a tiny problem so that exactly the kernels real work needs are compiled: the
DE kernel with its polish for each dtype (a solve without the polish uses it too), the float64
error report of float32 solves, and the clip fix's float64 Jacobians. The compile times are
recorded for the estimates that commands print (deik.solver.readiness).
"""

from __future__ import annotations

import argparse
import logging
import time
from collections.abc import Callable, Iterable

import numpy as np

from deik.console import add_output_flags, progress_bar, show_progress

DTYPES = ("float32", "float64")


def _solve(dtype: str) -> None:
    """A small solve with every stage (initialise, generations, polish, report) in `dtype`."""
    import deik

    sk = deik.chain(3, dims=3)
    target = deik.forward_kinematics(sk, np.full(sk.n_dofs, 0.3)).position("tip")
    problem = deik.Problem(sk, [deik.Position("tip", target, tolerance=1e-3), deik.Comfort(level=1)])
    deik.solve(problem, population=8, generations=2, dtype=dtype, seed=0)


def _jacobians() -> None:
    """The clip warm start's point Jacobians (float64)."""
    import deik
    from deik.solver.jacobians import point_jacobians

    sk = deik.chain(3, dims=3)
    point_jacobians(sk, np.zeros(sk.n_dofs), [sk.frame_index("tip")])


def steps(dtypes: Iterable[str] = DTYPES) -> list[tuple[str, Callable[[], None]]]:
    """(description, function) of every compile step for these dtypes."""
    out = [(f"DE, polish and report ({dtype})", lambda dtype=dtype: _solve(dtype)) for dtype in dtypes]
    return out + [("clip warm start Jacobians (float64)", _jacobians)]


def run_warmup(args: argparse.Namespace) -> int:
    """Compile the kernels for args.dtype (default both) and report how long it took."""
    from deik.solver.readiness import compile_note, pending, record_compiles

    dtypes = args.dtype or list(DTYPES)
    began = time.perf_counter()
    names = list(dict.fromkeys(name for dtype in dtypes for name in pending(dtype, clip=True)))
    if names:
        logging.getLogger(__name__).info(compile_note(names))
    todo = steps(dtypes)
    with progress_bar(len(todo), "deik warmup", "step", show_progress(args)) as bar:
        for description, step in todo:
            bar.set_postfix_str(description)
            step()
            bar.update()
    record_compiles()
    state = "are compiled and cached" if names else "were already compiled (loaded from the cache)"
    print(f"deik's CPU kernels for {', '.join(dtypes)} {state}: {time.perf_counter() - began:.1f} s")
    return 0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The `deik warmup` flags on subparser `parser`."""
    parser.add_argument("--dtype", action="append", choices=DTYPES, help="only this precision (repeatable)")
    add_output_flags(parser)
