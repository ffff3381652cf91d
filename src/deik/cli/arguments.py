"""Small pieces the command-line modules share: the usage error, number parsing, output checks."""

from __future__ import annotations

import argparse
import logging
import math
import os
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING

from deik.errors import DeikError, UsageError
from deik.io.atomic import NAME_MAX, check_writable
from deik.io.files import inputs_read

if TYPE_CHECKING:  # the solver loads NumPy: a command that needs no settings does without it
    from deik.solver.settings import Settings

# what a user's mistake raises: a DeikError (deik.errors: a wrong input, a solve that cannot run
# as asked, a GPU that cannot run it), a missing optional package's ImportError, an unreadable
# file's OSError. Anything else is a bug in deik.
USER_ERRORS = (DeikError, ImportError, OSError)
MAX_MAGNITUDE = 1e12  # of a number on the command line: larger is a typo (squares overflow float32)


def number(low: float = -MAX_MAGNITUDE, high: float = MAX_MAGNITUDE, above: bool = False) -> Callable[[str], float]:
    """An argparse `type` for a flag's number: finite, within [low, high] (above `low` when
    `above`), else one line naming the flag (argparse adds it) and the range."""
    shown = f"{'above' if above else 'from'} {low:g} to {high:g}"

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text[:40]!r} is not a number") from None
        if not (math.isfinite(value) and (value > low if above else value >= low) and value <= high):
            raise argparse.ArgumentTypeError(f"{text[:40]!r} is out of range: give a finite number {shown}")
        return value

    return parse


def numbers(flag: str, words: Iterable[str]) -> list[float]:
    """Finite floats from command-line words; UsageError naming `flag` otherwise."""
    values = []
    for word in words:
        try:
            value = float(word)
        except ValueError:
            raise UsageError(f"{flag}: {word!r} is not a number") from None
        if not (math.isfinite(value) and abs(value) <= MAX_MAGNITUDE):
            raise UsageError(f"{flag}: {word[:40]!r} is out of range: give a finite number from -1e+12 to 1e+12")
        values.append(value)
    return values


def check_outputs(
    outputs: dict[str, str | None],
    suffixes: dict[str, tuple[str, ...]],
    inputs: Iterable[str | None] = (),
    overwrite: bool | None = None,
) -> None:
    """Check every output a command will write before it starts work: `outputs` {flag: path or
    None}, `suffixes` {flag: allowed endings}. UsageError unless each folder exists and is
    writable, each path has an allowed ending, no two flags name one file, and no output is one
    of `inputs` (the files the command names) or of the files it has read so far (inside
    deik.io.files.command_inputs: those named inside other inputs too) unless `overwrite`
    (None: the command has no --overwrite, and the message offers none). Call it again once
    every input is read."""
    inputs = [*inputs, *inputs_read()]
    given = {flag: os.path.abspath(path) for flag, path in outputs.items() if path is not None}
    for flag, path in given.items():
        if outputs[flag].endswith(("/", os.sep)):
            raise UsageError(f"{flag}: {outputs[flag]!r} ends in a slash, as a folder does; give a file name")
        length = len(os.path.basename(path).encode())
        if length > NAME_MAX:
            raise UsageError(
                f"{flag}: the file name is {length} bytes, longer than the {NAME_MAX} a file system takes; shorten it"
            )
        folder = os.path.dirname(path)
        if os.path.isfile(folder):
            raise UsageError(f"{flag}: {folder!r} is a file, not a folder; give a path in a folder")
        if not os.path.isdir(folder):
            raise UsageError(f"{flag}: folder {folder!r} does not exist; create it first")
        if not os.access(folder, os.W_OK | os.X_OK):
            raise UsageError(f"{flag}: folder {folder!r} is not writable; choose another folder")
        try:
            check_writable(folder)
        except OSError as error:
            raise UsageError(f"{flag}: cannot write in folder {folder!r} ({error.strerror}); choose another") from None
        allowed = suffixes.get(flag)
        if allowed and os.path.basename(path).lower() in allowed:
            raise UsageError(f"{flag}: {outputs[flag]!r} has no name before {os.path.basename(path)}; give one")
        if allowed and os.path.splitext(path)[1].lower() not in allowed:
            raise UsageError(f"{flag}: {outputs[flag]!r} must end in {' or '.join(allowed)}")
        if os.path.isdir(path):
            raise UsageError(f"{flag}: {outputs[flag]!r} is a folder; give a file name")
        if os.path.exists(path) and not os.path.isfile(path):  # a write would put a file in its place
            raise UsageError(f"{flag}: {outputs[flag]!r} is a device, pipe or socket; give a regular file path")
    flags = list(given)
    for k, flag in enumerate(flags):
        for other in flags[k + 1 :]:
            if given[flag] == given[other]:
                raise UsageError(f"{flag} and {other} both name {outputs[flag]!r}; give each output its own file")
    if overwrite:
        return
    for flag, path in given.items():
        for source in inputs:
            if (
                source is not None
                and os.path.exists(path)
                and os.path.exists(source)
                and os.path.samefile(path, source)
            ):
                offer = "" if overwrite is None else ", or add --overwrite to replace the input"
                raise UsageError(f"{flag} {outputs[flag]!r} is the input file; write elsewhere{offer}")


def check_device(device: str) -> None:
    """DeviceError, one line naming the fix, when `device` is "gpu" and no usable CUDA GPU (or
    numba-cuda) is here (deik.solver.routing.require_gpu)."""
    if device != "gpu":
        return
    from deik.solver.routing import require_gpu

    require_gpu()


def announce_compile(device: str, dtype: str, polish: bool = True, clip: bool = False) -> list[str]:
    """Say in one note on stderr (the "deik" logger), before work whose solves run elsewhere
    (a library run's worker processes), which kernels they may compile first and about how long
    (deik.solver.readiness), so nobody waits in silence; returns their names. (A solve in this
    process says so itself, readiness.prepare.)"""
    from deik.solver.readiness import compile_note, pending

    names = pending(dtype, polish, clip, device)
    if names:
        logging.getLogger(__name__).info(compile_note(names, certain=not clip))
    return names


def add_up(parser: argparse.ArgumentParser) -> None:
    """--up X Y Z on `parser`: the world's up direction of the skeleton file (up_of reads it)."""
    parser.add_argument(
        "--up",
        nargs=3,
        metavar=("X", "Y", "Z"),
        help="the world's up direction (default: 0 1 0 for BVH, the BVH convention; 0 0 1 for URDF)",
    )


def up_of(args: argparse.Namespace) -> tuple[float, float, float] | None:
    """The unit up direction --up gives (any length), or None; UsageError for a zero or bad vector."""
    if not getattr(args, "up", None):
        return None
    x, y, z = numbers("--up", args.up)
    length = math.sqrt(x * x + y * y + z * z)
    if length < 1e-9:
        raise UsageError("--up: give a direction, e.g. --up 0 0 1 for a file made with Z up")
    return (x / length, y / length, z / length)


def add_free_translations(parser: argparse.ArgumentParser) -> None:
    """--free-translations on `parser` (solve, clip, retarget): position channels below a BVH's
    first translating joint keep the capture's values unless it is given (deik.io.bvh.read_bvh)."""
    parser.add_argument(
        "--free-translations",
        action="store_true",
        help="BVH: let deik move position channels below the first joint that translates (by default they "
        "keep the capture's values, so bones keep their lengths)",
    )


def checked_settings(settings: dict, flags: Iterable[str]) -> Settings:
    """deik.Settings of `settings` (name -> value); a UsageError naming the flag (--NAME) of one
    of `flags` (the names the command line gave) whose value does not fit (a settings error
    names its field first)."""
    from deik.solver.settings import Settings

    try:
        return Settings(**settings)
    except DeikError as error:
        name = next((name for name in flags if str(error).startswith(f"{name} ")), None)
        if name is None:
            raise
        raise UsageError(f"--{name.replace('_', '-')}: {error}") from None
