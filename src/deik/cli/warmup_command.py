"""`deik warmup`: compile every kernel a command uses, ahead of time, with a progress bar (the CPU
kernels, and with --device gpu the CUDA kernels too: deik.warmup, deik.solver.warmup)."""

from __future__ import annotations

import argparse
import logging

from deik.console import add_output_flags, show_progress
from deik.solver.warmup import DTYPES, kernels_to_compile, warmup


def run_warmup(args: argparse.Namespace) -> int:
    """Compile the kernels for args.dtype (default both) on args.device and report how long it took."""
    from deik.cli.arguments import check_device
    from deik.solver.readiness import compile_note

    dtypes, device = args.dtype or list(DTYPES), args.device
    check_device(device)
    names = kernels_to_compile(dtypes, device)
    if names:
        logging.getLogger(__name__).info(compile_note(names))
    done = warmup(dtypes, device, show_progress(args))
    state = "are compiled and cached" if done["compiled"] else "were already compiled (loaded from the cache)"
    which = "CPU and GPU" if device == "gpu" else "CPU"
    print(f"deik's {which} kernels for {', '.join(dtypes)} {state}: {done['seconds']:.1f} s")
    return 0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The `deik warmup` flags on subparser `parser`."""
    parser.add_argument("--dtype", action="append", choices=DTYPES, help="only this precision (repeatable)")
    parser.add_argument(
        "--device", choices=("cpu", "gpu"), default="cpu", help="gpu: the CUDA kernels too (needs an NVIDIA GPU)"
    )
    add_output_flags(parser)
